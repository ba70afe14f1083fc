//! Progress of a sweep that runs in this process, read from its output's work directory.
//!
//! The engine's progress sink hears of runs on the runner's thread, and only once the runs start
//! (after an `integrator: auto` pilot); Python wants the state before anything runs, and reads
//! it on its own thread with the GIL. Every finished run is a segment file
//! `X.h5.d/segments/<run hash>.seg` (written whole, by an atomic rename), so progress is the
//! number of the sweep's runs whose segment exists. This module computes the sweep's run hashes
//! once (the runner's own [`Sweep`], [`Grid`] and [`verify`] code, `integrator: auto` resolved
//! from the runner's cache as soon as the pilot has written it) and then polls the directory,
//! reading the status of each new segment once.

use std::collections::{HashMap, HashSet};
use std::fs::File;
use std::io::Read;
use std::path::PathBuf;
use std::time::SystemTime;

use chainsweep::engine::{shard, slurm};
use chainsweep::grid::{Grid, Shard};
use chainsweep::identity::{hex, RunHash};
use chainsweep::numerics::{auto, verify};
use chainsweep::store::segment::peek_status;
use chainsweep::store::work_dir_of;
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
    /// Runs made since the watch started (distinct run hashes whose segment is new or rewritten).
    pub ran: usize,
}

/// A segment file as last seen: its modification time and, once read, its status.
#[derive(Debug, Clone, Copy)]
struct Seen {
    modified: SystemTime,
    ok: Option<bool>,
}

/// Watches the work directory of one sweep (see the module docs).
pub struct Watch {
    segments: PathBuf,
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
    at_start: HashMap<RunHash, SystemTime>,
    seen: HashMap<RunHash, Seen>,
}

fn parse_hex(name: &str) -> Option<RunHash> {
    let stem = name.strip_suffix(".seg")?;
    if stem.len() != 64 {
        return None;
    }
    let mut out = [0u8; 32];
    for (i, o) in out.iter_mut().enumerate() {
        *o = u8::from_str_radix(stem.get(2 * i..2 * i + 2)?, 16).ok()?;
    }
    Some(out)
}

/// Every segment file in `dir` with its modification time.
fn list(dir: &PathBuf) -> Vec<(RunHash, SystemTime)> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    entries
        .filter_map(|e| {
            let e = e.ok()?;
            let hash = parse_hex(e.file_name().to_str()?)?;
            Some((hash, e.metadata().ok()?.modified().ok()?))
        })
        .collect()
}

fn peek_ok(path: PathBuf) -> Option<bool> {
    let mut head = Vec::new();
    File::open(path)
        .ok()?
        .take(4096)
        .read_to_end(&mut head)
        .ok()?;
    peek_status(&head).map(|(ok, _)| ok)
}

impl Watch {
    /// Starts watching the sweep of `req`, noting the segments that exist already. `None` when the
    /// sweep cannot be read: the runner then reports why, and there is no progress to show.
    pub fn new(req: &SweepRequest) -> Option<Watch> {
        let sweep = Sweep::load(req.file.to_str()?).ok()?;
        let grid = Grid::new(&sweep).ok()?;
        let shard = match &req.shard {
            Some(s) => Some(slurm::parse_shard_env(s, "--shard").ok()?),
            None => None,
        };
        let segments = work_dir_of(&req.output).join("segments");
        let auto_key = sweep.auto.map(|spec| auto::cache_key(&grid, &spec));
        let at_start = list(&segments).into_iter().collect();
        let mut w = Watch {
            segments,
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
        };
        w.resolve();
        Some(w)
    }

    /// Computes the run hashes once they are known (at once, or once `auto` has chosen).
    fn resolve(&mut self) {
        if self.units.is_some() {
            return;
        }
        if let Some(key) = &self.auto_key {
            let Some(dir) = self.segments.parent() else {
                return;
            };
            let Some(choice) = auto::read_cache(dir, key) else {
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

    /// Reads the work directory (the status of new or rewritten segments only) and counts.
    pub fn poll(&mut self) -> Progress {
        self.resolve();
        let Some(units) = &self.units else {
            return Progress {
                total: shard::points(&self.sweep, &self.grid, self.shard).len(),
                ..Progress::default()
            };
        };
        for (hash, modified) in list(&self.segments) {
            if !self.targets.contains(&hash) {
                continue;
            }
            if self.seen.get(&hash).map(|s| s.modified) == Some(modified) {
                continue;
            }
            let path = self.segments.join(format!("{}.seg", hex(&hash)));
            self.seen.insert(
                hash,
                Seen {
                    modified,
                    ok: peek_ok(path),
                },
            );
        }
        let mut p = Progress {
            total: units.len(),
            ..Progress::default()
        };
        for h in units {
            let Some(s) = self.seen.get(h) else { continue };
            let Some(ok) = s.ok else { continue };
            let old = self.at_start.get(h) == Some(&s.modified);
            // With `retry_failed`, a failed run from before counts once it has run again.
            if old && self.retry_failed && !ok {
                continue;
            }
            p.done += 1;
            p.failed += usize::from(!ok);
        }
        p.ran = self
            .seen
            .iter()
            .filter(|(h, s)| s.ok.is_some() && self.at_start.get(*h) != Some(&s.modified))
            .count();
        p
    }
}
