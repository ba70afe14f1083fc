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

use std::collections::{HashMap, HashSet};
use std::sync::atomic::{AtomicBool, Ordering};

use chainsweep_solver::Scene;
use serde_json::Value as Json;

use crate::error::{Error, Result};
use crate::exec;
use crate::grid::{multi_index, Grid, Searched};
use crate::identity::{invalid_scene_hash, run_hash_with, RunHash};
use crate::numerics::verify;
use crate::record::{RunRecord, VERIFY_OK};
use crate::search::fit::{model, Residuals};
use crate::search::{self, Item, Outcome, Point, SearchStatus, Value, ITEM_FLAGS, SEARCH_FLAGS};
use crate::store::hdf5::search::{Dims, FieldTable, SearchTables};
use crate::store::hdf5::Counts;
use crate::store::{RunStore, WorkDir};
use crate::sweep::search::{set_fields, Goal, SearchSpec};
use crate::sweep::{from_ref_at, Axis, Dim, Sweep};
use std::sync::Arc;

use super::assemble::{assemble, Assembly, VerifySource};
use super::run::RunOptions;
use super::schedule::{run_tasks, Coordinator, Executor, Schedule, Task};
use super::{check_output, thread_pool, DamageReport, ProgressSink, Start};

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

/// What drives the searches of a sweep.
pub struct Driver<'a> {
    /// The sweep.
    pub sweep: &'a Sweep,
    /// Its own grid (the searched fields at their base values).
    pub grid: &'a Grid,
    /// Its search.
    pub spec: &'a SearchSpec,
    /// How the searches map to the grid.
    pub layout: Layout,
    /// A fit's relative finite-difference step, sized from the runs' tolerance.
    pub fd_step: f64,
}

/// A run a round needs: its scene (`Err`: why the scene is invalid; it is then stored as a failed
/// run without running) and its point of the sweep's grid.
type Wanted = (std::result::Result<Scene, String>, usize);

