//! Periodic orbits of a chain left to itself (no drive, no dissipation): breathers and the free
//! oscillations of a backbone curve, found at a fixed period by shooting on time-reversal
//! symmetry and continued in frequency (the module docs of [`crate::periodic`] give the method).

use std::sync::atomic::{AtomicBool, Ordering};

use crate::chain::model::{spec_err, Chain, SpecError};
use crate::integrate::IntegrationStats;
use crate::observe::probes::{Probe, RecordSpec};
use crate::observe::steady::SteadyStateSpec;
use crate::periodic::dense::{self, Multiplier};
use crate::periodic::shooting::{
    has_jacobian, integrate_variational, two_period_run, ShootingError,
};
use crate::scene::solve::{state_scales, RunError, RunOutput};
use crate::scene::{Excitation, Scene};

/// The flow of an undriven, undissipative chain from a turning point (every velocity zero,
/// positions `x`) and its sensitivity to those positions.
#[derive(Debug, Clone)]
pub struct AutonomousMap {
    scene: Scene,
    chain: Chain,
    /// The whole static state, into which positions are written.
    start: Vec<f64>,
    /// The natural scales of positions and velocities (`2N`).
    scales: Vec<f64>,
    /// The positions of the scene's initial state: the first guess.
    guess: Vec<f64>,
}

/// A periodic orbit of a conservative chain, symmetric in time about its turning point at
/// `t = 0`.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct AutonomousOrbit {
    /// The period `T`, s.
    pub period_s: f64,
    /// The positions at `t = 0` (every velocity zero there).
    pub positions: Vec<f64>,
    /// Positions and velocities at `T/2`, the other turning point (velocities zero to the
    /// tolerance).
    pub half: Vec<f64>,
    /// The monodromy matrix over the whole period, row-major `2N × 2N` (left out of its
    /// serialisation: what is kept of an orbit is its multipliers).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub monodromy: Vec<f64>,
    /// Its eigenvalues, largest modulus first: two at `+1` (a shift along the orbit and a change
    /// of its energy, i.e. of its frequency, are not damped), the others in pairs `μ`, `1/μ̄`.
    pub multipliers: Vec<Multiplier>,
    /// Newton iterations taken.
    pub iterations: u32,
    /// Flows integrated with their variational equations (half periods, and the whole period
    /// of the monodromy).
    pub flows: u32,
    /// `max_i |v_i(T/2)| / s_i` at the orbit.
    pub residual: f64,
    /// Steps and evaluations of all the integrations.
    pub stats: IntegrationStats,
}

impl AutonomousOrbit {
    /// Its frequency `1/T`, Hz.
    pub fn frequency_hz(&self) -> f64 {
        1.0 / self.period_s
    }

    /// Half the difference of the positions at the two turning points, `(x(0) − x(T/2))/2`: the
    /// odd harmonics of each particle's motion (`x(t) = Σ_k c_k cos kωt` about a turning point),
    /// the fundamental's amplitude `c_1` plus `c_3 + c_5 + …`; the mean and the even harmonics
    /// cancel.
    pub fn odd_part(&self) -> Vec<f64> {
        self.positions
            .iter()
            .zip(&self.half)
            .map(|(a, b)| 0.5 * (a - b))
            .collect()
    }

    /// The indices of the two multipliers nearest `+1`, the pair every autonomous orbit has.
    fn trivial_pair(&self) -> [usize; 2] {
        let mut order: Vec<usize> = (0..self.multipliers.len()).collect();
        let distance = |i: usize| (self.multipliers[i].0 - 1.0).hypot(self.multipliers[i].1);
        order.sort_by(|&a, &b| distance(a).total_cmp(&distance(b)));
        [order[0], order.get(1).copied().unwrap_or(order[0])]
    }

    /// How far the pair of multipliers nearest `+1` lies from it (the larger distance): the
    /// accuracy of the monodromy, zero in exact arithmetic.
    pub fn trivial_pair_error(&self) -> f64 {
        self.trivial_pair()
            .iter()
            .map(|&i| (self.multipliers[i].0 - 1.0).hypot(self.multipliers[i].1))
            .fold(0.0, f64::max)
    }

    /// The largest modulus of the multipliers other than the pair at `+1`.
    pub fn largest_nontrivial_multiplier(&self) -> f64 {
        let pair = self.trivial_pair();
        self.multipliers
            .iter()
            .enumerate()
            .filter(|(i, _)| !pair.contains(i))
            .map(|(_, m)| m.0.hypot(m.1))
            .fold(0.0, f64::max)
    }

