//! `integrator: auto`: the engine picks the cheapest integrator setting that meets a target
//! relative error, from a short pilot on a few grid points, and records what it chose.
//!
//! A sweep asks for it in its base scene:
//!
//! ```json
//! "integrator": {"method": "auto", "target_rel_error": 1e-6, "pilot_points": 5}
//! ```
//!
//! (`pilot_points` is optional, default
//! [`DEFAULT_PILOT_POINTS`](crate::sweep::auto::DEFAULT_PILOT_POINTS); the request and the
//! choice are plain data in [`crate::sweep::auto`].) The solver knows no `auto`
//! method: the runner resolves it to one concrete [`IntegratorSpec`] before it builds the grid's
//! scenes, so run hashes, `status`, `point`, `merge`, dry runs and resume all see concrete scenes,
//! and a grid point of an `auto` sweep is the same run as that point with the chosen setting
//! written out.
//!
//! The resolution is a pure function of the sweep (deterministic on every machine, for any
//! `--jobs` and in every shard), because it decides by right-hand-side evaluation counts and
//! errors, never by wall time:
//!
//! 1. **Pilot points** ([`pilot_points`]): the first and last corners of the grid, its stiffest
//!    point (largest `μ τ / m_min`, see [`super::accuracy::scene_scales`]), its centre, then the
//!    other corners, without repeats, at most `pilot_points` of them.
//! 2. **Reference** on each pilot point: DOP853 at rtol 1e-12, or ROS34PW2 at rtol
//!    [`ROS34PW2_REFERENCE_RTOL`] where damping dominates (stiffness ratio over [`STIFF_RATIO`],
//!    as in `chainsweep accuracy`) and the target is at least [`ROS_REFERENCE_MIN_TARGET`]
//!    (ROS34PW2's reference is itself only ~5e-9 accurate in a peak's time, so tighter targets
//!    keep the DOP853 reference there too).
//! 3. **Candidates** ([`ladders`]), cheapest first: DOP853 with `predict_switches` and plain DOP853
//!    at rtol = target × [`DOP853_FACTORS`], and ROS34PW2 at rtol = target × [`ROS34PW2_FACTORS`]
//!    (ROS34PW2 first when a pilot point is damping-dominated). A candidate's error at a pilot
//!    point is the largest relative error of `leading_peak`, `leading_peak_time_s` and `record_max`
//!    over the probes against the reference — the quantity `run --verify` stores as
//!    `verify_rel_error_max`. It meets the target when that error is at most `target /
//!    SAFETY_FACTOR` (ROS34PW2: `target / ROS34PW2_SAFETY_FACTOR`) at every pilot point and every
//!    pilot run succeeds (energy-drift limit included). A method's ladder stops at its first
//!    candidate that meets the target, or once a candidate costs more than the best found.
//! 4. **Choice**: the candidate meeting the target with the smallest pilot cost, the sum of its
//!    RHS evaluations over the pilot points weighted by [`ROS34PW2_EVAL_WEIGHT`] for ROS34PW2.
//!    When none meets the target, the sweep is refused (exit 2) with the best error reached.
//!
//! The choice ([`AutoChoice`]) is cached in the output's work directory (`X.h5.d/auto.json`,
//! written atomically) under a key ([`cache_key`]) that covers every unresolved run hash (hence
//! the base scene, axes, record block, limits, numerics and solver versions), the request and
//! [`AUTO_VERSION`], so runs after the first, resumes and `status` do not repeat the pilot. It is
//! stored in the HDF5 file as root attributes (`auto`, `auto_method`, `auto_setting`, …), which
//! is also where `merge` takes it from.

use std::path::Path;
use std::time::Instant;

use chainsweep_solver::{IntegratorSpec, Method, Scene};
use rayon::prelude::*;
use sha2::{Digest, Sha256};

