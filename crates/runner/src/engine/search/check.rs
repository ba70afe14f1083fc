//! The checks on a search before anything runs: every searched interval is one the scene takes,
//! and a fit's recorded signals lie within the runs.

use chainsweep_solver::observe::grid_instant;
use chainsweep_solver::observe::probes::samples_in;

use crate::error::{Error, Result};
use crate::grid::Grid;
use crate::sweep::Sweep;

use super::driver::Driver;

/// A fit's recorded signals lie within the runs: every data instant, moved by any time shift the
/// fit may take, is within the history every point's scene records, from 0 to its last sample
/// (an input error naming the signal's instants otherwise, before anything runs). The last sample
/// is the last `i · history_interval_s` not after `duration_s` in floating point, which can be
/// one interval before `duration_s` (15 000 · 1e-8 > 1.5e-4): checked against `duration_s`, data
/// up to it passed here and then every run was refused.
fn check_data_within_runs(
    driver: &Driver<'_>,
    fit: &crate::sweep::fit::FitSpec,
    middle: &[f64],
) -> Result<()> {
    use crate::sweep::fit::Datum;
    for own in 0..driver.grid.len() {
        let Some((o, _)) = driver.layout.of_own(own) else {
            continue;
        };
        let k = driver.data_set(o);
        let (_, Ok(scene)) = driver.scene(own, middle) else {
            continue;
        };
        let set = &fit.sets[k];
        let dt = scene.record.history_interval_s;
        let last_sample = grid_instant(
            0.0,
            samples_in(0.0, dt, scene.duration_s).saturating_sub(1),
            dt,
        );
        for (i, d) in set.data.iter().enumerate() {
            let Datum::Signal(s) = d else { continue };
            let (smin, smax) = s.shift.map_or((0.0, 0.0), |iv| (iv.min, iv.max));
            let first = s.time_s[0] + smin;
            let last = s.time_s[s.time_s.len() - 1] + smax;
            if first < 0.0 || last > last_sample {
                let at = match fit.sets_dim {
                    Some(_) => format!("search.data_sets[{k}][{i}].signal.time_s"),
                    None => format!("search.data[{i}].signal.time_s"),
                };
                let label = driver.grid.point_label(driver.sweep, own);
                return Err(Error::input(
                    at,
                    format!(
                        "the data instants{} reach {first} to {last} s, beyond the runs' histories (0 to their last sample, {last_sample} s, the last multiple of history_interval_s = {dt} s not after duration_s = {} s{}): lengthen duration_s (by one history_interval_s where the data end at it), or narrow the data or their time_shift_s",
                        if s.shift.is_some() { ", moved by any time shift allowed," } else { "" },
                        scene.duration_s,
                        if label.is_empty() { String::new() } else { format!(" at {label}") }
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Every searched interval is one the scene takes at both ends, at every point of the sweep's
/// grid (each field at each of its ends, the others in the middle of theirs): an end the scene
/// refuses (a negative mass) is an input error naming it, caught before anything runs rather than
/// as failed runs that a search might take for an answer. (Nothing to check without a search.)
pub fn check_intervals(sweep: &Sweep, grid: &Grid) -> Result<()> {
    let Some(spec) = &sweep.search else {
        return Ok(());
    };
    let driver = Driver::new(sweep, grid);
    let middle: Vec<f64> = spec.fields.iter().map(|f| 0.5 * (f.min + f.max)).collect();
    if let Some(fit) = &spec.fit {
        check_data_within_runs(&driver, fit, &middle)?;
    }
    for own in 0..grid.len() {
        for (k, f) in spec.fields.iter().enumerate() {
            for (x, end) in [(f.min, "min"), (f.max, "max")] {
                let mut at = middle.clone();
                at[k] = x;
                if let (_, Err(why)) = driver.scene(own, &at) {
                    let label = grid.point_label(sweep, own);
                    let place = if label.is_empty() {
                        String::new()
                    } else {
                        format!(" at {label}")
                    };
                    return Err(Error::input(
                        format!("search.fields[{k}].{end}"),
                        format!(
                            "the scene refuses {} = {x}{place} ({}): a searched interval must hold only values the scene takes",
                            f.name,
                            why.trim_start_matches("the scene of this search point is invalid: ")
                        ),
                    ));
                }
            }
        }
    }
    Ok(())
}