    /// Whether the orbit is linearly stable: every multiplier but the pair at `+1` on the unit
    /// circle to `tolerance` (a conservative orbit's multipliers come in pairs `μ`, `1/μ̄`, so
    /// none inside without one outside).
    pub fn stable(&self, tolerance: f64) -> bool {
        self.largest_nontrivial_multiplier() <= 1.0 + tolerance
    }

    /// Whether the orbit is stable to the accuracy of its monodromy: [`Self::stable`] within the
    /// larger of 1e-6 and [`Self::trivial_pair_error`] (the splitting of the pair at `+1`, a
    /// Jordan block, bounds how far rounding and the tolerance move a simple multiplier).
    pub fn stable_to_its_accuracy(&self) -> bool {
        self.stable(self.trivial_pair_error().max(dense::UNIT_CIRCLE_TOLERANCE))
    }
}

/// Below this share of its motion at the fundamental an orbit found at period `T` is one of
/// period `T/k` (its fundamental vanishes but for the tolerance), not an orbit of that frequency.
const MIN_FUNDAMENTAL_SHARE: f64 = 1e-3;

/// Where a family of autonomous orbits ended.
#[derive(Debug, Clone)]
pub struct AutonomousFamily {
    /// The orbits found, in the order of the frequencies.
    pub orbits: Vec<AutonomousOrbit>,
    /// Why it stopped before the last frequency (the frequency and shooting's error), if it did.
    pub end: Option<String>,
    /// Whether the stop flag stopped it (it can be resumed from its last orbits).
    pub stopped: bool,
}

impl AutonomousMap {
    /// The flow of `scene`'s chain, which must be set in motion by an initial state
    /// (`excitation.initial_state`, whose displacements are the first guess of an orbit's
    /// turning point; its velocities are ignored), with elastic contacts and no dissipation.
    /// Errors name the field.
    pub fn new(scene: &Scene) -> Result<AutonomousMap, SpecError> {
        let mut scene = scene.clone();
        if !matches!(scene.excitation, Some(Excitation::InitialState(_))) {
            return Err(spec_err(
                "excitation",
                "an autonomous periodic orbit starts from an initial state (excitation.initial_state, the displacements of the first guess); a drive makes a driven orbit, found by PeriodMap",
            ));
        }
        scene.continuation = None;
        scene.record = Default::default();
        let chain = scene.validate()?;
        if chain.has_damping() {
            return Err(spec_err(
                "physics.damping_kg_s",
                "a dissipative chain has no free periodic orbits: its motion decays to rest; autonomous orbits need no damping",
            ));
        }
        if chain.has_plasticity() {
            return Err(spec_err(
                "chain",
                "plastic contacts dissipate and keep a history: autonomous orbits need elastic contacts",
            ));
        }
        let n = chain.n_particles();
        let start = chain.initial_state(0.0);
        if !has_jacobian(&chain, &start) {
            return Err(spec_err(
                "chain",
                "the chain gives no acceleration Jacobian (a mounted wall), which shooting on the variational equations needs",
            ));
        }
        let guess = scene.initial_state(&chain)[..n].to_vec();
        let scales = state_scales(&chain, &scene.impact_scales(&chain))[..2 * n].to_vec();
        Ok(AutonomousMap {
            scene,
            chain,
            start,
            scales,
            guess,
        })
    }

    /// Particles in the chain.
    pub fn n_particles(&self) -> usize {
        self.chain.n_particles()
    }

    /// The chain's static positions.
    pub fn rest_positions(&self) -> &[f64] {
        &self.start[..self.n_particles()]
    }

    /// The positions of the scene's initial state: the first guess of a turning point.
    pub fn first_guess(&self) -> &[f64] {
        &self.guess
    }

    /// The natural scales of positions and velocities (`2N`) the residual is measured in.
    pub fn scales(&self) -> &[f64] {
        &self.scales
    }

    /// The built chain.
    pub fn chain(&self) -> &Chain {
        &self.chain
    }

    /// The run of `scene`'s record (its probes; no histories) over two periods of `orbit` from
    /// its turning point, with the steady-state analysis at the orbit's frequency over both: its
    /// probes' harmonics, and in their settledness how far the second period departs from the
    /// first (rounding and the tolerance, for an orbit that is periodic).
    pub fn orbit_run(&self, scene: &Scene, orbit: &AutonomousOrbit) -> Result<RunOutput, RunError> {
        two_period_run(
            &self.scene,
            scene.record.clone(),
            orbit.frequency_hz(),
            self.turning_point(&orbit.positions),
        )
    }

    /// The whole state at a turning point with positions `x`: every velocity zero.
    fn turning_point(&self, x: &[f64]) -> Vec<f64> {
        let n = self.n_particles();
        let mut y = self.start.clone();
        y[..n].copy_from_slice(x);
        y[n..2 * n].fill(0.0);
        y
    }

