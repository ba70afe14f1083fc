//! The numerics of the runner: how results are checked and how integrator settings are chosen.
//!
//! - [`verify`]: `run --verify`: a sample of grid points re-run at a tighter setting, and the
//!   observed relative error of every summary;
//! - [`auto`]: `integrator: auto`, resolved to the cheapest setting that meets a target error by
//!   a pilot on a few grid points;
//! - [`accuracy`]: work-precision studies (`chainsweep accuracy`).
//!
//! All three measure a run against a reference the same way: [`probe_errors`], the relative
//! errors of the leading peak, its time and the record maximum at every probe.

pub mod accuracy;
pub mod auto;
pub mod verify;

use chainsweep_solver::observe::probes::ProbeSummary;

/// Relative error of `x` against the reference `r`: NaN when both are NaN (neither run has the
/// value), infinite when only one is (the runs disagree on whether it exists) or when `r` is 0 and
/// `x` is not.
pub fn rel_error(x: f64, r: f64) -> f64 {
    match (x.is_nan(), r.is_nan()) {
        (true, true) => f64::NAN,
        (true, false) | (false, true) => f64::INFINITY,
        _ => {
            if x == r {
                0.0
            } else if r == 0.0 {
                f64::INFINITY
            } else {
                ((x - r) / r).abs()
            }
        }
    }
}

/// Per probe, the relative errors of `run`'s leading peak, its time and its record maximum
/// against `reference`'s.
pub fn probe_errors(run: &[ProbeSummary], reference: &[ProbeSummary]) -> Vec<[f64; 3]> {
    run.iter()
        .zip(reference)
        .map(|(a, r)| {
            [
                rel_error(a.leading_peak, r.leading_peak),
                rel_error(a.leading_peak_time_s, r.leading_peak_time_s),
                rel_error(a.record_max, r.record_max),
            ]
        })
        .collect()
}

/// The NaN-skipping maximum, defined with the run record (the stored `verify_rel_error_max` is
/// one), which sits below the numerics.
pub use crate::record::max_ignoring_nan;

/// Rounds to 3 significant digits, so that ladder rungs and step sizes read `3e-7`, not
/// `2.9999999999999997e-7`.
pub fn round3(x: f64) -> f64 {
    format!("{x:.2e}").parse().unwrap_or(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_errors() {
        assert_eq!(rel_error(1.0, 1.0), 0.0);
        assert!((rel_error(1.01, 1.0) - 0.01).abs() < 1e-12);
        assert!(rel_error(f64::NAN, f64::NAN).is_nan());
        assert!(rel_error(f64::NAN, 1.0).is_infinite());
        assert!(rel_error(1.0, 0.0).is_infinite());
    }

    #[test]
    fn maxima_skip_nan() {
        assert!(max_ignoring_nan([f64::NAN, f64::NAN]).is_nan());
        assert_eq!(max_ignoring_nan([f64::NAN, 2.0, 1.0, f64::NAN]), 2.0);
        assert_eq!(max_ignoring_nan([1.0, f64::INFINITY]), f64::INFINITY);
        assert_eq!(round3(1e-6 * 0.3), 3e-7);
        assert_eq!(round3(1.23456), 1.23);
    }
}
