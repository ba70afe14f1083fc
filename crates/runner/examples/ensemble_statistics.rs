//! How long an ensemble's statistics take for a million stored samples: a Sobol' ensemble of
//! 2^17 × 8 replicates (1 048 576 members) over one input, its statistic's values given (a
//! log-normal quantity), and `engine::ensemble::tables` timed as `assemble` calls it: mean, sd,
//! three quantiles, two exceedance levels and a 20-bin histogram, each with its interval.
//! `cargo run --release -p chainsweep --example ensemble_statistics [REPEATS]`; run by
//! `scripts/bench_ensemble.py`.

use std::time::Instant;

use chainsweep::engine::ensemble::tables;
use chainsweep::sweep::Sweep;

fn main() {
    let repeats: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(5);
    let text = r#"{
      "base": {
        "chain": {"preset": "chain_055", "cylinders": 4},
        "physics": {"gravity": false, "damping_kg_s": 0.0, "wall": true},
        "striker_velocity_m_s": 1.0, "duration_s": 1e-4
      },
      "record": {"probes": [{"kind": "gauge_force", "cylinder": 2}]},
      "ensemble": {
        "inputs": [{"field": "striker_velocity_m_s", "uniform": {"min": 0.5, "max": 1.5}}],
        "samples": 131072, "replicates": 8,
        "statistics": [{"name": "peak", "of": {"summary": "leading_peak", "probe": "gauge_force_cyl2"}, "exceed": [100.0, 200.0]}]
      }
    }"#;
    let sweep = Sweep::parse(text).expect("the sweep parses");
    let n = sweep.n_points();
    let values: Vec<f64> = (0..n)
        .map(|i| 100.0 * (0.3 * ((i as f64 * 0.618_033_988_75).fract() - 0.5)).exp())
        .collect();
    let values = vec![values];
    let mut times = Vec::new();
    for _ in 0..repeats {
        let t = Instant::now();
        let (t_out, outcome) = tables(&sweep, &values, 0);
        times.push(t.elapsed().as_secs_f64());
        assert_eq!(outcome.samples, n);
        assert!(!t_out.tables.vars.is_empty());
    }
    times.sort_by(f64::total_cmp);
    println!(
        "{{\"samples\": {n}, \"median_s\": {:.4}, \"min_s\": {:.4}, \"max_s\": {:.4}}}",
        times[times.len() / 2],
        times[0],
        times[times.len() - 1]
    );
}