use super::accuracy::{scene_scales, STIFF_RATIO};
use super::{max_ignoring_nan, probe_errors, round3};
use crate::error::{Error, Result};
use crate::exec;
use crate::grid::Grid;
use crate::identity::hex;
use crate::record::RunRecord;
use crate::store::read_auto_choice_in;
use crate::sweep::auto::{adaptive, describe, AutoChoice, AutoSpec, Candidate};
use crate::sweep::{Limits, Sweep};

/// Version of the resolution procedure: part of the cache key, so a change of the procedure
/// re-runs the pilot of sweeps resolved before.
/// Version 2: DOP853 with `predict_switches` is a ladder of its own, tried first.
/// Version 3: with peaks located on the dense output, ROS34PW2's reference is at rtol 2e-11 and
/// its ladder reaches 2e-10: its third-order interpolant places a peak's time only to about 250
/// rtol (2.6e-7 at rtol 1e-9 on `sweeps/stress/auto-stiff.json`), which the sample-based
/// refinement of the same samples in both runs had hidden.
pub const AUTO_VERSION: u32 = 3;

/// A DOP853 candidate must reach `target / SAFETY_FACTOR` on the pilot points, because the pilot
/// sees a few points of the grid and the error of a tolerance-controlled method scatters between
/// grid points with a heavy tail (mostly in the leading-peak time and late record maxima).
/// Calibrated on five sweeps of `sweeps/` (fig08, fig08-light, critical-damping, mass-damping,
/// velocity-zip) at seven DOP853 tolerances, 1e-6 … 1e-9, with `run --verify 1`: the largest
/// error over the grid was above the five pilot points' largest by up to 4.5× (fig08), 4.3×
/// (critical-damping) and 30× (mass-damping at rtol 1e-8; 12.5× at 3e-9), and with switch
/// prediction 21× and 13× (mass-damping at 3e-8 and 3e-9). A factor of 5, enough without switch
/// prediction only because its rungs missed the worst tolerances, chose rungs with prediction that
/// missed targets 1e-5 and 1e-6 on mass-damping (1.8e-5, 1.3e-6); with 25 all five sweeps meet
/// both targets at every point. See `docs/NUMERICS.md`.
pub const SAFETY_FACTOR: f64 = 25.0;

/// What a ROS34PW2 candidate must reach on the pilot points, `target / ROS34PW2_SAFETY_FACTOR`:
/// on the damping-dominated grids it is chosen for the pilot's error was the grid's (ratio 1.0
/// on `sweeps/stress/auto-stiff.json`), and its reference (rtol 1e-10) is itself only ~5e-9
/// accurate, which a factor of 25 would not leave room for at a target of 1e-6.
pub const ROS34PW2_SAFETY_FACTOR: f64 = 5.0;

/// The safety factor of a candidate `spec` ([`SAFETY_FACTOR`], [`ROS34PW2_SAFETY_FACTOR`]).
pub fn safety_factor(spec: &IntegratorSpec) -> f64 {
    match spec {
        IntegratorSpec::Ros34pw2(_) => ROS34PW2_SAFETY_FACTOR,
        _ => SAFETY_FACTOR,
    }
}

/// Cost of one ROS34PW2 RHS evaluation in DOP853 evaluations: each comes with its share of
/// Jacobian evaluations and tridiagonal solves. Measured by `chainsweep accuracy` on the five
/// scenes of `docs/NUMERICS.md` (wall time per evaluation, ROS34PW2 over DOP853: 5.4, 6.6, 6.8,
/// 7.0, 7.8).
pub const ROS34PW2_EVAL_WEIGHT: f64 = 7.0;

/// DOP853 candidates: rtol = target × these, loosest first. DOP853's error is 1–10 × rtol on a
/// single scene and 20–1000 × rtol at the worst point of a grid, so rtol = target never reaches
/// `target / SAFETY_FACTOR` and the ladder starts below it.
pub const DOP853_FACTORS: &[f64] = &[0.3, 0.1, 0.03, 0.01, 0.003, 0.001, 3e-4, 1e-4];

