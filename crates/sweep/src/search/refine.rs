//! The objective over one or two fields, sampled until interpolating the samples is accurate to
//! the objective tolerance: points go where the curve bends or jumps, as python-adaptive's
//! learners put them, but as a pure function of the values (see [`super`]).
//!
//! - A curve (one field) is interpolated linearly between its samples. The objectives of
//!   chains are smooth between kinks and jumps (a leading peak changes its nature at some mass
//!   ratios), and the error of a chord across a kink is what a curvature estimate misses: the
//!   error of an interval is estimated by how far its ends fall from its neighbours' lines
//!   extended over it (half the larger miss, which bounds the chord's error when the curve is
//!   two lines meeting inside the interval, and is four times the h²/8 · |f''| of a smooth
//!   curve: conservative there); and, for an interval made by halving another, by half the error
//!   measured when it was made (its parent's chord missed the new point by the surplus s; where
//!   the curve is smooth the halves miss by about s/4; a half holding a kink can miss by more, up
//!   to 2s when the kink lies near the parent's end, which the neighbours' lines then bound). The
//!   `round` intervals of largest estimate are halved at a time, until every estimate is within
//!   the tolerance, or the intervals still above it are narrower than twice the field's tolerance
//!   (a jump, located to that tolerance).
//! - A surface (two fields) is a tree of rectangular cells, sampled at their corners and
//!   interpolated bilinearly in each. A cell's error along each field is the curve's estimate on
//!   the lines of its two edges along that field (half the larger miss of the neighbouring
//!   samples' lines extended over the edge). For a smooth surface the interior bends as its
//!   edges do; a saddle, whose centre is the mean of its corners, shows on its edges too. The
//!   `round` cells of largest error are halved at a time along the fields whose estimate is at
//!   least half the larger one, so that a surface that bends along one field is refined along
//!   that one only; until every cell is within the tolerance or too small to halve (each
//!   field's `tolerance`). A feature that lies wholly inside a first-scan cell and does not
//!   reach its edges is not seen: the scan (`scan`, per field) must be fine enough to see every
//!   feature.
//!
//! A run that failed (or gave no number) leaves a gap (`failed: gap`): the intervals or cells
//! touching it are not refined, and the outcome counts them.

use std::collections::BTreeMap;

use super::{linspace, Outcome, SearchStatus, Streams, Value};
use crate::sweep::search::{OnFailure, SearchSpec};

/// Most rounds of a refinement (far more than any budget allows: this bounds only a tolerance
/// below the floating-point resolution).
const MAX_ROUNDS: usize = 100_000;

/// A refinement that has ended: `unresolved` parts (`parts`: intervals or cells) still above the
/// tolerance make it stalled; `gaps` of them next to a failed run are said in the note.
fn ended(mut note: String, unresolved: usize, gaps: usize, parts: &str, largest: f64) -> Outcome {
    if gaps > 0 {
        note += &format!("; {gaps} {parts} next to a failed run left as gaps");
    }
    Outcome {
        status: if unresolved > 0 {
            SearchStatus::Stalled
        } else {
            SearchStatus::Converged
        },
        items: Vec::new(),
        refine_error: largest,
        note,
        fit: None,
    }
}

/// The estimated interpolation error of every interval of the samples `xs`, `ys` (sorted by
/// `x`), `surplus[i]` the error measured when interval `i` was made by halving (see the module
/// docs); `None` for an interval touching a sample without a number.
pub fn interval_errors(xs: &[f64], ys: &[Value], surplus: &[Option<f64>]) -> Vec<Option<f64>> {
    let n = xs.len();
    let slope = |i: usize| -> Option<f64> { Some((ys[i + 1]? - ys[i]?) / (xs[i + 1] - xs[i])) };
    (0..n.saturating_sub(1))
        .map(|i| {
            let (a, b) = (ys[i]?, ys[i + 1]?);
            let h = xs[i + 1] - xs[i];
            // How far each end falls from the line of the neighbouring interval on the other side.
            let left = (i >= 1)
                .then(|| slope(i - 1))
                .flatten()
                .map(|s| (b - (a + s * h)).abs());
            let right = (i + 2 < n)
                .then(|| slope(i + 1))
                .flatten()
                .map(|s| (a - (b - s * h)).abs());
            let miss = [left, right].into_iter().flatten().fold(0.0, f64::max);
            Some((0.5 * miss).max(surplus[i].map_or(0.0, |s| 0.5 * s)))
        })
        .collect()
}

