//! The published output file as a store of runs: `X.h5` read back and checked point by point,
//! with its snapshot (`X.h5.d/snapshot`, see [`crate::snapshot`]) giving back what damage took.
//!
//! Every run the file holds is either served as stored (its values match their checksums), or
//! restored from the snapshot (its summaries; its histories from the file where they match the
//! snapshot's checksum of them), or reported as damaged ([`Damage`]): it is then missing, and
//! `run` computes it again. A file that cannot be read at all is reported too, with what the
//! snapshot gives back of it; nothing is recomputed without a word.

use std::collections::HashMap;
use std::path::Path;

use crate::hdf5::{self, read::PointRead, FileRecords};
use crate::snapshot::{self, Snapshot, SNAPSHOT_FILE};
use crate::work_dir_of;
use chainsweep_sweep::grid::Grid;
use chainsweep_sweep::identity::{from_hex, RunHash};
use chainsweep_sweep::record::{holds_values, RunRecord, STATUS_PENDING};
use chainsweep_sweep::sweep::auto::AutoChoice;
use chainsweep_sweep::sweep::Sweep;

/// A point of the published file that cannot be read back: it is computed again.
#[derive(Debug, Clone, PartialEq)]
pub struct DamagedRun {
    /// Its point in the file's grid.
    pub point: usize,
    /// Its run hash, where known (the grid's at that point).
    pub hash: Option<RunHash>,
    /// Why it cannot be read back.
    pub why: String,
}

/// What damage was found in a published output file and its snapshot.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Damage {
    /// Why the file cannot be read at all (`None`: it can).
    pub file: Option<String>,
    /// What is wrong with its header (sweep, shard, shape; its points may be sound).
    pub header: Option<String>,
    /// Points that cannot be read back and that the snapshot does not give back.
    pub lost: Vec<DamagedRun>,
    /// Damaged runs whose values the snapshot gave back (nothing lost), with what was damaged.
    pub restored: Vec<DamagedRun>,
    /// Why the snapshot cannot be used, or how many of its blocks are damaged.
    pub snapshot: Option<String>,
}

impl Damage {
    /// Whether anything was found damaged.
    pub fn any(&self) -> bool {
        self.file.is_some()
            || self.header.is_some()
            || !self.lost.is_empty()
            || !self.restored.is_empty()
            || self.snapshot.is_some()
    }
}

/// How much of a published file to check when it is opened.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Check {
    /// Every stored value, run groups (histories) included: what resume, `merge` and `status`
    /// do before they trust a run.
    Everything,
    /// The summaries only (a progress display that polls the file).
    Summaries,
}

/// Where a run of the published file is read from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Source {
    /// The file, as stored.
    File,
    /// The snapshot (summaries), with the run group from the file where it has one.
    Snapshot,
}

/// The published output file as a store of runs, by hash.
pub struct PublishedFile {
    recs: Option<FileRecords>,
    snapshot: Option<Snapshot>,
    /// The file's grid (the one its points index).
    grid: Option<Grid>,
    points: HashMap<RunHash, (usize, bool, Source)>,
    /// Whether the file's bytes are exactly those published with its snapshot.
    intact: bool,
    /// What was found damaged.
    pub damage: Damage,
}

/// The sweep of a file from its sweep text and the JSON of its `integrator: auto` choice (empty:
/// none).
fn sweep_of(sweep_text: &str, auto: &str) -> Option<Sweep> {
    let mut sweep = Sweep::parse(sweep_text).ok()?;
    if !auto.is_empty() {
        sweep.apply_auto(AutoChoice::from_json(auto).ok()?);
    }
    Some(sweep)
}

/// The grid of `points` points of a file from its sweep text and auto choice (a sweep without a
/// search; an adaptive ensemble at the round that has them).
fn grid_of(sweep_text: &str, auto: &str, points: usize) -> Option<Grid> {
    let sweep = sweep_of(sweep_text, auto)?.with_points(points)?;
    (sweep.search.is_none())
        .then(|| Grid::new(&sweep).ok())
        .flatten()
        .filter(|g| g.len() == points)
}