impl<'a> Driver<'a> {
    /// The driver of `sweep`'s search (which it must have).
    pub fn new(sweep: &'a Sweep, grid: &'a Grid) -> Driver<'a> {
        let spec = sweep.search.as_ref().expect("a sweep with a search");
        Driver {
            sweep,
            grid,
            spec,
            layout: Layout::new(sweep, spec),
            fd_step: fd_step(sweep, grid),
        }
    }

    /// The data set of search `o` (a fit's: its point of the data-set dimension, or the one).
    pub fn data_set(&self, o: usize) -> usize {
        let Some(d) = self.spec.fit.as_ref().and_then(|f| f.sets_dim) else {
            return 0;
        };
        let mo = multi_index(&self.layout.outer_shape, o);
        self.layout
            .outer_dims
            .iter()
            .position(|&k| k == d)
            .map_or(0, |k| mo[k])
    }

    /// The scene of point `own` of the grid with the searched fields at `x`, and its run hash.
    pub fn scene(&self, own: usize, x: &[f64]) -> (RunHash, std::result::Result<Scene, String>) {
        let mut v: Json = self.grid.point_value(self.sweep, own);
        set_fields(&mut v, &self.spec.fields, x);
        let built = from_ref_at::<Scene>(&v, "").map_err(|e| e.to_string());
        let checked = built.and_then(|scene| match scene.validate() {
            Ok(chain) => {
                let moving = chainsweep_solver::integrates_moving_part_of(&scene, &chain);
                Ok((scene, moving))
            }
            Err(e) => Err(format!("`{}` {}", e.field, e.message)),
        });
        match checked {
            Ok((scene, moving)) => (
                run_hash_with(&scene, self.sweep.limits.energy_drift_max, moving),
                Ok(scene),
            ),
            Err(why) => (
                invalid_scene_hash(&v),
                Err(format!("the scene of this search point is invalid: {why}")),
            ),
        }
    }

    /// The objective of an evaluation from its runs' records (`None` where one is missing,
    /// failed or gives no number).
    fn value(&self, records: &[Option<&RunRecord>]) -> Value {
        let of = |r: &Option<&RunRecord>| r.and_then(|r| self.spec.objective.of(r));
        match &self.spec.across {
            None => of(&records[0]),
            Some(a) => a.combine.apply(of(&records[0]), of(&records[1])),
        }
    }

    /// Advances search `s` as far as the stored runs go: replays it, takes every batch whose
    /// runs are all stored, and stops at the first batch that needs runs (they go to `wanted`,
    /// the batch waits) or when the search ends (at its goal, or before a batch that would take
    /// it past its budget).
    pub fn advance(
        &self,
        s: &mut Search,
        store: &dyn RunStore,
        wanted: &mut HashMap<RunHash, Wanted>,
    ) -> Result<()> {
        if s.finished || !s.waiting.is_empty() {
            return Ok(());
        }
        let own = self.layout.own_points(s.outer);
        loop {
            let (outcome, asked) = match &self.spec.fit {
                Some(fit) => {
                    let set = &fit.sets[self.data_set(s.outer)];
                    search::fit::replay(
                        self.spec,
                        fit,
                        self.fd_step,
                        set.len(),
                        set.nuisances(),
                        &s.known_fit(),
                    )
                }
                None => search::replay(self.spec, &s.known()),
            };
            s.outcome = outcome;
            if asked.is_empty() {
                s.finished = true;
                return Ok(());
            }
            let n: usize = asked.iter().map(|(_, b)| b.len()).sum::<usize>() * own.len();
            if s.runs() + n > self.spec.budget {
                s.outcome.status = SearchStatus::Budget;
                s.outcome.note = format!(
                    "stopped before a round of {n} run(s) that would take it past its budget of {} ({} used)",
                    self.spec.budget,
                    s.runs()
                );
                s.finished = true;
                return Ok(());
            }
            let mut all_stored = true;
            let mut batches = Vec::new();
            for (stream, points) in asked {
                let mut hashes = Vec::new();
                for x in &points {
                    let mut hs = Vec::new();
                    for &p in &own {
                        let (h, scene) = self.scene(p, x);
                        if store.read(&h)?.is_none() {
                            all_stored = false;
                            wanted.entry(h).or_insert((scene, p));
                        }
                        hs.push(h);
                    }
                    hashes.push(hs);
                }
                batches.push((stream, points, hashes));
            }
            s.waiting = batches;
            if !all_stored {
                return Ok(());
            }
            self.absorb(s, store)?;
        }
    }

    /// Takes the values of the batches search `s` waits for, once all their runs are stored
    /// (else it keeps waiting: a round cut short by a stop). They are its next round (counted per
    /// search, so the same whether it ran now or is replayed).
    pub fn absorb(&self, s: &mut Search, store: &dyn RunStore) -> Result<bool> {
        let mut records: HashMap<RunHash, Option<RunRecord>> = HashMap::new();
        for (_, _, hashes) in &s.waiting {
            for h in hashes.iter().flatten() {
                if !records.contains_key(h) {
                    records.insert(*h, store.read(h)?);
                }
            }
        }
        if records.values().any(|r| r.is_none()) {
            return Ok(false);
        }
        let round = s.rounds;
        s.rounds += 1;
        for (stream, points, hashes) in std::mem::take(&mut s.waiting) {
            for (x, hs) in points.into_iter().zip(hashes) {
                let recs: Vec<Option<&RunRecord>> =
                    hs.iter().map(|h| records[h].as_ref()).collect();
                let (value, residuals) = match &self.spec.fit {
                    Some(fit) => {
                        let set = &fit.sets[self.data_set(s.outer)];
                        match model::predict(fit, set, &recs) {
                            Ok(p) => {
                                let chi2 = p.eval.residual.iter().map(|r| r * r).sum();
                                (Some(chi2), Some(Arc::new(p.eval)))
                            }
                            Err(_) => (None, None),
                        }
                    }
                    None => (self.value(&recs), None),
                };
                s.evals.push(Evaluation {
                    stream,
                    x,
                    value,
                    residuals,
                    hashes: hs,
                    round,
                });
            }
        }
        Ok(true)
    }

    /// Every search of `outer` advanced as far as the stored runs go, without running anything
    /// (`status`, `merge`, `gc`).
    pub fn replay_stored(&self, outer: &[usize], store: &dyn RunStore) -> Result<Vec<Search>> {
        let mut searches: Vec<Search> = outer.iter().map(|&o| Search::new(o)).collect();
        let mut wanted = HashMap::new();
        for s in &mut searches {
            self.advance(s, store, &mut wanted)?;
        }
        Ok(searches)
    }

    /// Evaluations per search in the output file: the most any search made (at least one).
    fn evaluations(searches: &[Search]) -> usize {
        searches
            .iter()
            .map(|s| s.evals.len())
            .max()
            .unwrap_or(0)
            .max(1)
    }

    /// The sweep of the output file: the sweep's axes and `evaluation` (0, 1, …).
    pub fn file_sweep(&self, searches: &[Search]) -> Sweep {
        let e = Self::evaluations(searches);
        let mut sweep = self.sweep.clone();
        sweep.dims.push(Dim {
            name: EVALUATION.into(),
            axes: vec![Axis {
                name: EVALUATION.into(),
                field: String::new(),
                values: (0..e as i64).map(Json::from).collect(),
                units: "1".into(),
                origin: "search".into(),
            }],
        });
        sweep
    }

    /// The grid of the output file: point (own point, evaluation) of the sweep's grid with the
    /// searched fields set; its run hash where a search made that evaluation (zero elsewhere).
    pub fn file_grid(&self, searches: &[Search]) -> Grid {
        let e = Self::evaluations(searches);
        let by_outer: HashMap<usize, &Search> = searches.iter().map(|s| (s.outer, s)).collect();
        let n_own = self.grid.len();
        let mut grid = self.grid.clone();
        grid.shape.push(e);
        grid.hashes = vec![[0; 32]; n_own * e];
        grid.particles = Vec::with_capacity(n_own * e);
        let mut points = Vec::with_capacity(n_own * e);
        for own in 0..n_own {
            let run = self.layout.of_own(own);
            for k in 0..e {
                grid.particles.push(self.grid.particles[own]);
                let eval = run.and_then(|(o, j)| {
                    by_outer
                        .get(&o)
                        .and_then(|s| s.evals.get(k))
                        .map(|ev| (ev, j))
                });
                match eval {
                    Some((ev, j)) => {
                        grid.hashes[own * e + k] = ev.hashes[j];
                        points.push((own, ev.x.clone()));
                    }
                    None => points.push((own, Vec::new())),
                }
            }
        }
        // A searched history interval differs between evaluations: no one time axis then.
        if self
            .spec
            .fields
            .iter()
            .any(|f| f.field == "record.history_interval_s")
        {
            grid.history_interval_s = None;
        }
        grid.searched = Some(Searched {
            fields: self.spec.fields.iter().map(|f| f.field.clone()).collect(),
            names: self.spec.fields.iter().map(|f| f.name.clone()).collect(),
            points,
        });
        grid
    }

    /// The search's tables for the output file (a fit's prediction read from `store`).
    pub fn tables(&self, searches: &[Search], store: &dyn RunStore) -> Result<SearchTables> {
        let e = Self::evaluations(searches);
        let n = self.layout.n_outer();
        let spec = self.spec;
        let by_outer: HashMap<usize, &Search> = searches.iter().map(|s| (s.outer, s)).collect();
        let items = match spec.goal {
            Goal::Refine => 0,
            _ => searches
                .iter()
                .map(|s| s.outcome.items.len())
                .max()
                .unwrap_or(0)
                .max(1),
        };
        let mut fields: Vec<FieldTable> = spec
            .fields
            .iter()
            .map(|f| FieldTable {
                name: f.name.clone(),
                field: f.field.clone(),
                units: f.units.clone(),
                values: vec![f64::NAN; n * e],
                item: vec![f64::NAN; n * items],
                item_uncertainty: vec![f64::NAN; n * items],
            })
            .collect();
        let mut objective = vec![f64::NAN; n * e];
        let mut round = vec![-1i64; n * e];
        let mut status = vec![0u8; n];
        let mut runs = vec![-1i64; n];
        let mut reason = vec![String::new(); n];
        let mut refine_error = vec![f64::NAN; n];
        let mut item_value = vec![f64::NAN; n * items];
        let mut item_status = vec![0u8; n * items];
        for o in 0..n {
            let Some(s) = by_outer.get(&o) else {
                continue;
            };
            for (k, ev) in s.evals.iter().enumerate() {
                for (i, f) in fields.iter_mut().enumerate() {
                    f.values[o * e + k] = ev.x[i];
                }
                objective[o * e + k] = ev.value.unwrap_or(f64::NAN);
                round[o * e + k] = ev.round as i64;
            }
            status[o] = s.outcome.status.code();
            runs[o] = s.runs() as i64;
            reason[o] = s.outcome.note.clone();
            refine_error[o] = s.outcome.refine_error;
            for (k, it) in s.outcome.items.iter().enumerate().take(items) {
                for (i, f) in fields.iter_mut().enumerate() {
                    f.item[o * items + k] = it.x[i];
                    f.item_uncertainty[o * items + k] = it.uncertainty[i];
                }
                item_value[o * items + k] = it.value.unwrap_or(f64::NAN);
                item_status[o * items + k] = it.status.code();
            }
        }
        let outer = Dims {
            dims: self
                .layout
                .outer_dims
                .iter()
                .map(|&d| (self.sweep.dims[d].name.clone(), self.sweep.dims[d].len()))
                .collect(),
        };
        let objective_name = match &spec.across {
            Some(a) => format!(
                "{} of ({}) at {} = points {} and {}",
                a.combine.name(),
                spec.objective.describe(),
                self.sweep.dims[a.dim].name,
                a.points[0],
                a.points[1]
            ),
            None => spec.objective.describe(),
        };
        let objective_units = spec.objective.units(&self.grid.probes);
        let objective_units = match &spec.across {
            Some(a) => a.combine.units(objective_units, objective_units),
            None => objective_units,
        };
        Ok(SearchTables {
            fit: super::fit::tables(self, searches, store)?,
            description: spec.describe(),
            goal: spec.goal.name().into(),
            outer,
            evaluations: e,
            fields,
            objective_name,
            objective_units,
            objective,
            round,
            status,
            runs,
            reason,
            refine_error: (spec.goal == Goal::Refine).then_some(refine_error),
            items: (items > 0).then(|| (spec.goal.item().to_string(), items)),
            item_value,
            item_status,
            flags: [SEARCH_FLAGS, ITEM_FLAGS],
        })
    }
}

