//! Storage: crash-safe append-only logs of finished runs in a work directory, and the HDF5 file
//! assembled from them.
//!
//! An output `X.h5` has a sibling work directory `X.h5.d/`:
//!
//! - `X.h5.d/lock`: held with an exclusive `flock` by the process working on `X.h5`; a second
//!   process is refused. The kernel drops the lock when its holder dies, even by `kill -9`.
//! - `X.h5.d/logs/<n>.log`: append-only logs of finished runs (see [`log`]), one per process
//!   that stored runs (each opens a new one); every record checksummed, a torn or corrupt one
//!   skipped (its run is computed again). A checkpoint makes them durable (`fdatasync`), which
//!   costs what was appended since the last one, nothing more.
//! - `X.h5.d/tmp/`: temporary files, emptied by the next process that takes the lock.
//! - `X.h5.d/auto.json`: what `integrator: auto` chose ([`AutoChoice`]), written atomically.
//!
//! `X.h5` itself is only ever replaced by renaming a completely written and `fsync`ed file over it
//! ([`WorkDir::publish`]), so it is always either the previous complete version or the new one.
//! It is a store of runs too: a run it holds (ok or failed) is read back from it
//! ([`hdf5::FileRecords::record`], bitwise the record written). So once a sweep is complete and
//! its file published, the logs are compacted ([`WorkDir::compact_after_publish`]): only the
//! records the file does not hold and the sweep needs (its verification runs) stay, in one log;
//! the runs of points the sweep no longer has (orphans of an edited sweep) go.
//!
//! Work directories of earlier versions hold one file per run, `segments/<runhash>.seg` (the
//! same record format, see [`segment`]); they are read, and moved into one log by the next
//! process that takes the lock.

pub mod hdf5;
pub mod log;
pub mod segment;

use std::collections::HashMap;
use std::fs::{self, File, OpenOptions};
use std::io::{Read, Write};
use std::os::unix::fs::FileExt;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, MutexGuard};

use fs4::fs_std::FileExt as _;

use crate::error::{Error, Result};
use crate::grid::Grid;
use crate::identity::{from_hex, hex, RunHash};
use crate::record::{RunRecord, STATUS_OK, STATUS_PENDING};
use crate::sweep::auto::AutoChoice;
use crate::sweep::Sweep;

use self::hdf5::FileRecords;
use self::log::{frame, log_name, log_seq, LOG_DIR};

/// Path of the work directory of an output file: `X.h5` → `X.h5.d`.
pub fn work_dir_of(output: &Path) -> PathBuf {
    let mut s = output.as_os_str().to_owned();
    s.push(".d");
    PathBuf::from(s)
}

/// What a store holds: the status of every stored run (`true`: it succeeded), by run hash.
pub type SegmentIndex = HashMap<RunHash, bool>;

/// Where finished runs are kept until the output file is assembled from them. The engine plans,
/// schedules and assembles through this narrow interface only.
pub trait RunStore: Sync {
    /// The stored record of the run `hash`; `None` when it is missing or unreadable (it is then
    /// run again).
    fn read(&self, hash: &RunHash) -> Result<Option<RunRecord>>;
    /// Stores a finished run: after a crash it is there whole or not at all (durable once
    /// [`RunStore::sync`] returns).
    fn write(&self, rec: &RunRecord) -> Result<()>;
    /// Every stored run whose record is whole (checksummed) and whether it succeeded: exactly the
    /// runs [`RunStore::read`] returns.
    fn index(&self) -> Result<SegmentIndex>;
    /// Makes every run written so far durable (a checkpoint).
    fn sync(&self) -> Result<()> {
        Ok(())
    }
}

/// Name of the file in a work directory that holds what `integrator: auto` chose.
pub const AUTO_CHOICE_FILE: &str = "auto.json";

/// The folder of one-file-per-run segments of earlier versions.
const SEGMENT_DIR: &str = "segments";

/// At most this many logs before the next process that takes the lock compacts them into one
/// (each process writes its own: a sweep resumed many times would otherwise leave many files).
pub const MAX_LOGS: usize = 16;

