//! Searches: minima, maxima, roots and refined curves of an objective over continuous fields,
//! with a fraction of a grid's runs.
//!
//! Every method here is a pure function of its evaluations. It is written as plain sequential
//! code (a scan, then Brent's method in each bracket, …) that asks for the objective at batches
//! of points through [`Streams::eval`]; the driver (the engine's `chainsweep::engine`) answers from the runs
//! stored so far, and when a batch is not known yet the method returns what it has found so far
//! with the batch as the next proposal. The driver runs the proposals (in parallel, stored as
//! they finish, like any run) and calls the method again from the start: it replays the same
//! steps over the known values and goes one batch further. So the points a search visits depend
//! only on the sweep file and the values found, never on the number of parallel runs, their
//! finishing order, or an interruption: a killed search resumes by replaying its stored runs.
//!
//! A search may split into independent parts (one per bracket of a scan, one per starting point):
//! each part asks through a stream of its own, so that the parts advance together, each a batch
//! per round.
//!
//! - [`line`]: one field: every local minimum (scan, then Brent's method in each bracket), every
//!   crossing of a level (scan, then Brent's root method);
//! - [`refine`]: one or two fields sampled until the interpolation of the objective is accurate;
//! - [`simplex`]: several fields: Nelder–Mead in the box, from the best points of a scan, with
//!   restarts.

pub mod fit;
pub mod line;
pub mod refine;
pub mod simplex;

use crate::sweep::search::{Goal, SearchSpec};

/// A point of the searched space: one value per searched field (field units).
pub type Point = Vec<f64>;

/// The objective at a point; `None` where its run failed or its value is not a number.
pub type Value = Option<f64>;

/// The evaluations a method sees: per stream, the values of the points it asked for, in order,
/// as far as they are known; and the batch each stream asks for next.
pub struct Streams<'a, T = Value> {
    known: &'a [Vec<T>],
    cursor: Vec<usize>,
    asked: Vec<(usize, Vec<Point>)>,
}

impl<'a, T: Clone> Streams<'a, T> {
    /// Streams whose known values are `known[stream]`.
    pub fn new(known: &'a [Vec<T>]) -> Self {
        Streams {
            known,
            cursor: Vec::new(),
            asked: Vec::new(),
        }
    }

    /// The values at `points` through `stream`, when they are known; `None` when they are not:
    /// the points are then the stream's next batch, and the stream must ask for nothing more.
    pub fn eval(&mut self, stream: usize, points: &[Point]) -> Option<Vec<T>> {
        if self.cursor.len() <= stream {
            self.cursor.resize(stream + 1, 0);
        }
        let known = self.known.get(stream).map_or(&[][..], |v| &v[..]);
        let at = self.cursor[stream];
        if at + points.len() <= known.len() {
            self.cursor[stream] = at + points.len();
            return Some(known[at..at + points.len()].to_vec());
        }
        debug_assert_eq!(at, known.len(), "a batch is evaluated whole");
        debug_assert!(
            self.asked.iter().all(|(s, _)| *s != stream),
            "one batch per stream and round"
        );
        self.asked.push((stream, points.to_vec()));
        None
    }

    /// The batches asked for, by stream, in the order asked.
    pub fn asked(&self) -> &[(usize, Vec<Point>)] {
        &self.asked
    }

    /// Consumes the streams into the batches asked for.
    pub fn into_asked(self) -> Vec<(usize, Vec<Point>)> {
        self.asked
    }
}

// How a found item stands, and its codes in the output file: with the file's other status codes
// (a fit's output file is read for them below this module, by an ensemble's `from_fit`).
pub use crate::record::{ItemStatus, ITEM_FLAGS};

/// A found minimum, maximum or root.
#[derive(Debug, Clone, PartialEq)]
pub struct Item {
    /// Where it is (field units).
    pub x: Point,
    /// How far the true one may be from `x`, per field (field units).
    pub uncertainty: Vec<f64>,
    /// The objective at `x` (`None`: no number there).
    pub value: Value,
    /// How it stands.
    pub status: ItemStatus,
}

