//! Progress of a sweep that runs in this process, read from its output's work directory.
//!
//! The engine's progress sink hears of runs on the runner's thread, and only once the runs start
//! (after an `integrator: auto` pilot); Python wants the state before anything runs, and reads
//! it on its own thread with the GIL. Every finished run is a checksummed record appended to a
//! log `X.h5.d/logs/<n>.log`, and a complete sweep's runs end up in the output file itself (its
//! logs compacted), so progress is the number of the sweep's runs stored in either. This module computes the sweep's run hashes
//! once (the runner's own [`Sweep`], [`Grid`] and [`verify`] code, `integrator: auto` resolved
//! from the runner's cache as soon as the pilot has written it) and then polls the logs,
//! reading each new record once (from where the last poll stopped), and the output file's
//! status column when it was published again.

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::time::SystemTime;

use chainsweep::engine::{shard, slurm};
use chainsweep::grid::{Grid, Shard};
use chainsweep::identity::RunHash;
use chainsweep::numerics::{auto, verify};
use chainsweep::store::log::{self, log_seq, LOG_DIR};
use chainsweep::store::published::Check;
use chainsweep::store::{published_runs, work_dir_of, Stored};
use chainsweep::sweep::Sweep;

use crate::sweep::SweepRequest;

/// Counts of a sweep's runs.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Progress {
    /// Grid points and verification runs finished (ok or failed).
    pub done: usize,
    /// Of those, the failed ones.
    pub failed: usize,
    /// Grid points of the shard and its sampled verification runs.
    pub total: usize,
}

/// Watches the work directory of one sweep (see the module docs).
pub struct Watch {
    /// The output's work directory.
    dir: PathBuf,
    /// The output file.
    output: PathBuf,
    sweep: Sweep,
    grid: Grid,
    shard: Option<Shard>,
    fraction: f64,
    retry_failed: bool,
    /// The cache key of an `integrator: auto` sweep not resolved yet.
    auto_key: Option<String>,
    /// What the sweep finishes, one entry per grid point of the shard and per verification run;
    /// `None` while `auto` is unresolved (the run hashes are not known yet).
    units: Option<Vec<RunHash>>,
    targets: HashSet<RunHash>,
    /// What was stored when the watch started.
    at_start: HashMap<RunHash, bool>,
    /// Runs of the sweep stored since, and their status.
    seen: HashMap<RunHash, bool>,
    /// How far each log was read.
    read_to: HashMap<PathBuf, u64>,
    /// When the output file was last read.
    published: Option<SystemTime>,
}

impl Watch {
    /// Starts watching the sweep of `req`, noting the segments that exist already. `None` when the
    /// sweep cannot be read: the runner then reports why, and there is no progress to show.
    pub fn new(req: &SweepRequest) -> Option<Watch> {
        let sweep = Sweep::load(req.file.to_str()?).ok()?;
        // A search's runs are not known before they are proposed: no count of them to show.
        if sweep.search.is_some() {
            return None;
        }
        let grid = Grid::new(&sweep).ok()?;
        let shard = match &req.shard {
            Some(s) => Some(slurm::parse_shard_env(s, "--shard").ok()?),
            None => None,
        };
        let dir = work_dir_of(&req.output);
        let auto_key = sweep.auto.map(|spec| auto::cache_key(&grid, &spec));
        let at_start = Stored::scan(&dir, Some(&req.output), Some(&grid), Check::Summaries)
            .map(|s| s.index())
            .unwrap_or_default();
        let mut w = Watch {
            dir,
            output: req.output.clone(),
            sweep,
            grid,
            shard,
            fraction: req.verify.unwrap_or(0.0).clamp(0.0, 1.0),
            retry_failed: req.retry_failed,
            auto_key,
            units: None,
            targets: HashSet::new(),
            at_start,
            seen: HashMap::new(),
            read_to: HashMap::new(),
            published: None,
        };
        // Records there at the start are not new.
        for (path, _) in w.logs() {
            if let Ok(end) = log::scan(&path, 0, |_| {}) {
                w.read_to.insert(path, end.end);
            }
        }
        w.published = modified(&w.output);
        w.resolve();
        Some(w)
    }

