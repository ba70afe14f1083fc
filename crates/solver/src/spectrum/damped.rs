//! The eigenvalues of a real matrix, for the damped (quadratic) eigenproblem
//! `(λ² M + λ C + K) x = 0` when the damping is not proportional to the stiffness: its companion
//! matrix `[[0, I], [−M^{−1/2} K M^{−1/2}, −M^{−1/2} C M^{−1/2}]]` (order `2N`) balanced
//! (Parlett & Reinsch), reduced to upper Hessenberg form by stabilised elementary similarity
//! transformations and solved by the Francis double-shift QR iteration: EISPACK's `balanc`,
//! `elmhes` and `hqr`, after Numerical Recipes (2nd ed., §11.5–11.6). `O(N³)`, so it is kept to
//! small chains ([`super::DENSE_DAMPED_LIMIT`]).

/// Eigenvalues `(re, im)` of the real `n × n` matrix `a` (row-major, destroyed), or `None` when
/// the QR iteration does not converge (30 iterations for one eigenvalue).
pub(crate) fn real_eigenvalues(a: &mut [f64], n: usize) -> Option<Vec<(f64, f64)>> {
    balance(a, n);
    hessenberg(a, n);
    hqr(a, n)
}

fn balance(a: &mut [f64], n: usize) {
    const RADIX: f64 = 2.0;
    let sqrdx = RADIX * RADIX;
    let mut done = false;
    while !done {
        done = true;
        for i in 0..n {
            let (mut r, mut c) = (0.0, 0.0);
            for j in 0..n {
                if j != i {
                    c += a[j * n + i].abs();
                    r += a[i * n + j].abs();
                }
            }
            if c != 0.0 && r != 0.0 {
                let mut g = r / RADIX;
                let mut f = 1.0;
                let s = c + r;
                while c < g {
                    f *= RADIX;
                    c *= sqrdx;
                }
                g = r * RADIX;
                while c > g {
                    f /= RADIX;
                    c /= sqrdx;
                }
                if (c + r) / f < 0.95 * s {
                    done = false;
                    let g = 1.0 / f;
                    for j in 0..n {
                        a[i * n + j] *= g;
                    }
                    for j in 0..n {
                        a[j * n + i] *= f;
                    }
                }
            }
        }
    }
}

fn hessenberg(a: &mut [f64], n: usize) {
    for m in 1..n.saturating_sub(1) {
        let mut x = 0.0f64;
        let mut i = m;
        for j in m..n {
            if a[j * n + m - 1].abs() > x.abs() {
                x = a[j * n + m - 1];
                i = j;
            }
        }
        if i != m {
            for j in m - 1..n {
                a.swap(i * n + j, m * n + j);
            }
            for j in 0..n {
                a.swap(j * n + i, j * n + m);
            }
        }
        if x != 0.0 {
            for i in m + 1..n {
                let mut y = a[i * n + m - 1];
                if y != 0.0 {
                    y /= x;
                    a[i * n + m - 1] = y;
                    for j in m..n {
                        a[i * n + j] -= y * a[m * n + j];
                    }
                    for j in 0..n {
                        a[j * n + m] += y * a[j * n + i];
                    }
                }
            }
        }
    }
}