fn segment_hash(file_name: &str) -> Option<RunHash> {
    from_hex(file_name.strip_suffix(".seg")?)
}

/// Where a stored run's record is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Loc {
    /// `segments/<hash>.seg` of an earlier version.
    Segment { ok: bool },
    /// In log number `log` (an index into [`Stored::logs`]).
    Log {
        log: usize,
        offset: u64,
        len: u64,
        ok: bool,
    },
    /// In the published output file, at grid point `point`.
    Published { point: usize, ok: bool },
}

impl Loc {
    fn ok(self) -> bool {
        match self {
            Loc::Segment { ok } | Loc::Log { ok, .. } | Loc::Published { ok, .. } => ok,
        }
    }
}

/// The published output file as a store of runs: its records by hash, read back with its own
/// grid (the one its points index).
struct PublishedFile {
    recs: FileRecords,
    grid: Grid,
    points: HashMap<RunHash, (usize, bool)>,
}

impl PublishedFile {
    /// The runs of the output file `path`; `None` when there is none, or it is no readable
    /// chainsweep file (its runs are then computed again).
    fn open(path: &Path) -> Option<PublishedFile> {
        Self::open_with(path, None)
    }

    /// As [`PublishedFile::open`], with `known`, the grid the caller just wrote the file from:
    /// taken instead of expanding the file's sweep again (182 points: 49 M instructions, on the
    /// serial path at the end of every sweep) when every run the file holds has that grid's run
    /// hash at its point, which the run hash of a scene (probes and record block included)
    /// makes the same grid for reading them back. Otherwise the file's own sweep is expanded.
    fn open_with(path: &Path, known: Option<&Grid>) -> Option<PublishedFile> {
        if !path.is_file() || !hdf5::is_hdf5(path) {
            return None;
        }
        let recs = FileRecords::open(path).ok()?;
        let mut points = HashMap::new();
        for i in 0..recs.len() {
            let st = recs.status(i);
            if st == STATUS_PENDING {
                continue;
            }
            if let Some(h) = from_hex(recs.hash_hex(i)) {
                points.insert(h, (i, st == STATUS_OK));
            }
        }
        let matches =
            |g: &Grid| g.len() == recs.len() && points.iter().all(|(h, &(i, _))| g.hashes[i] == *h);
        let grid = match known {
            Some(g) if matches(g) => g.clone(),
            _ => {
                let sweep = Sweep::parse(&recs.sweep_text).ok()?;
                let grid = Grid::new(&sweep).ok()?;
                if grid.len() != recs.len() {
                    return None;
                }
                grid
            }
        };
        Some(PublishedFile { recs, grid, points })
    }

    fn read(&self, hash: &RunHash, point: usize) -> Result<Option<RunRecord>> {
        if self.recs.hash_hex(point) != hex(hash) {
            return Ok(None);
        }
        self.recs.record(point, *hash, &self.grid)
    }
}

/// What a work directory (and its published output file) holds, as found by a scan: where each
/// stored run's record is. Memory: a few dozen bytes per run, never the records themselves.
pub struct Stored {
    dir: PathBuf,
    entries: HashMap<RunHash, Loc>,
    logs: Vec<PathBuf>,
    segments: usize,
    published: Option<Mutex<PublishedFile>>,
    ignored: Vec<PathBuf>,
    corrupt: usize,
    next_seq: u64,
}

impl std::fmt::Debug for Stored {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Stored")
            .field("dir", &self.dir)
            .field("runs", &self.entries.len())
            .field("logs", &self.logs)
            .field("segments", &self.segments)
            .finish()
    }
}

/// Whether `entry` is a regular file (not a directory, link to one, socket, …).
fn is_file(entry: &fs::DirEntry) -> bool {
    entry.file_type().map(|t| t.is_file()).unwrap_or(false)
}

