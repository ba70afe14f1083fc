//! A branch of periodic orbits continued in one scene parameter by pseudo-arclength, with its
//! folds, branch points, period doublings and Neimark–Sacker points located (the module docs of
//! [`crate::periodic`] give the method).

use crate::integrate::IntegrationStats;
use crate::periodic::dense::{self, Multiplier};
use crate::periodic::shooting::{Orbit, PeriodMap, ShootingError};
use crate::periodic::PeriodicOptions;
use crate::scene::Scene;
use crate::spec::{spec_err, SpecError};
use std::sync::atomic::{AtomicBool, Ordering};

/// Smallest cosine of the angle between consecutive tangents of an accepted step (about 14°): a
/// sharper turn halves the step, so that a resonance's peak and a fold are drawn in several points.
const MIN_TURN_COSINE: f64 = 0.97;

/// How a branch is continued.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BranchOptions {
    /// The parameter value the branch ends at.
    pub to: f64,
    /// First parameter step (default a fiftieth of the range).
    pub step: Option<f64>,
    /// Smallest step, in the parameter's units of arclength, before the branch ends (default a
    /// ten-thousandth of the first step).
    pub min_step: Option<f64>,
    /// Largest change of the parameter in one step (default a twentieth of the range); where the
    /// branch rises steeply the turn of its tangent (at most about 14° a step) bounds the step.
    pub max_step: Option<f64>,
    /// Most points on the branch, special points included (default 400).
    pub max_points: u32,
    /// Special points are located to this fraction of the range in arclength (default 1e-6).
    pub locate_tolerance: f64,
}

impl BranchOptions {
    /// Continuation to `to` with the defaults.
    pub fn new(to: f64) -> Self {
        BranchOptions {
            to,
            step: None,
            min_step: None,
            max_step: None,
            max_points: 400,
            locate_tolerance: 1e-6,
        }
    }

    /// Checks the options against the start `from`; errors name the field under `periodic`.
    pub fn validate(&self, from: f64) -> Result<(), SpecError> {
        if !self.to.is_finite() || self.to == from {
            return Err(spec_err(
                "periodic.to",
                format!(
                    "must be finite and differ from the start ({from}), got {}",
                    self.to
                ),
            ));
        }
        let range = (self.to - from).abs();
        for (field, v) in [
            ("periodic.step", self.step),
            ("periodic.min_step", self.min_step),
            ("periodic.max_step", self.max_step),
        ] {
            if let Some(v) = v {
                if !(v.is_finite() && v > 0.0 && v <= range) {
                    return Err(spec_err(
                        field,
                        format!("must lie in (0, {range}] (the range), got {v}"),
                    ));
                }
            }
        }
        if !(2..=20_000).contains(&self.max_points) {
            return Err(spec_err(
                "periodic.max_points",
                format!("must lie in 2..=20000, got {}", self.max_points),
            ));
        }
        if !(self.locate_tolerance > 0.0 && self.locate_tolerance < 0.1) {
            return Err(spec_err(
                "periodic.locate_tolerance",
                format!("must lie in (0, 0.1), got {}", self.locate_tolerance),
            ));
        }
        Ok(())
    }
}

/// What a point of a branch is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum PointKind {
    /// The first orbit, at the start.
    Start,
    /// An orbit the continuation stepped to.
    Regular,
    /// A fold (saddle-node, limit point): the branch turns back in the parameter.
    Fold,
    /// A branch point: another branch crosses.
    BranchPoint,
    /// A period doubling: a multiplier at −1.
    PeriodDoubling,
    /// A Neimark–Sacker point: a complex pair of multipliers on the unit circle.
    NeimarkSacker,
    /// The last orbit, at the end of the range.
    End,
}

impl PointKind {
    /// Every kind, in the order of their codes.
    pub const ALL: [PointKind; 7] = [
        PointKind::Regular,
        PointKind::Start,
        PointKind::End,
        PointKind::Fold,
        PointKind::BranchPoint,
        PointKind::PeriodDoubling,
        PointKind::NeimarkSacker,
    ];