/// A fit's relative finite-difference step: the square root of a hundred times the runs'
/// relative tolerance, so that the runs' error (about `rtol`) is a hundredth of the difference
/// at most while the step's own truncation stays near `√rtol` (fixed-step methods, whose error
/// changes smoothly with the fields: 1e-4).
fn fd_step(sweep: &Sweep, grid: &Grid) -> f64 {
    use chainsweep_solver::IntegratorSpec as I;
    if grid.is_empty() {
        return 1e-4;
    }
    let v = grid.point_value(sweep, 0);
    match from_ref_at::<Scene>(&v, "").map(|s| s.integrator) {
        Ok(I::Dop853(o) | I::Ros34pw2(o) | I::Vern6(o)) => {
            (100.0 * o.rtol).sqrt().clamp(1e-6, 1e-2)
        }
        _ => 1e-4,
    }
}

/// The name of the dimension of a search's evaluations.
pub const EVALUATION: &str = "evaluation";

/// Runs the scenes of a round.
struct SceneExecutor<'a> {
    scenes: &'a HashMap<RunHash, (Scene, usize)>,
    limits: &'a crate::sweep::Limits,
}

impl Executor for SceneExecutor<'_> {
    fn execute(&self, task: &Task) -> RunRecord {
        let (scene, own) = &self.scenes[&task.hash];
        exec::execute(scene, task.hash, self.limits, *own)
    }
}

