//! One field: every local minimum (or maximum) in an interval, and every crossing of a level.
//!
//! Both start with a scan of evenly spaced points. A minimum is bracketed by a scan point lower
//! than its two neighbours and located by Brent's method (golden sections and parabolic steps,
//! R. P. Brent, *Algorithms for Minimization without Derivatives*, 1973, ch. 5); a crossing is
//! bracketed by two neighbours on either side of the level and located by Brent's root method
//! (ch. 4: bisection, secant and inverse quadratic steps). Each bracket is a part of the search of
//! its own (its own stream), so that every bracket advances a point per round. Both methods keep
//! the solution inside a bracket that shrinks at every step (at worst like bisection or the golden
//! section), so they end whatever the objective's noise; they end when the bracket says the
//! solution is within the field's tolerance of the reported point.

use super::{linspace, Item, ItemStatus, Outcome, SearchStatus, Streams, Value};
use crate::sweep::search::{OnFailure, SearchSpec};

/// Most steps of Brent's methods in one bracket (they converge long before: this only bounds a
/// tolerance below the floating-point resolution of the field).
const MAX_STEPS: usize = 200;

/// A bracket's result: its item, and whether it is still being located.
struct Bracketed {
    item: Item,
    open: bool,
}

/// The point of the field where a run failed, as a note says it.
/// Every local minimum (`sign` 1) or maximum (`sign` -1) of the objective over the one field.
pub fn extrema(spec: &SearchSpec, s: &mut Streams, sign: f64) -> Outcome {
    let f = &spec.fields[0];
    let xs = linspace(f.min, f.max, spec.scan[0]);
    let points: Vec<Vec<f64>> = xs.iter().map(|&x| vec![x]).collect();
    let Some(ys) = s.eval(0, &points) else {
        return Outcome::running(Vec::new(), f64::NAN);
    };
    // Minimised: g = sign · y; a run without a number is worse than any (failed: worst).
    if spec.on_failure == OnFailure::Stop {
        if let Some(i) = ys.iter().position(|y| y.is_none()) {
            return Outcome::failed_at(spec, &[xs[i]]);
        }
    }
    let g: Vec<f64> = ys
        .iter()
        .map(|y| y.map_or(f64::INFINITY, |y| sign * y))
        .collect();
    if g.iter().all(|v| v.is_infinite()) {
        return Outcome {
            status: SearchStatus::NotFound,
            items: Vec::new(),
            refine_error: f64::NAN,
            note: "no run of the scan gave a number".into(),
            fit: None,
        };
    }
    let n = g.len();
    let mut items = Vec::new();
    let mut open = false;
    let mut stream = 0;
    for i in 0..n {
        let lower_left = i == 0 || g[i] < g[i - 1];
        let lower_right = i + 1 == n || g[i] <= g[i + 1];
        if !(lower_left && lower_right) || g[i].is_infinite() {
            continue;
        }
        if i == 0 || i + 1 == n {
            items.push(Item {
                x: vec![xs[i]],
                uncertainty: vec![0.0],
                value: ys[i],
                status: ItemStatus::AtBound,
            });
            continue;
        }
        stream += 1;
        let b = brent_minimum(
            spec,
            s,
            stream,
            [xs[i - 1], xs[i], xs[i + 1]],
            (g[i], ys[i]),
            sign,
        );
        open |= b.open;
        items.push(b.item);
    }
    if open {
        return Outcome::running(items, f64::NAN);
    }
    let found = items.len();
    let what = if sign > 0.0 { "minimum" } else { "maximum" };
    Outcome::finished(
        items,
        f64::NAN,
        format!(
            "{found} local {what}(s) in [{}, {}]",
            spec.fields[0].min, spec.fields[0].max
        ),
    )
}

