//! Several fields: the lowest (highest) point of the objective in a box, by Nelder–Mead.
//!
//! Why Nelder–Mead: searches here have two to four fields and an objective that costs a run per
//! point and is not smooth everywhere (a leading peak jumps when the pulse's structure changes).
//! Nelder–Mead (J. A. Nelder and R. Mead, Comput. J. 7, 308, 1965) needs no derivatives, one or
//! two points per step, and follows kinks; with restarts (a new simplex of the first size around
//! the best point once the old one has collapsed) it does not stall on a collapsed simplex. CMA-ES
//! would search multimodal landscapes more thoroughly, at 6 to 10 points per generation in these
//! dimensions; here a scan of the box finds the basins, and a search starts in each of the
//! best ones (`starts`).
//!
//! The search works in the unit box (each field scaled to [0, 1]); a point outside it is moved
//! to its nearest point in the box. It starts from the `starts` best local minima of a scan of
//! `scan` points per field, each a part of its own (its own stream), with a simplex one scan
//! spacing wide. A part converges when every vertex is within each field's tolerance of the best
//! one; it then restarts around its best point (at most three times) until a restart finds
//! nothing better.

use super::{linspace, Item, ItemStatus, Outcome, SearchStatus, Streams, Value};
use crate::sweep::search::{OnFailure, SearchSpec};

/// Most steps of one part (each one to d points).
const MAX_STEPS: usize = 2000;
/// Restarts of a part once its simplex has collapsed.
const MAX_RESTARTS: usize = 3;

/// The field values of unit-box point `u`.
fn to_fields(spec: &SearchSpec, u: &[f64]) -> Vec<f64> {
    spec.fields
        .iter()
        .zip(u)
        .map(|(f, &t)| {
            if t >= 1.0 {
                f.max
            } else if t <= 0.0 {
                f.min
            } else {
                f.min + (f.max - f.min) * t
            }
        })
        .collect()
}

fn clamp(u: Vec<f64>) -> Vec<f64> {
    u.into_iter().map(|t| t.clamp(0.0, 1.0)).collect()
}

/// The lowest (`sign` 1) or highest (`sign` -1) point of the objective over the fields.
pub fn minimise(spec: &SearchSpec, s: &mut Streams, sign: f64) -> Outcome {
    let d = spec.fields.len();
    let n = &spec.scan;
    let axes: Vec<Vec<f64>> = n.iter().map(|&k| linspace(0.0, 1.0, k)).collect();
    // The scan: every combination, the last field fastest.
    let total: usize = n.iter().product();
    let grid: Vec<Vec<f64>> = (0..total)
        .map(|mut k| {
            let mut u = vec![0.0; d];
            for i in (0..d).rev() {
                u[i] = axes[i][k % n[i]];
                k /= n[i];
            }
            u
        })
        .collect();
    let points: Vec<Vec<f64>> = grid.iter().map(|u| to_fields(spec, u)).collect();
    let Some(ys) = s.eval(0, &points) else {
        return Outcome::running(Vec::new(), f64::NAN);
    };
    if spec.on_failure == OnFailure::Stop {
        if let Some(k) = ys.iter().position(|y| y.is_none()) {
            return Outcome::failed_at(spec, &points[k]);
        }
    }
    let g: Vec<f64> = ys
        .iter()
        .map(|y| y.map_or(f64::INFINITY, |y| sign * y))
        .collect();
    // Local minima of the scan: no lower neighbour along any field.
    let strides: Vec<usize> = (0..d).map(|i| n[i + 1..].iter().product()).collect();
    let mut minima: Vec<usize> = (0..total)
        .filter(|&k| g[k].is_finite())
        .filter(|&k| {
            (0..d).all(|i| {
                let pos = (k / strides[i]) % n[i];
                let lower = pos > 0 && g[k - strides[i]] < g[k];
                let upper = pos + 1 < n[i] && g[k + strides[i]] < g[k];
                !lower && !upper
            })
        })
        .collect();
    if minima.is_empty() {
        return Outcome {
            status: SearchStatus::NotFound,
            items: Vec::new(),
            refine_error: f64::NAN,
            note: "no run of the scan gave a number".into(),
            fit: None,
        };
    }
    minima.sort_by(|&a, &b| g[a].total_cmp(&g[b]).then(a.cmp(&b)));
    minima.truncate(spec.starts);
    // One scan spacing along each field (in the unit box).
    let h: Vec<f64> = n.iter().map(|&k| 1.0 / (k - 1) as f64).collect();
    let mut items = Vec::new();
    let mut open = false;
    for (k, &start) in minima.iter().enumerate() {
        let (item, more) = nelder_mead(
            spec,
            s,
            k + 1,
            &grid[start],
            (g[start], ys[start]),
            &h,
            sign,
        );
        open |= more;
        items.push(item);
    }
    // Best first.
    items.sort_by(|a, b| {
        let key = |i: &Item| i.value.map_or(f64::INFINITY, |v| sign * v);
        key(a).total_cmp(&key(b))
    });
    if open {
        return Outcome::running(items, f64::NAN);
    }
    let n_found = items.len();
    Outcome::finished(
        items,
        f64::NAN,
        format!("the best of {n_found} local search(es) from the scan's best points"),
    )
}

