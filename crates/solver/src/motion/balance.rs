//! The energy balance measured from the chain's static state, for chains whose static state holds
//! energy (a precompression, a drive's preloaded wall, a load cell): the ledger's total less its
//! value at rest, computed without ever forming the large static terms.
//!
//! The ledger ([`super::system::Ledger`]) sums the elastic energy of every contact, the
//! gravitational potential and the precompression's, each of them large on a preloaded chain (5 N
//! on a few 8 mm spheres: microjoules), and their changes under a small drive are far below the
//! rounding of those sums (a 1e-9 N force moves the chain by 1e-16 m and exchanges 1e-25 J). At
//! static equilibrium the forces balance, `Σ_c F_s,c ∂δ_c/∂x = g m + F_p` at every particle, so the
//! first-order changes of the potentials cancel exactly, and the ledger's total less its value at
//! rest is
//!
//! `E − E_s = K + Σ_c R_c + ½ k u_m² + D + P + Σ_w F_s,w σ_w u_w − W`
//!
//! with `R_c = U_c(δ_c) − U_c(δ_s,c) − F_s,c (δ_c − δ_s,c)`, the second-order part of contact `c`'s
//! potential (computed from `r = (δ − δ_s)/δ_s` by its binomial series where `|r|` is small, so
//! its relative rounding is that of `r`), `u_m` a mounted wall's displacement, `D` and `P` the
//! dissipated and plastic work, `W` the external forces' work and, for a wall a drive moves by
//! `u_w`, `F_s,w σ_w u_w` the static part of that work (`σ_w = ±1`, the sign of `∂δ_w/∂u_w`), which
//! cancels against the drive's. Every term is then of the size of the motion. A particle the
//! static state does not hold (a striker, which gravity pulls and no contact carries) keeps the
//! first-order term of its unbalanced static force `r_i`: `− r_i (x_i − x_s,i)`.

use crate::chain::drive::DrivePoint;
use crate::chain::model::{Chain, ContactMap};
use crate::contact::Thornton;

/// Where `|r|` is at most this, `R_c` is summed as its binomial series.
const SERIES_BOUND: f64 = 0.25;

/// The energy balance of a chain above its static state.
#[derive(Debug, Clone)]
pub struct StaticBalance {
    mass: Vec<f64>,
    contacts: ContactMap,
    /// Per contact: coefficient `A`, exponent `n`, static overlap, static force, and
    /// `A δ_s^{n+1}/(n+1)` (its static potential).
    laws: Vec<(f64, f64, f64, f64, f64)>,
    /// Thornton's law and its history's index, per contact that has it.
    plastic: Vec<Option<(Thornton, usize)>>,
    /// Index of the dissipated work, of the pulse's and of the drive's work.
    work: Option<usize>,
    pulse_work: Option<usize>,
    drive_work: Option<usize>,
    /// A wall a drive moves: its displacement's index, `F_s,w σ_w`.
    moving_wall: Option<(usize, f64)>,
    /// A mounted wall: its displacement's index, mass and stiffness.
    mount: Option<(usize, f64, f64)>,
    /// The particles whose static forces do not balance (a striker under gravity): index,
    /// unbalanced force (towards the wall), static position.
    unbalanced: Vec<(usize, f64, f64)>,
}

/// The balance's terms in a state, J.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BalanceTerms {
    /// `E − E_s`: constant along an exact solution.
    pub total: f64,
    /// The energy of the motion: kinetic, the contacts' second-order potentials and a mounted
    /// wall's, all non-negative.
    pub motion: f64,
    /// The work the external forces have done beyond the static part of a moving wall's.
    pub work: f64,
}

