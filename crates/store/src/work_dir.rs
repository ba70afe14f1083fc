//! A locked work directory ([`WorkDir`]): the log this process appends to, checkpoints, the
//! output file published beside the logs, and compaction.

use std::fs::{self, File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, MutexGuard};

use chainsweep_sweep::error::{Error, Result};
use chainsweep_sweep::grid::Grid;
use chainsweep_sweep::identity::RunHash;
use chainsweep_sweep::record::RunRecord;
use chainsweep_sweep::sweep::auto::AutoChoice;

use crate::lock_file::take_lock;
use crate::log::{log_name, log_seq, Framer, LOG_DIR};
use crate::published::{Check, Damage, PublishedFile};
use crate::snapshot::SNAPSHOT_FILE;
use crate::stored::{segment_hash, Loc, LogFile, Stored};
use crate::{
    fsync_dir, is_file, list_dir, lock, no_link, work_dir_of, write_atomic, RunStore, SegmentIndex,
    AUTO_CHOICE_FILE, DAMAGED_DIR, MAX_LOGS, SEGMENT_DIR,
};
use crate::{hdf5, log, segment};

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
