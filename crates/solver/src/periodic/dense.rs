//! The small dense linear algebra of shooting: an LU factorisation with partial pivoting (solve
//! and determinant) and the Floquet multipliers of a monodromy matrix, for the `2N`-square
//! matrices of a chain's period map (a few hundred rows at most).

use crate::spectrum::real_eigenvalues;

/// An LU factorisation with partial pivoting of an `n × n` matrix, `P A = L U`, to solve with
/// several right-hand sides (inverse iteration) and to give the determinant.
#[derive(Debug, Clone)]
pub struct Lu {
    n: usize,
    /// `L` (unit diagonal, below) and `U` (on and above), row-major.
    lu: Vec<f64>,
    /// Step `k` of the elimination exchanged rows `k` and `pivots[k]`.
    pivots: Vec<usize>,
    det: f64,
}

impl Lu {
    /// Factors `a` (row-major `n × n`). `None` when a pivot is exactly zero (a singular matrix).
    pub fn factor(mut a: Vec<f64>, n: usize) -> Option<Lu> {
        debug_assert_eq!(a.len(), n * n);
        let mut det = 1.0;
        let mut pivots = Vec::with_capacity(n);
        for k in 0..n {
            let p = (k..n)
                .max_by(|&i, &j| a[i * n + k].abs().total_cmp(&a[j * n + k].abs()))
                .expect("a row");
            if a[p * n + k] == 0.0 {
                return None;
            }
            if p != k {
                for j in 0..n {
                    a.swap(k * n + j, p * n + j);
                }
                det = -det;
            }
            pivots.push(p);
            let pivot = a[k * n + k];
            det *= pivot;
            for i in k + 1..n {
                let f = a[i * n + k] / pivot;
                a[i * n + k] = f;
                if f == 0.0 {
                    continue;
                }
                for j in k + 1..n {
                    a[i * n + j] -= f * a[k * n + j];
                }
            }
        }
        Some(Lu {
            n,
            lu: a,
            pivots,
            det,
        })
    }

    /// `det A`.
    pub fn det(&self) -> f64 {
        self.det
    }

    /// Overwrites `b` with the solution `x` of `A x = b`.
    pub fn solve(&self, b: &mut [f64]) {
        let (n, a) = (self.n, &self.lu);
        debug_assert_eq!(b.len(), n);
        for (k, &p) in self.pivots.iter().enumerate() {
            b.swap(k, p);
        }
        for i in 0..n {
            let s: f64 = (0..i).map(|j| a[i * n + j] * b[j]).sum();
            b[i] -= s;
        }
        for i in (0..n).rev() {
            let s: f64 = (i + 1..n).map(|j| a[i * n + j] * b[j]).sum();
            b[i] = (b[i] - s) / a[i * n + i];
        }
    }
}

/// Solves `A x = b` in place (`a` row-major `n × n`, overwritten; `b` becomes `x`) by Gaussian
/// elimination with partial pivoting. Returns `det A`, or `None` when a pivot is exactly zero (a
/// singular matrix).
pub fn solve(a: &mut [f64], n: usize, b: &mut [f64]) -> Option<f64> {
    debug_assert_eq!(b.len(), n);
    let lu = Lu::factor(a.to_vec(), n)?;
    lu.solve(b);
    a.copy_from_slice(&lu.lu);
    Some(lu.det)
}