    /// How much of the motion from the turning point `x` over two periods `period_s` is at the
    /// fundamental `1/period_s`: the largest fundamental amplitude of a particle's displacement
    /// over the largest amplitude `√2 σ` of one (σ its standard deviation), each in the
    /// particle's position scale. About 1 for an orbit of period `period_s`; 0 for one of period
    /// `period_s / k`, which repeats `k` times (sampled 64 times a period: a motion of many more
    /// repeats aliases).
    fn fundamental_share(&self, x: &[f64], period_s: f64) -> Result<f64, RunError> {
        let n = self.n_particles();
        let record = RecordSpec {
            probes: (1..=n)
                .map(|particle| Probe::Displacement { particle })
                .collect(),
            steady_state: Some(SteadyStateSpec {
                harmonics: 1,
                ..SteadyStateSpec::new(None, 0, 2)
            }),
            ..RecordSpec::default()
        };
        let out = two_period_run(&self.scene, record, 1.0 / period_s, self.turning_point(x))?;
        let Some(steady) = out.steady_state else {
            return Ok(1.0);
        };
        let (mut fundamental, mut motion) = (0.0f64, 0.0f64);
        for (p, scale) in steady.probes.iter().zip(&self.scales) {
            let sigma = (p.rms * p.rms - p.mean * p.mean).max(0.0).sqrt();
            // An incomplete window (NaN) cannot tell: not refused.
            if !(p.amplitude[0].is_finite() && sigma.is_finite()) {
                return Ok(1.0);
            }
            fundamental = fundamental.max(p.amplitude[0] / scale);
            motion = motion.max(std::f64::consts::SQRT_2 * sigma / scale);
        }
        Ok(if motion > 0.0 {
            fundamental / motion
        } else {
            0.0
        })
    }

    /// Positions and velocities at `t` from the turning point `x` (every velocity zero), and
    /// `Φ = ∂(x, v)(t)/∂(x, v)(0)`, row-major `2N × 2N`, by the variational equations.
    pub fn flow(
        &self,
        x: &[f64],
        t: f64,
    ) -> Result<(Vec<f64>, Vec<f64>, IntegrationStats), RunError> {
        let n = self.n_particles();
        let y0 = self.turning_point(x);
        let (mut y, phi, _, stats) =
            integrate_variational(&self.scene, &self.chain, &y0, &self.scales, t)?;
        y.truncate(2 * n);
        Ok((y, phi, stats))
    }

    /// The orbit of period `period_s` through a turning point near `x0`: Newton's method on the
    /// `N` conditions `v(T/2) = 0` in the `N` unknowns `x(0)` (a motion that turns at `t = 0` and
    /// again at `T/2` retraces itself backwards, time-reversal symmetry, and so has period `T`),
    /// each step `(∂v(T/2)/∂x(0)) Δx = −v(T/2)` from the variational equations, halved (up to 5
    /// times) while it does not reduce the residual `max_i |v_i(T/2)| / s_i`, to `tolerance`
    /// in at most `max_iterations`; then the monodromy over the whole period and its
    /// multipliers. The static state is such an orbit at every period: a guess must start
    /// closer to the orbit sought.
    pub fn shoot(
        &self,
        x0: &[f64],
        period_s: f64,
        tolerance: f64,
        max_iterations: u32,
    ) -> Result<AutonomousOrbit, ShootingError> {
        let n = self.n_particles();
        let half_period = 0.5 * period_s;
        let residual_of = |y: &[f64]| {
            (0..n)
                .map(|i| y[n + i].abs() / self.scales[n + i])
                .fold(0.0, f64::max)
        };
        let mut x = x0.to_vec();
        let (mut y, mut phi, mut stats) = self.flow(&x, half_period)?;
        let mut flows = 1;
        let mut residual = residual_of(&y);
        for iteration in 0.. {
            if residual <= tolerance {
                // The static state satisfies v(T/2) = 0 at every period: not the orbit sought.
                let motion = (0..n)
                    .map(|i| (x[i] - self.start[i]).abs() / self.scales[i])
                    .fold(0.0, f64::max);
                if motion <= tolerance {
                    return Err(ShootingError::StaticState { motion });
                }
                // Nor does an orbit of period T/k, which turns at T/2 too: its motion has no
                // fundamental at 1/T.
                let share = self.fundamental_share(&x, period_s)?;
                if share < MIN_FUNDAMENTAL_SHARE {
                    return Err(ShootingError::MultipleCover { share });
                }
                let (_, monodromy, s) = self.flow(&x, period_s)?;
                stats.add(&s);
                flows += 1;
                let multipliers =
                    dense::multipliers(&monodromy, 2 * n).ok_or(ShootingError::Multipliers)?;
                return Ok(AutonomousOrbit {
                    period_s,
                    positions: x,
                    half: y,
                    monodromy,
                    multipliers,
                    iterations: iteration,
                    flows,
                    residual,
                    stats,
                });
            }
            if iteration >= max_iterations {
                return Err(ShootingError::NotConverged {
                    iterations: max_iterations,
                    residual,
                    tolerance,
                });
            }
            // ∂v(T/2)/∂x(0): rows n.., columns ..n of Φ.
            let mut a: Vec<f64> = (0..n)
                .flat_map(|i| (0..n).map(move |j| (i, j)))
                .map(|(i, j)| phi[(n + i) * 2 * n + j])
                .collect();
            let mut dx: Vec<f64> = y[n..].iter().map(|v| -v).collect();
            dense::solve(&mut a, n, &mut dx).ok_or(ShootingError::Singular)?;
            let mut lambda = 1.0;
            loop {
                let trial: Vec<f64> = x.iter().zip(&dx).map(|(x, d)| x + lambda * d).collect();
                let (ty, tphi, s) = self.flow(&trial, half_period)?;
                stats.add(&s);
                flows += 1;
                let r = residual_of(&ty);
                if r < residual || lambda < 0.05 {
                    (x, y, phi, residual) = (trial, ty, tphi, r);
                    break;
                }
                lambda *= 0.5;
            }
        }
        unreachable!("the loop returns")
    }
}