    /// Its name.
    pub fn name(self) -> &'static str {
        match self {
            PointKind::Start => "start",
            PointKind::Regular => "regular",
            PointKind::Fold => "fold",
            PointKind::BranchPoint => "branch_point",
            PointKind::PeriodDoubling => "period_doubling",
            PointKind::NeimarkSacker => "neimark_sacker",
            PointKind::End => "end",
        }
    }

    /// Its stored code: its place in [`PointKind::ALL`].
    pub fn code(self) -> u8 {
        PointKind::ALL
            .iter()
            .position(|&k| k == self)
            .expect("listed") as u8
    }

    /// Whether it is a bifurcation or fold (located, not stepped to).
    pub fn is_special(self) -> bool {
        matches!(
            self,
            PointKind::Fold
                | PointKind::BranchPoint
                | PointKind::PeriodDoubling
                | PointKind::NeimarkSacker
        )
    }
}

/// One orbit of a branch.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct BranchPoint {
    /// The parameter.
    pub parameter: f64,
    /// The orbit.
    pub orbit: Orbit,
    /// What the point is.
    pub kind: PointKind,
    /// The unit tangent's parameter component (scaled): its sign says which way the branch goes.
    pub tangent_parameter: f64,
    /// Scaled arclength from the start.
    pub arclength: f64,
    /// Where the continuation stood when it accepted this point (a stepped-to or start point;
    /// zero for a located special point): what [`resume_branch`] needs to go on from it exactly
    /// as it would have.
    pub progress: Progress,
    /// The unit tangent in the scaled unknowns `(x/s, p/s_p)`.
    pub(super) tangent: Vec<f64>,
    pub(super) determinant: f64,
    /// The scales `s` of the orbit components and, last, `s_p` of the parameter.
    pub(super) scales: Vec<f64>,
}

impl BranchPoint {
    /// The scales the continuation weighs the orbit components by (one each) and, last, the
    /// parameter's: the arclength is measured in `(x/s, p/s_p)`.
    pub fn scales(&self) -> &[f64] {
        &self.scales
    }

    /// The test function whose sign change marks a special point of `kind`; `outside` is the
    /// number of multipliers of the kind outside the unit circle on the stable side of the
    /// crossing (see [`dense::crossing_test`]).
    fn test(&self, kind: PointKind, outside: usize) -> f64 {
        let w = &self.orbit.multipliers;
        match kind {
            PointKind::Fold => self.tangent_parameter,
            PointKind::BranchPoint => self.determinant,
            PointKind::PeriodDoubling => dense::crossing_test(w, true, outside),
            PointKind::NeimarkSacker => dense::crossing_test(w, false, outside),
            _ => 0.0,
        }
    }

    /// Whether a special point of `kind` lies between `self` and `next`, and the `outside` count
    /// its test needs.
    fn crosses(&self, next: &BranchPoint, kind: PointKind) -> Option<usize> {
        let (a, b) = (
            dense::outside_counts(&self.orbit.multipliers),
            dense::outside_counts(&next.orbit.multipliers),
        );
        let sign_change = |k| self.test(k, 0) * next.test(k, 0) < 0.0;
        match kind {
            PointKind::Fold => sign_change(kind).then_some(0),
            // At a fold the determinant keeps its sign in theory; where rounding flips it beside
            // a fold, the fold is what is there.
            PointKind::BranchPoint => {
                (sign_change(kind) && !sign_change(PointKind::Fold)).then_some(0)
            }
            PointKind::PeriodDoubling => (a.1 != b.1).then_some(a.1.min(b.1)),
            PointKind::NeimarkSacker => (a.2 != b.2).then_some(a.2.min(b.2)),
            _ => None,
        }
    }
}

/// Where a continuation stood when it accepted a point.
#[derive(Debug, Clone, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Progress {
    /// The arclength step it takes next (scaled).
    pub next_step: f64,
    /// Points of the branch so far, this one included.
    pub points: usize,
    /// Period maps integrated so far.
    pub maps: u64,
    /// Special points detected since the previous accepted point but not located, with why.
    pub warnings: Vec<String>,
}