/// The scheduler's coordinator during a round: progress, and checkpoints of the output file.
struct Round<'a, 'b> {
    sink: &'a mut dyn ProgressSink,
    ran: usize,
    failed: usize,
    publish: &'b mut dyn FnMut() -> Result<()>,
}

impl Coordinator for Round<'_, '_> {
    fn finished(&mut self, _task: &Task, ok: bool) {
        self.ran += 1;
        self.failed += usize::from(!ok);
        self.sink.run_finished(!ok);
    }
    fn idle(&mut self) {
        self.sink.idle();
    }
    fn checkpoint(&mut self) -> Result<()> {
        (self.publish)()?;
        self.sink.checkpoint();
        Ok(())
    }
    fn stopping(&mut self, in_flight: usize) -> Result<()> {
        self.sink.stopping(in_flight);
        Ok(())
    }
    fn checkpoint_failed(&mut self, error: &Error, in_flight: usize) {
        self.sink.checkpoint_failed(&format!(
            "writing the output file failed: {error}. The sweep stops now: no new run starts, {in_flight} run(s) in flight (at most) finish; every finished run stays stored."
        ));
    }
    fn ended(&mut self) {}
}

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

/// Runs (or resumes) the searches of `sweep` (of `opts.shard`'s outer points) into
/// `opts.output`.
pub fn run_search(
    sweep: &mut Sweep,
    grid: &mut Grid,
    opts: &RunOptions,
    sink: &mut dyn ProgressSink,
    stop: &AtomicBool,
) -> Result<SearchReport> {
    check_output(&opts.output, opts.overwrite)?;
    let pool = thread_pool(opts.jobs)?;
    let origin = super::auto::resolve(
        sweep,
        grid,
        Some(&crate::store::work_dir_of(&opts.output)),
        &pool,
        sink,
    )?;
    let work = WorkDir::open(&opts.output, None)?;
    if origin == super::auto::AutoOrigin::Pilot {
        super::auto::cache(&work, sweep)?;
    }
    let damage = DamageReport::new(&opts.output, &work.damage(), sweep, grid);
    if damage.any() {
        sink.damage_found(&damage);
    }
    let driver = Driver::new(sweep, grid);
    let outer = outer_points(&driver.layout, opts.shard);
    let mut searches = driver.replay_stored(&outer, &work)?;
    let done_before: usize = searches.iter().map(|s| s.runs()).sum();
    // (What they wait for is asked again by the next round of runs.)
    for s in &mut searches {
        s.waiting.clear();
    }
    let most: usize = driver.spec.budget * outer.len();
    sink.started(&Start {
        total: most,
        done: done_before,
        failed: 0,
        points: outer.len(),
        resumed_points: searches.iter().filter(|s| s.finished).count(),
        output: &opts.output,
    });
    let mut ran = 0;
    let mut failed = 0;
    loop {
        let mut wanted: HashMap<RunHash, Wanted> = HashMap::new();
        for s in &mut searches {
            driver.advance(s, &work, &mut wanted)?;
        }
        if wanted.is_empty() || stop.load(Ordering::Relaxed) {
            break;
        }
        // Invalid scenes are failed runs at once; the others run.
        let mut scenes: HashMap<RunHash, (Scene, usize)> = HashMap::new();
        for (h, (scene, own)) in wanted {
            match scene {
                Ok(scene) => {
                    scenes.insert(h, (scene, own));
                }
                Err(why) => work.write(&RunRecord::failed(h, why, 0.0))?,
            }
        }
        let mut tasks: Vec<Task> = scenes
            .iter()
            .map(|(&hash, &(_, own))| Task {
                point: own,
                hash,
                verification: false,
            })
            .collect();
        tasks.sort_by_key(|t| (t.point, t.hash));
        let executor = SceneExecutor {
            scenes: &scenes,
            limits: &sweep.limits,
        };
        let schedule = Schedule {
            pool: &pool,
            checkpoint_every: opts.checkpoint_interval,
            stop,
        };
        {
            let snapshot = &searches;
            let mut publish = || -> Result<()> {
                publish_searches(&work, &driver, snapshot, opts, &VerifySource::empty(0.0))
                    .map(|_| ())
            };
            let mut coordinator = Round {
                sink: &mut *sink,
                ran: 0,
                failed: 0,
                publish: &mut publish,
            };
            run_tasks(&tasks, &executor, &work, &schedule, &mut coordinator)?;
            ran += coordinator.ran;
            failed += coordinator.failed;
        }
        for s in &mut searches {
            if !s.waiting.is_empty() {
                driver.absorb(s, &work)?;
            }
        }
    }
    sink.runs_ended();
    let stopped = stop.load(Ordering::Relaxed) && searches.iter().any(|s| !s.finished);
    // --verify: a sample of the evaluations' points, run at a tighter setting.
    let file_grid = driver.file_grid(&searches);
    let mut vsrc = VerifySource::empty(opts.verify_fraction);
    let mut verified = (0, None);
    if opts.verify_fraction > 0.0 && !stopped {
        // (The file grid's points name their point of the sweep's own grid: their scenes are
        // built from the sweep itself, not from the file's, which has `evaluation` beside.)
        verified = verify_searches(
            &work,
            driver.sweep,
            &file_grid,
            opts,
            &pool,
            sink,
            stop,
            &mut vsrc,
            &mut ran,
        )?;
    }
    let counts = publish_searches(&work, &driver, &searches, opts, &vsrc)?;
    if searches.iter().all(|s| s.finished) && !stopped {
        // Every search has ended and the file holds its runs: the logs beside it (one per
        // process that took part, interrupted ones included) shrink to what it lacks.
        work.compact_after_publish(&file_grid)?;
    }
    Ok(SearchReport {
        searches,
        ran,
        failed,
        stopped,
        counts,
        damage,
        verified,
    })
}