/// Brent's minimisation of g = `sign` · objective in the bracket `abc` (`b` the lowest, with
/// `fb` = (g, objective) there), through `stream`.
fn brent_minimum(
    spec: &SearchSpec,
    s: &mut Streams,
    stream: usize,
    abc: [f64; 3],
    fb: (f64, Value),
    sign: f64,
) -> Bracketed {
    const CGOLD: f64 = 0.381_966_011_250_105_1;
    let tol = spec.fields[0].tolerance;
    let (mut a, mut b) = (abc[0].min(abc[2]), abc[0].max(abc[2]));
    let (mut x, mut w, mut v) = (abc[1], abc[1], abc[1]);
    let (mut fx, mut fw, mut fv) = (fb.0, fb.0, fb.0);
    let mut yx = fb.1;
    let (mut d, mut e) = (0.0f64, 0.0f64);
    let item = |x: f64, a: f64, b: f64, yx: Value, status| Item {
        x: vec![x],
        uncertainty: vec![(x - 0.5 * (a + b)).abs() + 0.5 * (b - a)],
        value: yx,
        status,
    };
    for _ in 0..MAX_STEPS {
        let xm = 0.5 * (a + b);
        // Half the tolerance, so that the whole bracket is within the tolerance of x.
        let tol1 = 0.5 * tol + 4.0 * f64::EPSILON * x.abs();
        let tol2 = 2.0 * tol1;
        if (x - xm).abs() <= tol2 - 0.5 * (b - a) {
            return Bracketed {
                item: item(x, a, b, yx, ItemStatus::Converged),
                open: false,
            };
        }
        let mut golden = true;
        if e.abs() > tol1 {
            // A parabola through x, v, w.
            let r = (x - w) * (fx - fv);
            let mut q = (x - v) * (fx - fw);
            let mut p = (x - v) * q - (x - w) * r;
            q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            }
            q = q.abs();
            let etemp = e;
            if p.abs() < (0.5 * q * etemp).abs() && p > q * (a - x) && p < q * (b - x) {
                e = d;
                d = p / q;
                let u = x + d;
                if u - a < tol2 || b - u < tol2 {
                    d = tol1.copysign(xm - x);
                }
                golden = false;
            }
        }
        if golden {
            e = if x >= xm { a - x } else { b - x };
            d = CGOLD * e;
        }
        let u = if d.abs() >= tol1 {
            x + d
        } else {
            x + tol1.copysign(d)
        };
        let Some(ys) = s.eval(stream, &[vec![u]]) else {
            return Bracketed {
                item: item(x, a, b, yx, ItemStatus::Open),
                open: true,
            };
        };
        let yu = ys[0];
        if yu.is_none() && spec.on_failure == OnFailure::Stop {
            return Bracketed {
                item: Item {
                    x: vec![u],
                    uncertainty: vec![0.5 * (b - a)],
                    value: None,
                    status: ItemStatus::Failed,
                },
                open: false,
            };
        }
        let fu = yu.map_or(f64::INFINITY, |y| sign * y);
        if fu <= fx {
            if u >= x {
                a = x;
            } else {
                b = x;
            }
            (v, w, x) = (w, x, u);
            (fv, fw, fx) = (fw, fx, fu);
            yx = yu;
        } else {
            if u < x {
                a = u;
            } else {
                b = u;
            }
            if fu <= fw || w == x {
                (v, w) = (w, u);
                (fv, fw) = (fw, fu);
            } else if fu <= fv || v == x || v == w {
                v = u;
                fv = fu;
            }
        }
    }
    Bracketed {
        item: item(x, a, b, yx, ItemStatus::Stalled),
        open: false,
    }
}

/// Every crossing of the level by the objective over the one field.
pub fn roots(spec: &SearchSpec, s: &mut Streams) -> Outcome {
    let f = &spec.fields[0];
    let xs = linspace(f.min, f.max, spec.scan[0]);
    let points: Vec<Vec<f64>> = xs.iter().map(|&x| vec![x]).collect();
    let Some(ys) = s.eval(0, &points) else {
        return Outcome::running(Vec::new(), f64::NAN);
    };
    if let Some(i) = ys.iter().position(|y| y.is_none()) {
        return Outcome::failed_at(spec, &[xs[i]]);
    }
    let h: Vec<f64> = ys
        .iter()
        .map(|y| y.expect("checked") - spec.level)
        .collect();
    let mut items = Vec::new();
    let mut open = false;
    let mut stream = 0;
    for i in 0..h.len() {
        if h[i] == 0.0 {
            items.push(Item {
                x: vec![xs[i]],
                uncertainty: vec![0.0],
                value: ys[i],
                status: ItemStatus::Converged,
            });
        }
        if i + 1 < h.len() && h[i] * h[i + 1] < 0.0 {
            stream += 1;
            let b = brent_root(spec, s, stream, (xs[i], h[i]), (xs[i + 1], h[i + 1]));
            open |= b.open;
            items.push(b.item);
        }
    }
    if open {
        return Outcome::running(items, f64::NAN);
    }
    if items.is_empty() {
        let (lo, hi) = h
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, u), &v| {
                (l.min(v), u.max(v))
            });
        return Outcome {
            status: SearchStatus::NotFound,
            items,
            refine_error: f64::NAN,
            note: format!(
                "the objective does not cross {} in [{}, {}] at the scan's {} points (it runs from {} to {} there)",
                spec.level,
                f.min,
                f.max,
                spec.scan[0],
                lo + spec.level,
                hi + spec.level
            ),
            fit: None,
        };
    }
    let n = items.len();
    Outcome::finished(
        items,
        f64::NAN,
        format!(
            "{n} crossing(s) of {} in [{}, {}]",
            spec.level, f.min, f.max
        ),
    )
}

