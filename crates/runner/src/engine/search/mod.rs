//! A sweep with a `search`: one search at every point of its outer axes (its axes, but the one its
//! objective is taken across), all advancing together in rounds.
//!
//! A round asks every unfinished search for its next batch of points ([`crate::search::replay`]
//! over its values so far). The points whose runs are stored already are answered at once (a
//! resumed or merged search replays through them); the others run in parallel on the scheduler,
//! each stored as it finishes, like any run of a grid. Then every search takes its values and the
//! next round starts. The points are a function of the sweep file and the values only, so the
//! same command after `kill -9` replays the stored runs and goes on with the same points, and
//! `--jobs` changes nothing but the time.
//!
//! The runs of a search are kept in the work directory's logs (the output file is not the only
//! copy: a search is replayed from them). The output file holds them as a grid of the sweep's
//! axes and one more dimension, `evaluation`, with the search's tables ([`SearchTables`]).
//!
//! The searches' model is here; the driver of their points and runs is `driver`'s, running them
//! in rounds (and publishing, merging) `rounds`', the checks before anything runs `check`'s.

use crate::error::Result;
use crate::grid::multi_index;
use crate::identity::RunHash;
use crate::search::fit::Residuals;
use crate::search::{Item, Outcome, Point, SearchStatus, Value};
#[cfg(doc)]
use crate::store::hdf5::search::SearchTables;
use crate::store::hdf5::Counts;
use crate::store::RunStore;
use crate::sweep::search::SearchSpec;
use crate::sweep::Sweep;

use super::DamageReport;

mod check;
mod driver;
mod rounds;

pub use check::check_intervals;
pub use driver::{reached_runs, Driver};
pub use rounds::{merge_searches, run_search};

/// How a search's runs map to the sweep's own grid.
#[derive(Debug, Clone)]
pub struct Layout {
    /// The sweep's grid shape.
    pub shape: Vec<usize>,
    /// The outer dimensions (indices into the sweep's dimensions): all but the `across` one.
    pub outer_dims: Vec<usize>,
    /// Their shape: one search per point.
    pub outer_shape: Vec<usize>,
    /// The dimension every evaluation runs several points of, and their indices: the `across`
    /// axis's two, or every frequency of a fit's spectra.
    pub across: Option<(usize, Vec<usize>)>,
}

fn flat(shape: &[usize], mi: &[usize]) -> usize {
    mi.iter().zip(shape).fold(0, |acc, (&i, &n)| acc * n + i)
}

impl Layout {
    /// The layout of `sweep`'s search.
    pub fn new(sweep: &Sweep, spec: &SearchSpec) -> Layout {
        let shape = sweep.shape();
        let across = match (&spec.across, spec.fit.as_ref().and_then(|f| f.variant_dim)) {
            (Some(a), _) => Some((a.dim, a.points.to_vec())),
            (None, Some(d)) => Some((d, (0..shape[d]).collect())),
            (None, None) => None,
        };
        let outer_dims: Vec<usize> = (0..shape.len())
            .filter(|&d| Some(d) != across.as_ref().map(|a| a.0))
            .collect();
        let outer_shape = outer_dims.iter().map(|&d| shape[d]).collect();
        Layout {
            shape,
            outer_dims,
            outer_shape,
            across,
        }
    }

    /// Searches (outer points).
    pub fn n_outer(&self) -> usize {
        self.outer_shape.iter().product()
    }

    /// The points of the sweep's grid each evaluation of search `o` runs (one, or the two of
    /// `across`).
    pub fn own_points(&self, o: usize) -> Vec<usize> {
        let mo = multi_index(&self.outer_shape, o);
        let mut mi = vec![0; self.shape.len()];
        for (k, &d) in self.outer_dims.iter().enumerate() {
            mi[d] = mo[k];
        }
        match &self.across {
            None => vec![flat(&self.shape, &mi)],
            Some((d, points)) => points
                .iter()
                .map(|&j| {
                    mi[*d] = j;
                    flat(&self.shape, &mi)
                })
                .collect(),
        }
    }

    /// The search and the run of its evaluations that point `own` of the sweep's grid is
    /// (`None`: a value of the `across` axis no evaluation runs).
    pub fn of_own(&self, own: usize) -> Option<(usize, usize)> {
        let mi = multi_index(&self.shape, own);
        let mo: Vec<usize> = self.outer_dims.iter().map(|&d| mi[d]).collect();
        let o = flat(&self.outer_shape, &mo);
        match &self.across {
            None => Some((o, 0)),
            Some((d, points)) => points.iter().position(|&j| j == mi[*d]).map(|k| (o, k)),
        }
    }
}

/// One evaluation of a search: where, its runs, the objective there.
#[derive(Debug, Clone, PartialEq)]
pub struct Evaluation {
    /// The part of the search that asked for it.
    pub stream: usize,
    /// The searched fields' values.
    pub x: Point,
    /// Its runs (one per point of [`Layout::own_points`]).
    pub hashes: Vec<RunHash>,
    /// The objective (`None`: a run failed or gave no number); a fit's χ².
    pub value: Value,
    /// A fit's residuals (`None` for other goals, or where a run failed).
    pub residuals: Residuals,
    /// Why a fit's runs gave no residuals (a run failed, data beyond its history, a steady
    /// state that did not settle): said in the note of a fit that found no start.
    pub no_value: Option<String>,
    /// The round that proposed it.
    pub round: usize,
}