/// How a search stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SearchStatus {
    /// Not finished: it asks for more points.
    Running,
    /// Finished: every item located within the tolerance (or, refine, the objective
    /// interpolated within its tolerance).
    Converged,
    /// Stopped before a round that would have taken it past its budget of runs.
    Budget,
    /// Finished without finding what it looks for (no crossing of the level, no minimum).
    NotFound,
    /// Finished with an item, or the whole search, stopped by a failed run (`failed: stop`).
    Failed,
    /// Finished, but some item or region could not be resolved to the tolerance (noise, a jump
    /// narrower than the field's tolerance).
    Stalled,
    /// A fit ended at a minimum where the data do not determine some combination of its fields:
    /// not a confident answer.
    Unidentifiable,
}

impl SearchStatus {
    /// Its code in the output file (0: pending, never run).
    pub fn code(self) -> u8 {
        match self {
            SearchStatus::Running => 1,
            SearchStatus::Converged => 2,
            SearchStatus::Budget => 3,
            SearchStatus::NotFound => 4,
            SearchStatus::Failed => 5,
            SearchStatus::Stalled => 6,
            SearchStatus::Unidentifiable => 7,
        }
    }

    /// Its name.
    pub fn name(self) -> &'static str {
        match self {
            SearchStatus::Running => "running",
            SearchStatus::Converged => "converged",
            SearchStatus::Budget => "budget",
            SearchStatus::NotFound => "not_found",
            SearchStatus::Failed => "failed_run",
            SearchStatus::Stalled => "stalled",
            SearchStatus::Unidentifiable => "unidentifiable",
        }
    }
}

/// The codes and names of [`SearchStatus`] (0: pending), for the file's `flag_values`.
pub const SEARCH_FLAGS: (&[u8], &str) = (
    &[0, 1, 2, 3, 4, 5, 6, 7],
    "pending running converged budget not_found failed_run stalled unidentifiable",
);

/// What a search has found so far, or in the end.
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome {
    /// How it stands.
    pub status: SearchStatus,
    /// What it found: minima or maxima (best first for several fields, in field order for
    /// one), roots in field order.
    pub items: Vec<Item>,
    /// Refine: the largest estimated interpolation error (objective units; NaN elsewhere).
    pub refine_error: f64,
    /// Why it ended (or where it stands), in a sentence.
    pub note: String,
    /// A fit's answer: intervals, covariance, profiles (`None` for the other goals).
    pub fit: Option<Box<fit::FitOutcome>>,
}

impl Outcome {
    /// The outcome of a search (or the part of it) that a failed run at `at` stopped
    /// (`failed: stop`).
    pub fn failed_at(spec: &SearchSpec, at: &[f64]) -> Outcome {
        let place: Vec<String> = spec
            .fields
            .iter()
            .zip(at)
            .map(|(f, x)| format!("{} = {x}", f.name))
            .collect();
        Outcome {
            status: SearchStatus::Failed,
            items: Vec::new(),
            refine_error: f64::NAN,
            note: format!(
                "the run at {} failed or gave no number (failed: stop)",
                place.join(", ")
            ),
            fit: None,
        }
    }

    fn running(items: Vec<Item>, refine_error: f64) -> Outcome {
        Outcome {
            status: SearchStatus::Running,
            items,
            refine_error,
            note: String::new(),
            fit: None,
        }
    }

    /// The status the items give a finished search: failed if one failed, stalled if one could
    /// not be resolved, else converged.
    fn finished(items: Vec<Item>, refine_error: f64, note: String) -> Outcome {
        let status = if items.iter().any(|i| i.status == ItemStatus::Failed) {
            SearchStatus::Failed
        } else if items.iter().any(|i| i.status == ItemStatus::Stalled) {
            SearchStatus::Stalled
        } else {
            SearchStatus::Converged
        };
        Outcome {
            status,
            items,
            refine_error,
            note,
            fit: None,
        }
    }