/// A curve: the objective over one field.
pub fn curve(spec: &SearchSpec, s: &mut Streams) -> Outcome {
    let f = &spec.fields[0];
    let tol = spec.objective_tolerance;
    let mut xs = linspace(f.min, f.max, spec.scan[0]);
    let points: Vec<Vec<f64>> = xs.iter().map(|&x| vec![x]).collect();
    let Some(mut ys) = s.eval(0, &points) else {
        return Outcome::running(Vec::new(), f64::NAN);
    };
    // The error measured when each interval was made (none for the scan's).
    let mut surplus: Vec<Option<f64>> = vec![None; xs.len() - 1];
    for _ in 0..MAX_ROUNDS {
        if spec.on_failure == OnFailure::Stop {
            if let Some(i) = ys.iter().position(|y| y.is_none()) {
                return Outcome::failed_at(spec, &[xs[i]]);
            }
        }
        let errors = interval_errors(&xs, &ys, &surplus);
        let largest =
            errors
                .iter()
                .flatten()
                .fold(f64::NAN, |m, &e| if m.is_nan() || e > m { e } else { m });
        // Intervals above the tolerance that may still be halved.
        let mut todo: Vec<(usize, f64)> = errors
            .iter()
            .enumerate()
            .filter_map(|(i, e)| e.filter(|&e| e > tol).map(|e| (i, e)))
            .filter(|&(i, _)| 0.5 * (xs[i + 1] - xs[i]) >= f.tolerance)
            .collect();
        if todo.is_empty() {
            let unresolved = errors.iter().flatten().filter(|&&e| e > tol).count();
            let gaps = errors.iter().filter(|e| e.is_none()).count();
            let mut note = format!(
                "{} samples; largest estimated interpolation error {largest:.3e} (tolerance {tol:e})",
                xs.len()
            );
            if unresolved > 0 {
                note += &format!(
                    "; {unresolved} interval(s) narrower than twice the tolerance of {} still above it (a jump or a kink, located to that tolerance)",
                    f.name
                );
            }
            return ended(note, unresolved, gaps, "interval(s)", largest);
        }
        // The largest first (ties: lower x); then in x order.
        todo.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        todo.truncate(spec.round);
        todo.sort_by_key(|&(i, _)| i);
        let mids: Vec<Vec<f64>> = todo
            .iter()
            .map(|&(i, _)| vec![0.5 * (xs[i] + xs[i + 1])])
            .collect();
        let Some(new) = s.eval(0, &mids) else {
            return Outcome::running(Vec::new(), largest);
        };
        // (From the last, so that the earlier intervals keep their indices.)
        for (&(i, _), (m, y)) in todo.iter().zip(mids.iter().zip(new)).rev() {
            let miss = match (ys[i], ys[i + 1], y) {
                (Some(a), Some(b), Some(c)) => Some((c - 0.5 * (a + b)).abs()),
                _ => None,
            };
            xs.insert(i + 1, m[0]);
            ys.insert(i + 1, y);
            surplus[i] = miss;
            surplus.insert(i + 1, miss);
        }
    }
    Outcome {
        status: SearchStatus::Stalled,
        items: Vec::new(),
        refine_error: f64::NAN,
        note: "the refinement did not end within its rounds".into(),
        fit: None,
    }
}

/// A cell of a surface: its corners on the integer lattice of the surface.
#[derive(Debug, Clone, Copy)]
struct Cell {
    a0: u64,
    a1: u64,
    b0: u64,
    b1: u64,
}

/// Halvings of the first scan's cells the lattice can hold (exact midpoints down to 2^-30 of a
/// scan cell, far below any field's tolerance).
const LATTICE_BITS: u32 = 30;

/// The weight of an edge's miss in a cell's error: half, as for a curve's interval
/// (`interval_errors`), bounds the error of a kink along that edge.
const EDGE_WEIGHT: f64 = 0.5;

