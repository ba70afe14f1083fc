//! Classic fourth-order Runge–Kutta, fixed step.

use super::fixed::{self, FixedScheme};
use super::{IntegrateError, IntegrationStats, Integrator, OdeSystemDyn, StepObserver};

/// Classic RK4 with a fixed step; four right-hand-side evaluations per step (the derivative at the
/// end of a step is reused as the first stage of the next, and for the dense output).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rk4 {
    /// Requested step, s; the interval is split into equal steps no longer than this.
    pub dt: f64,
}

impl Rk4 {
    /// Its name in a sweep file.
    pub const NAME: &'static str = "rk4";
    /// Right-hand-side evaluations per step.
    pub const RHS_PER_STEP: u64 = 4;
    /// Order of accuracy.
    pub const ORDER: i32 = 4;
}

impl Integrator for Rk4 {
    fn name(&self) -> &'static str {
        Self::NAME
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
        fixed::integrate::<Rk4Step>(self.dt, sys, t0, y0, t_end, max_steps, obs)
    }
}

/// RK4's stages 2–4 and the argument of the stage being evaluated.
struct Rk4Step {
    k2: Vec<f64>,
    k3: Vec<f64>,
    k4: Vec<f64>,
    tmp: Vec<f64>,
}

impl FixedScheme for Rk4Step {
    const RHS_PER_STEP: u64 = Rk4::RHS_PER_STEP;

    fn new(dim: usize, _n_pos: usize) -> Self {
        Rk4Step {
            k2: vec![0.0; dim],
            k3: vec![0.0; dim],
            k4: vec![0.0; dim],
            tmp: vec![0.0; dim],
        }
    }

    fn step(
        &mut self,
        sys: &mut dyn OdeSystemDyn,
        t: f64,
        t_next: f64,
        h: f64,
        y: &[f64],
        k1: &[f64],
        y_new: &mut [f64],
        f_new: &mut [f64],
    ) {
        let Rk4Step { k2, k3, k4, tmp } = self;
        let dim = y.len();
        for i in 0..dim {
            tmp[i] = y[i] + 0.5 * h * k1[i];
        }
        sys.rhs(t + 0.5 * h, tmp, k2);
        for i in 0..dim {
            tmp[i] = y[i] + 0.5 * h * k2[i];
        }
        sys.rhs(t + 0.5 * h, tmp, k3);
        for i in 0..dim {
            tmp[i] = y[i] + h * k3[i];
        }
        sys.rhs(t_next, tmp, k4);
        for i in 0..dim {
            y_new[i] = y[i] + h / 6.0 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]);
        }
        sys.rhs(t_next, y_new, f_new);
    }
}
