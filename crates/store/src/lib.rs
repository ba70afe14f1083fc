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
//!
//! The index of stored runs is `stored`'s ([`Stored`]), the locked work directory `work_dir`'s
//! ([`WorkDir`]), its lock `lock_file`'s.

pub mod hdf5;
mod lock_file;
pub mod log;
pub mod published;
pub mod segment;
pub mod snapshot;
mod stored;
mod work_dir;

use std::collections::HashMap;
use std::fs::{self, File};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

use chainsweep_sweep::error::{Error, Result};
use chainsweep_sweep::identity::RunHash;
use chainsweep_sweep::record::RunRecord;
use chainsweep_sweep::sweep::auto::AutoChoice;

use self::published::{Check, PublishedFile};

pub use lock_file::writer_of;
pub use stored::Stored;
pub use work_dir::{Compaction, PublishedGuard, WorkDir};

/// Creates (if needed) the work directory of `output` with its folder `sub`, and locks it for this
/// process, without reading what it holds: for outputs that keep their own journals there (a
/// periodic sweep's branches), not runs. The lock lasts as long as the returned file.
pub fn lock_work_dir(output: &Path, sub: &str) -> Result<(File, PathBuf)> {
    let dir = work_dir_of(output);
    let folder = no_link(&dir.join(sub))?;
    fs::create_dir_all(&folder).map_err(Error::io("create", &dir))?;
    let lock = lock_file::take_lock(&dir, output)?;
    Ok((lock, no_link(&folder)?))
}

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

/// Whether `entry` is a regular file (not a directory, link to one, socket, …).
fn is_file(entry: &fs::DirEntry) -> bool {
    entry.file_type().map(|t| t.is_file()).unwrap_or(false)
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
pub fn no_link(path: &Path) -> Result<PathBuf> {
    match fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_symlink() => Err(Error::Other(format!(
            "{} is a symbolic link; chainsweep does not follow links inside a work directory (remove it, and the work directory is used as it is)",
            path.display()
        ))),
        _ => Ok(path.to_path_buf()),
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

/// What `integrator: auto` chose, as cached in work directory `dir`; `None` when there is no
/// readable choice.
pub fn read_auto_choice_in(dir: &Path) -> Option<AutoChoice> {
    let text = fs::read_to_string(dir.join(AUTO_CHOICE_FILE)).ok()?;
    AutoChoice::from_json(&text).ok()
}

/// The engine's error for a failure of the HDF5 library (without context: add it with
/// [`Error::hdf5_context`]).
pub(crate) fn h5(source: ::hdf5::Error) -> Error {
    Error::Hdf5 {
        context: String::new(),
        source: Box::new(source),
    }
}
