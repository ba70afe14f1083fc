//! The driver of a sweep's searches: each search's next batch of points asked of its method,
//! their scenes and runs, the values taken back from the stored runs, and the output file's
//! grid, sweep and tables of the searches as they stand.

use std::collections::{HashMap, HashSet};

use chainsweep_solver::Scene;
use serde_json::Value as Json;

use crate::error::Result;
use crate::grid::{multi_index, Grid, Searched};
use crate::identity::{invalid_scene_hash, run_hash_with, RunHash};
use crate::record::RunRecord;
use crate::search::fit::model;
use crate::search::{self, SearchStatus, Value, ITEM_FLAGS, SEARCH_FLAGS};
use crate::store::hdf5::search::{Dims, FieldTable, SearchTables};
use crate::store::RunStore;
use crate::sweep::search::{set_fields, Goal, SearchSpec};
use crate::sweep::{from_ref_at, Axis, Dim, Sweep};
use std::sync::Arc;

use super::{Evaluation, Layout, Search, EVALUATION};

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
pub(super) type Wanted = (std::result::Result<Scene, String>, usize);

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
            if s.outcome.status == SearchStatus::NotFound {
                // The proposer sees only that no evaluation gave a number; the runs say why.
                if let Some(why) = s.evals.iter().find_map(|e| e.no_value.as_deref()) {
                    s.outcome.note = format!("{} (the first: {why})", s.outcome.note);
                }
            }
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
                let (value, residuals, no_value) = match &self.spec.fit {
                    Some(fit) => {
                        let set = &fit.sets[self.data_set(s.outer)];
                        match model::predict(fit, set, &recs) {
                            Ok(p) => {
                                let chi2 = p.eval.residual.iter().map(|r| r * r).sum();
                                (Some(chi2), Some(Arc::new(p.eval)), None)
                            }
                            Err(why) => (None, None, Some(why)),
                        }
                    }
                    None => (self.value(&recs), None, None),
                };
                s.evals.push(Evaluation {
                    stream,
                    x,
                    value,
                    residuals,
                    no_value,
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
            fit: super::super::fit::tables(self, searches, store)?,
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
    if grid.is_empty() {
        return 1e-4;
    }
    let v = grid.point_value(sweep, 0);
    match from_ref_at::<Scene>(&v, "")
        .ok()
        .and_then(|s| s.integrator.adaptive_options().copied())
    {
        Some(o) => (100.0 * o.rtol).sqrt().clamp(1e-6, 1e-2),
        None => 1e-4,
    }
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