/// The eigenvector of the real eigenvalue `mu` of `m` (row-major `n × n`), by inverse iteration
/// with the LU factors of `m − mu I` (its shift moved by `1e-10 (1 + |mu|)` where it is exactly
/// singular), normalised to unit Euclidean norm with its largest component positive: the
/// eigenvector of the eigenvalue nearest `mu`. `None` when the iteration does not settle in 20
/// steps on a vector that `m` maps to a multiple of itself (the nearest eigenvalues a complex
/// pair, or two at the same distance).
pub fn eigenvector(m: &[f64], n: usize, mu: f64) -> Option<Vec<f64>> {
    let shifted = |shift: f64| {
        let mut a = m.to_vec();
        for i in 0..n {
            a[i * n + i] -= shift;
        }
        Lu::factor(a, n)
    };
    let lu = shifted(mu).or_else(|| shifted(mu + 1e-10 * (1.0 + mu.abs())))?;
    let normalise = |v: &mut Vec<f64>| {
        let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        let big = v
            .iter()
            .copied()
            .fold(0.0, |a: f64, x| if x.abs() > a.abs() { x } else { a });
        let s = big.signum() / norm;
        v.iter_mut().for_each(|x| *x *= s);
        norm.is_finite() && norm > 0.0
    };
    // A start with every component, so that no eigenvector is orthogonal to it.
    let mut v: Vec<f64> = (0..n).map(|i| 1.0 + 0.1 * (i as f64).sin()).collect();
    normalise(&mut v);
    for _ in 0..20 {
        let mut w = v.clone();
        lu.solve(&mut w);
        if !normalise(&mut w) {
            return None;
        }
        let change = v
            .iter()
            .zip(&w)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        v = w;
        if change < 1e-12 {
            // The residual of the eigenvalue equation at the Rayleigh quotient, relative to the
            // matrix's size.
            let mv: Vec<f64> = (0..n)
                .map(|i| (0..n).map(|j| m[i * n + j] * v[j]).sum())
                .collect();
            let lambda: f64 = mv.iter().zip(&v).map(|(a, b)| a * b).sum();
            let scale = m.iter().map(|x| x.abs()).fold(0.0, f64::max).max(mu.abs());
            let residual = mv
                .iter()
                .zip(&v)
                .map(|(a, b)| (a - lambda * b).abs())
                .fold(0.0, f64::max);
            return (residual <= 1e-6 * scale.max(1.0)).then_some(v);
        }
    }
    None
}

/// A Floquet multiplier `μ = re + i im`.
pub type Multiplier = (f64, f64);

/// The eigenvalues of the monodromy matrix `m` (row-major, `n × n`), the orbit's Floquet
/// multipliers, sorted by modulus, largest first (a conjugate pair: positive imaginary part
/// first). `None` when the QR iteration does not converge.
pub fn multipliers(m: &[f64], n: usize) -> Option<Vec<Multiplier>> {
    let mut a = m.to_vec();
    let mut w = real_eigenvalues(&mut a, n)?;
    w.sort_by(|x, y| {
        y.0.hypot(y.1)
            .total_cmp(&x.0.hypot(x.1))
            .then(y.1.total_cmp(&x.1))
    });
    Some(w)
}

/// Imaginary parts below this fraction of the modulus count as a real multiplier.
const REAL_TOLERANCE: f64 = 1e-9;

/// Whether a multiplier is real (to rounding).
pub fn is_real(m: Multiplier) -> bool {
    m.1.abs() <= REAL_TOLERANCE * m.0.hypot(m.1).max(f64::MIN_POSITIVE)
}

/// How far beyond the unit circle a multiplier must lie to count as outside it: the accuracy of
/// a monodromy matrix integrated to a tolerance, which bounds where a multiplier on the circle (an
/// undamped orbit's, or one at a fold) is found. Without it rounding alone (|μ| = 1 ± 1e-15)
/// decided an undamped orbit's stability and placed Neimark–Sacker points on a linear response.
/// (The autonomous orbits' check takes the same floor.)
pub const UNIT_CIRCLE_TOLERANCE: f64 = 1e-6;

/// Whether multiplier `m` lies outside the unit circle, beyond [`UNIT_CIRCLE_TOLERANCE`].
pub fn outside(m: Multiplier) -> bool {
    m.0.hypot(m.1) > 1.0 + UNIT_CIRCLE_TOLERANCE
}

/// Multipliers outside the unit circle ([`outside`]), by kind: `(real above +1, real below −1,
/// complex)`.
/// A change of the second between two orbits of a branch is a period doubling, of the third a
/// Neimark–Sacker bifurcation (a change of the first, a fold or a branch point, shows in the
/// tangent and the bordered determinant).
pub fn outside_counts(w: &[Multiplier]) -> (usize, usize, usize) {
    let mut c = (0, 0, 0);
    for &m in w {
        if !outside(m) {
            continue;
        }
        if !is_real(m) {
            c.2 += 1;
        } else if m.0 > 0.0 {
            c.0 += 1;
        } else {
            c.1 += 1;
        }
    }
    c
}