impl Stored {
    /// Scans work directory `dir` (absent: empty) and, when given, the published output file:
    /// every whole record is found (its checksum checked, so every run it lists can be read),
    /// torn and corrupt ones are left out. A later record of a run wins over an earlier one (a
    /// run retried with `--retry-failed`), a log's over the output file's. Anything that is not
    /// a regular file where a log or segment is expected is left out (see [`Stored::ignored`]).
    pub fn scan(dir: &Path, output: Option<&Path>) -> Result<Stored> {
        let mut s = Stored {
            dir: dir.to_path_buf(),
            entries: HashMap::new(),
            logs: Vec::new(),
            segments: 0,
            published: None,
            ignored: Vec::new(),
            corrupt: 0,
            next_seq: 1,
        };
        if let Some(p) = output.and_then(PublishedFile::open) {
            for (h, &(point, ok)) in &p.points {
                s.entries.insert(*h, Loc::Published { point, ok });
            }
            s.published = Some(Mutex::new(p));
        }
        let seg_dir = dir.join(SEGMENT_DIR);
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
        let log_dir = dir.join(LOG_DIR);
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
            let end = log::scan(&path, 0, |f| {
                entries.insert(
                    f.hash,
                    Loc::Log {
                        log,
                        offset: f.offset,
                        len: f.len,
                        ok: f.ok,
                    },
                );
            })
            .map_err(Error::io("read", &path))?;
            s.corrupt += end.corrupt + usize::from(end.torn);
            s.logs.push(path);
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

    /// Logs and one-file segments in the work directory.
    pub fn files(&self) -> usize {
        self.logs.len() + self.segments
    }

    /// The record of the run `hash`; `None` when it is not stored (or no longer readable).
    pub fn read(&self, hash: &RunHash) -> Result<Option<RunRecord>> {
        let Some(&loc) = self.entries.get(hash) else {
            return Ok(None);
        };
        let bytes = match loc {
            Loc::Published { point, .. } => {
                let Some(p) = &self.published else {
                    return Ok(None);
                };
                return lock(p).read(hash, point);
            }
            Loc::Segment { .. } => {
                let path = self
                    .dir
                    .join(SEGMENT_DIR)
                    .join(format!("{}.seg", hex(hash)));
                match fs::read(&path) {
                    Ok(b) => b,
                    Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
                    Err(e) => return Err(Error::io("read", &path)(e)),
                }
            }
            Loc::Log {
                log, offset, len, ..
            } => self.log_bytes(log, offset, len)?,
        };
        Ok(segment::decode(&bytes).filter(|r| &r.hash == hash))
    }

    fn log_bytes(&self, log: usize, offset: u64, len: u64) -> Result<Vec<u8>> {
        let path = &self.logs[log];
        let f = File::open(path).map_err(Error::io("open", path))?;
        let mut b = vec![0u8; len as usize];
        f.read_exact_at(&mut b, offset)
            .map_err(Error::io("read", path))?;
        Ok(b)
    }

    /// The segment bytes of a run stored in a log or segment (for compaction); `None` for one
    /// only in the output file, or unreadable.
    fn raw(&self, hash: &RunHash) -> Result<Option<Vec<u8>>> {
        match self.entries.get(hash) {
            Some(&Loc::Log {
                log, offset, len, ..
            }) => self.log_bytes(log, offset, len).map(Some),
            Some(Loc::Segment { .. }) => {
                let path = self
                    .dir
                    .join(SEGMENT_DIR)
                    .join(format!("{}.seg", hex(hash)));
                Ok(fs::read(path).ok())
            }
            _ => Ok(None),
        }
    }
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// The entries of directory `dir`; none when it does not exist.
fn list_dir(dir: &Path) -> Result<Vec<fs::DirEntry>> {
    match fs::read_dir(dir) {
        Ok(e) => e
            .collect::<std::io::Result<Vec<_>>>()
            .map_err(Error::io("list", dir)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(Vec::new()),
        Err(e) => Err(Error::io("list", dir)(e)),
    }
}

/// The runs the output file `path` holds (ok or failed), by hash; none when it is no readable
/// chainsweep file.
pub fn published_runs(path: &Path) -> SegmentIndex {
    PublishedFile::open(path)
        .map(|p| p.points.iter().map(|(h, &(_, ok))| (*h, ok)).collect())
        .unwrap_or_default()
}

/// Lists the runs stored in work directory `dir` (not counting its output file) with their
/// status, checksums checked. A missing directory is an empty index.
pub fn scan_segments(dir: &Path) -> Result<SegmentIndex> {
    Ok(Stored::scan(dir, None)?.index())
}

/// The log this process appends to.
#[derive(Debug)]
struct Writer {
    file: File,
    log: usize,
    end: u64,
    dirty: bool,
}

#[derive(Debug)]
struct State {
    stored: Stored,
    writer: Option<Writer>,
}

/// What a compaction did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Compaction {
    /// Records kept (moved into one log).
    pub kept: usize,
    /// Records held by the published output file, no longer kept beside it.
    pub published: usize,
    /// Records of runs not needed, removed.
    pub removed: usize,
    /// Files removed (logs and segments).
    pub files_removed: usize,
}

/// A locked work directory.
#[derive(Debug)]
pub struct WorkDir {
    /// The output file.
    pub output: PathBuf,
    /// The work directory (`output` + `.d`).
    pub dir: PathBuf,
    _lock: File,
    counter: AtomicU64,
    state: Mutex<State>,
}

impl RunStore for WorkDir {
    fn read(&self, hash: &RunHash) -> Result<Option<RunRecord>> {
        self.read_segment(hash)
    }

    fn write(&self, rec: &RunRecord) -> Result<()> {
        self.write_segment(rec)
    }

    fn index(&self) -> Result<SegmentIndex> {
        Ok(lock(&self.state).stored.index())
    }

    fn sync(&self) -> Result<()> {
        let mut st = lock(&self.state);
        let State { stored, writer } = &mut *st;
        if let Some(w) = writer.as_mut().filter(|w| w.dirty) {
            let path = &stored.logs[w.log];
            w.file.sync_data().map_err(Error::io("sync", path))?;
            w.dirty = false;
        }
        Ok(())
    }
}

fn fsync_dir(dir: &Path) -> Result<()> {
    let d = File::open(dir).map_err(Error::io("open directory", dir))?;
    d.sync_all().map_err(Error::io("sync directory", dir))
}

/// Writes `bytes` to `dest` atomically: a temporary file `tmp` written and synced, renamed over
/// `dest`, and the directory synced. `dest` is then either its previous version or the new one.
fn write_atomic(tmp: &Path, dest: &Path, bytes: &[u8]) -> Result<()> {
    {
        let mut f = File::create(tmp).map_err(Error::io("create", tmp))?;
        f.write_all(bytes).map_err(Error::io("write", tmp))?;
        f.sync_all().map_err(Error::io("sync", tmp))?;
    }
    fs::rename(tmp, dest).map_err(Error::rename(tmp, dest))?;
    fsync_dir(dest.parent().expect("a file in a directory"))
}

/// Takes the lock of the work directory `dir` of `output`; an error naming the holder's pid when
/// another process has it.
fn take_lock(dir: &Path, output: &Path) -> Result<File> {
    let lock_path = dir.join("lock");
    let mut lock = OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(false)
        .open(&lock_path)
        .map_err(Error::io("open", &lock_path))?;
    let got = lock
        .try_lock_exclusive()
        .map_err(Error::io("lock", &lock_path))?;
    if !got {
        let mut holder = String::new();
        let _ = lock.read_to_string(&mut holder);
        let holder = holder.trim();
        return Err(Error::Locked {
            output: output.to_path_buf(),
            lock: lock_path,
            holder: (!holder.is_empty()).then(|| holder.to_string()),
        });
    }
    lock.set_len(0)
        .and_then(|()| write!(lock, "{}", std::process::id()))
        .and_then(|()| lock.flush())
        .map_err(Error::io("write", &lock_path))?;
    Ok(lock)
}

impl WorkDir {
    /// Creates (if needed) and locks the work directory of `output`, clears its `tmp/`, and finds
    /// what it (and `output`) holds. One-file segments of an earlier version, and more than
    /// [`MAX_LOGS`] logs, are moved into one log. Fails with a clear message when another
    /// process holds the lock.
    pub fn open(output: &Path) -> Result<WorkDir> {
        let dir = work_dir_of(output);
        fs::create_dir_all(dir.join(LOG_DIR)).map_err(Error::io("create", &dir))?;
        fs::create_dir_all(dir.join("tmp")).map_err(Error::io("create", &dir))?;
        let lock_file = take_lock(&dir, output)?;
        // Nobody else can be writing: leftovers in tmp/ are from a process that died, and so are
        // empty logs (a process that stored nothing).
        let tmp = dir.join("tmp");
        for entry in fs::read_dir(&tmp).map_err(Error::io("list", &tmp))? {
            let _ = fs::remove_file(entry.map_err(Error::io("list", &tmp))?.path());
        }
        for entry in list_dir(&dir.join(LOG_DIR))? {
            let empty = entry.metadata().map(|m| m.is_file() && m.len() == 0);
            let named = entry.file_name().to_str().and_then(log_seq).is_some();
            if named && empty.unwrap_or(false) {
                let _ = fs::remove_file(entry.path());
            }
        }
        let stored = Stored::scan(&dir, Some(output))?;
        let work = WorkDir {
            output: output.to_path_buf(),
            dir,
            _lock: lock_file,
            counter: AtomicU64::new(0),
            state: Mutex::new(State {
                stored,
                writer: None,
            }),
        };
        let (segments, logs) = {
            let st = lock(&work.state);
            (st.stored.segments, st.stored.logs.len())
        };
        if segments > 0 || logs > MAX_LOGS {
            work.compact(&|_| true, false)?;
        }
        Ok(work)
    }

    /// A fresh temporary path in `tmp/`.
    pub fn tmp_path(&self, what: &str) -> PathBuf {
        let n = self.counter.fetch_add(1, Ordering::Relaxed);
        self.dir
            .join("tmp")
            .join(format!("{what}.{}.{n}.tmp", std::process::id()))
    }

    /// Appends a run's record to this process's log (created on the first one). A write that
    /// fails (a full disk) is cut off again, so the log stays whole and the run is simply not
    /// stored.
    pub fn write_segment(&self, rec: &RunRecord) -> Result<()> {
        let bytes = frame(&segment::encode(rec));
        let mut st = lock(&self.state);
        let State { stored, writer } = &mut *st;
        if writer.is_none() {
            *writer = Some(self.new_log(stored)?);
        }
        let w = writer.as_mut().expect("just created");
        let path = &stored.logs[w.log];
        if let Err(e) = w.file.write_all(&bytes) {
            let _ = w.file.set_len(w.end);
            return Err(Error::io("write", path)(e));
        }
        stored.entries.insert(
            rec.hash,
            Loc::Log {
                log: w.log,
                offset: w.end + log::FRAME_HEAD,
                len: bytes.len() as u64 - log::FRAME_HEAD,
                ok: rec.ok,
            },
        );
        w.end += bytes.len() as u64;
        w.dirty = true;
        Ok(())
    }

    /// Creates this process's log, with the next free sequence number.
    fn new_log(&self, stored: &mut Stored) -> Result<Writer> {
        let log_dir = self.dir.join(LOG_DIR);
        loop {
            let path = log_dir.join(log_name(stored.next_seq));
            stored.next_seq += 1;
            match OpenOptions::new()
                .read(true)
                .append(true)
                .create_new(true)
                .open(&path)
            {
                Ok(file) => {
                    fsync_dir(&log_dir)?;
                    stored.logs.push(path);
                    return Ok(Writer {
                        file,
                        log: stored.logs.len() - 1,
                        end: 0,
                        dirty: false,
                    });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
                Err(e) => return Err(Error::io("create", &path)(e)),
            }
        }
    }

    /// Writes `bytes` to the file `name` of the work directory atomically (temporary file, fsync,
    /// rename, fsync of the directory): the file is either the previous version or the new one.
    pub fn write_file_atomic(&self, name: &str, bytes: &[u8]) -> Result<()> {
        write_atomic(&self.tmp_path(name), &self.dir.join(name), bytes)
    }

    /// Caches what `integrator: auto` chose (atomically).
    pub fn write_auto_choice(&self, choice: &AutoChoice) -> Result<()> {
        self.write_file_atomic(AUTO_CHOICE_FILE, choice.to_json().as_bytes())
    }

    /// Reads a run's record; `None` when it is missing or corrupt.
    pub fn read_segment(&self, hash: &RunHash) -> Result<Option<RunRecord>> {
        lock(&self.state).stored.read(hash)
    }

    /// What the scan at [`WorkDir::open`] left out (not regular files), and how many records it
    /// found torn or corrupt.
    pub fn scan_notes(&self) -> (Vec<PathBuf>, usize) {
        let st = lock(&self.state);
        (st.stored.ignored.clone(), st.stored.corrupt)
    }

    /// Logs and one-file segments in the work directory now.
    pub fn store_files(&self) -> usize {
        lock(&self.state).stored.files()
    }

    /// Replaces the output file by the finished file at `tmp` (fsync, rename, fsync of the directory).
    pub fn publish(&self, tmp: &Path) -> Result<()> {
        {
            let f = File::open(tmp).map_err(Error::io("open", tmp))?;
            f.sync_all().map_err(Error::io("sync", tmp))?;
        }
        fs::rename(tmp, &self.output).map_err(Error::rename(tmp, &self.output))?;
        let parent = match self.output.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        fsync_dir(&parent)
    }

    /// After a complete output file was published: reads which runs it holds, and keeps beside
    /// it only the records it does not hold that `needed` says the sweep needs (its verification
    /// runs), in one log. The records it holds are read back from it from now on; records of
    /// runs not needed (orphans of an edited sweep) are removed. `grid`: the grid the file was
    /// just assembled from (used to read its records back when its run hashes are the file's).
    pub fn compact_after_publish(
        &self,
        grid: &Grid,
        needed: &dyn Fn(&RunHash) -> bool,
    ) -> Result<Compaction> {
        {
            let mut st = lock(&self.state);
            let stored = &mut st.stored;
            let Some(p) = PublishedFile::open_with(&self.output, Some(grid)) else {
                return Err(Error::Other(format!(
                    "{}: the output file just published cannot be read back",
                    self.output.display()
                )));
            };
            stored
                .entries
                .retain(|_, l| !matches!(l, Loc::Published { .. }));
            for (h, &(point, ok)) in &p.points {
                stored
                    .entries
                    .entry(*h)
                    .or_insert(Loc::Published { point, ok });
            }
            stored.published = Some(Mutex::new(p));
        }
        self.compact(needed, true)
    }

    /// Removes the records of runs that `needed` does not name (`chainsweep gc`): orphans of an
    /// edited sweep. The output file is left as it is.
    pub fn prune(&self, needed: &dyn Fn(&RunHash) -> bool) -> Result<Compaction> {
        self.compact(needed, false)
    }

    /// Rewrites every record in a log or segment that `keep` names, and (with `drop_published`)
    /// that the published output file does not hold with the same outcome, into one new log;
    /// then removes the other logs and segments. Crash-safe: the new log is written to `tmp/`,
    /// synced and renamed into place before anything is removed, and holds only records that
    /// were already stored.
    fn compact(&self, keep: &dyn Fn(&RunHash) -> bool, drop_published: bool) -> Result<Compaction> {
        let mut st = lock(&self.state);
        let State { stored, writer } = &mut *st;
        let mut report = Compaction::default();
        let mut moved: Vec<(RunHash, Loc)> = Vec::new();
        let mut gone: Vec<RunHash> = Vec::new();
        for (h, &loc) in &stored.entries {
            if matches!(loc, Loc::Published { .. }) {
                continue;
            }
            let in_file = stored
                .published
                .as_ref()
                .and_then(|p| lock(p).points.get(h).copied());
            if drop_published && in_file.map(|(_, ok)| ok) == Some(loc.ok()) {
                report.published += 1;
                gone.push(*h);
            } else if keep(h) {
                moved.push((*h, loc));
            } else {
                report.removed += 1;
                gone.push(*h);
            }
        }
        if gone.is_empty() && stored.segments == 0 && stored.logs.len() <= 1 {
            return Ok(report);
        }
        // In the order stored (sequential reads).
        moved.sort_by_key(|(_, l)| match *l {
            Loc::Log { log, offset, .. } => (log, offset),
            _ => (usize::MAX, 0),
        });
        let log_dir = self.dir.join(LOG_DIR);
        let mut new_entries: Vec<(RunHash, Loc)> = Vec::new();
        let mut new_log: Option<PathBuf> = None;
        if !moved.is_empty() {
            let tmp = self.tmp_path("compact.log");
            let written = (|| -> Result<()> {
                let f = File::create(&tmp).map_err(Error::io("create", &tmp))?;
                let mut out = std::io::BufWriter::with_capacity(1 << 20, f);
                let mut at = 0u64;
                for (h, loc) in &moved {
                    let Some(bytes) = stored.raw(h)? else {
                        continue;
                    };
                    if segment::verify(&bytes).map(|(vh, _)| vh) != Some(*h) {
                        continue;
                    }
                    let framed = frame(&bytes);
                    out.write_all(&framed).map_err(Error::io("write", &tmp))?;
                    new_entries.push((
                        *h,
                        Loc::Log {
                            log: 0,
                            offset: at + log::FRAME_HEAD,
                            len: bytes.len() as u64,
                            ok: loc.ok(),
                        },
                    ));
                    at += framed.len() as u64;
                }
                let f = out
                    .into_inner()
                    .map_err(|e| Error::io("write", &tmp)(e.into_error()))?;
                f.sync_all().map_err(Error::io("sync", &tmp))
            })();
            if let Err(e) = written {
                let _ = fs::remove_file(&tmp);
                return Err(e);
            }
            let dest = loop {
                let d = log_dir.join(log_name(stored.next_seq));
                stored.next_seq += 1;
                if !d.exists() {
                    break d;
                }
            };
            fs::rename(&tmp, &dest).map_err(Error::rename(&tmp, &dest))?;
            fsync_dir(&log_dir)?;
            new_log = Some(dest);
        }
        // The new log is durable: the old logs and segments can go.
        *writer = None;
        for path in &stored.logs {
            if Some(path) != new_log.as_ref() && fs::remove_file(path).is_ok() {
                report.files_removed += 1;
            }
        }
        let seg_dir = self.dir.join(SEGMENT_DIR);
        for entry in list_dir(&seg_dir)? {
            let named = entry.file_name().to_str().and_then(segment_hash).is_some();
            if named && is_file(&entry) && fs::remove_file(entry.path()).is_ok() {
                report.files_removed += 1;
            }
        }
        let _ = fs::remove_dir(&seg_dir);
        fsync_dir(&log_dir)?;
        stored.segments = 0;
        stored.logs = new_log.into_iter().collect();
        for h in gone {
            stored.entries.remove(&h);
        }
        for (h, _) in &moved {
            stored.entries.remove(h);
        }
        report.kept = new_entries.len();
        stored.entries.extend(new_entries);
        // Runs whose log record went but the output file holds: read from it.
        if let Some(p) = &stored.published {
            for (h, &(point, ok)) in &lock(p).points {
                stored
                    .entries
                    .entry(*h)
                    .or_insert(Loc::Published { point, ok });
            }
        }
        Ok(report)
    }
}

/// What `integrator: auto` chose, as cached in work directory `dir`; `None` when there is no
/// readable choice.
pub fn read_auto_choice_in(dir: &Path) -> Option<AutoChoice> {
    let text = fs::read_to_string(dir.join(AUTO_CHOICE_FILE)).ok()?;
    AutoChoice::from_json(&text).ok()
}