/// ROS34PW2 candidates: rtol = target × these, loosest first (its error is ≈ 1–250 × rtol).
pub const ROS34PW2_FACTORS: &[f64] = &[0.1, 0.03, 0.01, 0.003, 0.001, 3e-4];

/// Tightest DOP853 candidate: ten times the reference's tolerance.
pub const DOP853_MIN_RTOL: f64 = 1e-11;

/// Tolerance of the ROS34PW2 reference.
pub const ROS34PW2_REFERENCE_RTOL: f64 = 2e-11;

/// Tightest ROS34PW2 candidate: ten times the tolerance of its reference.
pub const ROS34PW2_MIN_RTOL: f64 = 2e-10;

/// Smallest target for which damping-dominated pilot points take the ROS34PW2 reference.
pub const ROS_REFERENCE_MIN_TARGET: f64 = 1e-6;

/// The cache key of an `auto` sweep: the SHA-256 of [`AUTO_VERSION`], the request, the grid's
/// shape and every run hash of the unresolved grid (which cover the scenes, the limits and the
/// numerics and solver versions).
pub fn cache_key(grid: &Grid, spec: &AutoSpec) -> String {
    let mut h = Sha256::new();
    h.update(b"chainsweep auto resolution\n");
    h.update(format!("version={AUTO_VERSION}\n").as_bytes());
    h.update(
        format!(
            "request={}\n",
            serde_json::to_string(spec).expect("AutoSpec serialises")
        )
        .as_bytes(),
    );
    h.update(format!("shape={:?}\n", grid.shape).as_bytes());
    for x in &grid.hashes {
        h.update(x);
    }
    let d: [u8; 32] = h.finalize().into();
    hex(&d)
}

/// The cached choice in work directory `dir`, if there is one for `key`.
pub fn read_cache(dir: &Path, key: &str) -> Option<AutoChoice> {
    let c = read_auto_choice_in(dir)?;
    (c.key == key && c.version == AUTO_VERSION).then_some(c)
}

/// Pilot points of a grid: the first and last corners, the stiffest point, the centre, then the
/// other corners (row-major order), without repeats, at most `n`; sorted.
pub fn pilot_points(sweep: &Sweep, grid: &Grid, n: usize) -> Result<Vec<usize>> {
    let shape = &grid.shape;
    let flat = |mi: &[usize]| {
        mi.iter()
            .zip(shape)
            .fold(0usize, |acc, (&i, &m)| acc * m + i)
    };
    let last: Vec<usize> = shape.iter().map(|&m| m - 1).collect();
    let centre: Vec<usize> = shape.iter().map(|&m| m / 2).collect();
    let mut order = vec![0, flat(&last)];
    let mut stiffest = (f64::NEG_INFINITY, 0usize);
    for i in 0..grid.len() {
        let r = scene_scales(&grid.build(sweep, i)?)?.stiffness_ratio;
        if r > stiffest.0 {
            stiffest = (r, i);
        }
    }
    order.push(stiffest.1);
    order.push(flat(&centre));
    let d = shape.len().min(16);
    for c in 0..(1usize << d) {
        let mi: Vec<usize> = (0..shape.len())
            .map(|k| {
                if k < d && c >> (d - 1 - k) & 1 == 1 {
                    last[k]
                } else {
                    0
                }
            })
            .collect();
        order.push(flat(&mi));
    }
    let mut out: Vec<usize> = Vec::new();
    for i in order {
        if out.len() == n {
            break;
        }
        if !out.contains(&i) {
            out.push(i);
        }
    }
    out.sort_unstable();
    Ok(out)
}

