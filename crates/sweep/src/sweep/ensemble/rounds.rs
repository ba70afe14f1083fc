//! The rounds of an ensemble: each round's size (an adaptive ensemble doubles its predecessor),
//! its samples as the grid's `member` dimension, and where each sample lies in its design.

use std::ops::Range;

use serde_json::Value;

use super::super::{Axis, Dim};
use super::{Design, EnsembleSpec, InputKind, Layout};
use crate::uq::clamp_unit;
use crate::uq::design::{self, Kind};
use crate::uq::dist::{correlate, lower_times, normal_quantile};

impl EnsembleSpec {
    /// Samples per replicate (or Saltelli's rows, Morris's trajectories) and replicates in round
    /// `k`: each round doubles its predecessor, Latin hypercubes by replicates (a Latin
    /// hypercube of `2n` points is not one of `n` and `n` more), the others by points.
    pub fn round_size(&self, k: usize) -> (usize, usize) {
        let grow = 1usize << k.min(40);
        match self.design {
            Design::Sample(Kind::LatinHypercube) => {
                (self.samples, self.replicates.saturating_mul(grow))
            }
            _ => (self.samples.saturating_mul(grow), self.replicates),
        }
    }

    /// Runs per point of the ordinary axes in round `k`.
    pub fn round_samples(&self, k: usize) -> usize {
        let (n, r) = self.round_size(k);
        match self.design {
            Design::Sample(_) => n.saturating_mul(r),
            Design::Saltelli => n.saturating_mul(self.inputs.len() + 2),
            Design::Morris { .. } => n.saturating_mul(self.inputs.len() + 1),
        }
    }

    /// Runs of round `k` over all points of the ordinary axes.
    pub fn round_runs(&self, k: usize) -> usize {
        self.round_samples(k).saturating_mul(self.outer_points)
    }

    /// Every value the ensemble may draw is one the scene (`base`, the sweep's normalised base)
    /// takes: an input error naming the input otherwise ([`inputs::check_reach`]). Checked where
    /// a sweep is read to be run, not each time a file's stored sweep text is read back.
    pub fn check_reach(&self, base: &Value) -> crate::error::Result<()> {
        super::inputs::check_reach(self, base)
    }

    /// The last round the ensemble may run: 0 of a fixed size; of an adaptive one the last
    /// within `max_runs`, whose samples hold every earlier round's.
    pub fn last_round(&self) -> usize {
        match self.max_runs {
            Some(m) => (0..41)
                .take_while(|&k| self.round_runs(k) <= m)
                .last()
                .unwrap_or(0),
            None => 0,
        }
    }

    /// Whether the ensemble grows until its statistics are within their tolerances.
    pub fn adaptive(&self) -> bool {
        self.max_runs.is_some()
    }

    /// The round whose samples are `n` per point, if one is (a file's round from its size).
    pub fn round_of_samples(&self, n: usize) -> Option<usize> {
        (0..41).find(|&k| self.round_samples(k) == n)
    }

    /// The design's points in the unit hypercube in round `k`, and where each lies.
    pub fn unit_points(&self, k: usize) -> (Vec<f64>, Layout) {
        let (n, r) = self.round_size(k);
        let d = self.columns.len();
        let groups: Vec<Range<usize>> = self.inputs.iter().map(|i| i.columns.clone()).collect();
        match self.design {
            Design::Sample(kind) => (
                design::sample(kind, d, n, r, self.seed),
                Layout::Replicates {
                    per: n,
                    replicates: r,
                },
            ),
            Design::Saltelli => (
                design::saltelli(d, &groups, n, self.seed).0,
                Layout::Saltelli { n },
            ),
            Design::Morris { levels } => {
                let (x, steps) = design::morris(d, &groups, n, levels, self.seed);
                (x, Layout::Morris(steps))
            }
        }
    }