/// A continued branch.
#[derive(Debug, Clone)]
pub struct Branch {
    /// Its points in order along the branch, located special points among them; each orbit's
    /// monodromy matrix is kept for the special points only (`on_point` sees every one whole).
    pub points: Vec<BranchPoint>,
    /// Why it ended.
    pub end: String,
    /// Special points detected but not located, with why.
    pub warnings: Vec<String>,
    /// Period maps integrated over the whole continuation.
    pub maps: u64,
    /// Steps and evaluations of all of them.
    pub stats: IntegrationStats,
    /// Whether it stopped because the stop flag was set (it can be resumed from its last
    /// accepted point, [`resume_branch`]).
    pub stopped: bool,
}

/// A corrected point: the orbit, the scaled unknowns, the scaled `∂P/∂p` column.
pub(super) struct Corrected {
    pub(super) u: Vec<f64>,
    pub(super) orbit: Orbit,
    pub(super) column: Vec<f64>,
}

/// The state of a continuation.
pub(super) struct Continuer<'a> {
    pub(super) scene_at: &'a dyn Fn(f64) -> Result<Scene, SpecError>,
    pub(super) options: &'a PeriodicOptions,
    /// Scales of the orbit components and of the parameter.
    pub(super) scales: Vec<f64>,
    pub(super) parameter_scale: f64,
    pub(super) maps: u64,
    pub(super) stats: IntegrationStats,
}

