//! The work directory's lock: taken by the one process working on an output file (an error
//! naming the holder's pid otherwise), and asked after without being taken.

use std::fs::{self, File, OpenOptions};
use std::io::{Read, Write};
use std::path::Path;

use fs4::fs_std::FileExt as _;

use chainsweep_sweep::error::{Error, Result};

use crate::{no_link, work_dir_of};

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
pub(super) fn take_lock(dir: &Path, output: &Path) -> Result<File> {
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