/// Brent's root method for objective − level between `(a, fa)` and `(b, fb)` (of opposite
/// signs), through `stream`.
fn brent_root(
    spec: &SearchSpec,
    s: &mut Streams,
    stream: usize,
    (mut a, mut fa): (f64, f64),
    (mut b, mut fb): (f64, f64),
) -> Bracketed {
    let tol = spec.fields[0].tolerance;
    let (mut c, mut fc) = (b, fb);
    let (mut d, mut e) = (b - a, b - a);
    let item = |b: f64, c: f64, fb: f64, status| Item {
        x: vec![b],
        uncertainty: vec![(c - b).abs()],
        value: Some(fb + spec.level),
        status,
    };
    for _ in 0..MAX_STEPS {
        if (fb > 0.0 && fc > 0.0) || (fb < 0.0 && fc < 0.0) {
            (c, fc) = (a, fa);
            d = b - a;
            e = d;
        }
        if fc.abs() < fb.abs() {
            (a, b, c) = (b, c, b);
            (fa, fb, fc) = (fb, fc, fb);
        }
        // The root lies between b and c: within the tolerance of b once |c - b| is.
        let tol1 = 2.0 * f64::EPSILON * b.abs() + 0.5 * tol;
        let xm = 0.5 * (c - b);
        if xm.abs() <= tol1 || fb == 0.0 {
            let mut it = item(b, c, fb, ItemStatus::Converged);
            if fb == 0.0 {
                it.uncertainty = vec![0.0];
            }
            return Bracketed {
                item: it,
                open: false,
            };
        }
        if e.abs() >= tol1 && fa.abs() > fb.abs() {
            let s_ = fb / fa;
            let (mut p, mut q);
            if a == c {
                p = 2.0 * xm * s_;
                q = 1.0 - s_;
            } else {
                let q_ = fa / fc;
                let r = fb / fc;
                p = s_ * (2.0 * xm * q_ * (q_ - r) - (b - a) * (r - 1.0));
                q = (q_ - 1.0) * (r - 1.0) * (s_ - 1.0);
            }
            if p > 0.0 {
                q = -q;
            }
            p = p.abs();
            let min1 = 3.0 * xm * q - (tol1 * q).abs();
            let min2 = (e * q).abs();
            if 2.0 * p < min1.min(min2) {
                e = d;
                d = p / q;
            } else {
                d = xm;
                e = d;
            }
        } else {
            d = xm;
            e = d;
        }
        a = b;
        fa = fb;
        b += if d.abs() > tol1 { d } else { tol1.copysign(xm) };
        let Some(ys) = s.eval(stream, &[vec![b]]) else {
            // (b is being evaluated: the bracket so far is [a, c].)
            return Bracketed {
                item: item(a, c, fa, ItemStatus::Open),
                open: true,
            };
        };
        let Some(y) = ys[0] else {
            return Bracketed {
                item: Item {
                    x: vec![b],
                    uncertainty: vec![(c - a).abs()],
                    value: None,
                    status: ItemStatus::Failed,
                },
                open: false,
            };
        };
        fb = y - spec.level;
    }
    Bracketed {
        item: item(b, c, fb, ItemStatus::Stalled),
        open: false,
    }
}

#[cfg(test)]
mod tests {
    use super::super::testing::{solve, spec};
    use super::super::*;
    use crate::sweep::search::{Goal, OnFailure};

    #[test]
    fn every_local_minimum_is_located_to_the_tolerance() {
        // Minima at 0.3 and 0.8 (and a rising end: no minimum at the bounds).
        let f = |x: &[f64]| {
            let x = x[0];
            Some((x - 0.3).powi(2) * (x - 0.8).powi(2) + 0.001 * x)
        };
        let mut sp = spec(Goal::Minimise, &[(0.0, 1.0, 1e-6)]);
        sp.scan = vec![11];
        let (out, points) = solve(&sp, f);
        assert_eq!(out.status, SearchStatus::Converged, "{out:?}");
        assert_eq!(out.items.len(), 2);
        // The true minima, from the derivative's roots (found to 1e-12 by bisection).
        let df = |x: f64| 2.0 * (x - 0.3) * (x - 0.8) * (2.0 * x - 1.1) + 0.001;
        let bisect = |mut a: f64, mut b: f64| {
            for _ in 0..100 {
                let m = 0.5 * (a + b);
                if df(a) * df(m) <= 0.0 {
                    b = m;
                } else {
                    a = m;
                }
            }
            0.5 * (a + b)
        };
        for (item, (a, b)) in out.items.iter().zip([(0.2, 0.4), (0.7, 0.9)]) {
            let truth = bisect(a, b);
            assert!(
                (item.x[0] - truth).abs() <= 1e-6,
                "{} vs {truth}",
                item.x[0]
            );
            assert!(
                item.uncertainty[0] <= 1e-6 && item.uncertainty[0] >= (item.x[0] - truth).abs()
            );
            assert_eq!(item.status, ItemStatus::Converged);
        }
        // Far fewer points than a grid of that resolution (10^6).
        assert!(points.len() < 60, "{}", points.len());
        // A pure function of the values: the same points again.
        assert_eq!(solve(&sp, f).1, points);
    }