/// The family of autonomous orbits through the frequencies `frequencies_hz` (in the order
/// given), by natural-parameter continuation: the orbit at each frequency by
/// [`AutonomousMap::shoot`] from a guess extrapolated linearly from the two orbits before it (the
/// first from `first_guess`, the second from the first). Calls `on_orbit` with each. Stops at
/// the first frequency where shooting fails: the orbits found before it and why it stopped.
pub fn continue_autonomous(
    map: &AutonomousMap,
    first_guess: &[f64],
    frequencies_hz: &[f64],
    tolerance: f64,
    max_iterations: u32,
    on_orbit: &mut dyn FnMut(&AutonomousOrbit),
) -> (Vec<AutonomousOrbit>, Option<String>) {
    let family = resume_autonomous(
        map,
        first_guess,
        &[],
        frequencies_hz,
        tolerance,
        max_iterations,
        None,
        on_orbit,
    );
    (family.orbits, family.end)
}

/// [`continue_autonomous`] going on after the orbits `before` (the family's orbits found so far,
/// in order; only the last two are used), through `frequencies_hz` (those still to do), checking
/// `stop` before each orbit: the guesses, and so the orbits, are those the uninterrupted
/// continuation makes. The family returned holds the new orbits only.
#[allow(clippy::too_many_arguments)]
pub fn resume_autonomous(
    map: &AutonomousMap,
    first_guess: &[f64],
    before: &[AutonomousOrbit],
    frequencies_hz: &[f64],
    tolerance: f64,
    max_iterations: u32,
    stop: Option<&AtomicBool>,
    on_orbit: &mut dyn FnMut(&AutonomousOrbit),
) -> AutonomousFamily {
    let mut last: Vec<AutonomousOrbit> = before[before.len().saturating_sub(2)..].to_vec();
    let mut orbits: Vec<AutonomousOrbit> = Vec::new();
    for &f in frequencies_hz {
        if stop.is_some_and(|s| s.load(Ordering::Relaxed)) {
            return AutonomousFamily {
                orbits,
                end: None,
                stopped: true,
            };
        }
        let guess = match last.as_slice() {
            [] => first_guess.to_vec(),
            [a] => a.positions.clone(),
            [.., a, b] => {
                let t = (f - b.frequency_hz()) / (b.frequency_hz() - a.frequency_hz());
                a.positions
                    .iter()
                    .zip(&b.positions)
                    .map(|(a, b)| b + t * (b - a))
                    .collect()
            }
        };
        match map.shoot(&guess, 1.0 / f, tolerance, max_iterations) {
            Ok(orbit) => {
                on_orbit(&orbit);
                if last.len() == 2 {
                    last.remove(0);
                }
                last.push(orbit.clone());
                orbits.push(orbit);
            }
            Err(e) => {
                return AutonomousFamily {
                    orbits,
                    end: Some(format!("at {f} Hz: {e}")),
                    stopped: false,
                }
            }
        }
    }
    AutonomousFamily {
        orbits,
        end: None,
        stopped: false,
    }
}