    /// The largest uncertainty of an item relative to its field's tolerance (NaN without items).
    pub fn relative_uncertainty(&self, spec: &SearchSpec) -> f64 {
        let mut m = f64::NAN;
        for it in &self.items {
            for (u, f) in it.uncertainty.iter().zip(&spec.fields) {
                let r = u / f.tolerance;
                if m.is_nan() || r > m {
                    m = r;
                }
            }
        }
        m
    }
}

/// One replay of the search `spec` over the known values `known` (per stream): what it has
/// found, and the batches it asks for next (none when it is finished).
pub fn replay(spec: &SearchSpec, known: &[Vec<Value>]) -> (Outcome, Vec<(usize, Vec<Point>)>) {
    let mut s = Streams::new(known);
    let outcome = match (spec.goal, spec.fields.len()) {
        (Goal::Minimise, 1) => line::extrema(spec, &mut s, 1.0),
        (Goal::Maximise, 1) => line::extrema(spec, &mut s, -1.0),
        (Goal::Minimise, _) => simplex::minimise(spec, &mut s, 1.0),
        (Goal::Maximise, _) => simplex::minimise(spec, &mut s, -1.0),
        (Goal::Root, _) => line::roots(spec, &mut s),
        (Goal::Refine, 1) => refine::curve(spec, &mut s),
        (Goal::Refine, _) => refine::surface(spec, &mut s),
        (Goal::Fit, _) => unreachable!("a fit's evaluations are residuals: see fit::replay"),
    };
    let asked = s.into_asked();
    debug_assert_eq!(outcome.status == SearchStatus::Running, !asked.is_empty());
    (outcome, asked)
}

/// `n` evenly spaced values from `min` to `max`, both included exactly.
pub fn linspace(min: f64, max: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| {
            if i + 1 == n {
                max
            } else {
                min + (max - min) * (i as f64 / (n - 1) as f64)
            }
        })
        .collect()
}

#[cfg(test)]
pub(crate) mod testing {
    //! Searches driven over analytic functions, as the driver drives them over runs.

    use super::*;
    use crate::sweep::search::{Combine, Objective, OnFailure, SearchField, Summary};

    /// A spec over `fields` (name, min, max, tolerance) with everything else at its default.
    pub fn spec(goal: Goal, fields: &[(f64, f64, f64)]) -> SearchSpec {
        SearchSpec {
            goal,
            fields: fields
                .iter()
                .enumerate()
                .map(|(i, &(min, max, tolerance))| SearchField {
                    name: format!("x{i}"),
                    field: format!("f{i}"),
                    min,
                    max,
                    tolerance,
                    units: "1".into(),
                })
                .collect(),
            objective: Objective::Two(
                Combine::Ratio,
                Summary {
                    column: "t_end_s",
                    probe: None,
                },
                Summary {
                    column: "t_end_s",
                    probe: None,
                },
            ),
            across: None,
            level: 0.0,
            objective_tolerance: 1e-3,
            scan: vec![10; fields.len()],
            budget: 10_000,
            round: 4,
            on_failure: match goal {
                Goal::Minimise | Goal::Maximise | Goal::Fit => OnFailure::Worst,
                Goal::Root => OnFailure::Stop,
                Goal::Refine => OnFailure::Gap,
            },
            starts: 2,
            fit: None,
        }
    }

    /// Drives `spec` over `f` until it finishes or would exceed its budget: the outcome, every
    /// point evaluated (in order), and the number of replays.
    pub fn solve(spec: &SearchSpec, f: impl Fn(&[f64]) -> Value) -> (Outcome, Vec<Point>) {
        let mut known: Vec<Vec<Value>> = Vec::new();
        let mut points = Vec::new();
        loop {
            let (mut outcome, asked) = replay(spec, &known);
            if asked.is_empty() {
                return (outcome, points);
            }
            let n: usize = asked.iter().map(|(_, b)| b.len()).sum();
            if points.len() + n > spec.budget {
                outcome.status = SearchStatus::Budget;
                return (outcome, points);
            }
            for (stream, batch) in asked {
                if known.len() <= stream {
                    known.resize(stream + 1, Vec::new());
                }
                for p in batch {
                    known[stream].push(f(&p));
                    points.push(p);
                }
            }
        }
    }
}