/// The sweep and grid an output file's points were run from (from its own header: the sweep
/// text, what `integrator: auto` chose, an adaptive ensemble's last round, a search's points);
/// `None` when they cannot be had or do not match the file's points.
pub fn own_sweep_and_grid(recs: &FileRecords) -> Option<(Sweep, Grid)> {
    let mut sweep = Sweep::parse(&recs.sweep_text).ok()?;
    if let Some(auto) = recs.auto_text() {
        sweep.apply_auto(AutoChoice::from_json(&auto).ok()?);
    }
    // (An adaptive ensemble's file holds its last round.)
    let sweep = sweep.with_points(recs.len()).unwrap_or(sweep);
    let grid = match sweep.search {
        // (A search's points are the file's: its grid from the run hashes it stores.)
        Some(_) => search_grid(&sweep, recs)?,
        None => Grid::new(&sweep).ok()?,
    };
    (grid.len() == recs.len()).then_some((sweep, grid))
}

/// The grid of a search's output file, to read its runs back: the sweep's own grid and the
/// `evaluation` dimension, each point's run hash the one the file stores (the points a search
/// made are the file's, not a function of the sweep alone).
pub fn search_grid(sweep: &Sweep, recs: &FileRecords) -> Option<Grid> {
    let own = Grid::new(sweep).ok()?;
    let n = recs.len();
    if own.is_empty() || n % own.len() != 0 {
        return None;
    }
    let e = n / own.len();
    let mut g = own.clone();
    g.shape.push(e);
    g.hashes = (0..n)
        .map(|i| from_hex(recs.hash_hex(i)).unwrap_or([0; 32]))
        .collect();
    g.particles = (0..n).map(|i| own.particles[i / e]).collect();
    Some(g)
}

/// The snapshot beside output `path`: `None` when there is none, `Err` when it cannot be used.
fn read_snapshot(path: &Path) -> Option<Result<Snapshot, String>> {
    let p = work_dir_of(path).join(SNAPSHOT_FILE);
    // Only a regular file (never through a link, never a FIFO).
    let meta = std::fs::symlink_metadata(&p).ok()?;
    if !meta.is_file() {
        return Some(Err(format!("{} is not a regular file", p.display())));
    }
    Some(match std::fs::read(&p) {
        Ok(bytes) => Snapshot::decode(bytes).map_err(|e| e.0),
        Err(e) => Err(format!("{}: {e}", p.display())),
    })
}

impl PublishedFile {
    /// The runs of the output file `path` and its snapshot; `None` when there is neither.
    /// `known`: a grid the caller has (its sweep's), used for the file when the file's points hold
    /// its run hashes (or the file cannot be read and the snapshot was made for it).
    pub fn open(path: &Path, known: Option<&Grid>, check: Check) -> Option<PublishedFile> {
        let exists = std::fs::symlink_metadata(path).is_ok();
        let snapshot = read_snapshot(path);
        if !exists && snapshot.is_none() {
            return None;
        }
        let mut damage = Damage::default();
        let snapshot = match snapshot {
            None => None,
            Some(Ok(s)) => {
                if s.damaged_blocks > 0 {
                    damage.snapshot = Some(format!(
                        "{} of its blocks are damaged (their runs are not in it)",
                        s.damaged_blocks
                    ));
                }
                Some(s)
            }
            Some(Err(why)) => {
                damage.snapshot = Some(why);
                None
            }
        };
        // Bytes exactly as published (their hash the snapshot's): every value is as it was written
        // and checked then, so neither the points' checksums nor the run groups need be read to
        // be checked again.
        let as_published = check == Check::Everything
            && exists
            && snapshot.as_ref().is_some_and(|s| {
                !s.header.file_sha256.is_empty()
                    && file_sha256(path).as_deref() == Some(s.header.file_sha256.as_str())
            });
        let recs = if !exists {
            damage.file = Some("it does not exist".into());
            None
        } else if !path.is_file() {
            damage.file = Some("it is not a regular file".into());
            None
        } else if !hdf5::is_hdf5(path) {
            damage.file = Some("it does not start with the HDF5 signature".into());
            None
        } else {
            let opened = if as_published {
                FileRecords::open_as_published(path)
            } else {
                FileRecords::open(path)
            };
            match opened {
                Ok(r) => Some(r),
                Err(e) => {
                    damage.file = Some(format!("HDF5 cannot read it: {e}"));
                    None
                }
            }
        };
        let intact = as_published && recs.is_some();
        let mut p = PublishedFile {
            grid: None,
            points: HashMap::new(),
            intact,
            damage,
            recs,
            snapshot,
        };
        p.grid = p.find_grid(known);
        p.index(if intact { Check::Summaries } else { check });
        if p.recs.is_none() && p.points.is_empty() && p.damage.lost.is_empty() && !exists {
            // Only a snapshot of nothing: no published file at all.
            return None;
        }
        Some(p)
    }

