//! `run --verify FRACTION`: a deterministic sample of grid points is run again at a tighter
//! setting, and the observed relative error of each summary is stored with the sweep.
//!
//! - The sample is a pure function of the grid: the points are ordered by the SHA-256 of the
//!   sweep key (the SHA-256 of every run hash, in grid order) and the point's flat index, and the
//!   first `ceil(FRACTION × n)` are taken. Every shard computes the same sample and runs the
//!   verifications of its own points, so a merge of shards equals a single-machine run.
//! - The tighter setting: DOP853 and ROS34PW2 at `rtol / 100` (and `atol / 100` when given),
//!   RK4 and Verlet at `dt / 4`; the step budget is multiplied by 4 (fixed-step methods need four
//!   times the steps).
//! - What is compared ([`compare`]): every probe's leading peak, its time, record maximum and its
//!   time; the steady state (the complex amplitude of every harmonic against the fundamental's, the
//!   mean and the RMS against the RMS); the largest overlap; the energy flow (every contact's
//!   largest and final energy passed, every particle's largest kinetic energy, against the largest
//!   of them). Each error is a bound on the run's own error `e` from its difference `d` to the
//!   tighter run, whose own error `e_t` it cannot see: `|e| ≤ d + |e_t|` ([`Allowance`]). A
//!   fixed-step method's error falls as the step's power, so `|e_t| ≤ s |e|` with `s = 4^-p` and
//!   `|e| ≤ d / (1 − s)`. An adaptive method's error usually falls tenfold or more with a
//!   hundredfold tighter tolerance (`s` = [`TIGHTER_ERROR_SHARE`]), but not everywhere: where an
//!   error is set by where a step lands on a switch rather than by the tolerance, both runs can
//!   share it (measured: a plastic contact's peak 2.5e-8 off from rtol 1e-6 to 1e-9, the two runs
//!   6.6e-9 apart). So the tighter run's error is also bounded by its tolerance: `|e_t| ≤ K
//!   rtol_t` with `K` = [`TIGHTER_ERROR_FACTOR`] (global errors measured 25–100 rtol), and the
//!   bound is `d / (1 − s) + K rtol_t` — never below the run's own rtol.
//! - What is not ([`NOT_VERIFIED`]): histories, minimum overlaps and space–time fields are not
//!   recorded by verification runs; the spectrum is not integrated (it is the same in both).
//! - A verification run is a run like any other: its record is stored in the work directory,
//!   under the hash of the tightened scene with a marker ([`verify_hash`]), so an interrupted
//!   verification resumes, and a point once verified stays verified in later assemblies.

use chainsweep_solver::{AdaptiveOptions, IntegratorSpec, Scene};
use sha2::{Digest, Sha256};

use chainsweep_solver::observe::flow::EnergyFlow;
use chainsweep_solver::observe::steady::SteadyProbe;

use super::{max_ignoring_nan, rel_error};
use crate::grid::Grid;
use crate::identity::{verify_hash, RunHash};
use crate::record::{RunRecord, VerifyInfo, VERIFY_FAILED, VERIFY_OK, VERIFY_PROBE_ERRORS};
use crate::sweep::Sweep;

/// What `--verify` does not compare, each with why: named by `run`'s report where a sweep records
/// it.
pub const NOT_VERIFIED: [(&str, &str); 5] = [
    ("histories", "not recorded by verification runs"),
    ("minimum overlaps", "not recorded by verification runs"),
    ("space-time fields", "not recorded by verification runs"),
    (
        "the spectrum",
        "not integrated in time: the same at any tolerance (exact to rounding)",
    ),
    (
        "the energy ledger's terms",
        "not compared (the ledger's closure is `energy_drift_max`, which is)",
    ),
];

/// The integrator one notch tighter (see the module docs).
pub fn tighten(mut spec: IntegratorSpec) -> IntegratorSpec {
    if let Some(dt_s) = spec.fixed_step_s() {
        return spec
            .method()
            .fixed(dt_s / 4.0)
            .expect("a method with a fixed step");
    }
    let o = spec
        .adaptive_options_mut()
        .expect("a method is adaptive or has a fixed step");
    *o = tighten_adaptive(*o);
    spec
}