/// Francis double-shift QR on an upper Hessenberg matrix (its entries below the subdiagonal are
/// ignored), 1-based indices inside as in the published algorithm.
#[allow(clippy::many_single_char_names)]
fn hqr(a: &mut [f64], n: usize) -> Option<Vec<(f64, f64)>> {
    let ix = |i: usize, j: usize| (i - 1) * n + (j - 1);
    let mut wr = vec![0.0; n + 1];
    let mut wi = vec![0.0; n + 1];
    let mut anorm = 0.0;
    for i in 1..=n {
        for j in i.saturating_sub(1).max(1)..=n {
            anorm += a[ix(i, j)].abs();
        }
    }
    let mut nn = n;
    let mut t = 0.0;
    let (mut p, mut q, mut r): (f64, f64, f64);
    let (mut x, mut y, mut z, mut w): (f64, f64, f64, f64);
    while nn >= 1 {
        let mut its = 0;
        loop {
            let mut l = nn;
            while l >= 2 {
                let mut s = a[ix(l - 1, l - 1)].abs() + a[ix(l, l)].abs();
                if s == 0.0 {
                    s = anorm;
                }
                if a[ix(l, l - 1)].abs() + s == s {
                    a[ix(l, l - 1)] = 0.0;
                    break;
                }
                l -= 1;
            }
            x = a[ix(nn, nn)];
            if l == nn {
                wr[nn] = x + t;
                wi[nn] = 0.0;
                nn -= 1;
            } else {
                y = a[ix(nn - 1, nn - 1)];
                w = a[ix(nn, nn - 1)] * a[ix(nn - 1, nn)];
                if l == nn - 1 {
                    p = 0.5 * (y - x);
                    q = p * p + w;
                    z = q.abs().sqrt();
                    x += t;
                    if q >= 0.0 {
                        z = p + z.copysign(p);
                        wr[nn - 1] = x + z;
                        wr[nn] = x + z;
                        if z != 0.0 {
                            wr[nn] = x - w / z;
                        }
                        wi[nn - 1] = 0.0;
                        wi[nn] = 0.0;
                    } else {
                        wr[nn - 1] = x + p;
                        wr[nn] = x + p;
                        wi[nn - 1] = -z;
                        wi[nn] = z;
                    }
                    nn -= 2;
                } else {
                    if its == 30 {
                        return None;
                    }
                    if its == 10 || its == 20 {
                        t += x;
                        for i in 1..=nn {
                            a[ix(i, i)] -= x;
                        }
                        let s = a[ix(nn, nn - 1)].abs() + a[ix(nn - 1, nn - 2)].abs();
                        x = 0.75 * s;
                        y = x;
                        w = -0.4375 * s * s;
                    }
                    its += 1;
                    let mut m = nn - 2;
                    loop {
                        z = a[ix(m, m)];
                        r = x - z;
                        let s = y - z;
                        p = (r * s - w) / a[ix(m + 1, m)] + a[ix(m, m + 1)];
                        q = a[ix(m + 1, m + 1)] - z - r - s;
                        r = a[ix(m + 2, m + 1)];
                        let s = p.abs() + q.abs() + r.abs();
                        p /= s;
                        q /= s;
                        r /= s;
                        if m == l {
                            break;
                        }
                        let u = a[ix(m, m - 1)].abs() * (q.abs() + r.abs());
                        let v = p.abs()
                            * (a[ix(m - 1, m - 1)].abs() + z.abs() + a[ix(m + 1, m + 1)].abs());
                        if u + v == v {
                            break;
                        }
                        m -= 1;
                    }
                    for i in m + 2..=nn {
                        a[ix(i, i - 2)] = 0.0;
                        if i != m + 2 {
                            a[ix(i, i - 3)] = 0.0;
                        }
                    }
                    let mut k = m;
                    while k < nn {
                        if k != m {
                            p = a[ix(k, k - 1)];
                            q = a[ix(k + 1, k - 1)];
                            r = 0.0;
                            if k != nn - 1 {
                                r = a[ix(k + 2, k - 1)];
                            }
                            x = p.abs() + q.abs() + r.abs();
                            if x != 0.0 {
                                p /= x;
                                q /= x;
                                r /= x;
                            }
                        }
                        let s = (p * p + q * q + r * r).sqrt().copysign(p);
                        if s != 0.0 {
                            if k == m {
                                if l != m {
                                    a[ix(k, k - 1)] = -a[ix(k, k - 1)];
                                }
                            } else {
                                a[ix(k, k - 1)] = -s * x;
                            }
                            p += s;
                            x = p / s;
                            y = q / s;
                            z = r / s;
                            q /= p;
                            r /= p;
                            for j in k..=nn {
                                p = a[ix(k, j)] + q * a[ix(k + 1, j)];
                                if k != nn - 1 {
                                    p += r * a[ix(k + 2, j)];
                                    a[ix(k + 2, j)] -= p * z;
                                }
                                a[ix(k + 1, j)] -= p * y;
                                a[ix(k, j)] -= p * x;
                            }
                            let mmin = if nn < k + 3 { nn } else { k + 3 };
                            for i in l..=mmin {
                                p = x * a[ix(i, k)] + y * a[ix(i, k + 1)];
                                if k != nn - 1 {
                                    p += z * a[ix(i, k + 2)];
                                    a[ix(i, k + 2)] -= p * r;
                                }
                                a[ix(i, k + 1)] -= p * q;
                                a[ix(i, k)] -= p;
                            }
                        }
                        k += 1;
                    }
                }
            }
            if nn < 2 || l + 1 >= nn {
                break;
            }
        }
    }
    Some((1..=n).map(|i| (wr[i], wi[i])).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eigenvalues_of_small_real_matrices() {
        // A rotation-scaling block and a real eigenvalue: 1 ± 2i and 3.
        let mut a = vec![1.0, -2.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 3.0];
        let mut w = real_eigenvalues(&mut a, 3).unwrap();
        w.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.total_cmp(&y.1)));
        let want = [(1.0, -2.0), (1.0, 2.0), (3.0, 0.0)];
        for (g, e) in w.iter().zip(want) {
            assert!(
                (g.0 - e.0).abs() < 1e-13 && (g.1 - e.1).abs() < 1e-13,
                "{w:?}"
            );
        }
        // A companion matrix of (x − 1)(x − 2)(x − 3)(x − 4): x⁴ − 10x³ + 35x² − 50x + 24.
        let mut c = vec![
            10.0, -35.0, 50.0, -24.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0,
        ];
        let mut w = real_eigenvalues(&mut c, 4).unwrap();
        w.sort_by(|x, y| x.0.total_cmp(&y.0));
        for (k, g) in w.iter().enumerate() {
            assert!((g.0 - (k + 1) as f64).abs() < 1e-11 && g.1 == 0.0, "{w:?}");
        }
    }
}
