//! Shard assignment: which grid points each of `N` machines runs.
//!
//! Today the rule is round-robin, every `N`-th point from the `K`-th; it lives here alone so that
//! a rule balanced by estimated cost can replace it. Whatever the rule, the shards partition the
//! grid, and a merge of their files equals a single-machine run.

use crate::grid::Shard;

/// Whether grid point `index` belongs to `shard` (every point belongs to no shard at all).
pub fn contains(shard: Option<Shard>, index: usize) -> bool {
    match shard {
        None => true,
        Some(Shard { k, n }) => index % n == k - 1,
    }
}

/// The grid points of `shard` in a grid of `n_points`, in grid order.
pub fn points(n_points: usize, shard: Option<Shard>) -> Vec<usize> {
    (0..n_points).filter(|&i| contains(shard, i)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_partition_the_grid() {
        let n = 23;
        let mut seen = vec![0; n];
        for k in 1..=4 {
            for i in points(n, Some(Shard { k, n: 4 })) {
                seen[i] += 1;
            }
        }
        assert!(seen.iter().all(|&c| c == 1));
        assert_eq!(points(5, None), vec![0, 1, 2, 3, 4]);
        assert_eq!(points(7, Some(Shard { k: 2, n: 3 })), vec![1, 4]);
    }
}
