//! The index of a work directory's stored runs ([`Stored`]): where each run's record is (a log,
//! a segment of an earlier version, the published output file), found by one scan with every
//! checksum checked, and the records read back through it.

use std::collections::HashMap;
use std::fs::{self, File};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use chainsweep_sweep::error::{Error, Result};
use chainsweep_sweep::grid::Grid;
use chainsweep_sweep::identity::{from_hex, hex, RunHash};
use chainsweep_sweep::record::RunRecord;

use crate::log::{log_seq, LOG_DIR};
use crate::published::{Check, Damage, PublishedFile};
use crate::segment::Checked;
use crate::{is_file, list_dir, no_link, RunStore, SegmentIndex, SEGMENT_DIR};
use crate::{log, segment};

pub(super) fn segment_hash(file_name: &str) -> Option<RunHash> {
    from_hex(file_name.strip_suffix(".seg")?)
}

/// Where a stored run's record is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Loc {
    /// `segments/<hash>.seg` of an earlier version.
    Segment { ok: bool },
    /// In log number `log` (an index into [`Stored::logs`]): the frame's payload, packed or not
    /// (see [`log`]).
    Log {
        log: usize,
        offset: u64,
        len: u64,
        packed: bool,
        ok: bool,
    },
    /// In the published output file (or restored from its snapshot).
    Published { ok: bool },
}

impl Loc {
    pub(super) fn ok(self) -> bool {
        match self {
            Loc::Segment { ok } | Loc::Log { ok, .. } | Loc::Published { ok, .. } => ok,
        }
    }
}

/// What a work directory (and its published output file) holds, as found by a scan: where each
/// stored run's record is. Memory: a few dozen bytes per run, never the records themselves.
pub struct Stored {
    pub(super) dir: PathBuf,
    pub(super) entries: HashMap<RunHash, Loc>,
    pub(super) logs: Vec<LogFile>,
    pub(super) segments: usize,
    pub(super) published: Option<PublishedFile>,
    pub(super) damage: Damage,
    pub(super) ignored: Vec<PathBuf>,
    pub(super) corrupt: usize,
    pub(super) next_seq: u64,
}

impl std::fmt::Debug for Stored {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Stored")
            .field("dir", &self.dir)
            .field("runs", &self.entries.len())
            .field(
                "logs",
                &self.logs.iter().map(|l| &l.path).collect::<Vec<_>>(),
            )
            .field("segments", &self.segments)
            .finish()
    }
}

/// A log of [`Stored`]: its path, and the handle its records are read through, opened at the
/// first read and kept while the log is, so that assembling a file of 100 000 runs does not open
/// and close the log 100 000 times. (A log is only ever appended to while it is in use, and is
/// replaced by a new path when compacted, so the handle always reads the file the offsets were
/// found in.)
pub(super) struct LogFile {
    pub(super) path: PathBuf,
    pub(super) reader: OnceLock<File>,
    pub(super) keys: log::KeyCache,
}

impl LogFile {
    pub(super) fn new(path: PathBuf) -> LogFile {
        LogFile {
            path,
            reader: OnceLock::new(),
            keys: log::KeyCache::default(),
        }
    }

    /// The log's read handle, opened now if it is not yet.
    fn reader(&self) -> Result<&File> {
        if let Some(f) = self.reader.get() {
            return Ok(f);
        }
        let f = File::open(&self.path).map_err(Error::io("open", &self.path))?;
        Ok(self.reader.get_or_init(|| f))
    }
}

impl Stored {
    /// Scans work directory `dir` (absent: empty) and, when given, the published output file
    /// (checked as `check` says; `known`: the caller's grid, see [`PublishedFile::open`]): every
    /// whole record is found (its checksum checked, so every run it lists can be read), torn and
    /// corrupt ones are left out, and so are the damaged runs of the output file (reported in
    /// [`Stored::damage`]). A later record of a run wins over an earlier one (a run retried with
    /// `--retry-failed`), a log's over the output file's. Anything that is not a regular file
    /// where a log or segment is expected is left out (see [`Stored::ignored`]); a symbolic link
    /// in place of the work directory's `logs/` or `segments/` is an error.
    pub fn scan(
        dir: &Path,
        output: Option<&Path>,
        known: Option<&Grid>,
        check: Check,
    ) -> Result<Stored> {
        let mut s = Stored {
            dir: dir.to_path_buf(),
            entries: HashMap::new(),
            logs: Vec::new(),
            segments: 0,
            published: None,
            damage: Damage::default(),
            ignored: Vec::new(),
            corrupt: 0,
            next_seq: 1,
        };
        if let Some(p) = output.and_then(|o| PublishedFile::open(o, known, check)) {
            for (h, _, ok) in p.runs() {
                s.entries.insert(*h, Loc::Published { ok });
            }
            s.damage = p.damage.clone();
            s.published = Some(p);
        }
        let seg_dir = no_link(&dir.join(SEGMENT_DIR))?;
        for entry in list_dir(&seg_dir)? {
            let Some(hash) = entry.file_name().to_str().and_then(segment_hash) else {
                continue;
            };
            if !is_file(&entry) {
                s.ignored.push(entry.path());
                continue;
            }
            s.segments += 1;
            match fs::read(entry.path()) {
                Ok(bytes) => match segment::verify(&bytes) {
                    Some((h, ok)) if h == hash => {
                        s.entries.insert(hash, Loc::Segment { ok });
                    }
                    _ => s.corrupt += 1,
                },
                Err(_) => s.corrupt += 1,
            }
        }
        let log_dir = no_link(&dir.join(LOG_DIR))?;
        let mut logs: Vec<(u64, PathBuf)> = Vec::new();
        for entry in list_dir(&log_dir)? {
            let Some(seq) = entry.file_name().to_str().and_then(log_seq) else {
                continue;
            };
            s.next_seq = s.next_seq.max(seq + 1);
            if !is_file(&entry) {
                s.ignored.push(entry.path());
                continue;
            }
            logs.push((seq, entry.path()));
        }
        logs.sort();
        for (_, path) in logs {
            let log = s.logs.len();
            let entries = &mut s.entries;
            let end = log::scan(&path, |f| {
                entries.insert(
                    f.hash,
                    Loc::Log {
                        log,
                        offset: f.offset,
                        len: f.len,
                        packed: f.packed,
                        ok: f.ok,
                    },
                );
            })
            .map_err(Error::io("read", &path))?;
            s.corrupt += end.corrupt + usize::from(end.torn);
            s.logs.push(LogFile::new(path));
        }
        Ok(s)
    }