/// One part: Nelder–Mead with restarts from `u0` (whose g and objective are `f0`), through
/// `stream`. Its item, and whether it is still searching.
fn nelder_mead(
    spec: &SearchSpec,
    s: &mut Streams,
    stream: usize,
    u0: &[f64],
    f0: (f64, Value),
    h: &[f64],
    sign: f64,
) -> (Item, bool) {
    let d = u0.len();
    let tol: Vec<f64> = spec
        .fields
        .iter()
        .map(|f| f.tolerance / (f.max - f.min))
        .collect();
    // Vertices: (u, g, objective).
    let mut simplex: Vec<(Vec<f64>, f64, Value)> = vec![(u0.to_vec(), f0.0, f0.1)];
    let to_g = |y: Value| y.map_or(f64::INFINITY, |y| sign * y);
    let item = |simplex: &[(Vec<f64>, f64, Value)], status| {
        let best = &simplex[0];
        let uncertainty = spec
            .fields
            .iter()
            .enumerate()
            .map(|(i, f)| {
                simplex
                    .iter()
                    .map(|v| (v.0[i] - best.0[i]).abs())
                    .fold(0.0, f64::max)
                    * (f.max - f.min)
            })
            .collect();
        Item {
            x: to_fields(spec, &best.0),
            uncertainty,
            value: best.2,
            status,
        }
    };
    // A simplex of size h around `c` (towards the box's inside).
    let around = |c: &[f64]| -> Vec<Vec<f64>> {
        (0..d)
            .map(|i| {
                let mut v = c.to_vec();
                v[i] = if c[i] + h[i] <= 1.0 {
                    c[i] + h[i]
                } else {
                    c[i] - h[i]
                };
                v
            })
            .collect()
    };
    let eval = |s: &mut Streams, us: &[Vec<f64>]| -> Option<Option<Vec<(f64, Value)>>> {
        let pts: Vec<Vec<f64>> = us.iter().map(|u| to_fields(spec, u)).collect();
        let ys = s.eval(stream, &pts)?;
        if spec.on_failure == OnFailure::Stop && ys.iter().any(|y| y.is_none()) {
            return Some(None);
        }
        Some(Some(ys.into_iter().map(|y| (to_g(y), y)).collect()))
    };
    macro_rules! step {
        ($us:expr) => {{
            let us: Vec<Vec<f64>> = $us;
            match eval(s, &us) {
                None => {
                    sort(&mut simplex);
                    return (item(&simplex, ItemStatus::Open), true);
                }
                Some(None) => {
                    sort(&mut simplex);
                    return (item(&simplex, ItemStatus::Failed), false);
                }
                Some(Some(v)) => us
                    .into_iter()
                    .zip(v)
                    .map(|(u, (g, y))| (u, g, y))
                    .collect::<Vec<_>>(),
            }
        }};
    }
    let first = step!(around(u0));
    simplex.extend(first);
    let mut restarts = 0;
    let mut best_at_restart = f64::INFINITY;
    for _ in 0..MAX_STEPS {
        sort(&mut simplex);
        let collapsed = (0..d).all(|i| {
            simplex
                .iter()
                .all(|v| (v.0[i] - simplex[0].0[i]).abs() <= tol[i])
        });
        if collapsed {
            // Restart around the best point until a restart finds nothing better.
            if restarts == MAX_RESTARTS || simplex[0].1 >= best_at_restart {
                return (item(&simplex, ItemStatus::Converged), false);
            }
            restarts += 1;
            best_at_restart = simplex[0].1;
            let best = simplex[0].clone();
            let fresh = step!(around(&best.0));
            simplex = vec![best];
            simplex.extend(fresh);
            continue;
        }
        let worst = simplex[d].clone();
        let centroid: Vec<f64> = (0..d)
            .map(|i| simplex[..d].iter().map(|v| v.0[i]).sum::<f64>() / d as f64)
            .collect();
        let along = |t: f64| -> Vec<f64> {
            clamp(
                centroid
                    .iter()
                    .zip(&worst.0)
                    .map(|(c, w)| c + t * (c - w))
                    .collect(),
            )
        };
        let r = step!(vec![along(1.0)]).remove(0);
        if r.1 < simplex[0].1 {
            let e = step!(vec![along(2.0)]).remove(0);
            simplex[d] = if e.1 < r.1 { e } else { r };
        } else if r.1 < simplex[d - 1].1 {
            simplex[d] = r;
        } else {
            let outside = r.1 < worst.1;
            let c = step!(vec![along(if outside { 0.5 } else { -0.5 })]).remove(0);
            if c.1 < r.1.min(worst.1) {
                simplex[d] = c;
            } else {
                // Shrink towards the best vertex.
                let best = simplex[0].0.clone();
                let shrunk: Vec<Vec<f64>> = simplex[1..]
                    .iter()
                    .map(|v| {
                        best.iter()
                            .zip(&v.0)
                            .map(|(b, x)| b + 0.5 * (x - b))
                            .collect()
                    })
                    .collect();
                let moved = step!(shrunk);
                simplex.truncate(1);
                simplex.extend(moved);
            }
        }
    }
    sort(&mut simplex);
    (item(&simplex, ItemStatus::Stalled), false)
}

