//! Shard assignment: which grid points each of `N` machines runs.
//!
//! Points are balanced by estimated cost (see [`assign`]): the Latin assignment gives every shard
//! every value of every axis in equal share, so that a cost the estimate cannot see (a damping
//! that shortens runs thirty-fold) is shared out too; when the estimate from the scenes (see
//! [`estimated_cost`]: a cylinder-count axis, a few very long runs) says that this is
//! unbalanced, greedy longest-processing-time on the estimate is used instead. Every-N-th
//! assignment gave each shard one value of a last axis whose length is a multiple of N: 4 shards
//! of a 480-run grid cost 28.7, 29.1, 16.8 and 11.8 CPU-s. The assignment is a pure function of the sweep file and `N`: every array
//! task computes the same one, on any machine (costs are quantised to integers before they are
//! compared or summed). The shards partition the grid, and a merge of their files equals a
//! single-machine run. A sweep that continues along an axis is shared out by whole lines along it
//! ([`assign_lines`]): each point starts from the one before it.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use crate::grid::{multi_index, Grid, Shard};
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
    let contact = scene.impact_scales(&chain).contact_duration_s();
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

/// The Latin (diagonal) assignment of a grid of `shape` to `n` shards: point `(i₁, …, i_d)` goes
/// to shard `(i₁ + … + i_d) mod n` (from 0). Along every axis, consecutive points go to
/// consecutive shards, so every shard gets every value of every axis in equal share (exactly,
/// when the axis length is a multiple of `n`): whatever the cost depends on, each shard gets a
/// representative sample of the grid. Every-N-th assignment instead gave each shard one value
/// of a last axis whose length is a multiple of `n`.
pub fn latin(shape: &[usize], n: usize) -> Vec<usize> {
    let n = n.max(1);
    let len: usize = shape.iter().product();
    (0..len)
        .map(|i| multi_index(shape, i).iter().sum::<usize>() % n)
        .collect()
}

/// The Latin assignment of an ensemble's grid (its last dimension the samples) to `n` shards by
/// each sample's key instead of its index (the ensemble's `member_keys`): point `(i₁, …, m)` goes
/// to shard `(i₁ + … + key(m)) mod n`. A sample's key stays the same as the rounds double the
/// samples, where its index does not (a Sobol' design doubles the samples of each replicate, so
/// an earlier replicate's samples move up), so each sample stays in its shard.
pub fn latin_by_keys(shape: &[usize], keys: &[usize], n: usize) -> Vec<usize> {
    let n = n.max(1);
    let len: usize = shape.iter().product();
    let last = shape.len() - 1;
    (0..len)
        .map(|i| {
            let m = multi_index(shape, i);
            (m[..last].iter().sum::<usize>() + keys[m[last]]) % n
        })
        .collect()
}

/// Greedy longest-processing-time assignment of points of costs `costs` to `n` shards (from 0):
/// the costliest point first (equal costs in grid order), each to the shard with the least cost
/// so far (the lower shard on a tie).
pub fn greedy(costs: &[u64], n: usize) -> Vec<usize> {
    let n = n.max(1);
    let mut order: Vec<usize> = (0..costs.len()).collect();
    order.sort_by_key(|&i| (Reverse(costs[i]), i));
    let mut load: BinaryHeap<Reverse<(u64, usize)>> = (0..n).map(|s| Reverse((0, s))).collect();
    let mut shard_of = vec![0; costs.len()];
    for i in order {
        let Reverse((l, s)) = load.pop().expect("n >= 1 shards");
        shard_of[i] = s;
        load.push(Reverse((l + costs[i], s)));
    }
    shard_of
}

/// The largest estimated cost of a shard under `shard_of`.
fn max_load(costs: &[u64], shard_of: &[usize], n: usize) -> u64 {
    let mut load = vec![0u64; n.max(1)];
    for (i, &k) in shard_of.iter().enumerate() {
        load[k] += costs[i];
    }
    load.into_iter().max().unwrap_or(0)
}

/// How much costlier (estimated) the costliest Latin shard may be than the costliest greedy
/// shard for the Latin assignment to be kept: 10 %.
pub const LATIN_TOLERANCE: f64 = 1.10;

