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

/// Tries at the work directory's lock before another process is taken to hold it, and the wait
/// between them (in all 100 ms: a probe's shared lock lasts microseconds).
const LOCK_TRIES: u32 = 11;
const LOCK_RETRY_WAIT: std::time::Duration = std::time::Duration::from_millis(10);

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
    // A probe (`writer_of`: `status`, `report --watch`) holds a shared lock for an instant: a
    // few tries over a little while tell it from a process working on the output, which a
    // starting run would otherwise report as another process working (naming a dead pid).
    let mut got = false;
    for attempt in 0..LOCK_TRIES {
        got = lock
            .try_lock_exclusive()
            .map_err(Error::io("lock", &lock_path))?;
        if got {
            break;
        }
        if attempt + 1 < LOCK_TRIES {
            std::thread::sleep(LOCK_RETRY_WAIT);
        }
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_probe_s_instant_shared_lock_does_not_refuse_a_starting_run() {
        let dir = std::env::temp_dir().join(format!("chainsweep-lock-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let output = dir.join("out.h5");
        let lock_path = dir.join("lock");
        fs::write(&lock_path, "").unwrap();
        // A probe holds a shared lock for 30 ms, as `status` does for an instant.
        let probe = File::open(&lock_path).unwrap();
        assert!(fs4::fs_std::FileExt::try_lock_shared(&probe).unwrap());
        let release = std::thread::spawn(move || {
            std::thread::sleep(std::time::Duration::from_millis(30));
            drop(probe);
        });
        let taken = take_lock(&dir, &output);
        release.join().unwrap();
        assert!(taken.is_ok(), "{:?}", taken.err());
        // A process that keeps it is still refused, naming it.
        let other = File::open(&lock_path).unwrap();
        drop(taken);
        assert!(fs4::fs_std::FileExt::try_lock_shared(&other).unwrap());
        assert!(take_lock(&dir, &output).is_err());
        let _ = fs::remove_dir_all(&dir);
    }
}
