//! The equations of motion of any chain that is not the paper's physics (see
//! [`crate::chain::model::Chain::is_paper_physics`]): per-contact power laws, the three dissipation
//! models, precompression and a half-sine force pulse.
//!
//! Specialised at compile time on the elastic law (`HERTZ`: every contact `n = 3/2`, `LINEAR`:
//! every contact `n = 1`, `POWER`: any `n` per contact) and on whether any contact dissipates, so
//! six variants in all, and two more for Hertz and per-contact power-law chains with Tsuji's
//! damping (`T`: its power `δ^{(n−1)/2}` costs a square root per contact, which no other chain
//! pays; on a linear law it is a constant, the linear viscous term); gravity, the wall,
//! clipping, precompression and the pulse are data, each a few operations per evaluation, not per
//! contact. The dissipation models are data too: every contact carries `(μ, γ, λ, β)` and the
//! kernel evaluates `μ + γ δ^{n−1} + λ δ^n` (+ `β √(δ^{n−1})` when `T`), fused operations on
//! powers it computes anyway.

use chainsweep_cpu::{dispatch, Kernel, MulAdd};

use crate::chain::model::Chain;
use crate::contact::{
    general_force, general_force_on_side, ContactParams, Damping, HERTZ, LINEAR, POWER,
};
use crate::integrate::{OdeSystem, Switch, Tridiagonal};
use crate::motion::{DriveTerm, MountTerm};

/// Right-hand side of a general chain. State `[x (N), v (N), q]`, `q` holding in order the
/// dissipated work (when `D`), the wall impulse (with a wall), the work of the force pulse or the
/// drive (with one) and the drive's own quadratures, the layout [`Chain::state_len`] defines. `T`: some contact carries Tsuji's term
/// (only with `D`).
#[derive(Debug, Clone)]
pub struct GeneralChainSystem<const LAW: u8, const D: bool, const T: bool = false> {
    inv_mass: Vec<f64>,
    stiffness: Vec<f64>,
    exponent: Vec<f64>,
    linear: Vec<f64>,
    viscoelastic: Vec<f64>,
    hunt_crossley: Vec<f64>,
    gravity: f64,
    wall: bool,
    /// The last contact (index `N − 1`) closes a ring: the last particle touches the first.
    ring: bool,
    /// The wall at the top: its contact's index and its position, m.
    top_wall: Option<(usize, f64)>,
    clip: bool,
    /// Particle the external forces act on.
    top: usize,
    precompression: f64,
    /// Half-sine pulse: amplitude (N), π/duration (1/s), duration (s); zero amplitude: none.
    pulse: (f64, f64, f64),
    force: Vec<f64>,
    power: Vec<f64>,
    switches: Vec<Switch>,
    /// Tsuji coefficients β, read only when `T`.
    tsuji: Vec<f64>,
    /// A boundary drive, when there is one.
    drive: Option<DriveTerm>,
    /// The mount of the wall under the chain, when it has one.
    mount: Option<MountTerm>,
}

/// `LAW` of a kernel whose contacts are all Hertz's (`n = 3/2`).
pub const HERTZ_LAW: u8 = HERTZ;
/// `LAW` of a kernel whose contacts are all linear (`n = 1`).
pub const LINEAR_LAW: u8 = LINEAR;
/// `LAW` of a kernel with any exponent per contact.
pub const POWER_LAW: u8 = POWER;

/// Law of every contact of a chain, as the kernel's `LAW` parameter.
pub fn law(chain: &Chain) -> u8 {
    if chain.exponent.iter().all(|&n| n == 1.5) {
        HERTZ
    } else if chain.exponent.iter().all(|&n| n == 1.0) {
        LINEAR
    } else {
        POWER
    }
}

