//! When `integrator: auto` is resolved, and where its choice comes from: the cache in the
//! output's work directory when it holds the choice for this sweep, else a pilot
//! ([`crate::numerics::auto::resolve`]); `merge` takes it from the shard files.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::grid::Grid;
use crate::numerics::auto as pilot;
use crate::store::{hdf5, WorkDir, AUTO_CHOICE_FILE};
use crate::sweep::auto::{describe, AutoChoice};
use crate::sweep::Sweep;

use super::{AutoResolution, ProgressSink};

/// How `integrator: auto` was resolved.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AutoOrigin {
    /// The sweep does not use `auto`.
    None,
    /// Taken from the cache in the output's work directory.
    Cache,
    /// Chosen by a pilot run now (to be cached by a command that holds the work directory).
    Pilot,
}

/// Resolves `integrator: auto` when the sweep asks for it: from the cache in `work_dir` when it
/// holds the choice for this sweep, else by running the pilot on `pool`; then rebuilds the grid
/// with the chosen integrator. `sink` hears the pilot's lines and the resolution.
pub fn resolve(
    sweep: &mut Sweep,
    grid: &mut Grid,
    work_dir: Option<&Path>,
    pool: &rayon::ThreadPool,
    sink: &mut dyn ProgressSink,
) -> Result<AutoOrigin> {
    let Some(spec) = sweep.auto else {
        return Ok(AutoOrigin::None);
    };
    if sweep.auto_choice.is_some() {
        return Ok(AutoOrigin::Cache);
    }
    let key = pilot::cache_key(grid, &spec);
    let (choice, origin) = match work_dir.and_then(|d| pilot::read_cache(d, &key).map(|c| (d, c))) {
        Some((dir, c)) => {
            sink.auto_resolved(AutoResolution::Cached {
                choice: &c,
                cache_file: &dir.join(AUTO_CHOICE_FILE),
            });
            (c, AutoOrigin::Cache)
        }
        None => {
            let c = pilot::resolve(sweep, grid, &spec, pool, |l| sink.pilot(l))?;
            sink.auto_resolved(AutoResolution::Chosen { choice: &c });
            (c, AutoOrigin::Pilot)
        }
    };
    sweep.apply_auto(choice);
    *grid = Grid::new(sweep)?;
    Ok(origin)
}

/// Caches the choice of `integrator: auto` in the (locked) work directory.
pub fn cache(work: &WorkDir, sweep: &Sweep) -> Result<()> {
    if let Some(c) = &sweep.auto_choice {
        work.write_auto_choice(c)?;
    }
    Ok(())
}

/// What the status of a sweep file found about `integrator: auto`.
#[derive(Debug, Clone)]
pub enum CachedChoice {
    /// The sweep does not use `auto`.
    NotAuto,
    /// The work directory holds the choice for this sweep (now applied to it).
    Chosen(Box<AutoChoice>),
    /// Not chosen yet: the cache file (which holds no choice for this sweep).
    NotChosen(PathBuf),
}

/// Applies the choice cached in `work_dir` to an `auto` sweep, without running a pilot.
pub fn apply_cached(sweep: &mut Sweep, grid: &mut Grid, work_dir: &Path) -> Result<CachedChoice> {
    let Some(spec) = sweep.auto else {
        return Ok(CachedChoice::NotAuto);
    };
    match pilot::read_cache(work_dir, &pilot::cache_key(grid, &spec)) {
        Some(c) => {
            sweep.apply_auto(c.clone());
            *grid = Grid::new(sweep)?;
            Ok(CachedChoice::Chosen(Box::new(c)))
        }
        None => Ok(CachedChoice::NotChosen(work_dir.join(AUTO_CHOICE_FILE))),
    }
}

/// Resolves `integrator: auto` of a merged sweep from its shard files: every shard must record
/// the same choice, made for this grid and engine version.
pub fn apply_from_shards(sweep: &mut Sweep, grid: &mut Grid, shards: &[PathBuf]) -> Result<()> {
    let Some(spec) = sweep.auto else {
        return Ok(());
    };
    // Every shard resolved `auto` alike (the choice is deterministic): take it from them.
    let key = pilot::cache_key(grid, &spec);
    let mut choice: Option<AutoChoice> = None;
    for s in shards {
        let c = hdf5::read_auto_choice(s)?.ok_or_else(|| {
            Error::Other(format!(
                "{}: the sweep's integrator is `auto` but the file records no choice (`auto` attribute)",
                s.display()
            ))
        })?;
        if c.key != key {
            return Err(Error::Other(format!(
                "{}: its `auto` choice was made for another grid or engine version (key {}, this chainsweep computes {key})",
                s.display(),
                c.key
            )));
        }
        match &choice {
            None => choice = Some(c),
            Some(first) if *first != c => {
                return Err(Error::Other(format!(
                    "{}: its `auto` choice ({}) differs from that of {} ({})",
                    s.display(),
                    describe(&c.integrator),
                    shards[0].display(),
                    describe(&first.integrator)
                )))
            }
            _ => {}
        }
    }
    sweep.apply_auto(choice.expect("at least one shard"));
    *grid = Grid::new(sweep)?;
    Ok(())
}
