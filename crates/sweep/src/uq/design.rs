//! Where an ensemble's samples lie in the unit hypercube `(0, 1)^d`, as pure functions of a seed:
//!
//! - **Sobol'** points (Joe & Kuo's direction numbers, `new-joe-kuo-6`, through the `sobol`
//!   crate's tables) with Owen's nested uniform scrambling, each replicate scrambled anew: any
//!   `2^m` first points of a replicate are a (t, m, s)-net, randomised so that the replicate's
//!   mean is unbiased and independent replicates give an honest interval;
//! - **Latin hypercube**: each dimension cut into `n` equal strata, one point in each, the strata
//!   paired at random;
//! - **Monte Carlo**: independent uniforms;
//! - **Saltelli's** design for Sobol' indices (matrices A, B and, per input group, A with that
//!   group's columns from B), from one scrambled Sobol' sequence of twice the dimensions;
//! - **Morris's** trajectories for elementary effects: a base point on a `p`-level grid, then one
//!   step of `Δ = p / (2 (p − 1))` per input group, in random order ([`MORRIS_STEP`]).
//!
//! Every design doubles without moving a point: the first `n` points of a Sobol' or Monte Carlo
//! replicate, and the first `n` rows of Saltelli's matrices, are the same at `2n`, so an adaptive
//! ensemble that doubles keeps every run it has.

use std::ops::Range;

use super::{mix64, unit, Stream};

/// The most dimensions a Sobol' design takes (the direction numbers tabulated).
pub const MAX_SOBOL_DIMS: usize = 1000;

/// A Sobol' sequence's direction numbers in `dims` dimensions, 32 bits each.
#[derive(Debug, Clone)]
pub struct Sobol {
    dirs: Vec<[u32; 32]>,
}

impl Sobol {
    /// The direction numbers of the first `dims` dimensions (at most [`MAX_SOBOL_DIMS`]).
    pub fn new(dims: usize) -> Sobol {
        assert!(dims <= MAX_SOBOL_DIMS, "checked at parse time");
        let params = sobol::params::JoeKuoD6::standard();
        let v = sobol::Sobol::<u32>::init_direction_vals::<u32>(dims.max(1), 32, &params);
        Sobol {
            dirs: v
                .into_iter()
                .map(|d| {
                    let mut a = [0u32; 32];
                    a.copy_from_slice(&d[..32]);
                    a
                })
                .collect(),
        }
    }

    /// Coordinate `d` of point `i` (in Gray-code order: the first `2^m` points are the
    /// sequence's first `2^m` in any order), as 32 bits.
    pub fn bits(&self, i: u32, d: usize) -> u32 {
        let mut g = i ^ (i >> 1);
        let mut x = 0;
        let mut k = 0;
        while g != 0 {
            if g & 1 == 1 {
                x ^= self.dirs[d][k];
            }
            g >>= 1;
            k += 1;
        }
        x
    }
}

/// Owen's nested uniform scrambling of the 32 digits `x` under `key`: digit `j` is flipped by a
/// random bit that depends on the `j` digits before it; the 21 digits beyond the 32nd, all zero in
/// the sequence, become random bits that depend on all 32. Returns a number in (0, 1).
pub fn owen(x: u32, key: u64) -> f64 {
    let mut y = 0u32;
    for j in 0..32 {
        let prefix = if j == 0 { 0 } else { (x >> (32 - j)) as u64 };
        let flip = (mix64(key ^ mix64(((j as u64) << 32) | prefix)) >> 63) as u32;
        let digit = (x >> (31 - j)) & 1;
        y |= (digit ^ flip) << (31 - j);
    }
    let low = mix64(key ^ mix64((33u64 << 32) | x as u64)) >> 43;
    unit((((y as u64) << 21) | low) << 11)
}

/// The designs of an ensemble drawn for statistics.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Scrambled Sobol' points.
    Sobol,
    /// Latin hypercube.
    LatinHypercube,
    /// Independent uniforms.
    MonteCarlo,
}