impl<const LAW: u8, const D: bool, const T: bool> GeneralChainSystem<LAW, D, T> {
    /// Builds the system; panics if the chain's laws or damping differ from the type's (a
    /// programming error: use [`crate::dispatch_chain_system`] to pick the type from a chain).
    pub fn new(chain: &Chain) -> Self {
        assert_eq!(law(chain), LAW, "law mismatch");
        assert_eq!(chain.has_damping(), D, "damping switch mismatch");
        assert_eq!(chain.has_tsuji_damping(), T, "Tsuji switch mismatch");
        let n = chain.n_particles();
        let pulse = match chain.force_pulse {
            Some((amplitude, duration)) => (amplitude, std::f64::consts::PI / duration, duration),
            None => (0.0, 0.0, 0.0),
        };
        GeneralChainSystem {
            inv_mass: chain.mass.iter().map(|m| 1.0 / m).collect(),
            stiffness: chain.stiffness.clone(),
            exponent: chain.exponent.clone(),
            linear: chain.damping.clone(),
            viscoelastic: chain.viscoelastic_damping.clone(),
            hunt_crossley: chain.hunt_crossley_damping.clone(),
            tsuji: chain.tsuji_damping.clone(),
            gravity: chain.gravity_m_s2,
            wall: chain.wall,
            ring: chain.ring,
            top_wall: chain.top_wall_m.map(|x| (chain.n_contacts() - 1, x)),
            clip: chain.clip_tensile,
            top: chain.first_chain_particle(),
            precompression: chain.top_force_n(),
            pulse,
            force: vec![0.0; n],
            power: vec![0.0; n],
            switches: (0..chain.n_contacts())
                .map(|c| crate::motion::contact_switch(&chain.contact_ends(c)))
                .collect(),
            drive: DriveTerm::of(chain),
            mount: MountTerm::of(chain),
        }
    }

    /// Law and dissipation of contact `c`.
    pub(crate) fn contact_parameters(&self, c: usize) -> ContactParams {
        ContactParams {
            a: self.stiffness[c],
            n: self.exponent[c],
            damping: Damping {
                linear: self.linear[c],
                viscoelastic: self.viscoelastic[c],
                hunt_crossley: self.hunt_crossley[c],
                tsuji: self.tsuji[c],
            },
        }
    }

    /// Inverse masses, 1/kg.
    pub(crate) fn inverse_masses(&self) -> &[f64] {
        &self.inv_mass
    }

    /// Whether the net contact force is clipped at zero.
    pub(crate) fn clips(&self) -> bool {
        self.clip
    }

    /// Whether the last particle rests on a wall.
    pub(crate) fn has_wall(&self) -> bool {
        self.wall
    }

    /// Whether the last contact closes a ring.
    pub(crate) fn is_ring(&self) -> bool {
        self.ring
    }

    /// The top wall's contact and position, m, when there is one.
    pub(crate) fn top_wall(&self) -> Option<(usize, f64)> {
        self.top_wall
    }

    /// Displacements and velocities of the wall under the chain and of the wall at the top at
    /// `(t, y)` (zero unless a drive moves them, see [`DriveTerm::walls`], or the wall under the
    /// chain is mounted).
    #[inline(always)]
    pub(crate) fn wall_motion(&self, t: f64, y: &[f64]) -> ((f64, f64), (f64, f64)) {
        self.walls(y, DriveTerm::at(&self.drive, t))
    }

    /// [`GeneralChainSystem::wall_motion`] with the drive's waveform already evaluated (`wave`,
    /// [`DriveTerm::at`]): a drive's walls, and a mounted wall's from its state.
    #[inline(always)]
    fn walls(&self, y: &[f64], wave: (f64, f64, f64)) -> ((f64, f64), (f64, f64)) {
        let (base, top) = DriveTerm::walls(&self.drive, y, wave);
        (self.mount.map_or(base, |m| m.wall(y)), top)
    }

    /// Force of the half-sine pulse at time `t`, N.
    #[inline(always)]
    fn pulse_force(&self, t: f64) -> f64 {
        let (amplitude, omega, duration) = self.pulse;
        if amplitude != 0.0 && t < duration {
            amplitude * (omega * t).sin()
        } else {
            0.0
        }
    }

