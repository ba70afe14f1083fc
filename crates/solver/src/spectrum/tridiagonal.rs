//! The symmetric tridiagonal eigenproblem `T u = λ u`, solved without any dense matrix:
//! eigenvalues by Sturm-sequence bisection, finished by Laguerre's iteration on the
//! characteristic polynomial, and eigenvectors by inverse iteration.
//!
//! - **Sturm count.** The number of eigenvalues below `x` is the number of negative pivots of
//!   the `LDLᵀ` factorisation of `T − x I`, `q₀ = a₀ − x`, `q_i = (a_i − x) − b_{i−1}²/q_{i−1}`
//!   (Sylvester's law of inertia); a pivot that vanishes is replaced by `−p_min`, `p_min` a tiny
//!   multiple of the largest `b²` (as LAPACK's `dstebz`). The count is monotone in `x` even in
//!   floating point, which makes bisection safe.
//! - **Isolation.** Intervals of the Gershgorin interval are bisected, each split serving every
//!   eigenvalue inside it, until each holds one eigenvalue (or is as narrow as the arithmetic
//!   allows: a multiple or numerically coincident eigenvalue).
//! - **Refinement.** Inside an interval holding exactly one eigenvalue, `p(x) = det(T − x I)`
//!   (a polynomial of real roots only) has one simple root. `G = p'/p = Σ q_i'/q_i` and
//!   `H = G² − p''/p = Σ ((q_i'/q_i)² − q_i''/q_i)` follow from the pivots' derivatives
//!   (`q_i' = −1 + b_{i−1}² q_{i−1}'/q_{i−1}²`, `q_i'' = b_{i−1}² (q_{i−1}''/q_{i−1}² −
//!   2 q_{i−1}'²/q_{i−1}³)`) in the same pass as the count, with one division per row and no
//!   overflow. Laguerre's two points `x − N/(G ± √((N − 1)(N H − G²)))` bound the roots adjacent
//!   to `x` on either side; the count says on which side the wanted one lies, and stepping to
//!   that side's point converges to it monotonically and cubically (Li & Zeng, SIAM J. Sci.
//!   Comput. 13, 1992). A step that leaves the bracket is replaced by bisection; the iteration
//!   stops when the step is below bisection's resolution (a few units in the last place of
//!   `‖T‖`): the answer bisection would give, in about 3 passes instead of 50 (5 in all per
//!   eigenvalue, isolation included, for `N = 3000`).
//! - **Lanes.** Each pass's recurrence is a chain of dependent divisions; four independent shifts
//!   (four intervals to split, or four eigenvalues to refine) run side by side in one pass, so
//!   that their divisions overlap (8× faster than one at a time for `N = 3000`).
//! - **Eigenvectors.** Inverse iteration (two solves of `(T − λ I) x = b` with the LU
//!   factorisation with partial pivoting, as LAPACK's `dstein`), each iterate orthogonalised
//!   against the vectors already found whose eigenvalues lie within `10⁻⁴ ‖T‖` of its own (where
//!   inverse iteration alone would mix them; farther ones are orthogonal to `ε/10⁻⁴`).
//!
//! Cost: a pass is `O(N)`, so `k` eigenvalues cost `O(k N)` (all of them `O(N²)`), each with its
//! vector `O(N)` more plus the orthogonalisations, a few near the ends of the spectrum.

/// A real symmetric tridiagonal matrix: diagonal `a` (length `N`) and off-diagonal `b` (`N − 1`).
#[derive(Debug, Clone, PartialEq)]
pub struct SymTridiagonal {
    /// Diagonal.
    pub diag: Vec<f64>,
    /// Off-diagonal: `b[i]` couples rows `i` and `i + 1`.
    pub off: Vec<f64>,
}

/// Eigenvalues closer than this (relative to `‖T‖`) have their eigenvectors orthogonalised
/// against each other.
const ORTHOGONALISE_WITHIN: f64 = 1e-4;