/// A surface: the objective over two fields.
pub fn surface(spec: &SearchSpec, s: &mut Streams) -> Outcome {
    let (fx, fy) = (&spec.fields[0], &spec.fields[1]);
    let tol = spec.objective_tolerance;
    let (na, nb) = (spec.scan[0] as u64, spec.scan[1] as u64);
    let step = 1u64 << LATTICE_BITS;
    let (top_a, top_b) = ((na - 1) * step, (nb - 1) * step);
    // A lattice coordinate in field units, both ends exact.
    let at = |k: u64, top: u64, min: f64, max: f64| {
        if k == top {
            max
        } else {
            min + (max - min) * (k as f64 / top as f64)
        }
    };
    let at_a = |k: u64| at(k, top_a, fx.min, fx.max);
    let at_b = |k: u64| at(k, top_b, fy.min, fy.max);
    let point = |a: u64, b: u64| vec![at_a(a), at_b(b)];
    let mut values: BTreeMap<(u64, u64), Value> = BTreeMap::new();
    let mut cells: Vec<Cell> = Vec::new();
    for i in 0..na - 1 {
        for j in 0..nb - 1 {
            cells.push(Cell {
                a0: i * step,
                a1: (i + 1) * step,
                b0: j * step,
                b1: (j + 1) * step,
            });
        }
    }
    // The first scan: the grid's points.
    let mut first: Vec<(u64, u64)> = Vec::new();
    for i in 0..na {
        for j in 0..nb {
            first.push((i * step, j * step));
        }
    }
    let batch: Vec<Vec<f64>> = first.iter().map(|&(a, b)| point(a, b)).collect();
    let Some(ys) = s.eval(0, &batch) else {
        return Outcome::running(Vec::new(), f64::NAN);
    };
    values.extend(first.into_iter().zip(ys));
    // A cell's estimated error along each field: a curve's interval's estimate (see
    // `interval_errors`) on the lines of its two edges along that field. (The larger, along the
    // first field, along the second.)
    let error = |c: &Cell, values: &BTreeMap<(u64, u64), Value>| -> Option<(f64, f64, f64)> {
        let v = |a, b| values.get(&(a, b)).copied().flatten();
        // Its corners hold numbers (a failed one leaves the cell a gap).
        v(c.a0, c.b0)?;
        v(c.a1, c.b0)?;
        v(c.a0, c.b1)?;
        v(c.a1, c.b1)?;
        // How far a corner falls from the line through the two samples beyond the opposite
        // corner on the same edge line, extended over the cell.
        let miss =
            |near: Option<f64>, beyond: Option<f64>, far: Option<f64>| match (near, beyond, far) {
                (Some(n), Some(b), Some(f)) => (f - (2.0 * n - b)).abs(),
                _ => 0.0,
            };
        let (wa, wb) = (c.a1 - c.a0, c.b1 - c.b0);
        let mut along_a = 0.0f64;
        for b in [c.b0, c.b1] {
            let before = c.a0.checked_sub(wa).and_then(|a| v(a, b));
            along_a = along_a.max(miss(v(c.a0, b), before, v(c.a1, b))).max(miss(
                v(c.a1, b),
                v(c.a1 + wa, b),
                v(c.a0, b),
            ));
        }
        let mut along_b = 0.0f64;
        for a in [c.a0, c.a1] {
            let before = c.b0.checked_sub(wb).and_then(|b| v(a, b));
            along_b = along_b.max(miss(v(a, c.b0), before, v(a, c.b1))).max(miss(
                v(a, c.b1),
                v(a, c.b1 + wb),
                v(a, c.b0),
            ));
        }
        let (along_a, along_b) = (EDGE_WEIGHT * along_a, EDGE_WEIGHT * along_b);
        Some((along_a.max(along_b), along_a, along_b))
    };
    let can_split = |lo: u64, hi: u64, at: &dyn Fn(u64) -> f64, tolerance: f64| {
        hi - lo >= 2 && 0.5 * (at(hi) - at(lo)) >= tolerance
    };
    // Along which fields a cell above the tolerance is halved: along those whose estimate is at
    // least half the larger one (a surface that bends along one field is refined along that one
    // only), never along a field at its tolerance.
    let split_along = |c: &Cell, (top, ea, eb): (f64, f64, f64)| -> (bool, bool) {
        let ok_a = can_split(c.a0, c.a1, &at_a, fx.tolerance);
        let ok_b = can_split(c.b0, c.b1, &at_b, fy.tolerance);
        (ok_a && ea >= 0.5 * top, ok_b && eb >= 0.5 * top)
    };
    for _ in 0..MAX_ROUNDS {
        if spec.on_failure == OnFailure::Stop {
            if let Some((&(a, b), _)) = values.iter().find(|(_, v)| v.is_none()) {
                return Outcome::failed_at(spec, &point(a, b));
            }
        }
        let errors: Vec<Option<(f64, f64, f64)>> =
            cells.iter().map(|c| error(c, &values)).collect();
        let largest =
            errors.iter().flatten().fold(
                f64::NAN,
                |m, &(e, _, _)| if m.is_nan() || e > m { e } else { m },
            );
        let mut todo: Vec<(usize, f64, (bool, bool))> = errors
            .iter()
            .enumerate()
            .filter_map(|(i, e)| {
                e.filter(|e| e.0 > tol)
                    .map(|e| (i, e.0, split_along(&cells[i], e)))
            })
            .filter(|&(_, _, (a, b))| a || b)
            .collect();
        if todo.is_empty() {
            let unresolved = errors.iter().flatten().filter(|e| e.0 > tol).count();
            let gaps = errors.iter().filter(|e| e.is_none()).count();
            let mut note = format!(
                "{} samples in {} cells; largest estimated interpolation error {largest:.3e} (tolerance {tol:e})",
                values.len(),
                cells.len()
            );
            if unresolved > 0 {
                note += &format!(
                    "; {unresolved} cell(s) at the fields' tolerance still above it (a jump or a kink)"
                );
            }
            return ended(note, unresolved, gaps, "cell(s)", largest);
        }
        todo.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        todo.truncate(spec.round);
        todo.sort_by_key(|&(i, _, _)| i);
        // Each split cell's children, and the points they need that are not known yet.
        let mut children: Vec<(usize, Vec<Cell>)> = Vec::new();
        let mut new: Vec<(u64, u64)> = Vec::new();
        for &(i, _, (along_a, along_b)) in &todo {
            let c = cells[i];
            let (am, bm) = ((c.a0 + c.a1) / 2, (c.b0 + c.b1) / 2);
            let a_parts: &[(u64, u64)] = if along_a {
                &[(c.a0, am), (am, c.a1)]
            } else {
                &[(c.a0, c.a1)]
            };
            let b_parts: &[(u64, u64)] = if along_b {
                &[(c.b0, bm), (bm, c.b1)]
            } else {
                &[(c.b0, c.b1)]
            };
            let mut kids = Vec::new();
            for &(b0, b1) in b_parts {
                for &(a0, a1) in a_parts {
                    kids.push(Cell { a0, a1, b0, b1 });
                }
            }
            let mut want = Vec::new();
            for k in &kids {
                want.extend([(k.a0, k.b0), (k.a1, k.b0), (k.a0, k.b1), (k.a1, k.b1)]);
            }
            for p in want {
                if !values.contains_key(&p) && !new.contains(&p) {
                    new.push(p);
                }
            }
            children.push((i, kids));
        }
        let batch: Vec<Vec<f64>> = new.iter().map(|&(a, b)| point(a, b)).collect();
        let Some(ys) = s.eval(0, &batch) else {
            return Outcome::running(Vec::new(), largest);
        };
        values.extend(new.into_iter().zip(ys));
        // Children replace their parents, in place (the order of cells is a function of the
        // splits only).
        for (i, kids) in children.into_iter().rev() {
            cells.splice(i..=i, kids);
        }
    }
    Outcome {
        status: SearchStatus::Stalled,
        items: Vec::new(),
        refine_error: f64::NAN,
        note: "the refinement did not end within its rounds".into(),
        fit: None,
    }
}