/// The test of a multiplier crossing the unit circle among those of one kind (`negative`: real
/// multipliers below zero, a period doubling; else complex ones, a Neimark–Sacker point) when
/// `outside` of them lie outside on one side of the crossing: the modulus of the next one less
/// one. It changes sign where that multiplier crosses, continuously along a branch as long as no
/// multiplier of the kind turns from real to complex.
pub fn crossing_test(w: &[Multiplier], negative: bool, outside: usize) -> f64 {
    let mut moduli: Vec<f64> = w
        .iter()
        .filter(|&&m| {
            if negative {
                is_real(m) && m.0 < 0.0
            } else {
                !is_real(m)
            }
        })
        .map(|m| m.0.hypot(m.1))
        .collect();
    moduli.sort_by(|a, b| b.total_cmp(a));
    moduli.get(outside).copied().unwrap_or(0.0) - 1.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_with_pivoting_and_gives_the_determinant() {
        // A zero in the first pivot position needs a row swap.
        let mut a = vec![0.0, 2.0, 1.0, 1.0, 1.0, 0.0, 3.0, 0.0, 1.0];
        let x = [1.0, -2.0, 0.5];
        let mut b: Vec<f64> = (0..3)
            .map(|i| (0..3).map(|j| a[i * 3 + j] * x[j]).sum())
            .collect();
        let det = solve(&mut a, 3, &mut b).unwrap();
        for i in 0..3 {
            assert!((b[i] - x[i]).abs() < 1e-14, "{b:?}");
        }
        // det = 0(1·1 − 0·0) − 2(1·1 − 0·3) + 1(1·0 − 1·3) = −5.
        assert!((det + 5.0).abs() < 1e-13, "{det}");
        let mut singular = vec![1.0, 2.0, 2.0, 4.0];
        assert!(solve(&mut singular, 2, &mut [1.0, 1.0]).is_none());
    }

    #[test]
    fn multipliers_of_a_rotation_and_a_scaling() {
        // A rotation by 0.3 rad scaled by 1.2, beside a real −1.5 and a real 0.5.
        let (c, s) = (1.2 * 0.3f64.cos(), 1.2 * 0.3f64.sin());
        #[rustfmt::skip]
        let m = [
            c, -s, 0.0, 0.0,
            s, c, 0.0, 0.0,
            0.0, 0.0, -1.5, 0.0,
            0.0, 0.0, 0.0, 0.5,
        ];
        let w = multipliers(&m, 4).unwrap();
        assert!((w[0].0 + 1.5).abs() < 1e-14 && w[0].1 == 0.0, "{w:?}");
        assert!(
            (w[1].0 - c).abs() < 1e-14 && (w[1].1 - s).abs() < 1e-14,
            "{w:?}"
        );
        assert!((w[2].1 + s).abs() < 1e-14, "{w:?}");
        assert_eq!(outside_counts(&w), (0, 1, 2));
        assert!((crossing_test(&w, true, 0) - 0.5).abs() < 1e-14);
        assert_eq!(crossing_test(&w, true, 1), -1.0);
        assert!((crossing_test(&w, false, 0) - 0.2).abs() < 1e-14);
        assert_eq!(crossing_test(&w, false, 2), -1.0);
    }

    #[test]
    fn inverse_iteration_finds_the_eigenvector_of_minus_one() {
        // A = S diag(−1, 0.5, 2) S⁻¹ with S's columns the eigenvectors.
        #[rustfmt::skip]
        let s = [
            1.0, 1.0, 0.0,
            2.0, 0.0, 1.0,
            0.0, 1.0, 1.0,
        ];
        // S⁻¹ = adj(S) / det S, det S = −3.
        #[rustfmt::skip]
        let inv = [
            1.0 / 3.0, 1.0 / 3.0, -1.0 / 3.0,
            2.0 / 3.0, -1.0 / 3.0, 1.0 / 3.0,
            -2.0 / 3.0, 1.0 / 3.0, 2.0 / 3.0,
        ];
        let d = [-1.0, 0.5, 2.0];
        let mut a = [0.0; 9];
        for i in 0..3 {
            for j in 0..3 {
                a[i * 3 + j] = (0..3).map(|k| s[i * 3 + k] * d[k] * inv[k * 3 + j]).sum();
            }
        }
        let v = eigenvector(&a, 3, -1.0).unwrap();
        // The first column (1, 2, 0), normalised, largest component positive.
        let n = 5f64.sqrt();
        for (x, want) in v.iter().zip([1.0 / n, 2.0 / n, 0.0]) {
            assert!((x - want).abs() < 1e-12, "{v:?}");
        }
        // A shift near, not at, the eigenvalue converges to the same vector.
        let w = eigenvector(&a, 3, -0.999).unwrap();
        assert!(
            v.iter().zip(&w).all(|(x, y)| (x - y).abs() < 1e-10),
            "{w:?}"
        );
        // det A = (−1)(0.5)(2).
        let lu = Lu::factor(a.to_vec(), 3).unwrap();
        assert!((lu.det() + 1.0).abs() < 1e-13, "{}", lu.det());
    }
}
