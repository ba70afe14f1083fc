//! The equations of motion: the paper's chain specialised at compile time on its physics switches,
//! with the energy and momentum ledger and the dispatch to a compiled right-hand side
//! ([`system`]); every other chain, with per-contact laws and dissipation ([`general`]); chains with Thornton's elastic–plastic
//! contacts, whose history is part of the state ([`plastic`]); and the
//! chain's tridiagonal Jacobian for the linearly implicit integrator (`jacobian`).

pub mod balance;
pub mod general;
mod jacobian;
pub mod plastic;
pub mod system;

use crate::chain::drive::{DrivePoint, Signal};
use crate::chain::model::{Chain, ContactEnds};
use crate::chain::mount::WallMount;
use crate::integrate::Switch;

/// A contact's overlap as a switching function of the positions (zero where it opens), for the
/// integrators that put step boundaries there.
pub(crate) fn contact_switch(e: &ContactEnds) -> Switch {
    match (e.above, e.below) {
        // The wall under the chain, moving: `x_N − u`.
        (Some(a), None) => Switch {
            plus: a,
            minus: e.wall_state,
            offset: e.offset,
        },
        (Some(a), b) => Switch {
            plus: a,
            minus: b,
            offset: e.offset,
        },
        // `x_top + u − x₁` vanishes where `x₁ − u − x_top` does.
        (None, Some(b)) => Switch {
            plus: b,
            minus: e.wall_state,
            offset: -e.offset,
        },
        (None, None) => unreachable!("a contact touches a particle"),
    }
}

/// A boundary drive as the right-hand sides apply it ([`crate::chain::drive`]).
#[derive(Debug, Clone)]
pub(crate) struct DriveTerm {
    /// Where it acts.
    pub point: DrivePoint,
    /// Its waveform.
    pub signal: Signal,
    /// Index in the state of its work, then of its impulse (a force) or its wall's displacement
    /// and velocity (an actuator or a base).
    pub work: usize,
}

impl DriveTerm {
    /// The drive of `chain`, when it has one.
    pub fn of(chain: &Chain) -> Option<Self> {
        let d = chain.drive.as_ref()?;
        Some(DriveTerm {
            point: d.point,
            signal: d.waveform.clone(),
            work: chain.external_work_index().expect("a drive's work"),
        })
    }

    /// The waveform's value, velocity and acceleration at `t` (zero without a drive): evaluated
    /// once per right-hand side.
    #[inline(always)]
    pub fn at(drive: &Option<DriveTerm>, t: f64) -> (f64, f64, f64) {
        drive.as_ref().map_or((0.0, 0.0, 0.0), |d| d.signal.eval(t))
    }

    /// Displacement and velocity of the wall under the chain and of the wall at the top (zero for
    /// a wall that does not move): the displacement from the state `y` (so that overlaps,
    /// switches and the ledger read the state alone), the velocity the waveform's own at the
    /// time of `wave` ([`DriveTerm::at`]), so that the work the wall does is exactly the
    /// elastic energy and the dissipation it feeds.
    #[inline(always)]
    pub fn walls(
        drive: &Option<DriveTerm>,
        y: &[f64],
        wave: (f64, f64, f64),
    ) -> ((f64, f64), (f64, f64)) {
        match drive {
            Some(d) if d.point == DrivePoint::Base => ((y[d.work + 1], wave.1), (0.0, 0.0)),
            Some(d) if d.point == DrivePoint::Actuator => ((0.0, 0.0), (y[d.work + 1], wave.1)),
            _ => ((0.0, 0.0), (0.0, 0.0)),
        }
    }

    /// The force a force drive puts on the first chain particle, N, from `wave`
    /// ([`DriveTerm::at`]; zero for the others).
    #[inline(always)]
    pub fn force(&self, wave: (f64, f64, f64)) -> f64 {
        if self.point == DrivePoint::Force {
            wave.0
        } else {
            0.0
        }
    }

    /// Writes the drive's quadratures into `dq` (the rates of the state from index `offset` on):
    /// its work, from the forces the right-hand side found (`top_force` from the wall at the top,
    /// `base_force` from the wall under the chain, both pushing the chain downwards), and its
    /// impulse (a force) or its wall's displacement and velocity, from `wave` ([`DriveTerm::at`]).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn rates(
        &self,
        wave: (f64, f64, f64),
        top_velocity: f64,
        top_force: f64,
        base_force: f64,
        dq: &mut [f64],
        offset: usize,
    ) {
        let k = self.work - offset;
        let (u, du, ddu) = wave;
        match self.point {
            DrivePoint::Force => {
                dq[k] = u * top_velocity;
                dq[k + 1] = u;
            }
            DrivePoint::Actuator | DrivePoint::Base => {
                let force = if self.point == DrivePoint::Actuator {
                    top_force
                } else {
                    base_force
                };
                dq[k] = force * du;
                dq[k + 1] = du;
                // The wall's velocity in the state serves the probes and the switches, which
                // read the state alone; the right-hand side takes the waveform's own.
                dq[k + 2] = ddu;
            }
        }
    }
}

/// A mounted wall under the chain as the right-hand sides apply it ([`crate::chain::mount`]): its
/// displacement `u` and velocity `w` are state components, moved by `M ẇ = F_w − F_s − k u − c w`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct MountTerm {
    /// Index in the state of its displacement (its velocity at the next).
    pub index: usize,
    inverse_mass: f64,
    stiffness: f64,
    damping: f64,
    /// The wall contact's static force `F_s`, N.
    static_force: f64,
}

impl MountTerm {
    /// The mount of `chain`, when its wall has one.
    pub fn of(chain: &Chain) -> Option<Self> {
        let m: WallMount = chain.wall_mount?;
        Some(MountTerm {
            index: chain.mount_state_index().expect("a mount"),
            inverse_mass: 1.0 / m.mass_kg,
            stiffness: m.stiffness_n_m,
            damping: m.damping_kg_s,
            static_force: chain.static_force(chain.n_particles() - 1),
        })
    }

    /// The wall's displacement and velocity in state `y`.
    #[inline(always)]
    pub fn wall(&self, y: &[f64]) -> (f64, f64) {
        (y[self.index], y[self.index + 1])
    }

    /// Writes the wall's rates into `dq` (the rates of the state from index `offset` on) under the
    /// force `wall_force` of the chain's last contact, and returns the dashpot's power.
    #[inline(always)]
    pub fn rates(&self, y: &[f64], wall_force: f64, dq: &mut [f64], offset: usize) -> f64 {
        let (u, w) = self.wall(y);
        let k = self.index - offset;
        let damper = self.damping * w;
        dq[k] = w;
        dq[k + 1] =
            (wall_force - self.static_force - self.stiffness * u - damper) * self.inverse_mass;
        damper * w
    }
}