impl Continuer<'_> {
    pub(super) fn dim(&self) -> usize {
        self.scales.len()
    }

    pub(super) fn map_at(&self, p: f64) -> Result<PeriodMap, String> {
        let scene = (self.scene_at)(p).map_err(|e| format!("at {p}: {e}"))?;
        PeriodMap::new(&scene, self.options).map_err(|e| format!("at {p}: {e}"))
    }

    pub(super) fn unscale(&self, u: &[f64]) -> (Vec<f64>, f64) {
        let m = self.dim();
        (
            u[..m]
                .iter()
                .zip(&self.scales)
                .map(|(u, s)| u * s)
                .collect(),
            u[m] * self.parameter_scale,
        )
    }

    pub(super) fn scale(&self, x: &[f64], p: f64) -> Vec<f64> {
        let mut u: Vec<f64> = x.iter().zip(&self.scales).map(|(x, s)| x / s).collect();
        u.push(p / self.parameter_scale);
        u
    }

    pub(super) fn count(&mut self, maps: u32, stats: &IntegrationStats) {
        self.maps += u64::from(maps);
        self.stats.add(stats);
    }

    /// `∂P/∂p̃ / s`, scaled, by a forward difference from `end = P(x, p)`.
    pub(super) fn parameter_column(
        &mut self,
        p: f64,
        x: &[f64],
        end: &[f64],
    ) -> Result<Vec<f64>, String> {
        let h = 1e-6 * p.abs().max(self.parameter_scale);
        let out = self
            .map_at(p + h)?
            .map(x, false)
            .map_err(|e| format!("at {}: {e}", p + h))?;
        self.count(out.maps, &out.stats);
        Ok(out
            .end
            .iter()
            .zip(end)
            .zip(&self.scales)
            .map(|((a, b), s)| (a - b) / h * self.parameter_scale / s)
            .collect())
    }

    /// The bordered matrix `[[S⁻¹ M S − I, ∂P/∂p̃], [rowᵀ]]`, row-major, order `m + 1`.
    fn bordered(&self, monodromy: &[f64], column: &[f64], row: &[f64]) -> Vec<f64> {
        let m = self.dim();
        let k = m + 1;
        let mut a = vec![0.0; k * k];
        for i in 0..m {
            for j in 0..m {
                a[i * k + j] = monodromy[i * m + j] * self.scales[j] / self.scales[i];
            }
            a[i * k + i] -= 1.0;
            a[i * k + m] = column[i];
        }
        a[m * k..].copy_from_slice(row);
        a
    }

    /// Newton's method on `[P(x, p) − x; τ·(u − u_pred)] = 0` from the predictor `u_pred`.
    pub(super) fn correct(&mut self, u_pred: &[f64], tangent: &[f64]) -> Result<Corrected, String> {
        let m = self.dim();
        let tolerance = self.options.tolerance;
        let mut u = u_pred.to_vec();
        let mut last = f64::INFINITY;
        for iteration in 0..=self.options.max_iterations {
            let (x, p) = self.unscale(&u);
            let map = self.map_at(p)?;
            let out = map.map(&x, true).map_err(|e| format!("at {p}: {e}"))?;
            self.count(out.maps, &out.stats);
            let residual = map.scaled_distance(&out.end, &x);
            let plane: f64 = tangent
                .iter()
                .zip(u.iter().zip(u_pred))
                .map(|(t, (a, b))| t * (a - b))
                .sum();
            let column = self.parameter_column(p, &x, &out.end)?;
            let monodromy = out.monodromy.expect("asked for");
            if residual <= tolerance && plane.abs() <= tolerance {
                let multipliers = dense::multipliers(&monodromy, m)
                    .ok_or_else(|| ShootingError::Multipliers.to_string())?;
                return Ok(Corrected {
                    u,
                    column,
                    orbit: Orbit {
                        state: x,
                        monodromy,
                        multipliers,
                        method: out.method,
                        iterations: iteration,
                        residual,
                        maps: out.maps,
                        stats: out.stats,
                    },
                });
            }
            if iteration == self.options.max_iterations || residual > 4.0 * last {
                return Err(format!(
                    "at {p}: Newton's method did not converge in {iteration} iterations (residual {residual:.3e}, tolerance {tolerance:.1e})"
                ));
            }
            last = residual;
            let mut a = self.bordered(&monodromy, &column, tangent);
            let mut b: Vec<f64> = x
                .iter()
                .zip(&out.end)
                .zip(&self.scales)
                .map(|((x, e), s)| (x - e) / s)
                .collect();
            b.push(-plane);
            dense::solve(&mut a, m + 1, &mut b)
                .ok_or_else(|| format!("at {p}: the bordered Newton matrix is singular"))?;
            for (u, d) in u.iter_mut().zip(&b) {
                *u += d;
            }
        }
        unreachable!("the loop returns")
    }

    /// The unit tangent at a corrected point, oriented along `previous`, and the determinant of
    /// the bordered matrix that gives it.
    fn tangent(&self, c: &Corrected, previous: &[f64]) -> Result<(Vec<f64>, f64), String> {
        let m = self.dim();
        let mut a = self.bordered(&c.orbit.monodromy, &c.column, previous);
        let mut t = vec![0.0; m + 1];
        t[m] = 1.0;
        let det = dense::solve(&mut a, m + 1, &mut t)
            .ok_or("the bordered matrix of the tangent is singular")?;
        let norm = t.iter().map(|v| v * v).sum::<f64>().sqrt();
        for v in &mut t {
            *v /= norm;
        }
        Ok((t, det))
    }

    pub(super) fn point(
        &self,
        c: Corrected,
        previous: &[f64],
        kind: PointKind,
        arclength: f64,
    ) -> Result<BranchPoint, String> {
        let (tangent, determinant) = self.tangent(&c, previous)?;
        let m = self.dim();
        let mut scales = self.scales.clone();
        scales.push(self.parameter_scale);
        Ok(BranchPoint {
            progress: Progress::default(),
            parameter: c.u[m] * self.parameter_scale,
            scales,
            tangent_parameter: tangent[m],
            orbit: c.orbit,
            kind,
            arclength,
            tangent,
            determinant,
        })
    }

    /// The point at arclength `sigma` from `a` along its tangent, corrected.
    fn along(
        &mut self,
        a: &BranchPoint,
        sigma: f64,
        kind: PointKind,
    ) -> Result<BranchPoint, String> {
        let ua = self.scale(&a.orbit.state, a.parameter);
        let pred: Vec<f64> = ua
            .iter()
            .zip(&a.tangent)
            .map(|(u, t)| u + sigma * t)
            .collect();
        let c = self.correct(&pred, &a.tangent)?;
        self.point(c, &a.tangent, kind, a.arclength + sigma)
    }

    #[allow(clippy::too_many_arguments)]
    /// Locates the zero of `kind`'s test between `a` and `b` (`b` at arclength `span` from `a`
    /// along `a`'s tangent) by the Illinois method, to `tolerance` in arclength.
    fn locate(
        &mut self,
        a: &BranchPoint,
        b: &BranchPoint,
        span: f64,
        kind: PointKind,
        outside: usize,
        tolerance: f64,
    ) -> Result<BranchPoint, String> {
        let (mut lo, mut hi) = (0.0, span);
        let (mut f_lo, mut f_hi) = (a.test(kind, outside), b.test(kind, outside));
        let mut best: Option<BranchPoint> = None;
        let mut side = 0;
        for _ in 0..60 {
            if (hi - lo).abs() <= tolerance {
                break;
            }
            let mut sigma = (lo * f_hi - hi * f_lo) / (f_hi - f_lo);
            if !sigma.is_finite() || sigma <= lo.min(hi) || sigma >= lo.max(hi) {
                sigma = 0.5 * (lo + hi);
            }
            let c = self.along(a, sigma, kind)?;
            let f = c.test(kind, outside);
            if f == 0.0 {
                return Ok(c);
            }
            if (f > 0.0) == (f_lo > 0.0) {
                lo = sigma;
                f_lo = f;
                if side == -1 {
                    f_hi *= 0.5;
                }
                side = -1;
            } else {
                hi = sigma;
                f_hi = f;
                if side == 1 {
                    f_lo *= 0.5;
                }
                side = 1;
            }
            best = Some(c);
        }
        best.ok_or_else(|| "the interval was already below the tolerance".to_string())
            .or_else(|_| self.along(a, 0.5 * (lo + hi), kind))
    }
}

