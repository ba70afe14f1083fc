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
//! - `X.h5.d/snapshot`: a compact, checksummed copy of the summaries `X.h5` holds, written with
//!   it ([`snapshot`]); what damage to `X.h5` takes, it gives back.
//! - `X.h5.d/damaged/`: an output file that could not be read at all, kept (never deleted by a
//!   command other than `gc`) when a new one replaces it.
//!
//! `X.h5` itself is only ever replaced by renaming a completely written and `fsync`ed file over it
//! ([`WorkDir::publish`]), so it is always either the previous complete version or the new one.
//! It is a store of runs too: a run it holds (ok or failed) is read back from it, every value
//! checked against its checksum ([`published`]; bitwise the record written). So once a sweep is
//! complete and its file published, the logs are compacted ([`WorkDir::compact_after_publish`]):
//! only the records the file does not hold stay, in one log (verification runs, and the runs of
//! points the sweep no longer has: orphans of an edited sweep, which only `gc` removes). No
//! publish drops a run: one the previous file held that the new one does not is moved into the
//! log first.
//!
//! The work directory's own paths (`lock`, `logs/`, `tmp/`, `segments/`, `snapshot`, `damaged/`)
//! are never followed through a symbolic link: one there is an error that names it.
//!
//! Work directories of earlier versions hold one file per run, `segments/<runhash>.seg` (the
//! same record format, see [`segment`]); they are read, and moved into one log by the next
//! process that takes the lock.

pub mod hdf5;
pub mod log;
pub mod published;
pub mod segment;
pub mod snapshot;

use std::collections::HashMap;
use std::fs::{self, File, OpenOptions};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, MutexGuard, OnceLock};

use fs4::fs_std::FileExt as _;

use crate::error::{Error, Result};
use crate::grid::Grid;
use crate::identity::{from_hex, hex, RunHash};
use crate::record::RunRecord;
use crate::sweep::auto::AutoChoice;

use self::log::{log_name, log_seq, Framer, LOG_DIR};
use self::published::{Check, Damage, PublishedFile};
use self::segment::Checked;
use self::snapshot::SNAPSHOT_FILE;

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

/// The folder where an output file that could not be read at all is kept when a new one
/// replaces it.
pub const DAMAGED_DIR: &str = "damaged";

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
    fn ok(self) -> bool {
        match self {
            Loc::Segment { ok } | Loc::Log { ok, .. } | Loc::Published { ok, .. } => ok,
        }
    }
}