/// Shifts evaluated side by side in one pass.
const LANES: usize = 4;

impl SymTridiagonal {
    /// The matrix of diagonal `diag` and off-diagonal `off` (`off.len() + 1 == diag.len()`).
    pub fn new(diag: Vec<f64>, off: Vec<f64>) -> Self {
        assert!(
            !diag.is_empty() && off.len() + 1 == diag.len(),
            "a tridiagonal matrix of {} rows needs {} off-diagonal entries, got {}",
            diag.len(),
            diag.len().saturating_sub(1),
            off.len()
        );
        SymTridiagonal { diag, off }
    }

    /// Order `N`.
    pub fn len(&self) -> usize {
        self.diag.len()
    }

    /// Whether the matrix has no rows (never: [`SymTridiagonal::new`] refuses it).
    pub fn is_empty(&self) -> bool {
        self.diag.is_empty()
    }

    /// The Gershgorin interval, which holds every eigenvalue.
    pub fn gershgorin(&self) -> (f64, f64) {
        let n = self.len();
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for i in 0..n {
            let r = if i > 0 { self.off[i - 1].abs() } else { 0.0 }
                + if i + 1 < n { self.off[i].abs() } else { 0.0 };
            lo = lo.min(self.diag[i] - r);
            hi = hi.max(self.diag[i] + r);
        }
        (lo, hi)
    }

    /// `max(|lo|, |hi|)` of the Gershgorin interval: a bound on `‖T‖₂`.
    pub fn norm_bound(&self) -> f64 {
        let (lo, hi) = self.gershgorin();
        lo.abs().max(hi.abs())
    }

    /// The smallest pivot magnitude the Sturm count lets stand.
    fn pivmin(&self) -> f64 {
        let b2 = self.off.iter().fold(1.0f64, |m, b| m.max(b * b));
        f64::MIN_POSITIVE * b2 / f64::EPSILON
    }

    /// The number of eigenvalues strictly below `x`.
    pub fn count_below(&self, x: f64) -> usize {
        self.sturm(x, self.pivmin()).0
    }

    /// One pass at `x`: the Sturm count and Laguerre's points (see [`Self::sturm_lanes`]).
    fn sturm(&self, x: f64, pivmin: f64) -> (usize, f64, f64) {
        let (c, l, r) = self.sturm_lanes(&[x; LANES], pivmin);
        (c[0], l[0], r[0])
    }

    /// One pass at each of `LANES` shifts `x` together (independent recurrences side by side,
    /// so that one's division overlaps the others'): the Sturm count below each, and the steps to
    /// Laguerre's two points of `p = det(T − x I)`, the left (negative) and the right one.
    fn sturm_lanes(
        &self,
        x: &[f64; LANES],
        pivmin: f64,
    ) -> ([usize; LANES], [f64; LANES], [f64; LANES]) {
        let n = self.len();
        let mut q = [0.0; LANES];
        let mut dq = [-1.0; LANES];
        let mut ddq = [0.0; LANES];
        let mut r = [0.0; LANES];
        // G = p'/p = Σ q'/q and H = G² − p''/p = Σ ((q'/q)² − q''/q).
        let mut g = [0.0; LANES];
        let mut h = [0.0; LANES];
        let mut count = [0usize; LANES];
        for l in 0..LANES {
            q[l] = self.diag[0] - x[l];
            if q[l].abs() < pivmin {
                q[l] = -pivmin;
            }
            r[l] = 1.0 / q[l];
            g[l] = dq[l] * r[l];
            h[l] = g[l] * g[l];
            count[l] = (q[l] < 0.0) as usize;
        }
        for i in 1..n {
            let b2 = self.off[i - 1] * self.off[i - 1];
            let a = self.diag[i];
            for l in 0..LANES {
                let t = b2 * r[l];
                let qi = (a - x[l]) - t;
                // q_i' = −1 + b² q'/q², q_i'' = b² (q''/q² − 2 q'²/q³), of the previous row.
                let tr = t * r[l];
                ddq[l] = tr * (ddq[l] - 2.0 * dq[l] * dq[l] * r[l]);
                dq[l] = -1.0 + tr * dq[l];
                let qi = if qi.abs() < pivmin { -pivmin } else { qi };
                r[l] = 1.0 / qi;
                let e = dq[l] * r[l];
                g[l] += e;
                h[l] += e * e - ddq[l] * r[l];
                count[l] += (qi < 0.0) as usize;
            }
        }
        // Laguerre's two points x − N/(G ± √((N − 1)(N H − G²))): for a polynomial of real
        // roots, the adjacent root on either side lies beyond the point on that side.
        let nf = n as f64;
        let mut left = [0.0; LANES];
        let mut right = [0.0; LANES];
        for l in 0..LANES {
            let root = ((nf - 1.0) * (nf * h[l] - g[l] * g[l])).max(0.0).sqrt();
            let (s1, s2) = (-nf / (g[l] + root), -nf / (g[l] - root));
            left[l] = s1.min(s2);
            right[l] = s1.max(s2);
        }
        (count, left, right)
    }