/// Continues the branch of periodic orbits of `scene_at(p)` from `p = from` towards
/// `options.to`: the first orbit by shooting from a state settled by time integration, then
/// pseudo-arclength steps until the parameter leaves `[from, to]` (the last point then solved at
/// the end of the range), the step falls below `min_step`, or `max_points` are reached. Calls
/// `on_point` with each point as it is accepted. Errors: the options or the scene at `from`
/// (naming the field), or no first orbit (named `periodic`).
pub fn continue_branch(
    scene_at: &dyn Fn(f64) -> Result<Scene, SpecError>,
    from: f64,
    periodic: &PeriodicOptions,
    options: &BranchOptions,
    on_point: &mut dyn FnMut(&BranchPoint),
) -> Result<Branch, SpecError> {
    continue_branch_stoppable(scene_at, from, periodic, options, None, on_point)
}

/// [`continue_branch`], stopping after the point it is computing once `stop` is set (an
/// interrupt from another thread): the branch then ends with [`Branch::stopped`], and
/// [`resume_branch`] goes on from its last accepted point.
pub fn continue_branch_stoppable(
    scene_at: &dyn Fn(f64) -> Result<Scene, SpecError>,
    from: f64,
    periodic: &PeriodicOptions,
    options: &BranchOptions,
    stop: Option<&AtomicBool>,
    on_point: &mut dyn FnMut(&BranchPoint),
) -> Result<Branch, SpecError> {
    periodic.validate()?;
    options.validate(from)?;
    let scene = scene_at(from)?;
    let map = PeriodMap::new(&scene, periodic)?;
    let first_guess =
        PeriodMap::settle(&scene, map.drive_hz(), periodic.settle_periods).map_err(|e| {
            spec_err(
                "periodic",
                format!("settling the first orbit at {from}: {e}"),
            )
        })?;
    let (mut c, start) = first_point(scene_at, from, &first_guess, periodic, options)?;
    let bounds = (from.min(options.to), from.max(options.to));
    Ok(c.follow_from(start, false, options, bounds, stop, on_point))
}