    /// The right-hand side over slices: the one kernel every `(LAW, D)` specialisation compiles,
    /// kept apart from the [`OdeSystem::rhs`] entry point so that a run-time CPU dispatch (a
    /// `#[target_feature]` trampoline) can wrap it without touching the physics.
    #[inline(always)]
    pub(crate) fn rhs_kernel(&mut self, t: f64, y: &[f64], dy: &mut [f64]) {
        let n = self.inv_mass.len();
        let (x, rest) = y.split_at(n);
        let v = &rest[..n];
        let (dx, rest) = dy.split_at_mut(n);
        let (dv, dq) = rest.split_at_mut(n);
        dx.copy_from_slice(v);

        const LANES: usize = 8;
        let m = n - 1;
        let clip = self.clip;
        let wave = DriveTerm::at(&self.drive, t);
        let ((base_u, base_du), (top_u, top_du)) = self.walls(y, wave);
        let force = &mut self.force[..m];
        let contact_power = &mut self.power[..m];
        let (a, e) = (&self.stiffness[..m], &self.exponent[..m]);
        let (mu, gamma, lambda) = (
            &self.linear[..m],
            &self.viscoelastic[..m],
            &self.hunt_crossley[..m],
        );
        // Read only by the kernels with Tsuji's term.
        let beta: &[f64] = if T { &self.tsuji[..m] } else { &[] };
        for c in 0..m {
            let params = ContactParams {
                a: a[c],
                n: e[c],
                damping: Damping {
                    linear: mu[c],
                    viscoelastic: gamma[c],
                    hunt_crossley: lambda[c],
                    tsuji: if T { beta[c] } else { 0.0 },
                },
            };
            let (fc, p) =
                general_force::<LAW, D, T>(&params, x[c] - x[c + 1], v[c] - v[c + 1], clip);
            force[c] = fc;
            if D {
                contact_power[c] = p;
            }
        }
        let mut power = [0.0f64; LANES];
        if D {
            let chunks = contact_power.chunks_exact(LANES);
            power[0] = chunks.remainder().iter().sum();
            for chunk in chunks {
                for k in 0..LANES {
                    power[k] += chunk[k];
                }
            }
        }
        // The contact under the last particle: the wall's, or the ring's closing one; then the
        // top wall's. Each a few operations per evaluation, whatever the chain's length.
        let end = |c: usize, overlap: f64, rate: f64| {
            let params = ContactParams {
                a: self.stiffness[c],
                n: self.exponent[c],
                damping: Damping {
                    linear: self.linear[c],
                    viscoelastic: self.viscoelastic[c],
                    hunt_crossley: self.hunt_crossley[c],
                    tsuji: if T { self.tsuji[c] } else { 0.0 },
                },
            };
            general_force::<LAW, D, T>(&params, overlap, rate, clip)
        };
        let (end_force, end_power) = if self.wall {
            end(m, x[m] - base_u, v[m] - base_du)
        } else if self.ring {
            end(m, x[m] - x[0], v[m] - v[0])
        } else {
            (0.0, 0.0)
        };
        let (top_force, top_power) = match self.top_wall {
            Some((c, position)) => end(c, position + top_u - x[0], top_du - v[0]),
            None => (0.0, 0.0),
        };

        let g = self.gravity;
        let im = &self.inv_mass[..n];
        if n == 1 {
            // One particle: on its wall (and under a wall at the top), no neighbour.
            dv[0] = g - end_force * im[0];
        } else {
            dv[0] = g - force[0] * im[0];
            for i in 1..n - 1 {
                dv[i] = g + (force[i - 1] - force[i]) * im[i];
            }
            dv[n - 1] = g + (force[n - 2] - end_force) * im[n - 1];
        }
        if self.ring {
            dv[0] += end_force * im[0];
        }
        if self.top_wall.is_some() {
            dv[0] += top_force * im[0];
        }
        let pulse = self.pulse_force(t);
        let drive_force = self.drive.as_ref().map_or(0.0, |d| d.force(wave));
        let external = self.precompression + pulse + drive_force;
        if external != 0.0 {
            dv[self.top] += external * im[self.top];
        }

        let mount_power = self.mount.map_or(0.0, |m| m.rates(y, end_force, dq, 2 * n));
        let mut k = 0;
        if D {
            dq[k] = power.iter().sum::<f64>() + end_power + top_power + mount_power;
            k += 1;
        }
        if self.wall || self.top_wall.is_some() {
            // The walls' impulse: the ring's closing contact is internal, and takes none.
            dq[k] = if self.wall { end_force } else { 0.0 } - top_force;
            k += 1;
        }
        if self.pulse.0 != 0.0 {
            dq[k] = pulse * v[self.top];
        }
        if let Some(d) = &self.drive {
            d.rates(wave, v[self.top], top_force, -end_force, dq, 2 * n);
        }
    }
}

impl<const LAW: u8, const D: bool, const T: bool> OdeSystem for GeneralChainSystem<LAW, D, T> {
    fn n_pos(&self) -> usize {
        self.inv_mass.len()
    }

    fn n_quad(&self) -> usize {
        D as usize
            + (self.wall || self.top_wall.is_some()) as usize
            + (self.pulse.0 != 0.0) as usize
            + self
                .drive
                .as_ref()
                .map_or(0, |d| 2 + d.point.moves_a_wall() as usize)
            + 2 * self.mount.is_some() as usize
    }

    fn switches(&self) -> &[Switch] {
        &self.switches
    }

