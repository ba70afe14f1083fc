//! Storage: crash-safe segments in a work directory, and the HDF5 file assembled from them.
//!
//! An output `X.h5` has a sibling work directory `X.h5.d/`:
//!
//! - `X.h5.d/lock`: held with an exclusive `flock` by the process working on `X.h5`; a second
//!   process is refused. The kernel drops the lock when its holder dies, even by `kill -9`.
//! - `X.h5.d/segments/<runhash>.seg`: one file per finished run (see [`segment`]), written to
//!   `X.h5.d/tmp/`, `fsync`ed, renamed into place and the directory `fsync`ed; a segment either
//!   exists whole or not at all.
//! - `X.h5.d/tmp/`: temporary files, emptied by the next process that takes the lock.
//! - `X.h5.d/auto.json`: what `integrator: auto` chose ([`AutoChoice`]), written atomically.
//!
//! `X.h5` itself is only ever replaced by renaming a completely written and `fsync`ed file over it
//! ([`WorkDir::publish`]), so it is always either the previous complete version or the new one.

pub mod hdf5;
pub mod segment;

use std::collections::HashMap;
use std::fs::{self, File, OpenOptions};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use fs4::fs_std::FileExt;

use crate::error::{Error, Result};
use crate::identity::{from_hex, hex, RunHash};
use crate::record::RunRecord;
use crate::sweep::auto::AutoChoice;

/// Path of the work directory of an output file: `X.h5` → `X.h5.d`.
pub fn work_dir_of(output: &Path) -> PathBuf {
    let mut s = output.as_os_str().to_owned();
    s.push(".d");
    PathBuf::from(s)
}

/// What a work directory holds: status of every segment, by run hash.
pub type SegmentIndex = HashMap<RunHash, bool>;

/// Where finished runs are kept until the output file is assembled from them. The engine plans,
/// schedules and assembles through this narrow interface only, so that another layout (for
/// example append-only logs per worker) can replace one file per run.
pub trait RunStore: Sync {
    /// The stored record of the run `hash`; `None` when it is missing or unreadable (it is then
    /// run again).
    fn read(&self, hash: &RunHash) -> Result<Option<RunRecord>>;
    /// Stores a finished run, crash-safely: after a crash it is there whole or not at all.
    fn write(&self, rec: &RunRecord) -> Result<()>;
    /// Every stored run and whether it succeeded, reading as little as possible.
    fn index(&self) -> Result<SegmentIndex>;
}

impl RunStore for WorkDir {
    fn read(&self, hash: &RunHash) -> Result<Option<RunRecord>> {
        self.read_segment(hash)
    }

    fn write(&self, rec: &RunRecord) -> Result<()> {
        self.write_segment(rec)
    }

    fn index(&self) -> Result<SegmentIndex> {
        scan_segments(&self.dir)
    }
}

/// Name of the file in a work directory that holds what `integrator: auto` chose.
pub const AUTO_CHOICE_FILE: &str = "auto.json";

fn segment_hash(file_name: &str) -> Option<RunHash> {
    from_hex(file_name.strip_suffix(".seg")?)
}

/// Lists the segments under `dir/segments` with their status (ok or failed), reading only their
/// headers. A missing directory is an empty index.
pub fn scan_segments(dir: &Path) -> Result<SegmentIndex> {
    let mut index = SegmentIndex::new();
    let seg_dir = dir.join("segments");
    let entries = match fs::read_dir(&seg_dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(index),
        Err(e) => return Err(Error::io("list", &seg_dir)(e)),
    };
    for entry in entries {
        let entry = entry.map_err(Error::io("list", &seg_dir))?;
        let name = entry.file_name();
        let Some(hash) = name.to_str().and_then(segment_hash) else {
            continue;
        };
        let mut head = Vec::new();
        let mut f = match File::open(entry.path()) {
            Ok(f) => f,
            Err(_) => continue,
        };
        Read::by_ref(&mut f)
            .take(4096)
            .read_to_end(&mut head)
            .map_err(Error::io("read", &entry.path()))?;
        if let Some((ok, _)) = segment::peek_status(&head) {
            index.insert(hash, ok);
        }
    }
    Ok(index)
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
    /// Creates (if needed) and locks the work directory of `output`, and clears its `tmp/`.
    /// Fails with a clear message when another process holds the lock.
    pub fn open(output: &Path) -> Result<WorkDir> {
        let dir = work_dir_of(output);
        fs::create_dir_all(dir.join("segments")).map_err(Error::io("create", &dir))?;
        fs::create_dir_all(dir.join("tmp")).map_err(Error::io("create", &dir))?;
        let lock = take_lock(&dir, output)?;
        // Nobody else can be writing: leftovers in tmp/ are from a process that died.
        let tmp = dir.join("tmp");
        for entry in fs::read_dir(&tmp).map_err(Error::io("list", &tmp))? {
            let _ = fs::remove_file(entry.map_err(Error::io("list", &tmp))?.path());
        }
        Ok(WorkDir {
            output: output.to_path_buf(),
            dir,
            _lock: lock,
            counter: AtomicU64::new(0),
        })
    }

    /// Path of the segment of a run.
    pub fn segment_path(&self, hash: &RunHash) -> PathBuf {
        self.dir.join("segments").join(format!("{}.seg", hex(hash)))
    }

    /// A fresh temporary path in `tmp/`.
    pub fn tmp_path(&self, what: &str) -> PathBuf {
        let n = self.counter.fetch_add(1, Ordering::Relaxed);
        self.dir
            .join("tmp")
            .join(format!("{what}.{}.{n}.tmp", std::process::id()))
    }

    /// Writes a run's segment atomically: temporary file, fsync, rename, fsync of the directory.
    pub fn write_segment(&self, rec: &RunRecord) -> Result<()> {
        let tmp = self.tmp_path(&hex(&rec.hash));
        write_atomic(&tmp, &self.segment_path(&rec.hash), &segment::encode(rec))
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

    /// Reads a run's segment; `None` when it is missing or corrupt.
    pub fn read_segment(&self, hash: &RunHash) -> Result<Option<RunRecord>> {
        read_segment_in(&self.dir, hash)
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
}

/// Reads the segment of `hash` under work directory `dir`; `None` when missing or corrupt.
pub fn read_segment_in(dir: &Path, hash: &RunHash) -> Result<Option<RunRecord>> {
    let path = dir.join("segments").join(format!("{}.seg", hex(hash)));
    match fs::read(&path) {
        Ok(bytes) => Ok(segment::decode(&bytes).filter(|r| &r.hash == hash)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(Error::io("read", &path)(e)),
    }
}

/// What `integrator: auto` chose, as cached in work directory `dir`; `None` when there is no
/// readable choice.
pub fn read_auto_choice_in(dir: &Path) -> Option<AutoChoice> {
    let text = fs::read_to_string(dir.join(AUTO_CHOICE_FILE)).ok()?;
    AutoChoice::from_json(&text).ok()
}
