//! The one fixed-step loop: equal steps covering `[t0, t_end]`, the step budget, the finiteness
//! check and the cubic Hermite dense output, for every fixed-step scheme ([`FixedScheme`]:
//! velocity Verlet, classic RK4), which brings only its step.

use super::{
    all_finite, Control, DenseStep, IntegrateError, IntegrationStats, OdeSystemDyn, StepObserver,
};

/// What a fixed-step scheme brings to the loop: its work space and one step.
pub(crate) trait FixedScheme {
    /// Right-hand sides each step evaluates, the derivative at its end included.
    const RHS_PER_STEP: u64;
    /// Work space for a system of dimension `dim` with `n_pos` positions.
    fn new(dim: usize, n_pos: usize) -> Self;
    /// One step of size `h` from `(t, y)`, where `f = f(t, y)`, to `t_next`: the solution into
    /// `y_new` and the derivative there into `f_new` (the next step's `f` and the dense output's
    /// end slope).
    #[allow(clippy::too_many_arguments)]
    fn step(
        &mut self,
        sys: &mut dyn OdeSystemDyn,
        t: f64,
        t_next: f64,
        h: f64,
        y: &[f64],
        f: &[f64],
        y_new: &mut [f64],
        f_new: &mut [f64],
    );
}

/// Integrates from `t0` to exactly `t_end` in equal steps of at most `dt` with the scheme `S`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn integrate<S: FixedScheme>(
    dt: f64,
    sys: &mut dyn OdeSystemDyn,
    t0: f64,
    y0: &[f64],
    t_end: f64,
    max_steps: u64,
    obs: &mut dyn StepObserver,
) -> Result<IntegrationStats, IntegrateError> {
    let (n_steps, h) = fixed_steps(t0, t_end, dt)?;
    let n_pos = sys.n_pos();
    let dim = 2 * n_pos + sys.n_quad();
    if y0.len() != dim || !all_finite(y0) {
        return Err(IntegrateError::InvalidSettings(
            "initial state has the wrong length or is not finite".into(),
        ));
    }
    let mut scheme = S::new(dim, n_pos);
    let mut y = y0.to_vec();
    let mut y_new = vec![0.0; dim];
    let mut f = vec![0.0; dim];
    let mut f_new = vec![0.0; dim];
    let mut stats = IntegrationStats::default();
    sys.rhs(t0, &y, &mut f);
    stats.rhs_evals += 1;
    obs.on_start(t0, &y);
    for k in 0..n_steps {
        if stats.steps >= max_steps {
            return Err(IntegrateError::StepBudget {
                max_steps,
                t: t0 + k as f64 * h,
            });
        }
        let t = t0 + k as f64 * h;
        let t_next = if k + 1 == n_steps {
            t_end
        } else {
            t0 + (k + 1) as f64 * h
        };
        scheme.step(sys, t, t_next, h, &y, &f, &mut y_new, &mut f_new);
        stats.rhs_evals += S::RHS_PER_STEP;
        stats.steps += 1;
        if !all_finite(&y_new) {
            return Err(IntegrateError::NonFinite { t: t_next });
        }
        let control = obs.on_step(&HermiteStep {
            t0: t,
            t1: t_next,
            y0: &y,
            y1: &y_new,
            f0: &f,
            f1: &f_new,
        });
        std::mem::swap(&mut y, &mut y_new);
        std::mem::swap(&mut f, &mut f_new);
        if control == Control::Stop {
            break;
        }
    }
    Ok(stats)
}

/// Cubic Hermite dense output: exact values and derivatives at both ends of a step give an
/// interpolant accurate to O(h⁴), enough for second- and fourth-order methods.
struct HermiteStep<'a> {
    t0: f64,
    t1: f64,
    y0: &'a [f64],
    y1: &'a [f64],
    f0: &'a [f64],
    f1: &'a [f64],
}

impl DenseStep for HermiteStep<'_> {
    fn t_start(&self) -> f64 {
        self.t0
    }
    fn t_end(&self) -> f64 {
        self.t1
    }
    fn y_end(&self) -> &[f64] {
        self.y1
    }
    #[inline]
    fn eval_component(&self, t: f64, i: usize) -> f64 {
        let h = self.t1 - self.t0;
        let s = (t - self.t0) / h;
        let s2 = s * s;
        let s3 = s2 * s;
        let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
        let h10 = s3 - 2.0 * s2 + s;
        let h01 = -2.0 * s3 + 3.0 * s2;
        let h11 = s3 - s2;
        h00 * self.y0[i] + h10 * h * self.f0[i] + h01 * self.y1[i] + h11 * h * self.f1[i]
    }
}

/// Number of equal steps of at most `dt` covering `[t0, t_end]`, and the step used.
fn fixed_steps(t0: f64, t_end: f64, dt: f64) -> Result<(u64, f64), IntegrateError> {
    if !(dt.is_finite() && dt > 0.0) {
        return Err(IntegrateError::InvalidSettings(format!(
            "time step must be a finite number > 0, got {dt}"
        )));
    }
    let span = t_end - t0;
    if !(span.is_finite() && span > 0.0) {
        return Err(IntegrateError::InvalidSettings(format!(
            "end time must exceed start time, got [{t0}, {t_end}]"
        )));
    }
    let n = (span / dt * (1.0 - 1e-12)).ceil().max(1.0);
    Ok((n as u64, span / n))
}