#[cfg(test)]
mod tests {
    use super::super::testing::{solve, spec};
    use super::super::*;
    use crate::sweep::search::Goal;

    /// The largest error of interpolating `f` linearly between `points` (sorted), checked at
    /// 20 001 points.
    fn linear_error(points: &[(f64, f64)], f: &dyn Fn(f64) -> f64, min: f64, max: f64) -> f64 {
        let mut worst: f64 = 0.0;
        for k in 0..=20_000 {
            let x = min + (max - min) * k as f64 / 20_000.0;
            let i = points
                .partition_point(|p| p.0 <= x)
                .clamp(1, points.len() - 1);
            let ((x0, y0), (x1, y1)) = (points[i - 1], points[i]);
            let y = y0 + (y1 - y0) * (x - x0) / (x1 - x0);
            worst = worst.max((y - f(x)).abs());
        }
        worst
    }

    #[test]
    fn a_curve_with_a_kink_gets_its_points_where_it_bends() {
        // Smooth but for a kink at 0.3 and a sharp bump at 0.7.
        let f = |x: f64| (x - 0.3).abs() + 0.2 * (-(x - 0.7).powi(2) / 0.001).exp();
        let mut sp = spec(Goal::Refine, &[(0.0, 1.0, 1e-4)]);
        sp.objective_tolerance = 1e-3;
        sp.scan = vec![11; sp.fields.len()];
        let (out, points) = solve(&sp, |x| Some(f(x[0])));
        assert_eq!(out.status, SearchStatus::Converged, "{}", out.note);
        assert!(out.refine_error <= 1e-3);
        let mut samples: Vec<(f64, f64)> = points.iter().map(|p| (p[0], f(p[0]))).collect();
        samples.sort_by(|a, b| a.0.total_cmp(&b.0));
        let adaptive = linear_error(&samples, &f, 0.0, 1.0);
        // A uniform grid of as many points does far worse.
        let n = samples.len();
        let uniform: Vec<(f64, f64)> = (0..n)
            .map(|i| {
                let x = i as f64 / (n - 1) as f64;
                (x, f(x))
            })
            .collect();
        let grid = linear_error(&uniform, &f, 0.0, 1.0);
        assert!(
            adaptive < 0.5 * grid,
            "adaptive {adaptive}, uniform {grid} with {n} points"
        );
        assert!(adaptive < 3e-3, "{adaptive}");
        // Denser around the bump than far from it.
        let near = samples.iter().filter(|p| (p.0 - 0.7).abs() < 0.1).count();
        let far = samples.iter().filter(|p| p.0 > 0.85).count();
        assert!(near > 3 * far, "{near} near the bump, {far} far");
    }

