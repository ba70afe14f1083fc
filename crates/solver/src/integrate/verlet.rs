//! Velocity Verlet, fixed step, second order; symplectic when no force depends on velocity.

use super::fixed::{self, FixedScheme};
use super::{IntegrateError, IntegrationStats, Integrator, OdeSystemDyn, StepObserver};

/// Velocity Verlet with a fixed step.
///
/// With velocity-dependent (viscous) forces the acceleration at the new position is evaluated with
/// the predicted velocity `v + h a`, which keeps the method explicit and second order. Quadratures
/// (dissipated work, wall impulse) and contact histories (Thornton's law) use the trapezoidal rule,
/// the histories predicted by explicit Euler for the evaluation at the new position. One
/// right-hand-side evaluation per step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VelocityVerlet {
    /// Requested step, s; the interval is split into equal steps no longer than this.
    pub dt: f64,
}

impl VelocityVerlet {
    /// Its name in a sweep file.
    pub const NAME: &'static str = "verlet";
    /// Right-hand-side evaluations per step.
    pub const RHS_PER_STEP: u64 = 1;
    /// Order of accuracy.
    pub const ORDER: i32 = 2;
}

impl Integrator for VelocityVerlet {
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
        fixed::integrate::<VerletStep>(self.dt, sys, t0, y0, t_end, max_steps, obs)
    }
}

/// Velocity Verlet needs no work space beyond the loop's: the number of positions.
struct VerletStep {
    n: usize,
}

impl FixedScheme for VerletStep {
    const RHS_PER_STEP: u64 = VelocityVerlet::RHS_PER_STEP;

    fn new(_dim: usize, n_pos: usize) -> Self {
        VerletStep { n: n_pos }
    }

    fn step(
        &mut self,
        sys: &mut dyn OdeSystemDyn,
        _t: f64,
        t_next: f64,
        h: f64,
        y: &[f64],
        f: &[f64],
        y_new: &mut [f64],
        f_new: &mut [f64],
    ) {
        let n = self.n;
        let dim = y.len();
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
        // The components after the velocities at the end of the step, predicted (explicit Euler)
        // for the right-hand side there: quadratures never feed back, but a chain's contact
        // histories (Thornton's law) do, and would otherwise be read stale. Corrected below.
        for i in 2 * n..dim {
            y_new[i] = y[i] + h * f[i];
        }
        sys.rhs(t_next, y_new, f_new);
        for i in 0..n {
            let v_half = y[n + i] + 0.5 * h * f[n + i];
            y_new[n + i] = v_half + 0.5 * h * f_new[n + i];
            f_new[i] = y_new[n + i];
        }
        for i in 2 * n..dim {
            y_new[i] = y[i] + 0.5 * h * (f[i] + f_new[i]);
        }
    }
}