    /// The field values of one unit point (`columns.len()` numbers).
    pub fn values(&self, u: &[f64]) -> Vec<f64> {
        let mut u = u.to_vec();
        if let Some((cols, l)) = &self.copula {
            let picked: Vec<f64> = cols.iter().map(|&c| u[c]).collect();
            for (c, v) in cols.iter().zip(correlate(l, &picked)) {
                u[*c] = v;
            }
        }
        let mut out = vec![0.0; u.len()];
        for input in &self.inputs {
            let cols = input.columns.clone();
            match &input.kind {
                InputKind::Independent(dists) => {
                    for (c, d) in cols.zip(dists) {
                        out[c] = d.quantile(clamp_unit(u[c]));
                    }
                }
                InputKind::Tied(d) => {
                    let x = d.quantile(clamp_unit(u[cols.start]));
                    for c in cols {
                        out[c] = x;
                    }
                }
                InputKind::Normal { mean, chol } => {
                    let z: Vec<f64> = cols
                        .clone()
                        .map(|c| normal_quantile(clamp_unit(u[c])))
                        .collect();
                    for ((c, m), x) in cols.zip(mean).zip(lower_times(chol, &z)) {
                        out[c] = m + x;
                    }
                }
            }
        }
        out
    }

    /// The `member` dimension of round `k`: its index axes and one axis per sampled column.
    pub fn dim(&self, k: usize) -> Dim {
        let (u, layout) = self.unit_points(k);
        let d = self.columns.len();
        let rows = u.len() / d.max(1);
        let index = |name: &str, values: Vec<i64>| Axis {
            name: name.to_string(),
            field: String::new(),
            values: values.into_iter().map(Value::from).collect(),
            units: "1".into(),
            origin: "ensemble".into(),
        };
        let mut axes = vec![index("member", (0..rows as i64).collect())];
        match &layout {
            Layout::Replicates { per, .. } => axes.push(index(
                "replicate",
                (0..rows).map(|s| (s / per) as i64).collect(),
            )),
            Layout::Saltelli { n } => {
                axes.push(index("block", (0..rows).map(|s| (s / n) as i64).collect()))
            }
            Layout::Morris(steps) => {
                axes.push(index(
                    "trajectory",
                    steps.iter().map(|s| s.trajectory as i64).collect(),
                ));
                axes.push(index("step", steps.iter().map(|s| s.step as i64).collect()));
            }
        }
        let mut columns: Vec<Vec<Value>> = vec![Vec::with_capacity(rows); d];
        for row in u.chunks(d) {
            for (c, x) in self.values(row).into_iter().enumerate() {
                columns[c].push(Value::from(x));
            }
        }
        let mut values = columns.into_iter();
        for (k, input) in self.inputs.iter().enumerate() {
            for c in input.columns.clone() {
                let col = &self.columns[c];
                axes.push(Axis {
                    name: col.name.clone(),
                    field: col.field.clone(),
                    values: values.next().expect("one list per column"),
                    units: col.units.clone(),
                    origin: format!("ensemble.inputs[{k}]"),
                });
            }
        }
        Dim {
            name: "member".into(),
            axes,
        }
    }

    /// A number for each sample of round `k` that it keeps in every later round: its block
    /// (replicate, Saltelli block, Morris trajectory) plus its place in the block (sample, row,
    /// step). A round doubles the blocks or the samples in each, and keeps the earlier samples
    /// where they were in their block, so that this sum — unlike the sample's index, which grows
    /// with the blocks before it — is the same from round to round: what a stable shard
    /// assignment needs.
    pub fn member_keys(&self, k: usize) -> Vec<usize> {
        match self.layout(k) {
            Layout::Replicates { per, replicates } => {
                (0..per * replicates).map(|m| m / per + m % per).collect()
            }
            Layout::Saltelli { n } => (0..n * (self.inputs.len() + 2))
                .map(|m| m / n + m % n)
                .collect(),
            Layout::Morris(steps) => steps.iter().map(|s| s.trajectory + s.step).collect(),
        }
    }

    /// Where each sample of round `k` lies in the design.
    pub fn layout(&self, k: usize) -> Layout {
        let (n, r) = self.round_size(k);
        match self.design {
            Design::Sample(_) => Layout::Replicates {
                per: n,
                replicates: r,
            },
            Design::Saltelli => Layout::Saltelli { n },
            Design::Morris { levels } => {
                let groups: Vec<Range<usize>> =
                    self.inputs.iter().map(|i| i.columns.clone()).collect();
                Layout::Morris(design::morris(self.columns.len(), &groups, n, levels, self.seed).1)
            }
        }
    }
}