/// The candidate ladders for `target` in the order they are tried: DOP853 ending its steps on
/// predicted contact switches (about half the evaluations of plain DOP853 on struck chains at the
/// same accuracy), plain DOP853, ROS34PW2; ROS34PW2 first where a pilot point is
/// damping-dominated (`stiff`).
pub fn ladders(target: f64, stiff: bool) -> Vec<Vec<IntegratorSpec>> {
    let dop853 = ladder(Method::Dop853, target);
    let predicting = dop853
        .iter()
        .map(|spec| match *spec {
            IntegratorSpec::Dop853(mut o) => {
                o.predict_switches = true;
                IntegratorSpec::Dop853(o)
            }
            other => other,
        })
        .collect();
    let ros34pw2 = ladder(Method::Ros34pw2, target);
    if stiff {
        vec![ros34pw2, predicting, dop853]
    } else {
        vec![predicting, dop853, ros34pw2]
    }
}

/// The candidate ladder of `method` for `target`, loosest first.
pub fn ladder(method: Method, target: f64) -> Vec<IntegratorSpec> {
    let (factors, min) = if method == Method::Ros34pw2 {
        (ROS34PW2_FACTORS, ROS34PW2_MIN_RTOL)
    } else {
        (DOP853_FACTORS, DOP853_MIN_RTOL)
    };
    factors
        .iter()
        .map(|f| round3(target * f))
        .filter(|&r| r >= min * (1.0 - 1e-9))
        .map(|r| adaptive(method, r))
        .collect()
}

/// The error of a pilot run against the reference: the largest relative error of the leading
/// peak, its time and the record maximum over the probes (`None` where they disagree on whether
/// a value exists; 0 when there is nothing to compare).
pub fn pilot_error(run: &RunRecord, reference: &RunRecord) -> Option<f64> {
    let e = max_ignoring_nan(
        probe_errors(&run.probes, &reference.probes)
            .into_iter()
            .flatten(),
    );
    if e.is_nan() {
        Some(0.0)
    } else if e.is_finite() {
        Some(e)
    } else {
        None
    }
}

/// Weighted cost of `evals` RHS evaluations of `spec`.
fn weighted(spec: &IntegratorSpec, evals: u64) -> f64 {
    match spec {
        IntegratorSpec::Ros34pw2(_) => evals as f64 * ROS34PW2_EVAL_WEIGHT,
        _ => evals as f64,
    }
}

/// Runs `scene` with `spec` (no histories) under `limits` and returns its record.
fn pilot_run(scene: &Scene, spec: IntegratorSpec, max_steps: u64, limits: &Limits) -> RunRecord {
    let mut s = scene.clone();
    s.integrator = spec;
    s.max_steps = max_steps;
    s.record.history = false;
    s.record.min_overlap = false;
    s.record.energy_flow = false;
    s.record.fields = None;
    exec::execute_pilot(&s, limits)
}

/// Resolves the `auto` request `spec` of `sweep` (whose `grid` holds the unresolved scenes) by
/// running the pilot on `pool`; `log` receives progress lines. An input error (exit 2) when no
/// candidate meets the target, or when a reference run fails.
pub fn resolve(
    sweep: &Sweep,
    grid: &Grid,
    spec: &AutoSpec,
    pool: &rayon::ThreadPool,
    mut log: impl FnMut(&str),
) -> Result<AutoChoice> {
    let start = Instant::now();
    let target = spec.target_rel_error;
    let pilot = Pilot::new(sweep, grid, spec, pool)?;
    log(&format!(
        "pilot on {} grid point(s) {:?} for a target relative error of {target:e} (candidates must reach {:e} there, ROS34PW2 {:e}); references: {}",
        pilot.points.len(),
        pilot.points,
        target / SAFETY_FACTOR,
        target / ROS34PW2_SAFETY_FACTOR,
        pilot.references.iter().map(describe).collect::<Vec<_>>().join(", ")
    ));
    let reference_runs = pilot.run_references()?;
    let mut total: u64 = reference_runs.iter().map(|r| r.rhs_evals).sum();
    let (candidates, best) = pilot.search(&reference_runs, &mut total, &mut log);
    let Some(b) = best else {
        return Err(pilot.nothing_meets_the_target(&candidates));
    };
    let c = &candidates[b];
    let choice = AutoChoice {
        key: cache_key(grid, spec),
        version: AUTO_VERSION,
        target_rel_error: target,
        safety_factor: safety_factor(&c.integrator),
        integrator: c.integrator,
        pilot_points: pilot.points.clone(),
        pilot_references: pilot.references.clone(),
        pilot_errors: c.errors.iter().map(|e| e.unwrap_or(f64::NAN)).collect(),
        pilot_rhs_evals: c.rhs_evals.iter().map(|e| e.unwrap_or(0)).collect(),
        pilot_cost_rhs_evals: total,
        candidates: candidates.clone(),
    };
    log(&format!(
        "pilot done in {:.1} s ({} candidates, {} RHS evaluations)",
        start.elapsed().as_secs_f64(),
        candidates.len(),
        total
    ));
    Ok(choice)
}