/// One search: at one outer point.
#[derive(Debug, Clone)]
pub struct Search {
    /// Its outer point.
    pub outer: usize,
    /// Its evaluations, in the order made.
    pub evals: Vec<Evaluation>,
    /// What it has found (final once `finished`).
    pub outcome: Outcome,
    /// Whether it has ended.
    pub finished: bool,
    /// Rounds taken (batches answered).
    rounds: usize,
    /// The batches asked for and being run: (stream, points, their runs).
    waiting: Vec<(usize, Vec<Point>, Vec<Vec<RunHash>>)>,
}

impl Search {
    /// The runs of the round it waits for (a round cut short, or under way): how many of them
    /// `store` holds, and how many there are.
    pub fn round_in_flight(&self, store: &dyn RunStore) -> Result<(usize, usize)> {
        let mut stored = 0;
        let mut total = 0;
        for (_, _, hashes) in &self.waiting {
            for h in hashes.iter().flatten() {
                total += 1;
                stored += store.read(h)?.is_some() as usize;
            }
        }
        Ok((stored, total))
    }

    fn new(outer: usize) -> Search {
        Search {
            outer,
            evals: Vec::new(),
            outcome: Outcome {
                status: SearchStatus::Running,
                items: Vec::new(),
                refine_error: f64::NAN,
                note: String::new(),
                fit: None,
            },
            finished: false,
            rounds: 0,
            waiting: Vec::new(),
        }
    }

    /// Runs used.
    pub fn runs(&self) -> usize {
        self.evals.iter().map(|e| e.hashes.len()).sum()
    }

    /// The known values, per stream, as the methods see them.
    fn known(&self) -> Vec<Vec<Value>> {
        let mut known: Vec<Vec<Value>> = Vec::new();
        for e in &self.evals {
            if known.len() <= e.stream {
                known.resize(e.stream + 1, Vec::new());
            }
            known[e.stream].push(e.value);
        }
        known
    }

    /// A fit's known residuals, per stream.
    fn known_fit(&self) -> Vec<Vec<Residuals>> {
        let mut known: Vec<Vec<Residuals>> = Vec::new();
        for e in &self.evals {
            if known.len() <= e.stream {
                known.resize(e.stream + 1, Vec::new());
            }
            known[e.stream].push(e.residuals.clone());
        }
        known
    }
}

/// The name of the dimension of a search's evaluations.
pub const EVALUATION: &str = "evaluation";

/// What a search sweep did.
#[derive(Debug, Clone)]
pub struct SearchReport {
    /// Every search of this run (or shard), by outer point.
    pub searches: Vec<Search>,
    /// Runs computed by this call.
    pub ran: usize,
    /// Of those, failed.
    pub failed: usize,
    /// Whether it was stopped (by the stop flag) before every search ended.
    pub stopped: bool,
    /// The state of the file's points.
    pub counts: Counts,
    /// Damage found in the output file when it started.
    pub damage: DamageReport,
    /// What `--verify` found: points verified and the largest relative error.
    pub verified: (usize, Option<f64>),
}

/// The outer points of `shard` (all without one): the Latin assignment of the outer grid.
pub fn outer_points(layout: &Layout, shard: Option<crate::grid::Shard>) -> Vec<usize> {
    match shard {
        None => (0..layout.n_outer()).collect(),
        Some(s) => super::shard::latin(&layout.outer_shape, s.n)
            .into_iter()
            .enumerate()
            .filter(|&(_, k)| k + 1 == s.k)
            .map(|(o, _)| o)
            .collect(),
    }
}

/// The outer point `o` by its axis values (`damping_kg_s=6`; empty without outer axes).
pub fn outer_label(sweep: &Sweep, layout: &Layout, o: usize) -> String {
    let mo = multi_index(&layout.outer_shape, o);
    let mut parts = Vec::new();
    for (k, &d) in layout.outer_dims.iter().enumerate() {
        for a in &sweep.dims[d].axes {
            parts.push(format!("{}={}", a.name, a.values[mo[k]]));
        }
    }
    parts.join(" ")
}

/// An item as a report says it: `mass_ratio = 0.57512 ± 4.1e-5 (objective 0.3665, converged)`.
pub fn describe_item(spec: &SearchSpec, it: &Item) -> String {
    let at: Vec<String> = spec
        .fields
        .iter()
        .zip(it.x.iter().zip(&it.uncertainty))
        .map(|(f, (x, u))| format!("{} = {x} ± {u:.2e}", f.name))
        .collect();
    let value = it.value.map_or("no number".to_string(), |v| {
        format!("objective {}", crate::error::number_text(v))
    });
    format!("{} ({value}, {})", at.join(", "), it.status.name())
}