/// Goes on with the branch of [`continue_branch`] (the same `scene_at`, `from`, `periodic` and
/// `options`) from `last`, the last point it accepted (a start or a stepped-to point, as
/// `on_point` gave it: its [`BranchPoint::progress`] holds the step, the count of points and of
/// period maps the continuation had reached), exactly as the continuation would have gone on:
/// the points after it are bitwise those an uninterrupted continuation gives. `last` itself is
/// not given to `on_point` again, nor counted in the returned branch's points.
pub fn resume_branch(
    scene_at: &dyn Fn(f64) -> Result<Scene, SpecError>,
    from: f64,
    periodic: &PeriodicOptions,
    options: &BranchOptions,
    last: &BranchPoint,
    stop: Option<&AtomicBool>,
    on_point: &mut dyn FnMut(&BranchPoint),
) -> Result<Branch, SpecError> {
    periodic.validate()?;
    options.validate(from)?;
    let bounds = (from.min(options.to), from.max(options.to));
    resume_within(scene_at, periodic, options, bounds, last, stop, on_point)
}

/// Goes on from `last` (a start or stepped-to point as `on_point` gave it) with the orbits of
/// `periodic`, while the parameter stays within `bounds`: what [`resume_branch`] and
/// [`crate::periodic::resume_period_doubled`] share. The scales and the count of period maps are
/// `last`'s, so the points after it are bitwise those of the uninterrupted continuation.
pub(super) fn resume_within(
    scene_at: &dyn Fn(f64) -> Result<Scene, SpecError>,
    periodic: &PeriodicOptions,
    options: &BranchOptions,
    bounds: (f64, f64),
    last: &BranchPoint,
    stop: Option<&AtomicBool>,
    on_point: &mut dyn FnMut(&BranchPoint),
) -> Result<Branch, SpecError> {
    let m = last.orbit.state.len();
    if last.kind.is_special() || last.scales.len() != m + 1 || last.tangent.len() != m + 1 {
        return Err(spec_err(
            "periodic",
            "a branch resumes from a start or stepped-to point as the continuation gave it",
        ));
    }
    let mut c = Continuer {
        scene_at,
        options: periodic,
        scales: last.scales[..m].to_vec(),
        parameter_scale: last.scales[m],
        maps: last.progress.maps,
        stats: IntegrationStats::default(),
    };
    let mut branch = c.follow_from(last.clone(), true, options, bounds, stop, on_point);
    branch.points.remove(0);
    Ok(branch)
}

/// [`continue_branch`] from a given first guess of the orbit at `from` (its components, as
/// [`PeriodMap::rest_state`] lays them out) instead of one settled by time integration: an orbit
/// found before, a point of another branch, or a state that time integration cannot reach (an
/// unstable orbit).
pub fn continue_branch_from(
    scene_at: &dyn Fn(f64) -> Result<Scene, SpecError>,
    from: f64,
    first_guess: &[f64],
    periodic: &PeriodicOptions,
    options: &BranchOptions,
    on_point: &mut dyn FnMut(&BranchPoint),
) -> Result<Branch, SpecError> {
    periodic.validate()?;
    options.validate(from)?;
    let (mut c, start) = first_point(scene_at, from, first_guess, periodic, options)?;
    let bounds = (from.min(options.to), from.max(options.to));
    Ok(c.follow(start, options, bounds, on_point))
}

/// The first orbit of a branch at `from`, shot from `first_guess`, with its tangent towards
/// `options.to`, and the continuation that starts there.
fn first_point<'a>(
    scene_at: &'a dyn Fn(f64) -> Result<Scene, SpecError>,
    from: f64,
    first_guess: &[f64],
    periodic: &'a PeriodicOptions,
    options: &BranchOptions,
) -> Result<(Continuer<'a>, BranchPoint), SpecError> {
    let map = PeriodMap::new(&scene_at(from)?, periodic)?;
    if first_guess.len() != map.dim() {
        return Err(spec_err(
            "periodic",
            format!(
                "the first guess has {} components, the orbit {}",
                first_guess.len(),
                map.dim()
            ),
        ));
    }
    let range = (options.to - from).abs();
    let direction = (options.to - from).signum();
    let mut c = Continuer {
        scene_at,
        options: periodic,
        scales: map.scales().to_vec(),
        parameter_scale: range,
        maps: 0,
        stats: IntegrationStats::default(),
    };
    let m = c.dim();
    let orbit = map
        .shoot(first_guess, periodic.tolerance, periodic.max_iterations)
        .map_err(|e| spec_err("periodic", format!("the first orbit at {from}: {e}")))?;
    c.count(orbit.maps, &orbit.stats);
    c.scales = orbit_scales(&map, &orbit.state);
    let column = c
        .parameter_column(from, &orbit.state, &orbit.state)
        .map_err(|e| spec_err("periodic", e))?;
    let mut seed = vec![0.0; m + 1];
    seed[m] = direction;
    let start = Corrected {
        u: c.scale(&orbit.state, from),
        orbit,
        column,
    };
    let start = c
        .point(start, &seed, PointKind::Start, 0.0)
        .map_err(|e| spec_err("periodic", format!("at {from}: {e}")))?;
    Ok((c, start))
}