/// The shard (from 0) of every point of a grid of `shape` whose points have estimated costs
/// `costs`: the [`latin`] assignment, robust to what the estimate ignores (a damping), unless
/// the estimate says it is unbalanced (its costliest shard more than [`LATIN_TOLERANCE`] times
/// the [`greedy`] one's, as with a few very costly points), then the greedy one.
pub fn assign(shape: &[usize], costs: &[u64], n: usize) -> Vec<usize> {
    let l = latin(shape, n);
    let g = greedy(costs, n);
    if max_load(costs, &l, n) as f64 <= LATIN_TOLERANCE * max_load(costs, &g, n) as f64 {
        l
    } else {
        g
    }
}

/// The shard (from 0) of every grid point of a sweep that continues along dimension `dim`: whole
/// lines along it (each point starts from the one before it), balanced by their summed estimated
/// cost (greedy longest-processing-time), so that no shard recomputes another's points.
pub fn assign_lines(shape: &[usize], costs: &[u64], n: usize, dim: usize) -> Vec<usize> {
    let stride: usize = shape[dim + 1..].iter().product();
    let len = shape[dim];
    // A line is named by its first point (coordinate 0 along `dim`); lines in grid order.
    let line_of = |p: usize| p - ((p / stride) % len) * stride;
    let lines: Vec<usize> = (0..costs.len()).filter(|&p| line_of(p) == p).collect();
    let index: std::collections::HashMap<usize, usize> =
        lines.iter().enumerate().map(|(k, &l)| (l, k)).collect();
    let mut line_costs = vec![0u64; lines.len()];
    for (p, &c) in costs.iter().enumerate() {
        line_costs[index[&line_of(p)]] += c;
    }
    let shard_of_line = greedy(&line_costs, n);
    (0..costs.len())
        .map(|p| shard_of_line[index[&line_of(p)]])
        .collect()
}

/// Which grid points belong to which shard, for one sweep and `N`.
#[derive(Debug, Clone)]
pub struct Assignment {
    /// The shard (`k`, from 1) of every grid point; empty without sharding (every point is 1's).
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
                shard_of: Vec::new(),
                costs: Vec::new(),
            },
            Some(Shard { n, .. }) => {
                let costs = quantised_costs(sweep, grid);
                let shards = match (sweep.continuation, sweep.adaptive_ensemble()) {
                    (Some(c), _) => assign_lines(&grid.shape, &costs, n, c.dim),
                    // A round of an adaptive ensemble keeps the last round's samples, and each
                    // keeps its shard (see `latin_by_keys`), so a shard's own file holds its
                    // earlier runs and it runs only the new samples. Costs may not choose: they
                    // are relative to the round's costliest sample.
                    (None, Some(e)) => {
                        latin_by_keys(&grid.shape, &e.member_keys(sweep.ensemble_round), n)
                    }
                    (None, None) => assign(&grid.shape, &costs, n),
                };
                let shard_of = shards.into_iter().map(|s| s + 1).collect();
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
        self.shard_of.get(index).copied().unwrap_or(1)
    }

    /// The grid points of `shard`, in grid order (every point of `grid_len` without a shard).
    pub fn points(&self, shard: Option<Shard>, grid_len: usize) -> Vec<usize> {
        match shard {
            None => (0..grid_len).collect(),
            Some(_) => (0..self.shard_of.len())
                .filter(|&i| self.contains(shard, i))
                .collect(),
        }
    }
}

/// The grid points of `shard` of `sweep`'s grid, in grid order (every point without a shard).
pub fn points(sweep: &Sweep, grid: &Grid, shard: Option<Shard>) -> Vec<usize> {
    Assignment::new(sweep, grid, shard).points(shard, grid.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_partition_the_points_and_share_out_every_axis() {
        // A 12 × 4 grid: every-N-th assignment in 4 shards gives each shard one value of the
        // last axis; the Latin one gives each shard every value, 3 times.
        let shape = [12, 4];
        let costs = vec![1u64; 48];
        let s = assign(&shape, &costs, 4);
        let mut last_axis = [[0; 4]; 4];
        for (i, &k) in s.iter().enumerate() {
            last_axis[k][i % 4] += 1;
        }
        assert_eq!(last_axis, [[3; 4]; 4]);
        // A pure function of the shape, the costs and N.
        assert_eq!(assign(&shape, &costs, 4), s);
        assert_eq!(assign(&shape, &costs, 1), vec![0; 48]);
        // One point costing as much as all others: greedy gives it a shard of its own.
        let mut skewed = vec![1u64; 48];
        skewed[5] = 47;
        let g = assign(&shape, &skewed, 2);
        assert!((0..48).filter(|&i| i != 5).all(|i| g[i] != g[5]));
    }
}