/// Runs the verification runs of the `--verify` sample of the file's points; the number
/// verified and the largest relative error.
#[allow(clippy::too_many_arguments)]
fn verify_searches(
    work: &WorkDir,
    sweep: &Sweep,
    grid: &Grid,
    opts: &RunOptions,
    pool: &rayon::ThreadPool,
    sink: &mut dyn ProgressSink,
    stop: &AtomicBool,
    vsrc: &mut VerifySource,
    ran: &mut usize,
) -> Result<(usize, Option<f64>)> {
    let sampled = verify::sample(grid, opts.verify_fraction);
    let mut tasks = Vec::new();
    let mut scenes: HashMap<RunHash, (Scene, usize)> = HashMap::new();
    for i in (0..grid.len()).filter(|&i| sampled[i] && grid.hashes[i] != [0; 32]) {
        // A failed run (an invalid scene among them: it has no scene to tighten) is not verified.
        if !work.read(&grid.hashes[i])?.is_some_and(|r| r.ok) {
            continue;
        }
        let (tight, vh) = verify::point_verification(sweep, grid, i);
        vsrc.insert(i, &tight, vh);
        if work.read(&vh)?.is_some() {
            vsrc.done.insert(vh, true);
            continue;
        }
        if scenes.insert(vh, (tight, i)).is_none() {
            tasks.push(Task {
                point: i,
                hash: vh,
                verification: true,
            });
        }
    }
    struct Tight<'a>(
        &'a HashMap<RunHash, (Scene, usize)>,
        &'a crate::sweep::Limits,
    );
    impl Executor for Tight<'_> {
        fn execute(&self, task: &Task) -> RunRecord {
            exec::execute_verification(&self.0[&task.hash].0, task.hash, self.1)
        }
    }
    let schedule = Schedule {
        pool,
        checkpoint_every: std::time::Duration::ZERO,
        stop,
    };
    let mut nothing = || Ok(());
    let mut coordinator = Round {
        sink: &mut *sink,
        ran: 0,
        failed: 0,
        publish: &mut nothing,
    };
    run_tasks(
        &tasks,
        &Tight(&scenes, &sweep.limits),
        work,
        &schedule,
        &mut coordinator,
    )?;
    *ran += coordinator.ran;
    let mut worst: Option<f64> = None;
    let mut n = 0;
    for (&i, vh) in &vsrc.hashes.clone() {
        let Some(tight) = work.read(vh)? else {
            continue;
        };
        vsrc.done.insert(*vh, tight.ok);
        let Some(rec) = work.read(&grid.hashes[i])? else {
            continue;
        };
        let info = verify::compare(&rec, Some(&tight), grid.probes.len(), vsrc.allowances[&i]);
        if info.status == VERIFY_OK {
            n += 1;
            let e = info.max_error();
            if !e.is_nan() && worst.map_or(true, |w| e > w) {
                worst = Some(e);
            }
        }
    }
    Ok((n, worst))
}

