//! The linear algebra of a step: the tridiagonal iteration matrix factorised once per attempt
//! and solved once per stage, and the tridiagonal product. Apart from the step because it is
//! LAPACK's algorithm, checked against a dense solve, and knows nothing of the method.

use crate::integrate::Tridiagonal;

// ---------------------------------------------------------------------------------------------
// Tridiagonal LU with partial pivoting (LAPACK dgttrf/dgtts2), factor once, solve per stage.
// ---------------------------------------------------------------------------------------------

/// LU factors of a tridiagonal matrix of order `n`.
#[derive(Debug, Clone, Default)]
pub(super) struct TriLu {
    /// Multipliers (`n-1`).
    dl: Vec<f64>,
    /// Diagonal of U (`n`).
    d: Vec<f64>,
    /// First super-diagonal of U (`n-1`).
    du: Vec<f64>,
    /// Second super-diagonal of U, fill-in from interchanges (`n-2`).
    du2: Vec<f64>,
    /// Whether rows `i` and `i+1` were interchanged at step `i`.
    swap: Vec<bool>,
}

impl TriLu {
    pub(super) fn new(n: usize) -> Self {
        TriLu {
            dl: vec![0.0; n.saturating_sub(1)],
            d: vec![0.0; n],
            du: vec![0.0; n.saturating_sub(1)],
            du2: vec![0.0; n.saturating_sub(2)],
            swap: vec![false; n.saturating_sub(1)],
        }
    }

    /// Factorises `I − a Kv − b Kx`. Returns `false` if a pivot is zero or not finite.
    pub(super) fn factor(&mut self, kx: &Tridiagonal, kv: &Tridiagonal, a: f64, b: f64) -> bool {
        let n = self.d.len();
        for i in 0..n {
            self.d[i] = 1.0 - a * kv.diag[i] - b * kx.diag[i];
        }
        for i in 0..n.saturating_sub(1) {
            self.dl[i] = -a * kv.lower[i] - b * kx.lower[i];
            self.du[i] = -a * kv.upper[i] - b * kx.upper[i];
            self.swap[i] = false;
        }
        self.du2.iter_mut().for_each(|x| *x = 0.0);
        for i in 0..n.saturating_sub(1) {
            if self.d[i].abs() >= self.dl[i].abs() {
                // No interchange (always the case for a diagonally dominant matrix): Thomas.
                if self.d[i] != 0.0 {
                    let fact = self.dl[i] / self.d[i];
                    self.dl[i] = fact;
                    self.d[i + 1] -= fact * self.du[i];
                }
            } else {
                let fact = self.d[i] / self.dl[i];
                self.d[i] = self.dl[i];
                self.dl[i] = fact;
                let temp = self.du[i];
                self.du[i] = self.d[i + 1];
                self.d[i + 1] = temp - fact * self.d[i + 1];
                if i + 2 < n {
                    self.du2[i] = self.du[i + 1];
                    self.du[i + 1] *= -fact;
                }
                self.swap[i] = true;
            }
        }
        self.d.iter().all(|p| *p != 0.0 && p.is_finite())
    }

    /// Solves in place with the factors.
    pub(super) fn solve(&self, b: &mut [f64]) {
        let n = self.d.len();
        if n == 0 {
            return;
        }
        for i in 0..n - 1 {
            if self.swap[i] {
                let temp = b[i];
                b[i] = b[i + 1];
                b[i + 1] = temp - self.dl[i] * b[i];
            } else {
                b[i + 1] -= self.dl[i] * b[i];
            }
        }
        b[n - 1] /= self.d[n - 1];
        if n > 1 {
            b[n - 2] = (b[n - 2] - self.du[n - 2] * b[n - 1]) / self.d[n - 2];
        }
        for i in (0..n.saturating_sub(2)).rev() {
            b[i] = (b[i] - self.du[i] * b[i + 1] - self.du2[i] * b[i + 2]) / self.d[i];
        }
    }
}

/// `out = M r` for a tridiagonal `M`.
pub(super) fn tri_mul(m: &Tridiagonal, r: &[f64], out: &mut [f64]) {
    let n = m.diag.len();
    for i in 0..n {
        let mut s = m.diag[i] * r[i];
        if i > 0 {
            s += m.lower[i - 1] * r[i - 1];
        }
        if i + 1 < n {
            s += m.upper[i] * r[i + 1];
        }
        out[i] = s;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tridiagonal_solver_with_and_without_pivoting() {
        let kx = Tridiagonal {
            lower: vec![3.0, -1.0, 2.0],
            diag: vec![0.5, -2.0, 1.0, 4.0],
            upper: vec![5.0, 0.25, -3.0],
        };
        let kv = Tridiagonal::zeros(4);
        // M = I − b kx with b = 1: not diagonally dominant, rows get interchanged.
        let mut lu = TriLu::new(4);
        assert!(lu.factor(&kx, &kv, 0.0, 1.0));
        assert!(lu.swap.iter().any(|s| *s));
        let x = [1.0, -2.0, 0.5, 3.0];
        let m = |i: usize, j: usize| {
            let k = if i == j {
                kx.diag[i]
            } else if j == i + 1 {
                kx.upper[i]
            } else if i == j + 1 {
                kx.lower[j]
            } else {
                0.0
            };
            f64::from(u8::from(i == j)) - k
        };
        let mut b: Vec<f64> = (0..4)
            .map(|i| (0..4).map(|j| m(i, j) * x[j]).sum())
            .collect();
        lu.solve(&mut b);
        for i in 0..4 {
            assert!((b[i] - x[i]).abs() < 1e-13, "{b:?}");
        }
        // A singular matrix is reported.
        let one = Tridiagonal {
            lower: vec![0.0],
            diag: vec![1.0, 1.0],
            upper: vec![0.0],
        };
        let mut lu = TriLu::new(2);
        assert!(!lu.factor(&one, &Tridiagonal::zeros(2), 0.0, 1.0));
    }
}
