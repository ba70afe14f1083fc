//! Branch switching at a period doubling: the eigenvector of the multiplier −1 and the branch of
//! orbits of twice the period that the doubling starts (the module docs of [`crate::periodic`]
//! give the method).

use std::sync::atomic::AtomicBool;

use crate::integrate::IntegrationStats;
use crate::periodic::branch::{
    resume_within, Branch, BranchOptions, BranchPoint, Continuer, PointKind,
};
use crate::periodic::dense::{self, is_real};
use crate::periodic::shooting::{Orbit, PeriodMap};
use crate::periodic::PeriodicOptions;
use crate::scene::Scene;
use crate::spec::{spec_err, SpecError};

/// A bifurcated orbit whose period-`T` split `max_i |P_T(x)_i − x_i| / s_i` is below this
/// fraction of the step along the eigenvector has fallen back onto the orbit of period `T`.
const FALLBACK_SPLIT: f64 = 0.1;

/// The eigenvector `v` of an orbit's multiplier nearest −1 (`M v = μ v`, `μ ≈ −1`), by inverse
/// iteration with the LU factors of `M − μ I`, as orbit components (physical units), unit
/// Euclidean norm in the orbit's `scales` (`Σ (v_i/s_i)² = 1`), its largest scaled component
/// positive. `None` when the orbit has no real negative multiplier or the iteration fails.
pub fn period_doubling_vector(orbit: &Orbit, scales: &[f64]) -> Option<Vec<f64>> {
    let m = orbit.state.len();
    let mu = orbit
        .multipliers
        .iter()
        .filter(|&&w| is_real(w) && w.0 < 0.0)
        .map(|w| w.0)
        .min_by(|a, b| (a + 1.0).abs().total_cmp(&(b + 1.0).abs()))?;
    // In the scaled components, S⁻¹ M S, where entries are of order one.
    let mut a = orbit.monodromy.clone();
    for i in 0..m {
        for j in 0..m {
            a[i * m + j] *= scales[j] / scales[i];
        }
    }
    let v = dense::eigenvector(&a, m, mu)?;
    Some(v.iter().zip(scales).map(|(v, s)| v * s).collect())
}

/// Continues the branch of orbits of twice the period that starts at `point`, a located period
/// doubling of a branch of [`crate::periodic::continue_branch`] continued with `periodic`: the
/// orbits of `2 × periodic.periods` drive periods, the first one corrected from the doubling's
/// orbit moved by the first step along the eigenvector of the multiplier −1 (on the hyperplane
/// through that predictor orthogonal to the step: the doubled branch leaves the doubling
/// orthogonally to the parent branch, a pitchfork of the doubled period map), the other sign
/// tried where the correction falls back onto the orbit of the single period (its split
/// `max_i |P_T(x)_i − x_i| / s_i` under a tenth of the step). Then pseudo-arclength steps as in
/// `continue_branch`, until the parameter leaves `[p − r, p + r]` with `p` the doubling's
/// parameter and `r = |options.to − p|` (a doubled branch may bend to either side of its
/// doubling: supercritical into the range where the single-period orbit is unstable,
/// subcritical into the other). Steps are in units of `r`. Errors name `periodic` (no doubling
/// at `point`, no eigenvector, no first doubled orbit) or the field of bad options.
pub fn continue_period_doubled(
    scene_at: &dyn Fn(f64) -> Result<Scene, SpecError>,
    point: &BranchPoint,
    periodic: &PeriodicOptions,
    options: &BranchOptions,
    on_point: &mut dyn FnMut(&BranchPoint),
) -> Result<Branch, SpecError> {
    continue_period_doubled_stoppable(scene_at, point, periodic, options, None, on_point)
}