impl Continuer<'_> {
    /// Pseudo-arclength steps from `start` (already corrected, with its tangent) until the
    /// parameter leaves `bounds` (the last point then solved at the bound it crossed), the step
    /// falls below `min_step`, or `max_points` are reached; special points located between steps.
    /// Steps are in units of `self.parameter_scale`.
    pub(super) fn follow(
        &mut self,
        start: BranchPoint,
        options: &BranchOptions,
        bounds: (f64, f64),
        on_point: &mut dyn FnMut(&BranchPoint),
    ) -> Branch {
        self.follow_from(start, false, options, bounds, None, on_point)
    }

    /// [`Continuer::follow`] from `start`, which was given to `on_point` already when `resumed`
    /// (its progress then says where the continuation stood), stopping once `stop` is set.
    pub(super) fn follow_from(
        &mut self,
        mut start: BranchPoint,
        resumed: bool,
        options: &BranchOptions,
        bounds: (f64, f64),
        stop: Option<&AtomicBool>,
        on_point: &mut dyn FnMut(&BranchPoint),
    ) -> Branch {
        let c = self;
        let periodic = c.options;
        let range = c.parameter_scale;
        let step = options.step.unwrap_or(range / 50.0) / range;
        let min_step = options.min_step.unwrap_or(step * range * 1e-4) / range;
        let max_step = options.max_step.unwrap_or(range / 20.0) / range;
        let (lo, hi) = bounds;
        if !resumed {
            start.progress = Progress {
                next_step: step,
                points: 1,
                maps: c.maps,
                warnings: Vec::new(),
            };
            on_point(&start);
        }
        let mut ds = start.progress.next_step;
        let mut count = start.progress.points;
        start.orbit.monodromy = Vec::new();
        let mut points = vec![start];
        let mut warnings = Vec::new();
        let mut stopped = false;
        let end = loop {
            if count >= options.max_points as usize {
                break format!("reached max_points ({})", options.max_points);
            }
            if stop.is_some_and(|s| s.load(Ordering::Relaxed)) {
                stopped = true;
                break "stopped (interrupted)".to_string();
            }
            let mut step_warnings = Vec::new();
            let a = points.last().expect("a start").clone();
            let b = match c.along(&a, ds, PointKind::Regular) {
                Ok(b) => b,
                Err(reason) => {
                    ds *= 0.5;
                    if ds < min_step {
                        break format!("the step fell below min_step: {reason}");
                    }
                    continue;
                }
            };
            let turn: f64 = a.tangent.iter().zip(&b.tangent).map(|(x, y)| x * y).sum();
            if turn < MIN_TURN_COSINE && ds > min_step {
                ds = (0.5 * ds).max(min_step);
                continue;
            }
            let mut special = Vec::new();
            for kind in [
                PointKind::Fold,
                PointKind::BranchPoint,
                PointKind::PeriodDoubling,
                PointKind::NeimarkSacker,
            ] {
                let Some(outside) = a.crosses(&b, kind) else {
                    continue;
                };
                match c.locate(&a, &b, ds, kind, outside, options.locate_tolerance) {
                    Ok(p) => special.push(p),
                    Err(e) => step_warnings.push(format!(
                        "a {} between {} and {} was not located: {e}",
                        kind.name(),
                        a.parameter,
                        b.parameter
                    )),
                }
            }
            // Special points lie between a and b: the branch stays in arclength order.
            special.sort_by(|x, y| x.arclength.total_cmp(&y.arclength));
            for mut p in special {
                count += 1;
                p.progress = Progress {
                    points: count,
                    maps: c.maps,
                    ..Progress::default()
                };
                on_point(&p);
                points.push(p);
            }
            let iterations = b.orbit.iterations;
            if b.parameter < lo || b.parameter > hi {
                let edge = if b.parameter > hi { hi } else { lo };
                let t = (edge - a.parameter) / (b.parameter - a.parameter);
                let guess: Vec<f64> = a
                    .orbit
                    .state
                    .iter()
                    .zip(&b.orbit.state)
                    .map(|(x, y)| x + t * (y - x))
                    .collect();
                let last = c.map_at(edge).and_then(|map| {
                    map.shoot(&guess, periodic.tolerance, periodic.max_iterations)
                        .map_err(|e| format!("at {edge}: {e}"))
                });
                match last {
                    Ok(orbit) => {
                        c.count(orbit.maps, &orbit.stats);
                        let column = c.parameter_column(edge, &orbit.state, &orbit.state);
                        let end = column.and_then(|column| {
                            let corrected = Corrected {
                                u: c.scale(&orbit.state, edge),
                                orbit,
                                column,
                            };
                            c.point(corrected, &b.tangent, PointKind::End, a.arclength + t * ds)
                        });
                        match end {
                            Ok(mut p) => {
                                count += 1;
                                p.progress = Progress {
                                    next_step: 0.0,
                                    points: count,
                                    maps: c.maps,
                                    warnings: step_warnings.clone(),
                                };
                                on_point(&p);
                                points.push(p);
                            }
                            Err(e) => step_warnings.push(format!("the end point at {edge}: {e}")),
                        }
                    }
                    Err(e) => step_warnings.push(format!("the end point: {e}")),
                }
                warnings.extend(step_warnings);
                break format!("reached the end of the range at {edge}");
            }
            // The largest step moves the parameter by at most max_step along the new tangent;
            // where the branch rises steeply (a resonance) the turn of the tangent limits it.
            let cap = max_step / b.tangent_parameter.abs().max(f64::MIN_POSITIVE);
            if iterations <= 2 {
                ds *= 1.5;
            } else if iterations >= 5 {
                ds = (0.7 * ds).max(min_step);
            }
            ds = ds.min(cap);
            count += 1;
            let mut b = b;
            b.progress = Progress {
                next_step: ds,
                points: count,
                maps: c.maps,
                warnings: step_warnings.clone(),
            };
            warnings.extend(step_warnings);
            on_point(&b);
            // Kept for special points only: a long chain's is (2N)² numbers an orbit.
            b.orbit.monodromy = Vec::new();
            points.push(b);
        };
        Branch {
            points,
            end,
            warnings,
            maps: c.maps,
            stats: c.stats,
            stopped,
        }
    }
}