    /// The eigenvalues of indices `first..first + count` in increasing order (index 0 the
    /// smallest), each to within a few units in the last place of `‖T‖`.
    pub fn eigenvalues(&self, first: usize, count: usize) -> Vec<f64> {
        let n = self.len();
        assert!(
            first + count <= n,
            "eigenvalues {first}..{} of a matrix of order {n}",
            first + count
        );
        let mut out = vec![f64::NAN; count];
        if count == 0 {
            return out;
        }
        let pivmin = self.pivmin();
        let (g_lo, g_hi) = self.gershgorin();
        let norm = g_lo.abs().max(g_hi.abs());
        // Widened so that the count is exactly 0 below and N above.
        let pad = 2.0 * f64::EPSILON * norm * n as f64 + 2.0 * pivmin;
        let (lo, hi) = (g_lo - pad, g_hi + pad);
        let tol = |a: f64, b: f64| 4.0 * f64::EPSILON * (norm.max(a.abs()).max(b.abs())) + pivmin;
        // Intervals (lo, hi, count below lo, count below hi), with count(lo) < first + count and
        // count(hi) > first: only those holding wanted eigenvalues are kept. Up to LANES of them
        // are split in one pass.
        let mut stack = vec![(lo, hi, 0usize, n)];
        let wanted = first..first + count;
        let mut isolated: Vec<(f64, f64, usize)> = Vec::with_capacity(count);
        let mut batch: Vec<(f64, f64, usize, usize)> = Vec::with_capacity(LANES);
        while !stack.is_empty() {
            batch.clear();
            while batch.len() < LANES {
                let Some((a, b, ca, cb)) = stack.pop() else {
                    break;
                };
                if cb <= ca || cb <= wanted.start || ca >= wanted.end {
                    continue;
                }
                if cb - ca == 1 {
                    isolated.push((a, b, ca));
                    continue;
                }
                let mid = 0.5 * (a + b);
                if b - a <= tol(a, b) || mid <= a || mid >= b {
                    // Numerically coincident eigenvalues: all at the midpoint.
                    for k in ca.max(wanted.start)..cb.min(wanted.end) {
                        out[k - first] = mid;
                    }
                    continue;
                }
                batch.push((a, b, ca, cb));
            }
            if batch.is_empty() {
                continue;
            }
            let mut mids = [0.0; LANES];
            for (m, &(a, b, _, _)) in mids.iter_mut().zip(&batch) {
                *m = 0.5 * (a + b);
            }
            let (counts, _, _) = self.sturm_lanes(&mids, pivmin);
            for (l, &(a, b, ca, cb)) in batch.iter().enumerate() {
                stack.push((mids[l], b, counts[l], cb));
                stack.push((a, mids[l], ca, counts[l]));
            }
        }
        self.refine(&isolated, pivmin, &tol, |k, lambda| out[k - first] = lambda);
        out
    }