    #[test]
    fn maxima_bounds_and_failed_runs() {
        let f = |x: &[f64]| Some((x[0] * 3.0).sin());
        let mut sp = spec(Goal::Maximise, &[(0.0, 3.0, 1e-5)]);
        sp.scan = vec![7];
        let (out, _) = solve(&sp, f);
        let xs: Vec<f64> = out.items.iter().map(|i| i.x[0]).collect();
        // sin 3x is largest at π/6 and 5π/6 in [0, 3].
        assert_eq!(xs.len(), 2);
        for (x, truth) in xs.iter().zip([1.0, 5.0]) {
            assert!(
                (x - truth * std::f64::consts::FRAC_PI_6).abs() < 1e-5,
                "{x}"
            );
        }
        assert!((out.items[0].value.unwrap() - 1.0).abs() < 1e-9);
        // Rising to the upper end: a maximum at the bound.
        let (out, _) = solve(&sp, |x: &[f64]| Some(x[0]));
        assert_eq!(out.items.len(), 1);
        assert_eq!(out.items[0].status, ItemStatus::AtBound);
        assert_eq!(out.items[0].x[0], 3.0);
        // A failed run counts as the worst (the search goes on) or stops it.
        let holed = |x: &[f64]| (x[0] != 1.5).then(|| -(x[0] - 2.0).powi(2));
        let (out, _) = solve(&sp, holed);
        assert_eq!(out.status, SearchStatus::Converged);
        // (Next to the failed run at 1.5, counted as the worst, the objective rises to it: a
        // maximum there too, under that rule.)
        let best = out
            .items
            .iter()
            .max_by(|a, b| a.value.unwrap().total_cmp(&b.value.unwrap()))
            .unwrap();
        assert!((best.x[0] - 2.0).abs() < 1e-5, "{out:?}");
        sp.on_failure = OnFailure::Stop;
        let (out, _) = solve(&sp, holed);
        assert_eq!(out.status, SearchStatus::Failed);
        assert!(out.note.contains("x0 = 1.5"), "{}", out.note);
    }

    #[test]
    fn every_crossing_is_located_and_a_level_never_crossed_is_not_found() {
        let f = |x: &[f64]| Some((x[0] - 1.0) * (x[0] - 2.5) * (x[0] - 4.0));
        let mut sp = spec(Goal::Root, &[(0.0, 5.0, 1e-4)]);
        sp.scan = vec![6];
        let (out, points) = solve(&sp, f);
        assert_eq!(out.status, SearchStatus::Converged, "{out:?}");
        let roots: Vec<f64> = out.items.iter().map(|i| i.x[0]).collect();
        assert_eq!(roots.len(), 3);
        for (r, truth) in roots.iter().zip([1.0, 2.5, 4.0]) {
            assert!((r - truth).abs() <= 1e-4, "{r} vs {truth}");
        }
        assert!(out.items.iter().all(|i| i.uncertainty[0] <= 1e-4));
        assert!(points.len() <= 6 + 3 * 12, "{}", points.len());
        sp.level = 100.0;
        let (out, points) = solve(&sp, f);
        assert_eq!(out.status, SearchStatus::NotFound);
        assert_eq!(points.len(), 6);
        assert!(out.note.contains("does not cross 100"), "{}", out.note);
    }

    #[test]
    fn a_budget_stops_a_search_with_what_it_has_found() {
        let f = |x: &[f64]| Some((x[0] - 0.37).abs().sqrt());
        let mut sp = spec(Goal::Minimise, &[(0.0, 1.0, 1e-9)]);
        sp.budget = 14;
        let (out, points) = solve(&sp, f);
        assert_eq!(out.status, SearchStatus::Budget);
        assert!(points.len() <= 14);
        assert_eq!(out.items[0].status, ItemStatus::Open);
        let it = &out.items[0];
        assert!((it.x[0] - 0.37).abs() <= it.uncertainty[0], "{it:?}");
    }
}