/// `replicates` independent replicates of `n` points each of design `kind` in `dims` dimensions:
/// row `r · n + i` is point `i` of replicate `r`, `dims` numbers in (0, 1) each (row-major).
pub fn sample(kind: Kind, dims: usize, n: usize, replicates: usize, seed: u64) -> Vec<f64> {
    let mut out = vec![0.0; replicates * n * dims];
    match kind {
        Kind::Sobol => {
            let s = Sobol::new(dims);
            for r in 0..replicates {
                for d in 0..dims {
                    let key = super::hash(&[seed, 1, r as u64, d as u64]);
                    for i in 0..n {
                        out[(r * n + i) * dims + d] = owen(s.bits(i as u32, d), key);
                    }
                }
            }
        }
        Kind::LatinHypercube => {
            for r in 0..replicates {
                for d in 0..dims {
                    let mut rng = Stream::new(&[seed, 2, r as u64, d as u64]);
                    let mut perm: Vec<usize> = (0..n).collect();
                    for i in (1..n).rev() {
                        perm.swap(i, rng.below(i + 1));
                    }
                    for i in 0..n {
                        out[(r * n + i) * dims + d] = (perm[i] as f64 + rng.uniform()) / n as f64;
                    }
                }
            }
        }
        Kind::MonteCarlo => {
            for r in 0..replicates {
                for i in 0..n {
                    // One stream per point: the first n points do not depend on n.
                    let mut rng = Stream::new(&[seed, 3, r as u64, i as u64]);
                    for d in 0..dims {
                        out[(r * n + i) * dims + d] = rng.uniform();
                    }
                }
            }
        }
    }
    out
}

/// Saltelli's design over `groups` (each a range of the `dims` columns, the inputs whose Sobol'
/// indices are asked): `n` rows of A, then `n` of B, then `n` of each `AB_g` (A with group `g`'s
/// columns from B), `n · (groups + 2)` rows in all; `block[row]` is 0 for A, 1 for B, `2 + g`.
pub fn saltelli(dims: usize, groups: &[Range<usize>], n: usize, seed: u64) -> (Vec<f64>, Vec<u32>) {
    let s = Sobol::new(2 * dims);
    let keys: Vec<u64> = (0..2 * dims)
        .map(|d| super::hash(&[seed, 4, d as u64]))
        .collect();
    let ab: Vec<f64> = (0..n)
        .flat_map(|i| {
            let s = &s;
            let keys = &keys;
            (0..2 * dims).map(move |d| owen(s.bits(i as u32, d), keys[d]))
        })
        .collect();
    let a = |i: usize, d: usize| ab[i * 2 * dims + d];
    let b = |i: usize, d: usize| ab[i * 2 * dims + dims + d];
    let mut out = Vec::with_capacity(n * (groups.len() + 2) * dims);
    let mut block = Vec::with_capacity(n * (groups.len() + 2));
    for blk in 0..groups.len() + 2 {
        for i in 0..n {
            for d in 0..dims {
                let from_b = match blk {
                    0 => false,
                    1 => true,
                    g => groups[g - 2].contains(&d),
                };
                out.push(if from_b { b(i, d) } else { a(i, d) });
            }
            block.push(blk as u32);
        }
    }
    (out, block)
}

/// One row of a Morris design: its trajectory, its step along it (0: the base point) and the
/// input group that step moved (`None` at the base point).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MorrisStep {
    /// The trajectory.
    pub trajectory: usize,
    /// The step (0 ..= groups).
    pub step: usize,
    /// The group moved at this step.
    pub moved: Option<usize>,
}

/// The step of a Morris design in (0, 1), whatever its levels: half of them (`Δ = p / (2 (p − 1))`
/// on the grid `0, 1/(p−1), …, 1`), between cell centres `(l + ½) / p`. Elementary effects are per
/// unit of this probability scale.
pub const MORRIS_STEP: f64 = 0.5;

