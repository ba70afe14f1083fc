//! Shard assignment: which grid points each of `N` machines runs.
//!
//! Points are balanced by estimated cost: every point's cost is estimated from its scene (see
//! [`estimated_cost`]), and the points, costliest first, go one by one to the shard with the
//! least estimated cost so far (greedy longest-processing-time). Equal costs are ordered by a
//! scrambled index, so that points differing only in a parameter the estimate ignores (a damping
//! value of the last axis) spread over the shards instead of lining up with them, as every-N-th
//! point assignment did. The assignment is a pure function of the sweep file and `N`: every array
//! task computes the same one, on any machine (costs are quantised to integers before they are
//! compared or summed). The shards partition the grid, and a merge of their files equals a
//! single-machine run.

use chainsweep_solver::scene::ImpactScales;

use crate::grid::{Grid, Shard};
use crate::sweep::Sweep;

/// Relative resolution of the quantised cost estimates (`2^-20`): costs closer than this count as
/// equal, so that the last bits of `powf` on another machine cannot change the assignment.
const COST_QUANTUM: f64 = (1u64 << 20) as f64;

/// Estimated cost of running `sweep`'s grid point `index`, in arbitrary units: particles ×
/// simulated time / the two-body contact time of the striker (the time scale the integrator's
/// steps resolve). Points whose scene cannot be built cost 1.
pub fn estimated_cost(sweep: &Sweep, grid: &Grid, index: usize) -> f64 {
    let Ok(scene) = grid.build(sweep, index) else {
        return 1.0;
    };
    let Ok(chain) = scene.validate() else {
        return 1.0;
    };
    let contact = ImpactScales::new(&chain, scene.striker_velocity_m_s).contact_duration_s();
    let cost = chain.mass.len() as f64 * scene.duration_s / contact;
    if cost.is_finite() && cost > 0.0 {
        cost
    } else {
        1.0
    }
}

/// The estimated costs of every grid point, quantised to integers (the largest is `2^20`).
pub fn quantised_costs(sweep: &Sweep, grid: &Grid) -> Vec<u64> {
    let costs: Vec<f64> = (0..grid.len())
        .map(|i| estimated_cost(sweep, grid, i))
        .collect();
    let max = costs.iter().copied().fold(0.0f64, f64::max);
    costs
        .iter()
        .map(|&c| ((c / max * COST_QUANTUM).round() as u64).max(1))
        .collect()
}

/// A fixed scramble of an index (SplitMix64's finaliser): the tie-break between equal costs.
fn scramble(i: usize) -> u64 {
    let mut z = (i as u64).wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The shard (from 0) of every point of costs `costs` among `n` shards: greedy
/// longest-processing-time, ties in cost broken by [`scramble`], ties in load by the lower shard.
pub fn assign(costs: &[u64], n: usize) -> Vec<usize> {
    let n = n.max(1);
    let mut order: Vec<usize> = (0..costs.len()).collect();
    order.sort_by_key(|&i| (std::cmp::Reverse(costs[i]), scramble(i), i));
    let mut load: std::collections::BinaryHeap<std::cmp::Reverse<(u64, usize)>> =
        (0..n).map(|s| std::cmp::Reverse((0, s))).collect();
    let mut shard_of = vec![0; costs.len()];
    for i in order {
        let std::cmp::Reverse((l, s)) = load.pop().expect("n >= 1 shards");
        shard_of[i] = s;
        load.push(std::cmp::Reverse((l + costs[i], s)));
    }
    shard_of
}

/// Which grid points belong to which shard, for one sweep and `N`.
#[derive(Debug, Clone)]
pub struct Assignment {
    /// The shard (`k`, from 1) of every grid point; all 1 without sharding.
    shard_of: Vec<usize>,
    /// Estimated (quantised) cost of every grid point.
    pub costs: Vec<u64>,
}

impl Assignment {
    /// The assignment of `sweep`'s grid to the shards of `shard` (one shard holding everything
    /// when `None`).
    pub fn new(sweep: &Sweep, grid: &Grid, shard: Option<Shard>) -> Assignment {
        match shard {
            None => Assignment {
                shard_of: vec![1; grid.len()],
                costs: Vec::new(),
            },
            Some(Shard { n, .. }) => {
                let costs = quantised_costs(sweep, grid);
                let shard_of = assign(&costs, n).into_iter().map(|s| s + 1).collect();
                Assignment { shard_of, costs }
            }
        }
    }

    /// Whether grid point `index` belongs to `shard` (every point belongs to no shard at all).
    pub fn contains(&self, shard: Option<Shard>, index: usize) -> bool {
        shard.map_or(true, |s| self.shard_of[index] == s.k)
    }

    /// The shard (from 1) of grid point `index`.
    pub fn shard_of(&self, index: usize) -> usize {
        self.shard_of[index]
    }

    /// The grid points of `shard`, in grid order.
    pub fn points(&self, shard: Option<Shard>) -> Vec<usize> {
        (0..self.shard_of.len())
            .filter(|&i| self.contains(shard, i))
            .collect()
    }
}

/// The grid points of `shard` of `sweep`'s grid, in grid order (every point without a shard).
pub fn points(sweep: &Sweep, grid: &Grid, shard: Option<Shard>) -> Vec<usize> {
    Assignment::new(sweep, grid, shard).points(shard)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_partition_the_points_and_balance_their_costs() {
        // Costs that depend only on the first axis of a 12 × 4 grid (the last axis, 4 values,
        // is ignored by the estimate): every-N-th assignment would give each of 4 shards one
        // value of the last axis; here each shard must get a mix and the same total.
        let costs: Vec<u64> = (0..48).map(|i| 10 + (i / 4) as u64 * 7).collect();
        let s = assign(&costs, 4);
        let mut load = [0u64; 4];
        let mut last_axis = [[0; 4]; 4];
        for (i, &k) in s.iter().enumerate() {
            load[k] += costs[i];
            last_axis[k][i % 4] += 1;
        }
        let (lo, hi) = (load.iter().min().unwrap(), load.iter().max().unwrap());
        assert!((hi - lo) as f64 <= 0.02 * *hi as f64, "{load:?}");
        assert!(
            last_axis
                .iter()
                .all(|c| c.iter().filter(|&&x| x > 0).count() >= 3),
            "{last_axis:?}"
        );
        // A pure function of the costs and N.
        assert_eq!(assign(&costs, 4), s);
        assert_eq!(assign(&costs, 1), vec![0; 48]);
        assert!(assign(&[5, 5], 3).iter().all(|&k| k < 3));
    }
}