    /// Computes the run hashes once they are known (at once, or once `auto` has chosen).
    fn resolve(&mut self) {
        if self.units.is_some() {
            return;
        }
        if let Some(key) = &self.auto_key {
            let Some(choice) = auto::read_cache(&self.dir, key) else {
                return;
            };
            self.sweep.apply_auto(choice);
            match Grid::new(&self.sweep) {
                Ok(g) => self.grid = g,
                Err(_) => return,
            }
        }
        let points = shard::points(&self.sweep, &self.grid, self.shard);
        let chosen = verify::sample(&self.grid, self.fraction);
        let mut units: Vec<RunHash> = points.iter().map(|&i| self.grid.hashes[i]).collect();
        let mut verifications = HashSet::new();
        for &i in points.iter().filter(|&&i| chosen[i]) {
            let (_, vh) = verify::point_verification(&self.sweep, &self.grid, i);
            if verifications.insert(vh) {
                units.push(vh);
            }
        }
        self.targets = units.iter().copied().collect();
        self.units = Some(units);
    }

    /// The logs of the work directory (regular files named like logs), oldest first.
    fn logs(&self) -> Vec<(PathBuf, u64)> {
        let Ok(entries) = std::fs::read_dir(self.dir.join(LOG_DIR)) else {
            return Vec::new();
        };
        let mut logs: Vec<(PathBuf, u64)> = entries
            .filter_map(|e| {
                let e = e.ok()?;
                let seq = log_seq(e.file_name().to_str()?)?;
                e.file_type().ok()?.is_file().then(|| (e.path(), seq))
            })
            .collect();
        logs.sort_by_key(|(_, seq)| *seq);
        logs
    }

    /// Notes a stored run of the sweep (new, or stored again since the start).
    fn note(&mut self, hash: RunHash, ok: bool, from_file: bool) {
        if !self.targets.contains(&hash) {
            return;
        }
        // The output file holds runs stored before the start too: only changes are new.
        if from_file && self.at_start.get(&hash) == Some(&ok) {
            return;
        }
        self.seen.insert(hash, ok);
    }

    /// Reads what was stored since the last poll (new log records; the output file when it
    /// was published again) and counts.
    pub fn poll(&mut self) -> Progress {
        self.resolve();
        let Some(units) = self.units.clone() else {
            return Progress {
                total: shard::points(&self.sweep, &self.grid, self.shard).len(),
                ..Progress::default()
            };
        };
        for (path, _) in self.logs() {
            let from = self.read_to.get(&path).copied().unwrap_or(0);
            let mut found = Vec::new();
            if let Ok(end) = log::scan(&path, from, |f| found.push((f.hash, f.ok))) {
                self.read_to.insert(path, end.end);
            }
            for (h, ok) in found {
                self.note(h, ok, false);
            }
        }
        let now = modified(&self.output);
        if now.is_some() && now != self.published {
            self.published = now;
            for (h, ok) in published_runs(&self.output) {
                self.note(h, ok, true);
            }
        }
        let units = &units;
        let mut p = Progress {
            total: units.len(),
            ..Progress::default()
        };
        for h in units {
            let ok = match (self.seen.get(h), self.at_start.get(h)) {
                (Some(&ok), _) => ok,
                // With `retry_failed`, a failed run from before counts once it has run again.
                (None, Some(&ok)) if ok || !self.retry_failed => ok,
                _ => continue,
            };
            p.done += 1;
            p.failed += usize::from(!ok);
        }
        p
    }
}

/// When `path` was last modified; `None` when it does not exist.
fn modified(path: &Path) -> Option<SystemTime> {
    std::fs::metadata(path).and_then(|m| m.modified()).ok()
}