    /// The grid the file's points index: `known` when the file's run hashes (or, for an
    /// unreadable file, the snapshot's) are its own, else the file's (or snapshot's) sweep.
    fn find_grid(&mut self, known: Option<&Grid>) -> Option<Grid> {
        if let Some(recs) = &self.recs {
            self.damage.header = recs.header_damage.clone();
            let n = recs.len();
            let matches = |g: &Grid| {
                g.len() == n
                    && (0..n).all(|i| {
                        recs.damage(i).is_some()
                            || recs.status(i) == STATUS_PENDING
                            || recs.holds(i, &g.hashes[i])
                    })
            };
            if let Some(g) = known.filter(|g| matches(g)) {
                return Some(g.clone());
            }
            if recs.header_damage.is_none() {
                let auto = recs.auto_text().unwrap_or_default();
                let sweep = sweep_of(&recs.sweep_text, &auto)?;
                if sweep.search.is_some() {
                    return search_grid(&sweep, recs);
                }
                if let Some(g) = sweep
                    .with_points(n)
                    .and_then(|s| Grid::new(&s).ok())
                    .filter(|g| g.len() == n)
                {
                    return Some(g);
                }
            }
            return None;
        }
        let s = self.snapshot.as_ref()?;
        if let Some(g) = known.filter(|g| g.len() == s.header.points) {
            if g.hashes.iter().any(|h| s.find(h).is_some()) {
                return Some(g.clone());
            }
        }
        grid_of(&s.header.sweep, &s.header.auto, s.header.points)
    }

