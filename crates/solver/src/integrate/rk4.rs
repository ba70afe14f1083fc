//! Classic fourth-order Runge–Kutta, fixed step.

use super::hermite::{fixed_steps, HermiteStep};
use super::{
    all_finite, Control, IntegrateError, IntegrationStats, Integrator, OdeSystemDyn, StepObserver,
};

/// Classic RK4 with a fixed step; four right-hand-side evaluations per step (the derivative at the
/// end of a step is reused as the first stage of the next, and for the dense output).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rk4 {
    /// Requested step, s; the interval is split into equal steps no longer than this.
    pub dt: f64,
}

impl Integrator for Rk4 {
    fn name(&self) -> &'static str {
        "rk4"
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
        let dim = 2 * sys.n_pos() + sys.n_quad();
        if y0.len() != dim || !all_finite(y0) {
            return Err(IntegrateError::InvalidSettings(
                "initial state has the wrong length or is not finite".into(),
            ));
        }
        let mut y = y0.to_vec();
        let mut y_new = vec![0.0; dim];
        let mut k1 = vec![0.0; dim];
        let mut k2 = vec![0.0; dim];
        let mut k3 = vec![0.0; dim];
        let mut k4 = vec![0.0; dim];
        let mut tmp = vec![0.0; dim];
        let mut stats = IntegrationStats::default();
        sys.rhs(t0, &y, &mut k1);
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
            for i in 0..dim {
                tmp[i] = y[i] + 0.5 * h * k1[i];
            }
            sys.rhs(t + 0.5 * h, &tmp, &mut k2);
            for i in 0..dim {
                tmp[i] = y[i] + 0.5 * h * k2[i];
            }
            sys.rhs(t + 0.5 * h, &tmp, &mut k3);
            for i in 0..dim {
                tmp[i] = y[i] + h * k3[i];
            }
            sys.rhs(t_next, &tmp, &mut k4);
            for i in 0..dim {
                y_new[i] = y[i] + h / 6.0 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]);
            }
            // Derivative at the new point: first stage of the next step and the dense output's end slope.
            sys.rhs(t_next, &y_new, &mut k4);
            stats.rhs_evals += 4;
            stats.steps += 1;
            if !all_finite(&y_new) {
                return Err(IntegrateError::NonFinite { t: t_next });
            }
            let control = obs.on_step(&HermiteStep {
                t0: t,
                t1: t_next,
                y0: &y,
                y1: &y_new,
                f0: &k1,
                f1: &k4,
            });
            std::mem::swap(&mut y, &mut y_new);
            std::mem::swap(&mut k1, &mut k4);
            if control == Control::Stop {
                break;
            }
        }
        Ok(stats)
    }
}
