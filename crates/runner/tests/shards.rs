//! Balanced shards: on the paper's Fig. 8 grid and on a grid whose last axis (10 damping values)
//! is a multiple of the number of shards, the shards' real costs (right-hand-side evaluations of
//! their runs, a noise-free measure of CPU time) differ by at most 15 %, where every-N-th
//! assignment gave 20 % and 70 % (on Fig. 8, 11 % since its sweep ends steps on predicted contact
//! switches, which narrowed the gap between its μ = 0 and μ = 6 runs); every point belongs to
//! exactly one shard, and the assignment
//! is the same every time it is computed.

use std::path::Path;

use rayon::prelude::*;

use chainsweep::engine::{self, shard::Assignment};
use chainsweep::grid::Shard;

/// The right-hand-side evaluations of every run of `file`'s grid.
fn costs(file: &str) -> (Vec<f64>, chainsweep::sweep::Sweep, chainsweep::grid::Grid) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../sweeps")
        .join(file);
    let (sweep, grid) = engine::load(&path).unwrap();
    let rhs: Vec<f64> = (0..grid.len())
        .into_par_iter()
        .map(|i| {
            let scene = grid.build(&sweep, i).unwrap();
            chainsweep_solver::run(&scene).unwrap().stats.rhs_evals as f64
        })
        .collect();
    (rhs, sweep, grid)
}

/// (largest - smallest) / largest of the shards' summed costs.
fn spread(cost: &[f64], shard_of: impl Fn(usize) -> usize, n: usize) -> f64 {
    let mut load = vec![0.0; n];
    for (i, c) in cost.iter().enumerate() {
        load[shard_of(i)] += c;
    }
    let hi = load.iter().copied().fold(f64::MIN, f64::max);
    let lo = load.iter().copied().fold(f64::MAX, f64::min);
    (hi - lo) / hi
}

fn check(file: &str, shards: &[usize], every_nth_worse_than: f64) {
    let (cost, sweep, grid) = costs(file);
    for &n in shards {
        let a = Assignment::new(&sweep, &grid, Some(Shard { k: 1, n }));
        let mut seen = vec![0; grid.len()];
        for k in 1..=n {
            for i in a.points(Some(Shard { k, n }), grid.len()) {
                assert_eq!(a.shard_of(i), k);
                seen[i] += 1;
            }
        }
        assert!(
            seen.iter().all(|&c| c == 1),
            "{file} in {n}: not a partition"
        );
        let again = Assignment::new(&sweep, &grid, Some(Shard { k: 2, n }));
        assert!((0..grid.len()).all(|i| again.shard_of(i) == a.shard_of(i)));
        let s = spread(&cost, |i| a.shard_of(i) - 1, n);
        assert!(s <= 0.15, "{file} in {n} shards: costs differ by {s:.3}");
        let old = spread(&cost, |i| i % n, n);
        eprintln!("{file} in {n} shards: costs differ by {s:.3} (every N-th point: {old:.3})");
        assert!(old > every_nth_worse_than, "{file} in {n}: {old}");
    }
}

#[test]
fn shards_of_the_fig8_grid_cost_the_same_within_15_percent() {
    // 91 mass ratios × 2 damping values: every-N-th gives shard pairs one damping each (8 % apart
    // in 2 shards since the damped pulse's shorter moving part costs less, 10 % before).
    check("fig08.json", &[2, 4], 0.05);
}

#[test]
fn shards_of_a_grid_whose_last_axis_is_a_multiple_of_n_cost_the_same_within_15_percent() {
    // 20 mass ratios × 10 damping values, in 5 shards.
    check("mass-damping.json", &[5], 0.5);
}

/// A round of an adaptive ensemble keeps the earlier rounds' samples, and each keeps the shard it
/// had, whatever the design and the number of shards: a shard's own file then holds its earlier
/// runs, and it runs only its new samples. (A sample's index does not stay: a Sobol' design
/// doubles the samples of every replicate, so a later replicate's samples move up.)
#[test]
fn an_adaptive_ensemble_s_samples_keep_their_shard_as_the_rounds_double() {
    use chainsweep::grid::Grid;
    use chainsweep::sweep::Sweep;
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../sweeps/examples/ensemble-tolerance.json");
    let text = std::fs::read_to_string(&path).unwrap();
    // (A Morris design computes no statistics, so it is never adaptive.)
    for design in ["sobol", "monte_carlo", "latin_hypercube", "saltelli"] {
        let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
        v["ensemble"]["design"] = design.into();
        v["ensemble"]["samples"] = 8.into();
        if design == "saltelli" {
            // Saltelli's intervals come from the bootstrap, not from replicates.
            v["ensemble"].as_object_mut().unwrap().remove("replicates");
        } else {
            v["ensemble"]["replicates"] = 4.into();
        }
        let sweep = Sweep::parse_in(&v.to_string(), path.parent().unwrap())
            .unwrap_or_else(|e| panic!("{design}: {e}"));
        assert!(sweep.ensemble.as_ref().unwrap().adaptive());
        for n in [2, 3, 5] {
            for k in 0..3 {
                let (a, b) = (sweep.at_ensemble_round(k), sweep.at_ensemble_round(k + 1));
                let (ga, gb) = (Grid::new(&a).unwrap(), Grid::new(&b).unwrap());
                let shard = Some(Shard { k: 1, n });
                let (sa, sb) = (
                    Assignment::new(&a, &ga, shard),
                    Assignment::new(&b, &gb, shard),
                );
                let of_b: std::collections::HashMap<_, usize> = gb
                    .hashes
                    .iter()
                    .enumerate()
                    .map(|(i, h)| (*h, sb.shard_of(i)))
                    .collect();
                assert!(gb.len() == 2 * ga.len(), "{design}: round {k} doubles");
                for (i, h) in ga.hashes.iter().enumerate() {
                    assert_eq!(
                        of_b.get(h),
                        Some(&sa.shard_of(i)),
                        "{design}, {n} shards: sample {i} of round {k}"
                    );
                }
                // The samples are shared out evenly: no shard has more than its share and one.
                let mut count = vec![0usize; n];
                for i in 0..gb.len() {
                    count[sb.shard_of(i) - 1] += 1;
                }
                let (lo, hi) = (count.iter().min().unwrap(), count.iter().max().unwrap());
                assert!(
                    hi - lo <= 1 + gb.len() / 50,
                    "{design}, {n} shards, round {}: {count:?}",
                    k + 1
                );
            }
        }
    }
}
