//! Butcher's order conditions over rooted trees, for checking any explicit tableau as data: a
//! set of weights `w` (the solution's, an embedded one's, or the interpolant's at `θ`) has order
//! `p` when `Σ_i w_i Φ_i(t) = θ^|t| / γ(t)` for every rooted tree `t` with at most `p` vertices.

use super::explicit::{ExplicitMethod, Tableau};

/// A rooted tree as the list of its root's subtrees (sorted, so that each tree has one form).
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct Tree(Vec<Tree>);

impl Tree {
    /// Number of vertices.
    pub fn order(&self) -> usize {
        1 + self.0.iter().map(Tree::order).sum::<usize>()
    }

    /// γ(t) = |t| Π γ(subtrees).
    fn density(&self) -> f64 {
        self.order() as f64 * self.0.iter().map(Tree::density).product::<f64>()
    }

    /// Φ_i(t) for every stage: Π over subtrees of (A Φ(subtree))_i, with its magnitude (the same
    /// with |A|) to scale the rounding tolerance.
    fn stage_weights(&self, a: &[Vec<f64>]) -> (Vec<f64>, Vec<f64>) {
        let s = a.len();
        let (mut phi, mut mag) = (vec![1.0; s], vec![1.0; s]);
        for sub in &self.0 {
            let (p, m) = sub.stage_weights(a);
            for i in 0..s {
                phi[i] *= (0..s).map(|j| a[i][j] * p[j]).sum::<f64>();
                mag[i] *= (0..s).map(|j| (a[i][j] * m[j]).abs()).sum::<f64>();
            }
        }
        (phi, mag)
    }
}

/// Every rooted tree with at most `max` vertices (1, 1, 2, 4, 9, 20, 48, 115 of each order).
pub fn trees(max: usize) -> Vec<Tree> {
    // Grafting a leaf onto every vertex of every tree one smaller gives all of them.
    fn graft(t: &Tree) -> Vec<Tree> {
        let mut out = vec![];
        let mut with_leaf = t.0.clone();
        with_leaf.push(Tree(vec![]));
        with_leaf.sort();
        out.push(Tree(with_leaf));
        for (k, sub) in t.0.iter().enumerate() {
            for g in graft(sub) {
                let mut subs = t.0.clone();
                subs[k] = g;
                subs.sort();
                out.push(Tree(subs));
            }
        }
        out
    }
    let mut all = vec![Tree(vec![])];
    for order in 2..=max {
        let mut new: Vec<Tree> = all
            .iter()
            .filter(|t| t.order() == order - 1)
            .flat_map(graft)
            .collect();
        new.sort();
        new.dedup();
        all.extend(new);
    }
    all
}

/// The tableau's full matrix `A` (every stage, the continuous extension's too) and its nodes.
pub fn matrix(tableau: &Tableau) -> (Vec<Vec<f64>>, Vec<f64>) {
    let s = tableau.stages.len();
    let mut a = vec![vec![0.0; s]; s];
    for (i, stage) in tableau.stages.iter().enumerate() {
        for &(j, v) in stage.a {
            assert!(j < i, "stage {i} reads stage {j}: not explicit");
            a[i][j] = v;
        }
    }
    (a, tableau.stages.iter().map(|st| st.c).collect())
}

/// Weights given as non-zero entries, as a full vector over `s` stages.
pub fn dense_weights(entries: &[(usize, f64)], s: usize) -> Vec<f64> {
    let mut w = vec![0.0; s];
    for &(j, v) in entries {
        w[j] = v;
    }
    w
}

/// The interpolant's weights `b_j(θ)`, read off the method's own continuous extension: the
/// interpolant of a step whose stage `j` alone is 1 (and `y_new − y = h b_j` with `h = 1`).
pub fn interpolant_weights<M: ExplicitMethod>(theta: f64) -> Vec<f64> {
    let tableau = M::TABLEAU;
    let b = dense_weights(tableau.weights(), tableau.stages.len());
    (0..tableau.stages.len())
        .map(|j| {
            let c = M::dense_coefficients(1.0, 0.0, b[j], |m| if m == j { 1.0 } else { 0.0 });
            M::interpolate(|r| c[r], theta)
        })
        .collect()
}

/// The largest violation of `Σ w_i Φ_i(t) = θ^|t| / γ(t)` over the trees with at most `order`
/// vertices, relative to the size of the terms.
pub fn worst_condition(a: &[Vec<f64>], w: &[f64], theta: f64, order: usize) -> f64 {
    trees(order)
        .iter()
        .map(|t| {
            let (phi, mag) = t.stage_weights(a);
            let lhs: f64 = w.iter().zip(&phi).map(|(w, p)| w * p).sum();
            let scale: f64 = w.iter().zip(&mag).map(|(w, m)| (w * m).abs()).sum();
            let rhs = theta.powi(t.order() as i32) / t.density();
            (lhs - rhs).abs() / scale.max(1.0)
        })
        .fold(0.0, f64::max)
}

/// The row sums of `A` equal the nodes (every stage's argument is consistent to first order).
pub fn worst_row_sum(a: &[Vec<f64>], c: &[f64]) -> f64 {
    a.iter()
        .zip(c)
        .map(|(row, c)| (row.iter().sum::<f64>() - c).abs())
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_trees_of_each_order_are_counted_as_in_the_literature() {
        // OEIS A000081.
        let all = trees(8);
        let counts: Vec<usize> = (1..=8)
            .map(|p| all.iter().filter(|t| t.order() == p).count())
            .collect();
        assert_eq!(counts, [1, 1, 2, 4, 9, 20, 48, 115]);
    }

    #[test]
    fn the_classic_rk4_tableau_is_of_order_four_exactly() {
        let a = vec![
            vec![0.0; 4],
            vec![0.5, 0.0, 0.0, 0.0],
            vec![0.0, 0.5, 0.0, 0.0],
            vec![0.0, 0.0, 1.0, 0.0],
        ];
        let b = [1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0];
        assert!(worst_row_sum(&a, &[0.0, 0.5, 0.5, 1.0]) < 1e-16);
        assert!(worst_condition(&a, &b, 1.0, 4) < 1e-15);
        assert!(worst_condition(&a, &b, 1.0, 5) > 1e-3);
        // One wrong weight breaks order 1 already.
        let wrong = [1.0 / 6.0, 1.0 / 3.0, 0.3, 1.0 / 6.0];
        assert!(worst_condition(&a, &wrong, 1.0, 1) > 1e-3);
    }
}