/// Writes and publishes the output file of the searches as they stand.
fn publish_searches(
    work: &WorkDir,
    driver: &Driver<'_>,
    searches: &[Search],
    opts: &RunOptions,
    vsrc: &VerifySource,
) -> Result<Counts> {
    publish_as(work, driver, searches, opts.shard, &opts.provenance, vsrc)
}

/// [`publish_searches`] with the file's shard and provenance.
fn publish_as(
    work: &WorkDir,
    driver: &Driver<'_>,
    searches: &[Search],
    shard: Option<crate::grid::Shard>,
    provenance: &crate::store::hdf5::Provenance,
    vsrc: &VerifySource,
) -> Result<Counts> {
    let grid = driver.file_grid(searches);
    let sweep = driver.file_sweep(searches);
    let tables = driver.tables(searches, work)?;
    let points: Vec<usize> = (0..grid.len())
        .filter(|&i| grid.hashes[i] != [0; 32])
        .collect();
    let index = work.index()?;
    let done: HashMap<RunHash, bool> = points
        .iter()
        .filter_map(|&i| {
            let h = grid.hashes[i];
            index.get(&h).map(|&ok| (h, ok))
        })
        .collect();
    assemble(
        work,
        &Assembly {
            sweep: &sweep,
            grid: &grid,
            points: &points,
            shard,
            done: &done,
            provenance,
            verify: vsrc,
            search: Some(&tables),
        },
    )
    .map(|written| written.counts)
}