/// An adaptive method's options a hundred times tighter (within the ranges a scene allows).
fn tighten_adaptive(o: AdaptiveOptions) -> AdaptiveOptions {
    AdaptiveOptions {
        rtol: (o.rtol / 100.0).max(1e-15),
        atol: o.atol.map(|a| (a / 100.0).max(1e-18)),
        ..o
    }
}

/// The verification scene of a grid point's scene.
pub fn tight_scene(scene: &Scene) -> Scene {
    let mut s = scene.clone();
    s.integrator = tighten(scene.integrator);
    s.max_steps = scene.max_steps.saturating_mul(4);
    s.record.history = false;
    s.record.min_overlap = false;
    s.record.fields = None;
    s
}

/// The key of a sweep for sampling: the SHA-256 of every run hash in grid order.
pub fn sweep_key(grid: &Grid) -> [u8; 32] {
    let mut h = Sha256::new();
    h.update(b"chainsweep verification sample v1\n");
    for x in &grid.hashes {
        h.update(x);
    }
    h.finalize().into()
}

/// Which grid points are verified at `fraction` (in [0, 1]): exactly `ceil(fraction × n)` of
/// them, a deterministic pseudo-random sample seeded by the sweep key.
pub fn sample(grid: &Grid, fraction: f64) -> Vec<bool> {
    let n = grid.len();
    let mut chosen = vec![false; n];
    if fraction.is_nan() || fraction <= 0.0 {
        return chosen;
    }
    let k = ((fraction.min(1.0) * n as f64).ceil() as usize).min(n);
    let key = sweep_key(grid);
    let mut order: Vec<(u64, usize)> = (0..n)
        .map(|i| {
            let mut h = Sha256::new();
            h.update(key);
            h.update((i as u64).to_le_bytes());
            let d: [u8; 32] = h.finalize().into();
            (u64::from_le_bytes(d[..8].try_into().expect("8 bytes")), i)
        })
        .collect();
    order.sort_unstable();
    for &(_, i) in &order[..k] {
        chosen[i] = true;
    }
    chosen
}

/// The largest share of a run's error that its verification run, a hundred times tighter, is
/// taken to keep (adaptive methods; see the module docs).
pub const TIGHTER_ERROR_SHARE: f64 = 0.1;

/// How many times its relative tolerance an adaptive verification run's own error is taken to be
/// at most (see the module docs).
pub const TIGHTER_ERROR_FACTOR: f64 = 100.0;

/// What a verification run's own error adds to the difference between it and the run it
/// verifies: a share of the run's error, and a floor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Allowance {
    /// The largest share of the run's error the verification run keeps.
    pub share: f64,
    /// The largest error of the verification run whatever the run's (relative).
    pub floor: f64,
}

impl Allowance {
    /// The allowance of a verification run under `tight`, the run's integrator `base`
    /// tightened. An adaptive one's tolerance a hundred times tighter keeps at most
    /// [`TIGHTER_ERROR_SHARE`] of the run's error; tightened less (the run's rtol below 1e-13,
    /// the tighter one held at 1e-15), it keeps that share times how much less, and where that
    /// reaches half the run's error (tightened less than twenty times: at rtol 1e-15 the same
    /// run) nothing is bounded: the errors are NaN, not the floor of a run compared with itself.
    pub fn of(base: &IntegratorSpec, tight: &IntegratorSpec) -> Allowance {
        match (base.adaptive_options(), tight.adaptive_options()) {
            (Some(b), Some(o)) => {
                let tightened = b.rtol / o.rtol;
                let share = TIGHTER_ERROR_SHARE * (100.0 / tightened).max(1.0);
                Allowance {
                    share: if share < 0.5 { share } else { f64::NAN },
                    floor: TIGHTER_ERROR_FACTOR * o.rtol,
                }
            }
            // A fixed step of order p at a quarter of the step: 4^-p of the error.
            _ => Allowance {
                share: 0.25f64.powi(tight.method().order()),
                floor: 0.0,
            },
        }
    }