/// The pilot of an `auto` request: its grid points, their scenes and reference settings.
struct Pilot<'a> {
    sweep: &'a Sweep,
    grid: &'a Grid,
    pool: &'a rayon::ThreadPool,
    target: f64,
    points: Vec<usize>,
    scenes: Vec<Scene>,
    /// Whether each pilot point is damping-dominated.
    stiff: Vec<bool>,
    references: Vec<IntegratorSpec>,
}

impl<'a> Pilot<'a> {
    /// Picks the pilot points and, for each, its scene and reference setting.
    fn new(
        sweep: &'a Sweep,
        grid: &'a Grid,
        spec: &AutoSpec,
        pool: &'a rayon::ThreadPool,
    ) -> Result<Pilot<'a>> {
        let target = spec.target_rel_error;
        let points = pilot_points(sweep, grid, spec.pilot_points)?;
        let mut scenes = Vec::new();
        let mut stiff = Vec::new();
        for &i in &points {
            let scene = grid.build(sweep, i)?;
            stiff.push(scene_scales(&scene)?.stiffness_ratio > STIFF_RATIO);
            scenes.push(scene);
        }
        let references = stiff
            .iter()
            .map(|&s| {
                if s && target >= ROS_REFERENCE_MIN_TARGET {
                    adaptive(Method::Ros34pw2, ROS34PW2_REFERENCE_RTOL)
                } else {
                    adaptive(Method::Dop853, 1e-12)
                }
            })
            .collect();
        Ok(Pilot {
            sweep,
            grid,
            pool,
            target,
            points,
            scenes,
            stiff,
            references,
        })
    }

    /// The reference run at every pilot point; an input error when one fails.
    fn run_references(&self) -> Result<Vec<RunRecord>> {
        // The references are yardsticks, not results: the sweep's energy-drift limit is not theirs.
        let no_limit = Limits {
            energy_drift_max: None,
            ..self.sweep.limits
        };
        let runs: Vec<RunRecord> = self.pool.install(|| {
            self.scenes
                .par_iter()
                .zip(&self.references)
                .map(|(s, r)| pilot_run(s, *r, s.max_steps.saturating_mul(4), &no_limit))
                .collect()
        });
        if let Some(k) = runs.iter().position(|r| !r.ok) {
            return Err(Error::input(
                "base.integrator",
                format!(
                    "`auto`: the pilot's reference run ({}) failed at grid point {} ({}): {}; give a fixed integrator instead",
                    describe(&self.references[k]),
                    self.points[k],
                    self.grid.point_label(self.sweep, self.points[k]),
                    runs[k].reason
                ),
            ));
        }
        Ok(runs)
    }

    /// Tries the candidates, method by method, cheapest first: each method's ladder stops at its
    /// first candidate meeting the target, or once one costs more than the best so far. Returns
    /// every candidate tried and the best; adds their RHS evaluations to `total`.
    fn search(
        &self,
        references: &[RunRecord],
        total: &mut u64,
        log: &mut impl FnMut(&str),
    ) -> (Vec<Candidate>, Option<usize>) {
        let mut candidates: Vec<Candidate> = Vec::new();
        let mut best: Option<usize> = None;
        for ladder in ladders(self.target, self.stiff.iter().any(|&s| s)) {
            for spec in ladder {
                let c = self.try_candidate(spec, references, total);
                log(&format!(
                    "pilot {}: largest error {:.2e}{}, {} RHS evaluations{}",
                    describe(&spec),
                    c.max_error(),
                    if c.meets_target {
                        " (meets the target)"
                    } else {
                        ""
                    },
                    c.rhs_evals.iter().flatten().sum::<u64>(),
                    match &c.failure {
                        Some(f) => format!("; a run failed {f}"),
                        None => String::new(),
                    }
                ));
                let best_cost = best.and_then(|b| candidates[b].cost);
                let (meets, cost) = (c.meets_target, c.cost);
                candidates.push(c);
                if meets {
                    if best_cost.map_or(true, |b| cost.expect("met") < b) {
                        best = Some(candidates.len() - 1);
                    }
                    break;
                }
                if let (Some(b), Some(cc)) = (best_cost, cost) {
                    if cc > b {
                        // Tighter settings of this method cost more still.
                        break;
                    }
                }
            }
        }
        (candidates, best)
    }

    /// Runs candidate `spec` at every pilot point and measures it against the `references`.
    fn try_candidate(
        &self,
        spec: IntegratorSpec,
        references: &[RunRecord],
        total: &mut u64,
    ) -> Candidate {
        let runs: Vec<RunRecord> = self.pool.install(|| {
            self.scenes
                .par_iter()
                .map(|s| pilot_run(s, spec, s.max_steps, &self.sweep.limits))
                .collect()
        });
        let mut errors = Vec::new();
        let mut evals = Vec::new();
        let mut failure = None;
        for (k, r) in runs.iter().enumerate() {
            *total += r.rhs_evals;
            if r.ok {
                errors.push(pilot_error(r, &references[k]));
                evals.push(Some(r.rhs_evals));
            } else {
                errors.push(None);
                evals.push(None);
                failure.get_or_insert_with(|| {
                    format!("at grid point {}: {}", self.points[k], r.reason)
                });
            }
        }
        let cost = evals
            .iter()
            .try_fold(0.0, |acc, e| e.map(|e| acc + weighted(&spec, e)));
        let meets_target = errors
            .iter()
            .all(|e| matches!(e, Some(x) if *x <= self.target / safety_factor(&spec)));
        Candidate {
            integrator: spec,
            errors,
            rhs_evals: evals,
            cost,
            meets_target,
            failure,
        }
    }

    /// The input error when no candidate meets the target, with the closest one.
    fn nothing_meets_the_target(&self, candidates: &[Candidate]) -> Error {
        let closest = candidates
            .iter()
            .min_by(|a, b| a.max_error().total_cmp(&b.max_error()));
        let what = match closest {
            Some(c) if c.max_error().is_finite() => format!(
                "the best was {} with a largest pilot error of {:.2e}",
                describe(&c.integrator),
                c.max_error()
            ),
            _ => format!(
                "no candidate succeeded at every pilot point ({})",
                candidates
                    .first()
                    .map(|c| format!(
                        "{}: a run failed {}",
                        describe(&c.integrator),
                        c.failure.as_deref().unwrap_or("")
                    ))
                    .unwrap_or_default()
            ),
        };
        Error::input(
            "base.integrator.target_rel_error",
            format!(
                "`auto` found no setting meeting the target {:e} on the pilot points {:?} (each must reach {:e}, with ROS34PW2 {:e}): {what}; loosen the target or give a fixed integrator",
                self.target, self.points, self.target / SAFETY_FACTOR, self.target / ROS34PW2_SAFETY_FACTOR
            ),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ladders_are_rounded_and_bounded() {
        let l = ladder(Method::Dop853, 1e-6);
        let r: Vec<f64> = l
            .iter()
            .map(|s| crate::sweep::auto::setting_of(s).0)
            .collect();
        assert_eq!(r, vec![3e-7, 1e-7, 3e-8, 1e-8, 3e-9, 1e-9, 3e-10, 1e-10]);
        let r: Vec<f64> = ladder(Method::Dop853, 1e-8)
            .iter()
            .map(|s| crate::sweep::auto::setting_of(s).0)
            .collect();
        assert_eq!(r, vec![3e-9, 1e-9, 3e-10, 1e-10, 3e-11, 1e-11]);
        let r: Vec<f64> = ladder(Method::Ros34pw2, 1e-7)
            .iter()
            .map(|s| crate::sweep::auto::setting_of(s).0)
            .collect();
        assert_eq!(r, vec![1e-8, 3e-9, 1e-9, 3e-10]);
        assert!(ladder(Method::Ros34pw2, 1e-6)
            .iter()
            .all(|s| s.method() == Method::Ros34pw2));
    }

    #[test]
    fn switch_prediction_is_tried_first_unless_damping_dominates() {
        let predicting = |l: &[IntegratorSpec]| {
            l.iter()
                .map(|s| match s {
                    IntegratorSpec::Dop853(o) => (Method::Dop853, o.predict_switches),
                    IntegratorSpec::Ros34pw2(o) => (Method::Ros34pw2, o.predict_switches),
                    other => panic!("{other:?}"),
                })
                .collect::<Vec<_>>()
        };
        let plain = ladders(1e-6, false);
        assert_eq!(plain.len(), 3);
        assert!(predicting(&plain[0]) == vec![(Method::Dop853, true); 8]);
        assert!(predicting(&plain[1]) == vec![(Method::Dop853, false); 8]);
        assert!(predicting(&plain[2])
            .iter()
            .all(|&m| m == (Method::Ros34pw2, false)));
        // The same rungs as plain DOP853's.
        assert!(plain[0].iter().zip(&plain[1]).all(|(a, b)| {
            crate::sweep::auto::setting_of(a) == crate::sweep::auto::setting_of(b)
        }));
        let stiff = ladders(1e-6, true);
        assert_eq!(stiff[0], plain[2]);
        assert_eq!(&stiff[1..], &plain[..2]);
        assert_eq!(
            crate::sweep::auto::describe(&plain[0][0]),
            "dop853 rtol 3e-7 predict_switches"
        );
    }

    #[test]
    fn pilot_points_cover_corners_centre_and_stiffest() {
        let text = r#"{
          "base": {
            "chain": {"preset": "chain_055", "cylinders": 8,
                      "cylinder": {"mass": {"heavy_cylinders": {"mass_ratio": 0.55}}, "height_m": null}},
            "physics": {"gravity": true, "damping_kg_s": 0.0, "wall": true},
            "striker_velocity_m_s": 1.3, "duration_s": 1e-4,
            "integrator": {"method": "auto", "target_rel_error": 1e-6}
          },
          "axes": [
            {"field": "chain.cylinder.mass.heavy_cylinders.mass_ratio", "values": [0.2, 0.4, 0.6, 0.8, 1.0]},
            {"field": "physics.damping_kg_s", "values": [0, 3, 6]}
          ]
        }"#;
        let sweep = Sweep::parse(text).unwrap();
        assert!(sweep.auto.is_some());
        let grid = Grid::new(&sweep).unwrap();
        // corners 0, 2, 12, 14; centre (2, 1) = 7; stiffest: μ = 6 at the lightest ε (0.2) = 2.
        assert_eq!(
            pilot_points(&sweep, &grid, 5).unwrap(),
            vec![0, 2, 7, 12, 14]
        );
        assert_eq!(pilot_points(&sweep, &grid, 3).unwrap(), vec![0, 2, 14]);
        assert_eq!(pilot_points(&sweep, &grid, 64).unwrap().len(), 5);
    }
}
