//! Cubic Hermite dense output for the fixed-step methods: exact values and derivatives at both ends
//! of a step give an interpolant accurate to O(h⁴), enough for second- and fourth-order methods.

use super::DenseStep;

pub(crate) struct HermiteStep<'a> {
    pub t0: f64,
    pub t1: f64,
    pub y0: &'a [f64],
    pub y1: &'a [f64],
    pub f0: &'a [f64],
    pub f1: &'a [f64],
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
pub(crate) fn fixed_steps(
    t0: f64,
    t_end: f64,
    dt: f64,
) -> Result<(u64, f64), super::IntegrateError> {
    if !(dt.is_finite() && dt > 0.0) {
        return Err(super::IntegrateError::InvalidSettings(format!(
            "time step must be a finite number > 0, got {dt}"
        )));
    }
    let span = t_end - t0;
    if !(span.is_finite() && span > 0.0) {
        return Err(super::IntegrateError::InvalidSettings(format!(
            "end time must exceed start time, got [{t0}, {t_end}]"
        )));
    }
    let n = (span / dt * (1.0 - 1e-12)).ceil().max(1.0);
    Ok((n as u64, span / n))
}