/// Orders vertices by g (ties: by position, so the order is a function of the values only).
fn sort(simplex: &mut [(Vec<f64>, f64, Value)]) {
    simplex.sort_by(|a, b| {
        a.1.total_cmp(&b.1).then_with(|| {
            a.0.iter()
                .zip(&b.0)
                .map(|(x, y)| x.total_cmp(y))
                .find(|o| o.is_ne())
                .unwrap_or(std::cmp::Ordering::Equal)
        })
    });
}

#[cfg(test)]
mod tests {
    use super::super::testing::{solve, spec};
    use super::super::*;
    use crate::sweep::search::Goal;

    #[test]
    fn the_lowest_point_of_a_bowl_and_of_a_valley() {
        let bowl = |x: &[f64]| Some((x[0] - 0.31).powi(2) + 3.0 * (x[1] - 1.42).powi(2));
        let mut sp = spec(Goal::Minimise, &[(0.0, 1.0, 1e-4), (0.0, 2.0, 1e-4)]);
        sp.scan = vec![5; sp.fields.len()];
        let (out, points) = solve(&sp, bowl);
        assert_eq!(out.status, SearchStatus::Converged, "{out:?}");
        let best = &out.items[0];
        assert!(
            (best.x[0] - 0.31).abs() < 2e-4 && (best.x[1] - 1.42).abs() < 2e-4,
            "{best:?}"
        );
        assert!(points.len() < 300, "{}", points.len());
        // Rosenbrock's valley (minimum at (1, 1)), in a box that holds it.
        let rosen = |x: &[f64]| Some((1.0 - x[0]).powi(2) + 100.0 * (x[1] - x[0] * x[0]).powi(2));
        let mut sp = spec(Goal::Minimise, &[(-1.5, 1.5, 1e-4), (-0.5, 2.0, 1e-4)]);
        sp.scan = vec![5; sp.fields.len()];
        let (out, _) = solve(&sp, rosen);
        let best = &out.items[0];
        assert!(
            (best.x[0] - 1.0).abs() < 1e-3 && (best.x[1] - 1.0).abs() < 2e-3,
            "{best:?}"
        );
        // Deterministic.
        assert_eq!(solve(&sp, rosen).1, solve(&sp, rosen).1);
    }

    #[test]
    fn a_minimum_on_the_box_boundary_and_a_maximum() {
        // Lowest at x0 = 0 (the bound), x1 = 0.7.
        let f = |x: &[f64]| Some(x[0] + (x[1] - 0.7).powi(2));
        let mut sp = spec(Goal::Minimise, &[(0.0, 1.0, 1e-4), (0.0, 1.0, 1e-4)]);
        sp.scan = vec![4; sp.fields.len()];
        let (out, _) = solve(&sp, f);
        let best = &out.items[0];
        assert!(
            best.x[0] < 1e-4 && (best.x[1] - 0.7).abs() < 2e-4,
            "{best:?}"
        );
        let mut sp = spec(Goal::Maximise, &[(0.0, 1.0, 1e-4), (0.0, 1.0, 1e-4)]);
        sp.scan = vec![4; sp.fields.len()];
        let (out, _) = solve(&sp, |x: &[f64]| {
            Some(-(x[0] - 0.2).powi(2) - (x[1] - 0.9).powi(2))
        });
        let best = &out.items[0];
        assert!(
            (best.x[0] - 0.2).abs() < 2e-4 && (best.x[1] - 0.9).abs() < 2e-4,
            "{best:?}"
        );
    }
}