/// Morris's design: `trajectories` trajectories of `groups.len() + 1` points on a `levels`-level
/// grid (even `levels`), each group moved once by `Δ` in random order. The grid's levels
/// `0, 1/(p−1), …, 1` are taken at the centres of `p` equal cells of (0, 1), so that an unbounded
/// distribution's quantile stays finite.
pub fn morris(
    dims: usize,
    groups: &[Range<usize>],
    trajectories: usize,
    levels: usize,
    seed: u64,
) -> (Vec<f64>, Vec<MorrisStep>) {
    let p = levels as f64;
    let half = levels / 2;
    let mut out = Vec::with_capacity(trajectories * (groups.len() + 1) * dims);
    let mut steps = Vec::with_capacity(trajectories * (groups.len() + 1));
    let to_unit = |level: usize| (level as f64 + 0.5) / p;
    for t in 0..trajectories {
        let mut rng = Stream::new(&[seed, 5, t as u64]);
        let mut level: Vec<usize> = (0..dims).map(|_| rng.below(half)).collect();
        let mut order: Vec<usize> = (0..groups.len()).collect();
        for i in (1..order.len()).rev() {
            order.swap(i, rng.below(i + 1));
        }
        for step in 0..=groups.len() {
            let moved = (step > 0).then(|| order[step - 1]);
            if let Some(g) = moved {
                for d in groups[g].clone() {
                    level[d] += half;
                }
            }
            out.extend(level.iter().map(|&l| to_unit(l)));
            steps.push(MorrisStep {
                trajectory: t,
                step,
                moved,
            });
        }
    }
    (out, steps)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sobol_first_points_are_the_published_ones() {
        // Joe & Kuo's sequence, dimension 2 (direction numbers 1/2, 3/4): points 0, 1/2, 3/4, 1/4
        // in natural order, so 0, 1/2, 1/4, 3/4 in Gray-code order (point i is the natural
        // point i ^ (i >> 1)).
        let s = Sobol::new(3);
        let x: Vec<f64> = (0..4).map(|i| s.bits(i, 1) as f64 / 4294967296.0).collect();
        assert_eq!(x, vec![0.0, 0.5, 0.25, 0.75]);
    }

    #[test]
    fn scrambled_nets_stay_stratified_and_double_without_moving() {
        // Each of 16 scrambled points falls in its own sixteenth of every axis (a (0, 4, 1)-net
        // in each dimension), and the first 16 of 32 are the 16.
        let a = sample(Kind::Sobol, 5, 16, 2, 7);
        let b = sample(Kind::Sobol, 5, 32, 2, 7);
        for r in 0..2 {
            for d in 0..5 {
                let mut cells: Vec<usize> = (0..16)
                    .map(|i| (a[(r * 16 + i) * 5 + d] * 16.0) as usize)
                    .collect();
                cells.sort();
                assert_eq!(cells, (0..16).collect::<Vec<_>>());
                for i in 0..16 {
                    assert_eq!(a[(r * 16 + i) * 5 + d], b[(r * 32 + i) * 5 + d]);
                }
            }
        }
        let lhs = sample(Kind::LatinHypercube, 3, 10, 1, 1);
        for d in 0..3 {
            let mut cells: Vec<usize> = (0..10).map(|i| (lhs[i * 3 + d] * 10.0) as usize).collect();
            cells.sort();
            assert_eq!(cells, (0..10).collect::<Vec<_>>());
        }
    }

    #[test]
    fn saltelli_blocks_swap_one_group() {
        let groups = [0..1, 1..3];
        let (x, block) = saltelli(3, &groups, 4, 1);
        assert_eq!(block.len(), 16);
        let row = |k: usize| &x[k * 3..k * 3 + 3];
        for i in 0..4 {
            let (a, b, ab0, ab1) = (row(i), row(4 + i), row(8 + i), row(12 + i));
            assert_eq!(ab0, &[b[0], a[1], a[2]]);
            assert_eq!(ab1, &[a[0], b[1], b[2]]);
        }
    }

    #[test]
    fn morris_moves_one_group_per_step() {
        let groups = [0..1, 1..2, 2..4];
        let (x, steps) = morris(4, &groups, 3, 4, 9);
        for k in 1..steps.len() {
            let Some(g) = steps[k].moved else { continue };
            let (a, b) = (&x[(k - 1) * 4..k * 4], &x[k * 4..k * 4 + 4]);
            for d in 0..4 {
                let moved = (b[d] - a[d]).abs();
                if groups[g].contains(&d) {
                    assert!((moved - 0.5).abs() < 1e-12);
                } else {
                    assert_eq!(moved, 0.0);
                }
            }
        }
    }
}
