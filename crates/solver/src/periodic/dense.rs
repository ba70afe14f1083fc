//! The small dense linear algebra of shooting: an LU factorisation with partial pivoting (solve
//! and determinant) and the Floquet multipliers of a monodromy matrix, for the `2N`-square
//! matrices of a chain's period map (a few hundred rows at most).

use crate::spectrum::real_eigenvalues;

/// Solves `A x = b` in place (`a` row-major `n × n`, overwritten by its LU factors; `b` becomes
/// `x`) by Gaussian elimination with partial pivoting. Returns `det A`, or `None` when a pivot is
/// exactly zero (a singular matrix).
pub fn solve(a: &mut [f64], n: usize, b: &mut [f64]) -> Option<f64> {
    debug_assert_eq!(a.len(), n * n);
    debug_assert_eq!(b.len(), n);
    let mut det = 1.0;
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
            b.swap(k, p);
            det = -det;
        }
        let pivot = a[k * n + k];
        det *= pivot;
        for i in k + 1..n {
            let f = a[i * n + k] / pivot;
            if f == 0.0 {
                continue;
            }
            a[i * n + k] = f;
            for j in k + 1..n {
                a[i * n + j] -= f * a[k * n + j];
            }
            b[i] -= f * b[k];
        }
    }
    for i in (0..n).rev() {
        let mut s = b[i];
        for j in i + 1..n {
            s -= a[i * n + j] * b[j];
        }
        b[i] = s / a[i * n + i];
    }
    Some(det)
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

/// Multipliers outside the unit circle, by kind: `(real above +1, real below −1, complex)`.
/// A change of the second between two orbits of a branch is a period doubling, of the third a
/// Neimark–Sacker bifurcation (a change of the first, a fold or a branch point, shows in the
/// tangent and the bordered determinant).
pub fn outside_counts(w: &[Multiplier]) -> (usize, usize, usize) {
    let mut c = (0, 0, 0);
    for &m in w {
        if m.0.hypot(m.1) <= 1.0 {
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
}