/// `merge` of the shard files of a sweep with a search: every run they give back is taken into
/// the output's work directory, and every search is replayed through them (nothing runs): those
/// whose shard is missing or stopped early stay unfinished. The searches, the merged file's
/// counts, and the damage found in the shard files.
pub fn merge_searches(
    work: &WorkDir,
    sweep: &Sweep,
    grid: &Grid,
    shards: &[std::path::PathBuf],
    provenance: &crate::store::hdf5::Provenance,
) -> Result<(Vec<Search>, Counts, Vec<DamageReport>)> {
    use crate::store::published::{Check, PublishedFile};
    let mut damage = Vec::new();
    for path in shards {
        let Some(p) = PublishedFile::open(path, None, Check::Everything) else {
            return Err(Error::Other(format!("{}: cannot be read", path.display())));
        };
        let d = DamageReport::new(path, &p.damage, sweep, grid);
        if d.any() {
            damage.push(d);
        }
        let hashes: Vec<RunHash> = p.runs().map(|(h, _, _)| *h).collect();
        for h in hashes {
            if work.read(&h)?.is_none() {
                if let Some(rec) = p.read(&h) {
                    work.write(&rec)?;
                }
            }
        }
    }
    let driver = Driver::new(sweep, grid);
    let outer: Vec<usize> = (0..driver.layout.n_outer()).collect();
    let searches = driver.replay_stored(&outer, work)?;
    let counts = publish_as(
        work,
        &driver,
        &searches,
        None,
        provenance,
        &VerifySource::empty(0.0),
    )?;
    Ok((searches, counts, damage))
}