/// Scales of the orbit components for the arclength: the first orbit's largest displacement
/// amplitude `A = max_i √(Δx_i² + (v_i/ω)²)` (from the rest state; exact for a sinusoid) for
/// every position and `ω A` for every velocity, so that the arclength weighs the response's size
/// against the parameter evenly; a chain that does not move keeps the integrator's scales.
fn orbit_scales(map: &PeriodMap, x: &[f64]) -> Vec<f64> {
    let n = map.n_particles();
    let rest = map.rest_state();
    let omega = std::f64::consts::TAU * map.drive_hz() / map.periods() as f64;
    let amplitude = (0..n)
        .map(|i| (x[i] - rest[i]).hypot(x[n + i] / omega))
        .fold(0.0, f64::max);
    let mut scales = map.scales().to_vec();
    if amplitude > 0.0 && amplitude.is_finite() {
        scales[..n].fill(amplitude);
        scales[n..2 * n].fill(omega * amplitude);
    }
    scales
}

/// The Floquet multipliers of an orbit as `(modulus, argument)`, largest first.
pub fn polar(multipliers: &[Multiplier]) -> Vec<(f64, f64)> {
    multipliers
        .iter()
        .map(|&(re, im)| (re.hypot(im), im.atan2(re)))
        .collect()
}