impl StaticBalance {
    /// The balance of `chain` about its static state.
    pub fn new(chain: &Chain) -> Self {
        let laws: Vec<(f64, f64, f64, f64, f64)> = (0..chain.n_contacts())
            .map(|c| {
                let (a, n, d) = (
                    chain.stiffness[c],
                    chain.exponent[c],
                    chain.static_overlap[c],
                );
                let potential = if d > 0.0 {
                    crate::contact::potential(a, n, d)
                } else {
                    0.0
                };
                let force = if d > 0.0 { chain.static_force(c) } else { 0.0 };
                (a, n, d, force, potential)
            })
            .collect();
        let mut plastic = vec![None; chain.n_contacts()];
        for (c, t, h) in chain.plastic_contacts() {
            plastic[c] = Some((t, h));
        }
        let moving_wall = chain.moving_wall().map(|(point, index)| {
            let (contact, sign) = match point {
                DrivePoint::Actuator => (chain.n_contacts() - 1, 1.0),
                _ => (chain.n_particles() - 1, -1.0),
            };
            let force = if chain.static_overlap[contact] > 0.0 {
                chain.static_force(contact)
            } else {
                0.0
            };
            (index, force * sign)
        });
        // Each particle's static forcing less what its contacts' static forces give it.
        let n = chain.n_particles();
        let mut residual: Vec<f64> = chain.mass.iter().map(|m| m * chain.gravity_m_s2).collect();
        residual[chain.first_chain_particle()] += chain.top_force_n();
        for (c, &(_, _, ds, fs, _)) in laws.iter().enumerate() {
            if ds <= 0.0 {
                continue;
            }
            let e = chain.contact_ends(c);
            if let Some(a) = e.above {
                residual[a] -= fs;
            }
            if let Some(b) = e.below {
                residual[b] += fs;
            }
        }
        let unbalanced = (0..n)
            .filter(|&i| residual[i] != 0.0)
            .map(|i| (i, residual[i], chain.equilibrium_position[i]))
            .collect();
        StaticBalance {
            unbalanced,
            mass: chain.mass.clone(),
            contacts: ContactMap::of(chain),
            laws,
            plastic,
            work: chain.work_index(),
            pulse_work: chain.force_pulse.and(chain.external_work_index()),
            drive_work: chain.drive.as_ref().and(chain.external_work_index()),
            moving_wall,
            mount: chain.wall_mount.map(|m| {
                (
                    chain.mount_state_index().expect("a mount"),
                    m.mass_kg,
                    m.stiffness_n_m,
                )
            }),
        }
    }

    /// The balance's terms in state `y` whose particles from `k` on are at rest in their static
    /// state (all of them move with `k = N`).
    pub fn terms(&self, y: &[f64], k: usize) -> BalanceTerms {
        let n = self.mass.len();
        let mut motion = 0.0;
        for (m, v) in self.mass[..k].iter().zip(&y[n..n + k]) {
            motion += 0.5 * m * v * v;
        }
        let contacts = if k == n {
            self.laws.len()
        } else {
            k.min(n - 1)
        };
        let mut plastic_work = 0.0;
        for c in 0..contacts {
            let overlap = self.contacts.overlap(c, y);
            let (a, e, ds, fs, us) = self.laws[c];
            match &self.plastic[c] {
                Some((law, h)) if overlap + y[*h].max(0.0) > law.yield_overlap => {
                    let (recoverable, work) = law.energies(overlap, y[*h]);
                    motion += recoverable - us - fs * (overlap - ds);
                    plastic_work += work;
                }
                _ => motion += second_order_potential(a, e, ds, fs, us, overlap),
            }
        }
        if let Some((i, mass, stiffness)) = self.mount {
            let (u, w) = (y[i], y[i + 1]);
            motion += 0.5 * (mass * w * w + stiffness * u * u);
        }
        let mut work = 0.0;
        for i in [self.pulse_work, self.drive_work].into_iter().flatten() {
            work += y[i];
        }
        if let Some((i, static_part)) = self.moving_wall {
            work -= static_part * y[i];
        }
        let dissipated = self.work.map_or(0.0, |i| y[i]);
        let mut unbalanced = 0.0;
        for &(i, r, xs) in self.unbalanced.iter().filter(|u| u.0 < k) {
            unbalanced -= r * (y[i] - xs);
        }
        BalanceTerms {
            total: motion + dissipated + plastic_work - work + unbalanced,
            motion,
            work,
        }
    }
}