    /// The one eigenvalue of each interval `(a, b, k)` (`k` its index), `LANES` at a time:
    /// Laguerre's iteration on `det(T − x I)` (cubically and, for a polynomial of real roots,
    /// monotonically convergent), safeguarded by the bracket the Sturm count keeps: a step that
    /// leaves it is replaced by bisection. Each result goes to `found(k, λ)`.
    fn refine(
        &self,
        jobs: &[(f64, f64, usize)],
        pivmin: f64,
        tol: &impl Fn(f64, f64) -> f64,
        mut found: impl FnMut(usize, f64),
    ) {
        /// One eigenvalue in progress: its bracket, index, iterate and passes so far.
        #[derive(Clone, Copy)]
        struct Lane {
            a: f64,
            b: f64,
            k: usize,
            x: f64,
            passes: usize,
        }
        let mut lanes: [Option<Lane>; LANES] = [None; LANES];
        let mut next = 0;
        loop {
            for lane in lanes.iter_mut().filter(|l| l.is_none()) {
                if let Some(&(a, b, k)) = jobs.get(next) {
                    *lane = Some(Lane {
                        a,
                        b,
                        k,
                        x: 0.5 * (a + b),
                        passes: 0,
                    });
                    next += 1;
                }
            }
            if lanes.iter().all(Option::is_none) {
                return;
            }
            let mut xs = [0.0; LANES];
            for (x, lane) in xs.iter_mut().zip(&lanes) {
                // An idle lane repeats a busy one's shift (its result is not read).
                *x = lane
                    .or(lanes.iter().flatten().next().copied())
                    .map_or(0.0, |l| l.x);
            }
            let (counts, left, right) = self.sturm_lanes(&xs, pivmin);
            for (l, slot) in lanes.iter_mut().enumerate() {
                let Some(lane) = slot.as_mut() else { continue };
                lane.passes += 1;
                // The eigenvalue lies right of x when no more than k lie below it.
                let step = if counts[l] <= lane.k {
                    lane.a = lane.x;
                    right[l]
                } else {
                    lane.b = lane.x;
                    left[l]
                };
                let (a, b) = (lane.a, lane.b);
                let next_x = lane.x + step;
                let done = if b - a <= tol(a, b) || lane.passes >= 200 {
                    Some(0.5 * (a + b))
                } else if step.is_finite() && step.abs() <= tol(a, b) {
                    // Converged to rounding: the step is below bisection's resolution (it may
                    // cross the root by an ulp or two, so the bracket's ends are kept).
                    Some(next_x.clamp(a, b))
                } else if step.is_finite() && next_x > a && next_x < b {
                    lane.x = next_x;
                    None
                } else {
                    let mid = 0.5 * (a + b);
                    if mid <= a || mid >= b {
                        Some(mid)
                    } else {
                        lane.x = mid;
                        None
                    }
                };
                if let Some(lambda) = done {
                    found(lane.k, lambda);
                    *slot = None;
                }
            }
        }
    }