    /// The bound on a run's error from its difference `d` to the verification run (NaN and
    /// infinities as they are).
    pub fn bound(&self, d: f64) -> f64 {
        if d.is_finite() {
            d / (1.0 - self.share) + self.floor
        } else {
            d
        }
    }
}

/// The verification outcome of a point from its run and its verification run.
pub fn compare(
    base: &RunRecord,
    tight: Option<&RunRecord>,
    n_probes: usize,
    allowance: Allowance,
) -> VerifyInfo {
    let Some(tight) = tight else {
        return VerifyInfo::none(n_probes);
    };
    if !tight.ok {
        return VerifyInfo {
            status: VERIFY_FAILED,
            ..VerifyInfo::none(n_probes)
        };
    }
    if !base.ok {
        return VerifyInfo::none(n_probes);
    }
    let errors: Vec<[f64; VERIFY_PROBE_ERRORS]> = (0..n_probes)
        .map(|p| {
            let (a, r) = (base.probes.get(p), tight.probes.get(p));
            let e = |get: fn(&chainsweep_solver::observe::probes::ProbeSummary) -> f64| match (a, r)
            {
                (Some(a), Some(r)) => rel_error(get(a), get(r)),
                _ => f64::NAN,
            };
            [
                e(|s| s.leading_peak),
                e(|s| s.leading_peak_time_s),
                e(|s| s.record_max),
                e(|s| s.record_max_time_s),
                match (base.steady_probe(p), tight.steady_probe(p)) {
                    (Some(a), Some(r)) => steady_error(a, r),
                    _ => f64::NAN,
                },
            ]
        })
        .collect();
    let flow = match (&base.energy_flow, &tight.energy_flow) {
        (Some(a), Some(r)) => flow_error(a, r),
        _ => f64::NAN,
    };
    let bound = |d| allowance.bound(d);
    let errors = errors.into_iter().map(|e| e.map(bound)).collect();
    VerifyInfo {
        status: VERIFY_OK,
        errors,
        run_errors: [rel_error(base.max_overlap_m, tight.max_overlap_m), flow].map(bound),
    }
}

/// The error of a probe's steady state against the tighter run's: the largest of each harmonic's
/// complex amplitude `A_k e^{iφ_k}` against the fundamental's amplitude, and of the mean and the
/// RMS against the RMS (a mean or a harmonic may be near zero, which a relative error of its own
/// would inflate). (Harmonics against the RMS understated them where a probe carries a mean, a
/// preload, far above its oscillation: 1e-5 reported, 4.5e-5 true.)
fn steady_error(a: &SteadyProbe, r: &SteadyProbe) -> f64 {
    // The oscillation's amplitude, √2 σ, where the fundamental is rounding (a node, a
    // response at 2f): the harmonics' errors are not divided by nothing.
    let oscillation = (2.0 * (r.rms * r.rms - r.mean * r.mean)).max(0.0).sqrt();
    let fundamental = r.amplitude.first().copied().unwrap_or(0.0);
    let harmonic_scale = fundamental.max(oscillation);
    let against = |d: f64, scale: f64| if d == 0.0 { 0.0 } else { d / scale };
    let mut worst =
        against((a.mean - r.mean).abs(), r.rms).max(against((a.rms - r.rms).abs(), r.rms));
    for k in 0..a.amplitude.len().min(r.amplitude.len()) {
        let (x, y) = (
            (
                a.amplitude[k] * a.phase_rad[k].cos(),
                a.amplitude[k] * a.phase_rad[k].sin(),
            ),
            (
                r.amplitude[k] * r.phase_rad[k].cos(),
                r.amplitude[k] * r.phase_rad[k].sin(),
            ),
        );
        worst = worst.max(against((x.0 - y.0).hypot(x.1 - y.1), harmonic_scale));
    }
    worst
}

