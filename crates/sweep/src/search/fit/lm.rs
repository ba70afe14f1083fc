//! The step of Levenberg–Marquardt in Moré's trust-region form, over a box.
//!
//! Given the residuals `r` and their Jacobian `J` at a point (in the box's unit coordinates), the
//! step `δ` minimises the linear model `‖r + J δ‖²` within a ball `‖δ‖ ≤ Δ`: the Gauss–Newton step
//! when it lies inside, else `δ(λ) = −(JᵀJ + λ I)⁻¹ Jᵀ r` with λ chosen so that `‖δ(λ)‖ = Δ`
//! (Moré 1978, "The Levenberg–Marquardt algorithm: implementation and theory"). The model is
//! solved exactly through the eigen-decomposition of `JᵀJ`: a fit has at most six fields, so the
//! secular equation in λ is solved to rounding by bisection, without Moré's safeguarded Newton
//! iteration that large problems need. Bounds: a field at a bound whose gradient points outwards
//! is held there (the active set), and the step is projected into the box.

use nalgebra::{DMatrix, DVector, SymmetricEigen};

/// `JᵀJ` and `Jᵀr` of the free columns `free` of `j` (column-major, `n` rows).
pub fn normal_equations(j: &[f64], r: &[f64], free: &[usize]) -> (DMatrix<f64>, DVector<f64>) {
    let n = r.len();
    let m = free.len();
    let mut a = DMatrix::zeros(m, m);
    let mut g = DVector::zeros(m);
    for (p, &cp) in free.iter().enumerate() {
        let col_p = &j[cp * n..(cp + 1) * n];
        g[p] = col_p.iter().zip(r).map(|(x, y)| x * y).sum();
        for (q, &cq) in free.iter().enumerate().skip(p) {
            let col_q = &j[cq * n..(cq + 1) * n];
            let v: f64 = col_p.iter().zip(col_q).map(|(x, y)| x * y).sum();
            a[(p, q)] = v;
            a[(q, p)] = v;
        }
    }
    (a, g)
}

/// The step minimising `‖r + J δ‖²` (`a = JᵀJ`, `g = Jᵀr`) within `‖δ‖ ≤ radius` (`radius`
/// infinite: the Gauss–Newton step, directions the data do not determine left out).
pub fn trust_step(a: &DMatrix<f64>, g: &DVector<f64>, radius: f64) -> DVector<f64> {
    let m = g.len();
    if m == 0 {
        return DVector::zeros(0);
    }
    let eig = SymmetricEigen::new(a.clone());
    let top = eig.eigenvalues.iter().fold(0.0f64, |t, &l| t.max(l.abs()));
    let floor = top * 1e-13;
    // Components of the gradient along the eigenvectors.
    let c: Vec<f64> = (0..m).map(|i| eig.eigenvectors.column(i).dot(g)).collect();
    let step = |lambda: f64| -> DVector<f64> {
        let mut d = DVector::zeros(m);
        for (i, ci) in c.iter().enumerate() {
            let l = eig.eigenvalues[i].max(0.0) + lambda;
            if l > floor {
                d -= eig.eigenvectors.column(i) * (ci / l);
            }
        }
        d
    };
    let gn = step(0.0);
    if gn.norm() <= radius {
        return gn;
    }
    // ‖δ(λ)‖ falls from ‖δ(0)‖ > Δ towards 0; at λ = ‖g‖/Δ it is at most Δ.
    let (mut lo, mut hi) = (0.0, g.norm() / radius);
    for _ in 0..200 {
        let mid = if lo == 0.0 {
            hi * 1e-12
        } else {
            (lo * hi).sqrt()
        };
        let mid = if mid <= lo || mid >= hi {
            0.5 * (lo + hi)
        } else {
            mid
        };
        if step(mid).norm() > radius {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-14 * hi {
            break;
        }
    }
    step(hi)
}

/// The decrease of `‖r + J δ‖²` the linear model predicts for the step `δ`.
pub fn predicted_decrease(a: &DMatrix<f64>, g: &DVector<f64>, d: &DVector<f64>) -> f64 {
    -(2.0 * g.dot(d) + d.dot(&(a * d)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_newton_inside_the_ball_and_moré_on_it() {
        // r(x) = A x - b, exactly linear: the Gauss-Newton step lands on the solution.
        let j = vec![1.0, 0.0, 1.0, 0.0, 2.0, 1.0]; // columns (1,0,1) and (0,2,1)
        let r = vec![-1.0, -2.0, -3.0];
        let (a, g) = normal_equations(&j, &r, &[0, 1]);
        let d = trust_step(&a, &g, f64::INFINITY);
        // Normal equations solved: A d = -g.
        let back = &a * &d + &g;
        assert!(back.norm() < 1e-12, "{back}");
        // On a small ball the step has the ball's radius and decreases the model.
        let d = trust_step(&a, &g, 0.1);
        assert!((d.norm() - 0.1).abs() < 1e-9);
        assert!(predicted_decrease(&a, &g, &d) > 0.0);
    }

    #[test]
    fn a_singular_problem_steps_only_where_the_data_tell() {
        // Two identical columns: only their sum is determined.
        let j = vec![1.0, 1.0, 1.0, 1.0];
        let r = vec![-2.0, -2.0];
        let (a, g) = normal_equations(&j, &r, &[0, 1]);
        let d = trust_step(&a, &g, f64::INFINITY);
        assert!(
            (d[0] - d[1]).abs() < 1e-12 && (d[0] + d[1] - 2.0).abs() < 1e-9,
            "{d}"
        );
    }
}
