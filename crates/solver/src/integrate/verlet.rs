//! Velocity Verlet, fixed step, second order; symplectic when no force depends on velocity.

use super::hermite::{fixed_steps, HermiteStep};
use super::{
    all_finite, Control, IntegrateError, IntegrationStats, Integrator, OdeSystemDyn, StepObserver,
};

/// Velocity Verlet with a fixed step.
///
/// With velocity-dependent (viscous) forces the acceleration at the new position is evaluated with
/// the predicted velocity `v + h a`, which keeps the method explicit and second order. Quadratures
/// (dissipated work, wall impulse) use the trapezoidal rule. One right-hand-side evaluation per step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VelocityVerlet {
    /// Requested step, s; the interval is split into equal steps no longer than this.
    pub dt: f64,
}

impl Integrator for VelocityVerlet {
    fn name(&self) -> &'static str {
        "verlet"
    }

    fn integrate(
        &self,
        sys: &mut dyn OdeSystemDyn,
        t0: f64,
        y0: &[f64],
        t_end: f64,
        max_steps: u64,
        obs: &mut dyn StepObserver,
    ) -> Result<IntegrationStats, IntegrateError> {
        let (n_steps, h) = fixed_steps(t0, t_end, self.dt)?;
        let n = sys.n_pos();
        let dim = 2 * n + sys.n_quad();
        if y0.len() != dim || !all_finite(y0) {
            return Err(IntegrateError::InvalidSettings(
                "initial state has the wrong length or is not finite".into(),
            ));
        }
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
            {
                let (x, rest) = y.split_at(n);
                let v = &rest[..n];
                let a = &f[n..2 * n];
                let (xn, rest_n) = y_new.split_at_mut(n);
                let vn = &mut rest_n[..n];
                for i in 0..n {
                    let v_half = v[i] + 0.5 * h * a[i];
                    xn[i] = x[i] + h * v_half;
                    vn[i] = v_half + 0.5 * h * a[i];
                }
            }
            sys.rhs(t_next, &y_new, &mut f_new);
            stats.rhs_evals += 1;
            for i in 0..n {
                let v_half = y[n + i] + 0.5 * h * f[n + i];
                y_new[n + i] = v_half + 0.5 * h * f_new[n + i];
                f_new[i] = y_new[n + i];
            }
            for i in 2 * n..dim {
                y_new[i] = y[i] + 0.5 * h * (f[i] + f_new[i]);
            }
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
}