/// The error of an energy flow against the tighter run's: the largest difference of any of its
/// values against the largest of them (the energy that flows is a fraction of what came in).
fn flow_error(a: &EnergyFlow, r: &EnergyFlow) -> f64 {
    let values = |f: &EnergyFlow| -> Vec<f64> {
        f.energy_passed_max_j
            .iter()
            .chain(&f.energy_passed_final_j)
            .chain(&f.max_kinetic_energy_j)
            .copied()
            .collect()
    };
    let (x, y) = (values(a), values(r));
    if x.len() != y.len() {
        return f64::INFINITY;
    }
    let scale = max_ignoring_nan(y.iter().map(|v| v.abs()));
    let worst = max_ignoring_nan(x.iter().zip(&y).map(|(a, b)| (a - b).abs()));
    if worst == 0.0 {
        0.0
    } else {
        worst / scale
    }
}

/// The verification scene and hash of point `i`, and what its run's own error adds.
pub fn point_verification(sweep: &Sweep, grid: &Grid, i: usize) -> (Scene, RunHash, Allowance) {
    let scene = grid.build(sweep, i).expect("every point was validated");
    let tight = tight_scene(&scene);
    let h = verify_hash(&grid.hashes[i], &tight);
    let allowance = Allowance::of(&scene.integrator, &tight.integrator);
    (tight, h, allowance)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tightening() {
        assert_eq!(
            tighten(IntegratorSpec::Rk4 { dt_s: 4e-8 }),
            IntegratorSpec::Rk4 { dt_s: 1e-8 }
        );
        match tighten(IntegratorSpec::default()) {
            IntegratorSpec::Dop853(AdaptiveOptions { rtol, atol, .. }) => {
                assert!((rtol - 1e-11).abs() < 1e-25);
                assert_eq!(atol, None);
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_tolerance_that_cannot_be_tightened_enough_bounds_nothing() {
        let at = |rtol: f64| {
            let mut base = IntegratorSpec::default();
            base.adaptive_options_mut().expect("adaptive").rtol = rtol;
            Allowance::of(&base, &tighten(base))
        };
        assert_eq!(at(1e-9).share, TIGHTER_ERROR_SHARE);
        assert_eq!(at(1e-13).share, TIGHTER_ERROR_SHARE);
        // Tightened 50 times (the tighter run held at 1e-15): twice the share.
        assert!((at(5e-14).share - 2.0 * TIGHTER_ERROR_SHARE).abs() < 1e-12);
        // Ten times, or not at all: the verification run is nearly or exactly the run itself.
        for rtol in [1e-14, 1e-15] {
            assert!(at(rtol).bound(1e-13).is_nan(), "{rtol}");
        }
    }

    #[test]
    fn a_steady_harmonics_error_is_against_the_fundamental_not_a_preload() {
        // A contact under 20 N oscillating by 1e-3 N: a 4.5e-8 N error of the fundamental is
        // 4.5e-5 of it, not 2e-9 of the RMS (the preload).
        let probe = |a1: f64| SteadyProbe {
            mean: 20.0,
            rms: (400.0 + a1 * a1 / 2.0).sqrt(),
            amplitude: vec![a1],
            phase_rad: vec![0.0],
            settledness: 0.0,
            settled: true,
            transmission_db: 0.0,
        };
        let e = steady_error(&probe(1e-3 + 4.5e-8), &probe(1e-3));
        assert!((e - 4.5e-5).abs() < 1e-7, "{e}");
        // A fundamental that is rounding (a probe responding at 2f): against the oscillation.
        let at_2f = |a2: f64| SteadyProbe {
            mean: 0.0,
            rms: a2 / 2f64.sqrt(),
            amplitude: vec![1e-20, a2],
            phase_rad: vec![0.0, 0.0],
            settledness: 0.0,
            settled: true,
            transmission_db: 0.0,
        };
        let e = steady_error(&at_2f(1.0 + 1e-9), &at_2f(1.0));
        assert!(e < 1e-8, "{e}");
    }
}