    /// Finds every run the file gives back, checked as `check` says; damaged ones restored from
    /// the snapshot where it can, the others reported.
    fn index(&mut self, check: Check) {
        let Some(grid) = &self.grid else {
            if let Some(recs) = &self.recs {
                // The file's grid is unknown (its header is damaged and no caller's grid
                // matches): its runs cannot be read back.
                for i in 0..recs.len() {
                    if recs.status(i) != STATUS_PENDING || recs.damage(i).is_some() {
                        self.damage.lost.push(DamagedRun {
                            point: i,
                            hash: from_hex(recs.hash_hex(i)),
                            why: "the file's sweep cannot be read, so its runs cannot be labelled"
                                .into(),
                        });
                    }
                }
            }
            return;
        };
        let groups = grid.has_run_arrays();
        let whole_chain = |i: usize| (!grid.moving_part).then(|| u64::from(grid.particles[i]));
        let mut lost = Vec::new();
        let mut restored = Vec::new();
        let mut restore = |i: usize, why: String, points: &mut HashMap<_, _>| {
            let h = grid.hashes[i];
            let from_snapshot = self
                .snapshot
                .as_ref()
                .and_then(|s| s.record(&h, whole_chain(i)));
            let Some((rec, group_sum)) = from_snapshot else {
                lost.push(DamagedRun {
                    point: i,
                    hash: Some(h),
                    why,
                });
                return;
            };
            if rec.ok && groups {
                let group = self.recs.as_ref().map(|r| r.read_group(i, grid, group_sum));
                match group {
                    Some(Ok(_)) => {}
                    Some(Err(e)) => {
                        lost.push(DamagedRun {
                            point: i,
                            hash: Some(h),
                            // (Its group was what was damaged: the snapshot has no histories.)
                            why: if e == why {
                                why
                            } else {
                                format!("{why}; its summaries are in the snapshot, but {e}")
                            },
                        });
                        return;
                    }
                    None => {
                        lost.push(DamagedRun {
                            point: i,
                            hash: Some(h),
                            why: format!(
                                "{why}; its summaries are in the snapshot, its histories were only in the file"
                            ),
                        });
                        return;
                    }
                }
            }
            restored.push(DamagedRun {
                point: i,
                hash: Some(h),
                why,
            });
            points.insert(h, (i, rec.ok, Source::Snapshot));
        };
        let mut points = HashMap::new();
        match &self.recs {
            Some(recs) => {
                for i in 0..recs.len() {
                    let damaged = match recs.damage(i) {
                        Some(why) => Some(why.to_string()),
                        None if recs.status(i) == STATUS_PENDING => {
                            // A pending point names no run, so a finished run wiped back to a
                            // pending point's fill values passes its own check; the snapshot,
                            // which holds the run there, says otherwise (asked only of a file
                            // whose bytes are not those published with it).
                            let wiped = !self.intact
                                && self.snapshot.as_ref().and_then(|s| s.find(&grid.hashes[i]))
                                    == Some(i);
                            if !wiped {
                                continue;
                            }
                            Some("it reads as pending, but its snapshot holds its run".to_string())
                        }
                        None if !recs.holds(i, &grid.hashes[i]) => {
                            // A run of another version of the engine (or of the sweep): it is
                            // not this grid's and is left out, as resume always did.
                            continue;
                        }
                        None if check == Check::Everything
                            && groups
                            && holds_values(recs.status(i)) =>
                        {
                            match recs.record(i, grid.hashes[i], grid) {
                                PointRead::Damaged(why) => Some(why),
                                _ => None,
                            }
                        }
                        None => None,
                    };
                    match damaged {
                        Some(why) => restore(i, why, &mut points),
                        None => {
                            points.insert(
                                grid.hashes[i],
                                (i, holds_values(recs.status(i)), Source::File),
                            );
                        }
                    }
                }
            }
            None => {
                let why = format!(
                    "the file cannot be read ({})",
                    self.damage.file.as_deref().unwrap_or("")
                );
                let held: Vec<usize> = match &self.snapshot {
                    Some(s) => (0..grid.len())
                        .filter(|&i| s.find(&grid.hashes[i]).is_some())
                        .collect(),
                    None => Vec::new(),
                };
                for i in held {
                    restore(i, why.clone(), &mut points);
                }
            }
        }
        self.points = points;
        self.damage.lost = lost;
        self.damage.restored = restored;
    }

    /// Whether the file's bytes are exactly those published with its snapshot (nothing in it has
    /// changed since, damaged or not; known only when opened to check everything).
    pub fn intact(&self) -> bool {
        self.intact
    }