    #[test]
    fn a_jump_is_located_to_the_field_tolerance_and_said_so() {
        let f = |x: &[f64]| Some(if x[0] < 0.4123 { 0.0 } else { 1.0 });
        let mut sp = spec(Goal::Refine, &[(0.0, 1.0, 1e-3)]);
        sp.objective_tolerance = 1e-2;
        let (out, points) = solve(&sp, f);
        assert_eq!(out.status, SearchStatus::Stalled, "{}", out.note);
        assert!(out.note.contains("a jump"), "{}", out.note);
        let mut xs: Vec<f64> = points.iter().map(|p| p[0]).collect();
        xs.sort_by(f64::total_cmp);
        let i = xs.partition_point(|&x| x < 0.4123);
        assert!(xs[i] - xs[i - 1] < 2e-3, "{} {}", xs[i - 1], xs[i]);
        // Failed runs: gaps, counted.
        // (4/9 is a point of the 10-point scan.)
        let holed = |x: &[f64]| ((x[0] - 4.0 / 9.0).abs() > 1e-12).then(|| x[0] * x[0]);
        let (out, _) = solve(&sp, holed);
        assert!(out.note.contains("left as gaps"), "{}", out.note);
    }

    #[test]
    fn a_surface_is_refined_where_it_varies_and_along_the_field_it_varies_in() {
        // A ridge along x = 0.6 on a plane: curved across x only.
        let f = |x: &[f64]| Some(0.1 * x[1] + 1.0 / (1.0 + ((x[0] - 0.6) / 0.1).powi(2)));
        let mut sp = spec(Goal::Refine, &[(0.0, 1.0, 1e-3), (0.0, 2.0, 1e-3)]);
        sp.objective_tolerance = 5e-3;
        sp.scan = vec![5; sp.fields.len()];
        sp.round = 8;
        let (out, points) = solve(&sp, f);
        assert_eq!(out.status, SearchStatus::Converged, "{}", out.note);
        let near = points.iter().filter(|p| (p[0] - 0.6).abs() < 0.2).count();
        assert!(near * 10 > points.len() * 6, "{near} of {}", points.len());
        // Never halved along y, where the surface is linear: the scan's 5 lines only.
        let mut ys: Vec<f64> = points.iter().map(|p| p[1]).collect();
        ys.sort_by(f64::total_cmp);
        ys.dedup();
        assert_eq!(ys.len(), 5, "{ys:?}");
        // Again: the same points.
        assert_eq!(solve(&sp, f).1, points);
    }

    #[test]
    fn a_saddle_is_refined_although_its_centres_sit_on_their_corners_mean() {
        // x² − y² on square cells: the centre is exactly the mean of the corners, so only the
        // edges show the curvature. Bilinear interpolation errs by up to h²/4 on a cell of
        // side h: 5e-3 needs h ≤ 0.141, at least 8 cells a side.
        let f = |x: &[f64]| Some(x[0] * x[0] - x[1] * x[1]);
        let mut sp = spec(Goal::Refine, &[(0.0, 1.0, 1e-3), (0.0, 1.0, 1e-3)]);
        sp.objective_tolerance = 5e-3;
        sp.scan = vec![3; sp.fields.len()];
        sp.round = 8;
        let (out, points) = solve(&sp, f);
        assert_eq!(out.status, SearchStatus::Converged, "{}", out.note);
        for k in 0..2 {
            let mut xs: Vec<f64> = points.iter().map(|p| p[k]).collect();
            xs.sort_by(f64::total_cmp);
            xs.dedup();
            let widest = xs.windows(2).map(|w| w[1] - w[0]).fold(0.0, f64::max);
            assert!(widest <= 0.1415, "field {k}: lines {widest} apart");
        }
    }
}
