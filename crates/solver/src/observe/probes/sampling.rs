//! The one sampling grid every record takes its instants from (`t0 + j·interval`: summaries,
//! histories, fields, the steady state) and the batched interpolation that feeds them. Apart so
//! that the count of a run's samples ([`samples_in`], which the runner sizes its files with) and
//! the loop that takes them sit side by side and cannot drift apart.

use crate::integrate::DenseStep;
use crate::observe::grid_instant;

/// Fills `times` with the sample times `t0 + j·interval`, `j = first, first + 1, …`, up to `until`
/// (at most `times.len()` of them) and returns how many there are: one sampling grid for the
/// summaries, the histories and the fields alike.
#[inline]
fn batch_times(t0: f64, first: u64, interval: f64, until: f64, times: &mut [f64]) -> usize {
    let mut count = 0;
    while count < times.len() {
        let t = grid_instant(t0, first + count as u64, interval);
        if t > until {
            break;
        }
        times[count] = t;
        count += 1;
    }
    count
}

/// How many instants `t0 + i·interval` (`i = 0, 1, …`) lie in `[t0, t_end]`, counted as the
/// sampling loop ([`batch_times`]) takes them: `i` while `t0 + i·interval ≤ t_end` in floating
/// point (which a quotient rounded down can miss by one either way). What a run that is not
/// stopped early records: the writer of the results sizes its time axis with it.
pub fn samples_in(t0: f64, interval: f64, t_end: f64) -> u64 {
    if interval.is_nan() || interval <= 0.0 || t_end.is_nan() || t_end < t0 {
        return u64::from(t_end >= t0);
    }
    let at = |i: u64| grid_instant(t0, i, interval);
    let mut last = ((t_end - t0) / interval).floor().max(0.0) as u64;
    while last > 0 && at(last) > t_end {
        last -= 1;
    }
    while at(last + 1) <= t_end {
        last += 1;
    }
    last + 1
}

/// Feeds `sink` the instants `t0 + i·interval` of `grid` from `i = *next` up to `until` (and
/// advances `*next` past them), each with the state whose `components` are interpolated in
/// `step` there: in batches of [`SAMPLE_BATCH`] (one interpolant set-up for all of a batch),
/// the samples then fed in time order exactly as one at a time (the values of a sample do not
/// depend on the batch it is in). `batch` holds a batch's values (as many rows of the components
/// as it has room for, at most [`SAMPLE_BATCH`]), `state` the components of one sample.
#[allow(clippy::too_many_arguments)]
#[inline]
pub(crate) fn sample_grid(
    step: &dyn DenseStep,
    (t0, interval): (f64, f64),
    next: &mut u64,
    until: f64,
    components: &[usize],
    batch: &mut [f64],
    state: &mut [f64],
    mut sink: impl FnMut(f64, &[f64]),
) {
    let m = components.len();
    let rows = batch
        .len()
        .checked_div(m)
        .map_or(SAMPLE_BATCH, |r| r.clamp(1, SAMPLE_BATCH));
    let mut times = [0.0f64; SAMPLE_BATCH];
    loop {
        let count = batch_times(t0, *next, interval, until, &mut times[..rows]);
        if count == 0 {
            break;
        }
        let values = &mut batch[..count * m];
        step.eval_components_at(&times[..count], components, values);
        for (&t, row) in times[..count].iter().zip(values.chunks_exact(m.max(1))) {
            for (&i, &v) in components.iter().zip(row) {
                state[i] = v;
            }
            sink(t, state);
        }
        *next += count as u64;
        if count < rows {
            break;
        }
    }
}

/// Most samples interpolated in one call ([`DenseStep::eval_components_at`]).
pub(super) const SAMPLE_BATCH: usize = 32;

#[cfg(test)]
mod tests {
    use super::*;

    /// `samples_in` counts the instants the sampling loop takes, including where the quotient
    /// `t_end / interval` rounds to the wrong side of an integer (1e-3 / 1e-6, 0.3 / 0.1, …).
    #[test]
    fn samples_in_counts_what_the_sampling_loop_takes() {
        let mut rng = crate::contact::SplitMix64(7);
        let mut cases = vec![
            (1e-6, 1e-3),
            (0.1, 0.3),
            (1e-7, 2e-4),
            (3e-6, 1e-3),
            (1.0, 0.0),
        ];
        for _ in 0..2000 {
            let dt = 10f64.powf(-7.0 + 3.0 * (rng.symmetric() + 1.0) / 2.0);
            let k = (rng.next_u64() % 5000) as f64;
            cases.push((dt, k * dt));
            cases.push((dt, k * dt * (1.0 + 1e-15)));
        }
        for (dt, t_end) in cases {
            let mut count = 0u64;
            let mut times = [0.0; SAMPLE_BATCH];
            loop {
                let c = batch_times(0.0, count, dt, t_end, &mut times);
                count += c as u64;
                if c < SAMPLE_BATCH {
                    break;
                }
            }
            assert_eq!(
                samples_in(0.0, dt, t_end),
                count,
                "interval {dt:e}, end {t_end:e}"
            );
        }
    }
}