    /// Every run the file gives back: its point in the file's grid, and whether it succeeded.
    pub fn runs(&self) -> impl Iterator<Item = (&RunHash, usize, bool)> + '_ {
        self.points.iter().map(|(h, &(i, ok, _))| (h, i, ok))
    }

    /// Whether the file gives back the run `hash`.
    pub fn holds(&self, hash: &RunHash) -> bool {
        self.points.contains_key(hash)
    }

    /// Whether the run `hash` the file gives back succeeded (`None`: it gives back no such run).
    pub fn ok(&self, hash: &RunHash) -> Option<bool> {
        self.points.get(hash).map(|&(_, ok, _)| ok)
    }

    /// Whether the run `hash` the file gives back finished without its steady state settling
    /// ([`chainsweep_sweep::record::STATUS_UNSETTLED`]).
    pub fn unsettled(&self, hash: &RunHash) -> bool {
        let Some(&(i, _, source)) = self.points.get(hash) else {
            return false;
        };
        let status = match source {
            Source::File => self.recs.as_ref().map(|r| r.status(i)),
            Source::Snapshot => self.snapshot.as_ref().and_then(|s| s.status(hash)),
        };
        status == Some(chainsweep_sweep::record::STATUS_UNSETTLED)
    }

    /// Runs the file gives back.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether it gives back none.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The file's grid, when known.
    pub fn grid(&self) -> Option<&Grid> {
        self.grid.as_ref()
    }

    /// The file's records, when HDF5 can read it.
    pub fn file(&self) -> Option<&FileRecords> {
        self.recs.as_ref()
    }

    /// The snapshot, when it could be read.
    pub fn snapshot(&self) -> Option<&Snapshot> {
        self.snapshot.as_ref()
    }

    /// The record of the run `hash`, checked; `None` when the file does not give it back.
    pub fn read(&self, hash: &RunHash) -> Option<RunRecord> {
        let &(i, _, source) = self.points.get(hash)?;
        let grid = self.grid.as_ref()?;
        match source {
            Source::File => match self.recs.as_ref()?.record(i, *hash, grid) {
                PointRead::Run(rec) => Some(*rec),
                PointRead::Pending | PointRead::Damaged(_) => None,
            },
            Source::Snapshot => {
                let whole_chain = (!grid.moving_part).then(|| u64::from(grid.particles[i]));
                let (mut rec, group_sum) = self.snapshot.as_ref()?.record(hash, whole_chain)?;
                if rec.ok && grid.has_run_arrays() {
                    let (history, min_overlap, fields, flow) =
                        self.recs.as_ref()?.read_group(i, grid, group_sum).ok()?;
                    rec.history = history;
                    rec.min_overlap_m = min_overlap;
                    rec.fields = fields;
                    rec.energy_flow = flow;
                }
                Some(rec)
            }
        }
    }

    /// The verification outcome stored with the run `hash`.
    pub fn verify_info(&self, hash: &RunHash) -> Option<chainsweep_sweep::record::VerifyInfo> {
        let &(i, _, source) = self.points.get(hash)?;
        match source {
            Source::File => Some(self.recs.as_ref()?.verify_info(i)),
            Source::Snapshot => self.snapshot.as_ref()?.verify_info(hash),
        }
    }
}

/// The SHA-256 (hex) of the file at `path`, read through once; `None` when it cannot be read.
pub fn file_sha256(path: &Path) -> Option<String> {
    use sha2::{Digest, Sha256};
    use std::io::Read;
    let mut f = std::fs::File::open(path).ok()?;
    let mut h = Sha256::new();
    let mut buf = vec![0u8; 1 << 20];
    loop {
        let n = f.read(&mut buf).ok()?;
        if n == 0 {
            break;
        }
        h.update(&buf[..n]);
    }
    Some(chainsweep_sweep::identity::hex(&h.finalize().into()))
}

/// The snapshot bytes of a file just written from `table` for `grid` (whose sweep is `sweep`),
/// whose bytes hash to `file_sha256`.
pub fn snapshot_of(
    sweep: &Sweep,
    grid: &Grid,
    table: &chainsweep_sweep::record::columns::Table,
    shard: &str,
    created_utc: &str,
    file_sha256: String,
) -> Vec<u8> {
    let header = snapshot::Header {
        layout_version: hdf5::LAYOUT_VERSION,
        points: grid.len(),
        probes: grid.probes.len(),
        moving_part: grid.moving_part,
        run_groups: grid.has_run_arrays(),
        spectrum: grid.spectrum,
        harmonics: grid.steady_harmonics,
        energy_ledger: grid.energy_ledger,
        sweep: sweep.text.clone(),
        auto: sweep
            .auto_choice
            .as_ref()
            .map(|c| c.to_json())
            .unwrap_or_default(),
        shard: shard.to_string(),
        created_utc: created_utc.to_string(),
        file_sha256,
    };
    snapshot::encode(&header, table, &grid.hashes)
}