/// What a work directory (and its published output file) holds, as found by a scan: where each
/// stored run's record is. Memory: a few dozen bytes per run, never the records themselves.
pub struct Stored {
    dir: PathBuf,
    entries: HashMap<RunHash, Loc>,
    logs: Vec<LogFile>,
    segments: usize,
    published: Option<PublishedFile>,
    damage: Damage,
    ignored: Vec<PathBuf>,
    corrupt: usize,
    next_seq: u64,
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
struct LogFile {
    path: PathBuf,
    reader: OnceLock<File>,
    keys: log::KeyCache,
}

impl LogFile {
    fn new(path: PathBuf) -> LogFile {
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

/// Whether `entry` is a regular file (not a directory, link to one, socket, …).
fn is_file(entry: &fs::DirEntry) -> bool {
    entry.file_type().map(|t| t.is_file()).unwrap_or(false)
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
    fn raw(&self, hash: &RunHash) -> Result<Option<Checked>> {
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

/// The runs the output file `path` gives back (ok or failed), by hash, their summaries checked;
/// none when it is no readable chainsweep file.
pub fn published_runs(path: &Path) -> SegmentIndex {
    PublishedFile::open(path, None, Check::Summaries)
        .map(|p| p.runs().map(|(h, _, ok)| (*h, ok)).collect())
        .unwrap_or_default()
}

/// Lists the runs stored in work directory `dir` (not counting its output file) with their
/// status, checksums checked. A missing directory is an empty index.
pub fn scan_segments(dir: &Path) -> Result<SegmentIndex> {
    Ok(Stored::scan(dir, None, None, Check::Summaries)?.index())
}

/// `path` itself when it is not a symbolic link (or does not exist); an error naming it when it
/// is one: the work directory's own paths are never followed through links (clearing `tmp/`
/// through one would empty the folder it points to).
fn no_link(path: &Path) -> Result<PathBuf> {
    match fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_symlink() => Err(Error::Other(format!(
            "{} is a symbolic link; chainsweep does not follow links inside a work directory (remove it, and the work directory is used as it is)",
            path.display()
        ))),
        _ => Ok(path.to_path_buf()),
    }
}

/// The published output file of a locked work directory, held while borrowed.
pub struct PublishedGuard<'a> {
    st: MutexGuard<'a, State>,
}

impl std::ops::Deref for PublishedGuard<'_> {
    type Target = PublishedFile;
    fn deref(&self) -> &PublishedFile {
        self.st
            .stored
            .published
            .as_ref()
            .expect("checked when made")
    }
}

/// The log this process appends to.
#[derive(Debug)]
struct Writer {
    file: File,
    log: usize,
    end: u64,
    dirty: bool,
    framer: Framer,
}

#[derive(Debug)]
struct State {
    stored: Stored,
    writer: Option<Writer>,
}

/// What a compaction did.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Compaction {
    /// Records kept (moved into one log).
    pub kept: usize,
    /// Records held by the published output file, no longer kept beside it.
    pub published: usize,
    /// Records of runs not needed, removed.
    pub removed: usize,
    /// Those runs, by hash, and whether each succeeded.
    pub removed_runs: Vec<(RunHash, bool)>,
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
            let path = &stored.logs[w.log].path;
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

/// Whether a process holds the work directory of `output` (a run writing it now): `Some` with
/// the holder's pid as its lock file names it (empty when it names none), `None` when no process
/// holds it or there is no work directory. Takes no lock it keeps and creates nothing.
pub fn writer_of(output: &Path) -> Option<String> {
    let lock_path = work_dir_of(output).join("lock");
    let meta = fs::symlink_metadata(&lock_path).ok()?;
    if !meta.is_file() {
        return None;
    }
    let mut lock = File::open(&lock_path).ok()?;
    // A shared lock is refused while the writer holds its exclusive one; taken, it is let go at
    // once (when `lock` is closed).
    match fs4::fs_std::FileExt::try_lock_shared(&lock) {
        Ok(true) => None,
        Ok(false) => {
            let mut holder = String::new();
            let _ = Read::by_ref(&mut lock)
                .take(LOCK_READ_BYTES)
                .read_to_string(&mut holder);
            Some(holder.trim().to_string())
        }
        Err(_) => None,
    }
}

/// Most bytes of a lock file read to name its holder (a pid).
const LOCK_READ_BYTES: u64 = 64;

/// Takes the lock of the work directory `dir` of `output`; an error naming the holder's pid when
/// another process has it.
fn take_lock(dir: &Path, output: &Path) -> Result<File> {
    let lock_path = no_link(&dir.join("lock"))?;
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
        // The holder's pid: a few bytes (never read a damaged, huge lock file whole).
        let mut holder = String::new();
        let _ = Read::by_ref(&mut lock)
            .take(LOCK_READ_BYTES)
            .read_to_string(&mut holder);
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
    /// what it (and `output`, every value checked) holds; `known`: the caller's grid (see
    /// [`PublishedFile::open`]). One-file segments of an earlier version, and more than
    /// [`MAX_LOGS`] logs, are moved into one log. Fails with a clear message when another
    /// process holds the lock, or when a path of the work directory is a symbolic link.
    pub fn open(output: &Path, known: Option<&Grid>) -> Result<WorkDir> {
        let dir = work_dir_of(output);
        let logs = no_link(&dir.join(LOG_DIR))?;
        let tmp = no_link(&dir.join("tmp"))?;
        fs::create_dir_all(&logs).map_err(Error::io("create", &dir))?;
        fs::create_dir_all(&tmp).map_err(Error::io("create", &dir))?;
        let lock_file = take_lock(&dir, output)?;
        // Nobody else can be writing: leftovers in tmp/ are from a process that died, and so are
        // empty logs (a process that stored nothing). (Checked again under the lock: `tmp/` is
        // never emptied through a link.)
        let tmp = no_link(&tmp)?;
        for entry in fs::read_dir(&tmp).map_err(Error::io("list", &tmp))? {
            let entry = entry.map_err(Error::io("list", &tmp))?;
            if entry.file_type().is_ok_and(|t| !t.is_dir()) {
                let _ = fs::remove_file(entry.path());
            }
        }
        for entry in list_dir(&logs)? {
            let empty = entry.metadata().map(|m| m.is_file() && m.len() == 0);
            let named = entry.file_name().to_str().and_then(log_seq).is_some();
            if named && empty.unwrap_or(false) {
                let _ = fs::remove_file(entry.path());
            }
        }
        let stored = Stored::scan(&dir, Some(output), known, Check::Everything)?;
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
            work.compact(&|_| true, false, false)?;
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
        let segment_bytes = segment::encode(rec);
        let mut st = lock(&self.state);
        let State { stored, writer } = &mut *st;
        if writer.is_none() {
            *writer = Some(self.new_log(stored)?);
        }
        let w = writer.as_mut().expect("just created");
        let path = &stored.logs[w.log].path;
        let (bytes, packed) = w.framer.frame(&segment_bytes, w.end);
        if let Err(e) = w.file.write_all(&bytes) {
            let _ = w.file.set_len(w.end);
            w.framer.forget();
            return Err(Error::io("write", path)(e));
        }
        stored.entries.insert(
            rec.hash,
            Loc::Log {
                log: w.log,
                offset: w.end + log::FRAME_HEAD,
                len: bytes.len() as u64 - log::FRAME_HEAD,
                packed,
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
                    stored.logs.push(LogFile::new(path));
                    return Ok(Writer {
                        file,
                        log: stored.logs.len() - 1,
                        end: 0,
                        dirty: false,
                        framer: Framer::default(),
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

    /// What was found damaged in the output file and its snapshot when the work directory was
    /// opened (or since last published).
    pub fn damage(&self) -> Damage {
        lock(&self.state).stored.damage.clone()
    }

    /// The published output file as opened (or last re-read), when there is one.
    pub fn published_file(&self) -> Option<PublishedGuard<'_>> {
        let st = lock(&self.state);
        st.stored.published.as_ref()?;
        Some(PublishedGuard { st })
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

    /// Replaces the output file by the finished file at `tmp`, which holds the runs `holds`
    /// names, with its snapshot `snapshot`. No run is dropped: every run the current output file
    /// gives back that the new one does not hold (a point an edited sweep no longer has) is
    /// appended to the log first. An output file that could not be read at all is kept in
    /// `damaged/` (a hard link, or a copy). Then the snapshot and the file are renamed into place,
    /// each written, synced and its directory synced: each is always its previous complete
    /// version or the new one.
    pub fn publish(
        &self,
        tmp: &Path,
        snapshot: &[u8],
        holds: &dyn Fn(&RunHash) -> bool,
    ) -> Result<()> {
        self.keep_runs_not_held(holds)?;
        {
            let f = File::open(tmp).map_err(Error::io("open", tmp))?;
            f.sync_all().map_err(Error::io("sync", tmp))?;
        }
        self.keep_unreadable_output()?;
        write_atomic(
            &self.tmp_path("snapshot"),
            &self.dir.join(SNAPSHOT_FILE),
            snapshot,
        )?;
        fs::rename(tmp, &self.output).map_err(Error::rename(tmp, &self.output))?;
        let parent = match self.output.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        fsync_dir(&parent)
    }

    /// Appends to the log (and syncs) every run that only the published output file (or its
    /// snapshot) holds and `holds` does not name.
    fn keep_runs_not_held(&self, holds: &dyn Fn(&RunHash) -> bool) -> Result<()> {
        let records: Vec<RunRecord> = {
            let st = lock(&self.state);
            let Some(p) = &st.stored.published else {
                return Ok(());
            };
            p.runs()
                .map(|(h, _, _)| h)
                .filter(|h| {
                    !holds(h) && matches!(st.stored.entries.get(*h), Some(Loc::Published { .. }))
                })
                .filter_map(|h| p.read(h))
                .collect()
        };
        if records.is_empty() {
            return Ok(());
        }
        for rec in &records {
            self.write_segment(rec)?;
        }
        self.sync()
    }

    /// Keeps an output file that could not be read at all in `damaged/`, once: before a new one
    /// replaces it, whatever it still holds stays for a closer look (`gc` removes it).
    fn keep_unreadable_output(&self) -> Result<()> {
        let mut st = lock(&self.state);
        if st.stored.damage.file.is_none() || !self.output.is_file() {
            return Ok(());
        }
        let dir = no_link(&self.dir.join(DAMAGED_DIR))?;
        fs::create_dir_all(&dir).map_err(Error::io("create", &dir))?;
        let name = self
            .output
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "output.h5".into());
        let stamp = hdf5::utc_now().replace(':', "");
        let dest = (0..)
            .map(|k| dir.join(format!("{stamp}-{k}-{name}")))
            .find(|d| !d.exists())
            .expect("a free name");
        if fs::hard_link(&self.output, &dest).is_err() {
            fs::copy(&self.output, &dest).map_err(Error::io("copy to", &dest))?;
        }
        fsync_dir(&dir)?;
        st.stored.damage.file = None;
        Ok(())
    }

    /// After a complete output file was published: reads which runs it holds, and keeps beside
    /// it only the records it does not hold, in one log (verification runs, and orphans of an
    /// edited sweep, which only `gc` removes). The records it holds are read back from it from
    /// now on. `grid`: the grid the file was just assembled from (used to read its records back
    /// when its run hashes are the file's).
    pub fn compact_after_publish(&self, grid: &Grid) -> Result<Compaction> {
        {
            let mut st = lock(&self.state);
            let stored = &mut st.stored;
            // Just written from checked records: its summaries are checked again (a disk that
            // changed them since is caught), its histories at the next open.
            let p = PublishedFile::open(&self.output, Some(grid), Check::Summaries)
                .filter(|p| p.damage.file.is_none() && p.damage.lost.is_empty());
            let Some(p) = p else {
                return Err(Error::Other(format!(
                    "{}: the output file just published cannot be read back",
                    self.output.display()
                )));
            };
            stored
                .entries
                .retain(|_, l| !matches!(l, Loc::Published { .. }));
            for (h, _, ok) in p.runs() {
                stored.entries.entry(*h).or_insert(Loc::Published { ok });
            }
            stored.damage = p.damage.clone();
            stored.published = Some(p);
        }
        self.compact(&|_| true, true, false)
    }

    /// Removes the records of runs that `needed` does not name (`chainsweep gc`): orphans of an
    /// edited sweep; with `dry_run`, only says which. The output file is left as it is.
    pub fn prune(&self, needed: &dyn Fn(&RunHash) -> bool, dry_run: bool) -> Result<Compaction> {
        self.compact(needed, false, dry_run)
    }

    /// Rewrites every record in a log or segment that `keep` names, and (with `drop_published`)
    /// that the published output file does not hold with the same outcome, into one new log;
    /// then removes the other logs and segments. Crash-safe: the new log is written to `tmp/`,
    /// synced and renamed into place before anything is removed, and holds only records that
    /// were already stored. With `dry_run`, only reports what it would remove.
    fn compact(
        &self,
        keep: &dyn Fn(&RunHash) -> bool,
        drop_published: bool,
        dry_run: bool,
    ) -> Result<Compaction> {
        let mut st = lock(&self.state);
        let State { stored, writer } = &mut *st;
        let mut report = Compaction::default();
        let mut moved: Vec<(RunHash, Loc)> = Vec::new();
        let mut gone: Vec<RunHash> = Vec::new();
        for (h, &loc) in &stored.entries {
            if matches!(loc, Loc::Published { .. }) {
                continue;
            }
            let in_file = stored.published.as_ref().and_then(|p| p.ok(h));
            if drop_published && in_file == Some(loc.ok()) {
                report.published += 1;
                gone.push(*h);
            } else if keep(h) {
                moved.push((*h, loc));
            } else {
                report.removed += 1;
                report.removed_runs.push((*h, loc.ok()));
                gone.push(*h);
            }
        }
        report.removed_runs.sort();
        if dry_run || (gone.is_empty() && stored.segments == 0 && stored.logs.len() <= 1) {
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
                let mut framer = Framer::default();
                for (h, loc) in &moved {
                    let Some(checked) = stored.raw(h)?.filter(|c| c.hash() == *h) else {
                        continue;
                    };
                    let (framed, packed) = framer.frame(checked.bytes(), at);
                    out.write_all(&framed).map_err(Error::io("write", &tmp))?;
                    new_entries.push((
                        *h,
                        Loc::Log {
                            log: 0,
                            offset: at + log::FRAME_HEAD,
                            len: framed.len() as u64 - log::FRAME_HEAD,
                            packed,
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
        for LogFile { path, .. } in &stored.logs {
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
        stored.logs = new_log.into_iter().map(LogFile::new).collect();
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
            for (h, _, ok) in p.runs() {
                stored.entries.entry(*h).or_insert(Loc::Published { ok });
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