/// Every run the searches of `outer` reach by replay through the stored runs (`gc` keeps them).
pub fn reached_runs(
    driver: &Driver<'_>,
    outer: &[usize],
    store: &dyn RunStore,
) -> Result<HashSet<RunHash>> {
    let searches = driver.replay_stored(outer, store)?;
    Ok(searches
        .iter()
        .flat_map(|s| {
            s.evals.iter().flat_map(|e| e.hashes.iter().copied()).chain(
                s.waiting
                    .iter()
                    .flat_map(|(_, _, hs)| hs.iter().flatten().copied()),
            )
        })
        .collect())
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

/// A fit's recorded signals lie within the runs: every data instant, moved by any time shift the
/// fit may take, is within `[0, duration_s]` of every point's scene (an input error naming the
/// signal's instants otherwise, before anything runs).
fn check_data_within_runs(
    driver: &Driver<'_>,
    fit: &crate::sweep::fit::FitSpec,
    middle: &[f64],
) -> Result<()> {
    use crate::sweep::fit::Datum;
    for own in 0..driver.grid.len() {
        let Some((o, _)) = driver.layout.of_own(own) else {
            continue;
        };
        let k = driver.data_set(o);
        let (_, Ok(scene)) = driver.scene(own, middle) else {
            continue;
        };
        let set = &fit.sets[k];
        for (i, d) in set.data.iter().enumerate() {
            let Datum::Signal(s) = d else { continue };
            let (smin, smax) = s.shift.map_or((0.0, 0.0), |iv| (iv.min, iv.max));
            let first = s.time_s[0] + smin;
            let last = s.time_s[s.time_s.len() - 1] + smax;
            if first < 0.0 || last > scene.duration_s {
                let at = match fit.sets_dim {
                    Some(_) => format!("search.data_sets[{k}][{i}].signal.time_s"),
                    None => format!("search.data[{i}].signal.time_s"),
                };
                let label = driver.grid.point_label(driver.sweep, own);
                return Err(Error::input(
                    at,
                    format!(
                        "the data instants{} reach {first} to {last} s, beyond the runs (0 to duration_s = {} s{}): lengthen duration_s, or narrow the data or their time_shift_s",
                        if s.shift.is_some() { ", moved by any time shift allowed," } else { "" },
                        scene.duration_s,
                        if label.is_empty() { String::new() } else { format!(" at {label}") }
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Every searched interval is one the scene takes at both ends, at every point of the sweep's
/// grid (each field at each of its ends, the others in the middle of theirs): an end the scene
/// refuses (a negative mass) is an input error naming it, caught before anything runs rather than
/// as failed runs that a search might take for an answer. (Nothing to check without a search.)
pub fn check_intervals(sweep: &Sweep, grid: &Grid) -> Result<()> {
    let Some(spec) = &sweep.search else {
        return Ok(());
    };
    let driver = Driver::new(sweep, grid);
    let middle: Vec<f64> = spec.fields.iter().map(|f| 0.5 * (f.min + f.max)).collect();
    if let Some(fit) = &spec.fit {
        check_data_within_runs(&driver, fit, &middle)?;
    }
    for own in 0..grid.len() {
        for (k, f) in spec.fields.iter().enumerate() {
            for (x, end) in [(f.min, "min"), (f.max, "max")] {
                let mut at = middle.clone();
                at[k] = x;
                if let (_, Err(why)) = driver.scene(own, &at) {
                    let label = grid.point_label(sweep, own);
                    let place = if label.is_empty() {
                        String::new()
                    } else {
                        format!(" at {label}")
                    };
                    return Err(Error::input(
                        format!("search.fields[{k}].{end}"),
                        format!(
                            "the scene refuses {} = {x}{place} ({}): a searched interval must hold only values the scene takes",
                            f.name,
                            why.trim_start_matches("the scene of this search point is invalid: ")
                        ),
                    ));
                }
            }
        }
    }
    Ok(())
}