/// [`continue_period_doubled`], stopping after the point it is computing once `stop` is set: the
/// branch then ends with [`Branch::stopped`], and [`resume_period_doubled`] goes on from its last
/// accepted point.
pub fn continue_period_doubled_stoppable(
    scene_at: &dyn Fn(f64) -> Result<Scene, SpecError>,
    point: &BranchPoint,
    periodic: &PeriodicOptions,
    options: &BranchOptions,
    stop: Option<&AtomicBool>,
    on_point: &mut dyn FnMut(&BranchPoint),
) -> Result<Branch, SpecError> {
    if point.kind != PointKind::PeriodDoubling {
        return Err(spec_err(
            "periodic",
            format!(
                "branch switching to the doubled period starts at a period doubling, not at a {} point",
                point.kind.name()
            ),
        ));
    }
    let from = point.parameter;
    options.validate(from)?;
    let doubled = doubled(periodic)?;
    let m = point.orbit.state.len();
    let (scales, parent_parameter_scale) = (&point.scales[..m], point.scales[m]);
    let v = period_doubling_vector(&point.orbit, scales).ok_or_else(|| {
        spec_err(
            "periodic",
            format!(
                "no eigenvector of the multiplier −1 at the period doubling at {from}: {:?}",
                point.orbit.multipliers
            ),
        )
    })?;
    let range = (options.to - from).abs();
    let mut c = Continuer {
        scene_at,
        options: &doubled,
        scales: scales.to_vec(),
        parameter_scale: range,
        maps: 0,
        stats: IntegrationStats::default(),
    };
    // The parent's tangent in this continuation's scaling, and the direction along v orthogonal
    // to it.
    let mut parent = point.tangent.clone();
    parent[m] *= parent_parameter_scale / range;
    normalise(&mut parent);
    let mut tau: Vec<f64> = v.iter().zip(scales).map(|(v, s)| v / s).collect();
    tau.push(0.0);
    let along: f64 = tau.iter().zip(&parent).map(|(a, b)| a * b).sum();
    tau.iter_mut()
        .zip(&parent)
        .for_each(|(t, p)| *t -= along * p);
    normalise(&mut tau);

    let single = |p: f64| -> Result<PeriodMap, String> {
        let scene = scene_at(p).map_err(|e| format!("at {p}: {e}"))?;
        PeriodMap::new(&scene, periodic).map_err(|e| format!("at {p}: {e}"))
    };
    let sigma = options.step.unwrap_or(range / 50.0) / range;
    let u0 = c.scale(&point.orbit.state, from);
    let mut failures = Vec::new();
    for sign in [1.0, -1.0] {
        let direction: Vec<f64> = tau.iter().map(|t| sign * t).collect();
        let predictor: Vec<f64> = u0
            .iter()
            .zip(&direction)
            .map(|(u, t)| u + sigma * t)
            .collect();
        let corrected = match c.correct(&predictor, &direction) {
            Ok(corrected) => corrected,
            Err(e) => {
                failures.push(e);
                continue;
            }
        };
        let (x, p) = c.unscale(&corrected.u);
        let split = single(p).and_then(|map| {
            let out = map.map(&x, false).map_err(|e| format!("at {p}: {e}"))?;
            c.count(out.maps, &out.stats);
            Ok(out
                .end
                .iter()
                .zip(&x)
                .zip(scales)
                .fold(0.0, |a: f64, ((e, x), s)| a.max((e - x).abs() / s)))
        });
        match split {
            Ok(split) if split >= FALLBACK_SPLIT * sigma => {}
            Ok(split) => {
                failures.push(format!(
                    "at {p}: fell back onto the orbit of the single period (split {split:.2e})"
                ));
                continue;
            }
            Err(e) => {
                failures.push(e);
                continue;
            }
        }
        let start = c
            .point(corrected, &direction, PointKind::Start, 0.0)
            .map_err(|e| spec_err("periodic", format!("at {p}: {e}")))?;
        return Ok(c.follow_from(
            start,
            false,
            options,
            doubled_bounds(options, from),
            stop,
            on_point,
        ));
    }
    Err(spec_err(
        "periodic",
        format!(
            "no orbit of the doubled period beside the period doubling at {from}: {}",
            failures.join("; ")
        ),
    ))
}

/// Goes on with the branch of [`continue_period_doubled`] (the same `scene_at`, `periodic` and
/// `options`, from the period doubling at parameter `doubling`) from `last`, the last point it
/// accepted as `on_point` gave it, exactly as the continuation would have gone on: the points
/// after it are bitwise those an uninterrupted continuation gives (as [`resume_branch`] does for
/// the branch of the single period). `last` is not given to `on_point` again.
///
/// [`resume_branch`]: crate::periodic::resume_branch
pub fn resume_period_doubled(
    scene_at: &dyn Fn(f64) -> Result<Scene, SpecError>,
    doubling: f64,
    periodic: &PeriodicOptions,
    options: &BranchOptions,
    last: &BranchPoint,
    stop: Option<&AtomicBool>,
    on_point: &mut dyn FnMut(&BranchPoint),
) -> Result<Branch, SpecError> {
    options.validate(doubling)?;
    let doubled = doubled(periodic)?;
    let bounds = doubled_bounds(options, doubling);
    resume_within(scene_at, &doubled, options, bounds, last, stop, on_point)
}

/// Where the branch of twice the period from the doubling at `at` may go: within `|to − at|` of
/// it on either side. One definition for the continuation and its resume, which must agree to
/// the bit.
fn doubled_bounds(options: &BranchOptions, at: f64) -> (f64, f64) {
    let range = (options.to - at).abs();
    (at - range, at + range)
}

/// The orbit options of the branch of twice the period that starts at a period doubling of a
/// branch of `periodic`'s orbits: twice the drive periods per orbit, the rest the same.
pub fn doubled_orbits(periodic: &PeriodicOptions) -> PeriodicOptions {
    PeriodicOptions {
        periods: 2 * periodic.periods,
        ..*periodic
    }
}

/// [`doubled_orbits`], checked.
fn doubled(periodic: &PeriodicOptions) -> Result<PeriodicOptions, SpecError> {
    let doubled = doubled_orbits(periodic);
    doubled.validate()?;
    Ok(doubled)
}

fn normalise(v: &mut [f64]) {
    let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    v.iter_mut().for_each(|x| *x /= norm);
}