/// `R = U(δ) − U(δ_s) − F_s (δ − δ_s)` of a contact `F = A δ^n` (zero where open) whose static
/// overlap, force and potential are `ds`, `fs` and `us`: by the binomial series of
/// `(1 + r)^{n+1} − 1 − (n+1) r` in `r = (δ − δ_s)/δ_s` where `|r|` is small (every term then of
/// the size of the motion), directly elsewhere.
fn second_order_potential(a: f64, n: f64, ds: f64, fs: f64, us: f64, overlap: f64) -> f64 {
    let delta = overlap - ds;
    if ds > 0.0 && overlap > 0.0 {
        let r = delta / ds;
        if r.abs() <= SERIES_BOUND {
            // us (1 + r)^{m} − us − m us r with m = n + 1: us Σ_{j≥2} C(m, j) r^j.
            let m = n + 1.0;
            let (mut coefficient, mut power, mut sum) = (m, r, 0.0);
            for j in 2..64 {
                coefficient *= (m - (j - 1) as f64) / j as f64;
                power *= r;
                let term = coefficient * power;
                sum += term;
                if term.abs() <= 1e-17 * sum.abs() {
                    break;
                }
            }
            return us * sum;
        }
    }
    let u = if overlap > 0.0 {
        crate::contact::potential(a, n, overlap)
    } else {
        0.0
    };
    u - us - fs * delta
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::drive::{DriveSpec, Harmonic, Waveform};
    use crate::chain::model::PhysicsSpec;
    use crate::chain::mount::WallMount;
    use crate::motion::system::Ledger;
    use crate::problems::monodisperse;
    use crate::ChainSpec;

    /// The balance is the ledger's total less its value at rest: for states moved well away
    /// from rest (so that the absolute totals resolve the change), the two changes agree, on
    /// chains with a striker under gravity, a precompression, a wall at the top, a load cell and
    /// every drive.
    #[test]
    fn the_balance_changes_as_the_ledger_s_total() {
        let harmonic = Waveform::Harmonic(Harmonic {
            amplitude: 1e-7,
            frequency_hz: 1e3,
            phase_rad: 0.3,
            ramp_periods: 0.0,
        });
        for (striker, top_wall, mount, force, gravity, drive) in [
            (true, false, false, 2.0, true, None),
            (true, false, true, 0.0, true, None),
            (
                false,
                true,
                false,
                3.0,
                true,
                Some(DriveSpec::ActuatorM(harmonic.clone())),
            ),
            (
                false,
                false,
                false,
                3.0,
                false,
                Some(DriveSpec::BaseM(harmonic.clone())),
            ),
            (
                false,
                false,
                true,
                1.0,
                true,
                Some(DriveSpec::ForceN(harmonic.clone())),
            ),
        ] {
            let mut spec = monodisperse(5, None, striker);
            if top_wall {
                spec.top_wall_material = Some(spec.wall_material);
            }
            if mount {
                spec.wall_mount = Some(WallMount {
                    mass_kg: 0.03,
                    stiffness_n_m: 3e7,
                    damping_kg_s: 5.0,
                });
            }
            let physics = PhysicsSpec {
                gravity,
                wall: true,
                damping_kg_s: 2.0,
                precompression_force_n: force,
                ..PhysicsSpec::default()
            };
            let mut chain = Chain::build(&ChainSpec::Sequence(spec), &physics).unwrap();
            if let Some(d) = drive {
                chain = chain.with_drive(d.validate(1e-2).unwrap()).unwrap();
            }
            let (ledger, balance) = (Ledger::new(&chain), StaticBalance::new(&chain));
            let y0 = chain.initial_state(0.0);
            let mut y = y0.clone();
            let n = chain.n_particles();
            for (i, v) in y.iter_mut().enumerate() {
                // A tenth of a micrometre and centimetres per second; quadratures a microjoule.
                *v += 1e-7 * ((i as f64 * 0.7).sin() + 0.2) * if i < n { 1.0 } else { 1e5 };
            }
            let by_ledger = ledger.energy(&y).total() - ledger.energy(&y0).total();
            let by_balance = balance.terms(&y, n).total - balance.terms(&y0, n).total;
            assert!(
                (by_balance - by_ledger).abs() <= 1e-9 * by_ledger.abs().max(1e-9),
                "striker {striker}, top wall {top_wall}, mount {mount}: {by_balance:e} against {by_ledger:e}"
            );
        }
    }

    #[test]
    fn the_series_is_the_direct_difference() {
        let (a, n, ds) = (1.3e10, 1.5, 7e-7);
        let us = crate::contact::potential(a, n, ds);
        let fs = crate::contact::elastic_force(a, n, ds);
        for r in [-0.25, -0.1, -1e-3, 1e-3, 0.1, 0.25] {
            let d = ds * (1.0 + r);
            let series = second_order_potential(a, n, ds, fs, us, d);
            let direct = crate::contact::potential(a, n, d) - us - fs * (d - ds);
            assert!(
                (series / direct - 1.0).abs() < 1e-9,
                "{r}: {series} {direct}"
            );
        }
        // Far below the rounding of the potentials, the series keeps its digits: ½ k Δ².
        let k = n * a * ds.powf(n - 1.0);
        let tiny = 1e-14;
        let r = second_order_potential(a, n, ds, fs, us, ds + tiny);
        assert!((r / (0.5 * k * tiny * tiny) - 1.0).abs() < 1e-6, "{r}");
    }
}