    /// Every stored run and whether it succeeded.
    pub fn index(&self) -> SegmentIndex {
        self.entries.iter().map(|(h, l)| (*h, l.ok())).collect()
    }

    /// Whether the run `hash` is stored, and if so whether it succeeded.
    pub fn get(&self, hash: &RunHash) -> Option<bool> {
        self.entries.get(hash).map(|l| l.ok())
    }

    /// Runs stored.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether no run is stored.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// What was left out because it is not a regular file (a directory named like a log, …).
    pub fn ignored(&self) -> &[PathBuf] {
        &self.ignored
    }

    /// Records found torn or corrupt (their runs are computed again).
    pub fn corrupt(&self) -> usize {
        self.corrupt
    }

    /// What was found damaged in the published output file and its snapshot.
    pub fn damage(&self) -> &Damage {
        &self.damage
    }

    /// The published output file, when there is one.
    pub fn published(&self) -> Option<&PublishedFile> {
        self.published.as_ref()
    }

    /// Logs and one-file segments in the work directory.
    pub fn files(&self) -> usize {
        self.logs.len() + self.segments
    }

    /// The record of the run `hash`; `None` when it is not stored (or no longer readable).
    pub fn read(&self, hash: &RunHash) -> Result<Option<RunRecord>> {
        let Some(&loc) = self.entries.get(hash) else {
            return Ok(None);
        };
        let checked = match loc {
            Loc::Published { .. } => {
                let Some(p) = &self.published else {
                    return Ok(None);
                };
                return Ok(p.read(hash));
            }
            Loc::Segment { .. } => {
                let path = self
                    .dir
                    .join(SEGMENT_DIR)
                    .join(format!("{}.seg", hex(hash)));
                match fs::read(&path) {
                    Ok(b) => Checked::verify(b),
                    Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
                    Err(e) => return Err(Error::io("read", &path)(e)),
                }
            }
            Loc::Log {
                log,
                offset,
                len,
                packed,
                ..
            } => self.log_bytes(log, offset, len, packed)?,
        };
        Ok(checked
            .filter(|c| &c.hash() == hash)
            .and_then(|c| c.decode()))
    }

    /// The segment bytes of the frame at `offset` of log `log`, checked; `None` when their
    /// checksum fails or a packed one no longer inflates.
    fn log_bytes(
        &self,
        log: usize,
        offset: u64,
        len: u64,
        packed: bool,
    ) -> Result<Option<Checked>> {
        let log = &self.logs[log];
        log::read_at(log.reader()?, offset, len, packed, &log.keys)
            .map_err(Error::io("read", &log.path))
    }

    /// The segment bytes of a run stored in a log or segment (for compaction), checked; `None`
    /// for one only in the output file, or unreadable.
    pub(super) fn raw(&self, hash: &RunHash) -> Result<Option<Checked>> {
        match self.entries.get(hash) {
            Some(&Loc::Log {
                log,
                offset,
                len,
                packed,
                ..
            }) => self.log_bytes(log, offset, len, packed),
            Some(Loc::Segment { .. }) => {
                let path = self
                    .dir
                    .join(SEGMENT_DIR)
                    .join(format!("{}.seg", hex(hash)));
                Ok(fs::read(path).ok().and_then(Checked::verify))
            }
            _ => Ok(None),
        }
    }
}

/// What a scan found, as a store that only reads (`status`: nothing is written).
impl RunStore for Stored {
    fn read(&self, hash: &RunHash) -> Result<Option<RunRecord>> {
        Stored::read(self, hash)
    }

    fn write(&self, _rec: &RunRecord) -> Result<()> {
        Err(Error::Other(
            "the runs a scan found are read only (no work directory is locked)".into(),
        ))
    }

    fn index(&self) -> Result<SegmentIndex> {
        Ok(Stored::index(self))
    }
}