    /// Eigenvectors (unit 2-norm) of the eigenvalues `lambdas`, given in increasing order as
    /// [`SymTridiagonal::eigenvalues`] returns them: column `j` of the result is `u_j`, stored as
    /// `vectors[j * N + i]`.
    pub fn eigenvectors(&self, lambdas: &[f64]) -> Vec<f64> {
        let n = self.len();
        let norm = self.norm_bound().max(f64::MIN_POSITIVE);
        let mut vectors = vec![0.0; n * lambdas.len()];
        let mut rng = crate::contact::SplitMix64(0x5eed_5eed);
        let mut lu = TridiagonalLu::with_capacity(n);
        let mut first_close = 0;
        for j in 0..lambdas.len() {
            // Vectors already found whose eigenvalues lie close enough to mix into this one.
            while lambdas[j] - lambdas[first_close] > ORTHOGONALISE_WITHIN * norm {
                first_close += 1;
            }
            lu.factor(self, lambdas[j], f64::EPSILON * norm);
            let (done, rest) = vectors.split_at_mut(j * n);
            let x = &mut rest[..n];
            for xi in x.iter_mut() {
                *xi = rng.symmetric();
            }
            // Two solves: the first from a random start is close to converged (the shift is an
            // eigenvalue to rounding), the second cleans it up.
            for _ in 0..2 {
                normalise(x);
                lu.solve(x);
                for c in first_close..j {
                    let u = &done[c * n..(c + 1) * n];
                    let d: f64 = u.iter().zip(x.iter()).map(|(p, q)| p * q).sum();
                    for (xi, ui) in x.iter_mut().zip(u) {
                        *xi -= d * ui;
                    }
                }
            }
            normalise(x);
            // One sign convention: the largest component positive.
            let big = x
                .iter()
                .fold(0.0f64, |m, &v| if v.abs() > m.abs() { v } else { m });
            if big < 0.0 {
                for xi in x.iter_mut() {
                    *xi = -*xi;
                }
            }
        }
        vectors
    }
}

/// Scales `x` to unit 2-norm (in two passes, so that a huge iterate does not overflow).
fn normalise(x: &mut [f64]) {
    let big = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if big == 0.0 || !big.is_finite() {
        return;
    }
    let inv = 1.0 / big;
    let s: f64 = x.iter().map(|v| (v * inv) * (v * inv)).sum();
    let scale = inv / s.sqrt();
    for v in x.iter_mut() {
        *v *= scale;
    }
}

/// The LU factorisation with partial pivoting of `T − λ I` (Gaussian elimination on a
/// tridiagonal matrix, which fills one more diagonal above when rows are swapped), as LINPACK's
/// `dgtsl`; a vanishing pivot is replaced by `tiny`, as inverse iteration wants.
struct TridiagonalLu {
    /// Pivot row's diagonal (stored as its reciprocal once factored), first and second
    /// superdiagonal, the multiplier, and whether rows `i` and `i + 1` were swapped.
    d: Vec<f64>,
    u1: Vec<f64>,
    u2: Vec<f64>,
    l: Vec<f64>,
    swap: Vec<bool>,
}

impl TridiagonalLu {
    fn with_capacity(n: usize) -> Self {
        TridiagonalLu {
            d: Vec::with_capacity(n),
            u1: Vec::with_capacity(n),
            u2: Vec::with_capacity(n),
            l: Vec::with_capacity(n),
            swap: Vec::with_capacity(n),
        }
    }

    fn factor(&mut self, t: &SymTridiagonal, lambda: f64, tiny: f64) {
        let n = t.len();
        self.d.clear();
        self.u1.clear();
        self.u2.clear();
        self.l.clear();
        self.swap.clear();
        // The current row i, reduced: (diag, super) in columns i, i + 1.
        let mut di = t.diag[0] - lambda;
        let mut ui = if n > 1 { t.off[0] } else { 0.0 };
        for i in 0..n - 1 {
            let sub = t.off[i];
            let dn = t.diag[i + 1] - lambda;
            let un = if i + 2 < n { t.off[i + 1] } else { 0.0 };
            if sub.abs() > di.abs() {
                // Swap: row i + 1 becomes the pivot row: [sub, dn, un].
                let m = di / sub;
                self.d.push(sub);
                self.u1.push(dn);
                self.u2.push(un);
                self.l.push(m);
                self.swap.push(true);
                di = ui - m * dn;
                ui = -m * un;
            } else {
                let p = if di.abs() < tiny { tiny } else { di };
                let m = sub / p;
                self.d.push(p);
                self.u1.push(ui);
                self.u2.push(0.0);
                self.l.push(m);
                self.swap.push(false);
                di = dn - m * ui;
                ui = un;
            }
        }
        self.d.push(if di.abs() < tiny { tiny } else { di });
        self.u1.push(0.0);
        self.u2.push(0.0);
        // The back substitution multiplies by the pivots' reciprocals.
        for d in self.d.iter_mut() {
            *d = 1.0 / *d;
        }
    }