    /// Every switch is a contact's overlap (with a wall, fixed or moving, for some), and an open
    /// contact carries no force under any law or dissipation model.
    fn vanishes_below(&self, _switch: usize) -> bool {
        true
    }

    /// The dissipative terms act only while a contact is compressed, and the linear viscous one
    /// jumps where it opens or closes: held on one side, an interior contact acts as it does there.
    /// The contacts with a wall (or the ring's closing one) are not held: their switches carry the
    /// walls' motion.
    fn hold_switch(&self, switch: usize, positive: bool, y: &[f64], dy: &mut [f64]) {
        let n = self.inv_mass.len();
        let c = switch;
        if !D || c + 1 >= n {
            return;
        }
        // Switch `c` is the overlap `x[c] − x[c+1]` of the contact between particles c and c+1.
        let (overlap, rel_velocity) = (y[c] - y[c + 1], y[n + c] - y[n + c + 1]);
        let params = self.contact_parameters(c);
        let (force, power) = general_force::<LAW, D, T>(&params, overlap, rel_velocity, self.clip);
        let (held, held_power) =
            general_force_on_side::<LAW, D, T>(&params, overlap, rel_velocity, self.clip, positive);
        let change = held - force;
        dy[n + c] -= change * self.inv_mass[c];
        dy[n + c + 1] += change * self.inv_mass[c + 1];
        // The first quadrature is the dissipated work.
        dy[2 * n] += held_power - power;
    }

    fn acceleration_jacobian(
        &self,
        t: f64,
        y: &[f64],
        kx: &mut Tridiagonal,
        kv: &mut Tridiagonal,
    ) -> bool {
        self.jacobian(t, y, kx, kv);
        true
    }

    #[inline]
    fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]) {
        dispatch(GeneralRhsKernel {
            sys: self,
            t,
            y,
            dy,
        });
    }
}

/// [`GeneralChainSystem::rhs_kernel`] compiled for the CPU's vector instructions at run time.
struct GeneralRhsKernel<'a, const LAW: u8, const D: bool, const T: bool> {
    sys: &'a mut GeneralChainSystem<LAW, D, T>,
    t: f64,
    y: &'a [f64],
    dy: &'a mut [f64],
}

impl<const LAW: u8, const D: bool, const T: bool> Kernel for GeneralRhsKernel<'_, LAW, D, T> {
    type Output = ();
    #[inline(always)]
    fn run<M: MulAdd>(self) {
        self.sys.rhs_kernel(self.t, self.y, self.dy);
    }
}

#[cfg(test)]
mod tests {
    use super::{GeneralChainSystem, HERTZ_LAW};
    use crate::chain::model::{Chain, ChainSpec, PhysicsSpec};
    use crate::integrate::OdeSystem;
    use crate::motion::system::tests::close;

    /// An interior contact held on one side acts as it does there, as the paper's chain's does
    /// (`motion::system::tests`): held open just past closing, as if it had no damping; held on
    /// the side it is on, unchanged; the wall's contact is not held.
    #[test]
    fn a_held_interior_contact_acts_as_on_its_side() {
        let physics = PhysicsSpec {
            damping_kg_s: 6.0,
            ..PhysicsSpec::default()
        };
        // A force pulse on the top makes it a general chain (Hertz, linear damping).
        let chain = Chain::build(&ChainSpec::chain_055(4), &physics)
            .unwrap()
            .with_force_pulse(10.0, 1e-5);
        let mut sys = GeneralChainSystem::<HERTZ_LAW, true, false>::new(&chain);
        let n = sys.n_pos();
        let c = 3;
        let mut y = chain.initial_state(1.3);
        y[c + 1] = y[c] - 1e-12;
        y[n + c + 1] = y[n + c] - 0.4;
        let mut dy = vec![0.0; y.len()];
        sys.rhs(1e-6, &y, &mut dy);
        let mut same = dy.clone();
        sys.hold_switch(c, true, &y, &mut same);
        assert_eq!(same, dy);
        sys.hold_switch(n - 1, false, &y, &mut same);
        assert_eq!(same, dy, "the wall's contact is not held");
        let mut open = dy.clone();
        sys.hold_switch(c, false, &y, &mut open);
        let mut undamped = sys.clone();
        undamped.linear[c] = 0.0;
        let mut expected = vec![0.0; y.len()];
        undamped.rhs(1e-6, &y, &mut expected);
        close(&open, &expected, "contact 3 held open");
        assert_ne!(open, dy, "the viscous term is a real change");
    }
}