    /// Solves in place.
    fn solve(&self, x: &mut [f64]) {
        let n = x.len();
        for i in 0..n - 1 {
            if self.swap[i] {
                x.swap(i, i + 1);
            }
            x[i + 1] -= self.l[i] * x[i];
        }
        x[n - 1] *= self.d[n - 1];
        if n > 1 {
            x[n - 2] = (x[n - 2] - self.u1[n - 2] * x[n - 1]) * self.d[n - 2];
        }
        for i in (0..n.saturating_sub(2)).rev() {
            x[i] = (x[i] - self.u1[i] * x[i + 1] - self.u2[i] * x[i + 2]) * self.d[i];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The second-difference matrix `tridiag(−1, 2, −1)`: `λ_j = 2 − 2 cos(jπ/(N+1))`.
    fn laplacian(n: usize) -> SymTridiagonal {
        SymTridiagonal::new(vec![2.0; n], vec![-1.0; n - 1])
    }

    #[test]
    fn second_difference_eigenvalues_to_machine_accuracy() {
        for n in [1, 2, 3, 10, 257] {
            let t = laplacian(n);
            let got = t.eigenvalues(0, n);
            for (j, l) in got.iter().enumerate() {
                let exact =
                    2.0 - 2.0 * ((j + 1) as f64 * std::f64::consts::PI / (n + 1) as f64).cos();
                assert!(
                    (l - exact).abs() < 8.0 * f64::EPSILON * 4.0,
                    "{n} {j} {l} {exact}"
                );
            }
            // A range gives the same numbers.
            if n > 4 {
                let part = t.eigenvalues(2, 3);
                assert_eq!(&part[..], &got[2..5]);
            }
        }
    }

    #[test]
    fn multiple_eigenvalues_and_split_matrices() {
        // Two decoupled blocks with the same spectrum: every eigenvalue double.
        let t = SymTridiagonal::new(vec![2.0, 2.0, 5.0, 2.0, 2.0], vec![-1.0, 0.0, 0.0, -1.0]);
        let l = t.eigenvalues(0, 5);
        for (got, want) in l.iter().zip([1.0, 1.0, 3.0, 3.0, 5.0]) {
            assert!((got - want).abs() < 1e-14, "{l:?}");
        }
        let v = t.eigenvectors(&l);
        // Orthonormal, even within the double eigenvalues.
        for i in 0..5 {
            for j in 0..5 {
                let d: f64 = (0..5).map(|r| v[i * 5 + r] * v[j * 5 + r]).sum();
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((d - want).abs() < 1e-13, "{i} {j} {d}");
            }
        }
    }

    #[test]
    fn inverse_iteration_gives_orthonormal_eigenvectors() {
        let n = 300;
        let t = laplacian(n);
        let l = t.eigenvalues(0, n);
        let v = t.eigenvectors(&l);
        for j in 0..n {
            let u = &v[j * n..(j + 1) * n];
            for i in 0..n {
                let tu = t.diag[i] * u[i]
                    + if i > 0 { t.off[i - 1] * u[i - 1] } else { 0.0 }
                    + if i + 1 < n { t.off[i] * u[i + 1] } else { 0.0 };
                assert!((tu - l[j] * u[i]).abs() < 1e-13, "residual {j} {i}");
            }
            for k in 0..j {
                let d: f64 = u
                    .iter()
                    .zip(&v[k * n..(k + 1) * n])
                    .map(|(a, b)| a * b)
                    .sum();
                assert!(d.abs() < 1e-12, "{j} {k} {d}");
            }
        }
    }
}
