//! An `autonomous` block's families: the free orbits of the conservative scene at each grid
//! point, continued in their frequency ([`resume_autonomous`]), journaled one line per orbit, and
//! stored in the driven branches' layout.

use std::sync::atomic::AtomicBool;

use chainsweep_solver::observe::steady::SteadyProbe;
use chainsweep_solver::periodic::{
    resume_autonomous, AutonomousMap, AutonomousOrbit, Monodromy, PointKind,
};

use super::journal::{Entry, Journal};
use super::{probe_values, run_parts, PeriodicDryRun};
use crate::error::{Error, Result};
use crate::store::hdf5::periodic::StoredPoint;
use crate::sweep::periodic::PeriodicSpec;

/// The family of free orbits of grid point `point` at `frequencies`, after those `journal` holds
/// (each new one journaled by `write` and pushed onto it): how it ended, `None` when `stop`
/// stopped it.
pub(super) fn free_family(
    spec: &PeriodicSpec,
    point: &serde_json::Value,
    frequencies: &[f64],
    journal: &mut Journal,
    write: &mut dyn FnMut(&Entry) -> Result<()>,
    stop: &AtomicBool,
) -> Result<Option<Entry>> {
    let scene = spec.scene_of(point)?;
    let map = match AutonomousMap::new(&scene) {
        Ok(map) => map,
        Err(e) => {
            return Ok(Some(Entry::Failed {
                reason: e.to_string(),
            }))
        }
    };
    // The orbits journaled so far: their number says which frequencies are left, the last two
    // make the next guess.
    let journaled: Vec<&AutonomousOrbit> = journal
        .points
        .iter()
        .filter_map(|e| match e {
            Entry::Free { orbit, .. } => Some(orbit.as_ref()),
            _ => None,
        })
        .collect();
    let done = journaled.len().min(frequencies.len());
    let last_two: Vec<AutonomousOrbit> = journaled[journaled.len().saturating_sub(2)..]
        .iter()
        .map(|&o| o.clone())
        .collect();
    let mut failure: Option<Error> = None;
    let family = resume_autonomous(
        &map,
        map.first_guess(),
        &last_two,
        &frequencies[done..],
        spec.orbit.tolerance,
        spec.orbit.max_iterations,
        Some(stop),
        &mut |orbit| {
            if failure.is_some() {
                return;
            }
            let entry = free_entry(&map, &scene, orbit);
            if let Err(e) = write(&entry) {
                failure = Some(e);
            }
            journal.points.push(entry);
        },
    );
    if let Some(e) = failure {
        return Err(e);
    }
    if family.stopped {
        return Ok(None);
    }
    let orbits = journal.points.len();
    // Flows of the orbits found, journaled or new: the same whether or not it was resumed.
    let flows: u64 = journal
        .points
        .iter()
        .map(|e| match e {
            Entry::Free { orbit, .. } => u64::from(orbit.flows),
            _ => 0,
        })
        .sum();
    Ok(Some(match family.end {
        None => Entry::End {
            end: format!("reached the end of the range at {} Hz", spec.branch.to),
            warnings: Vec::new(),
            maps: flows,
        },
        Some(reason) if orbits == 0 => Entry::Failed {
            reason: format!("no first orbit: shooting failed {reason}"),
        },
        Some(reason) => Entry::End {
            end: format!("shooting failed {reason}: the family ends at the orbit before"),
            warnings: Vec::new(),
            maps: flows,
        },
    }))
}

/// The journal entry of a free orbit: the orbit and the run of two orbit periods from it.
pub(super) fn free_entry(
    map: &AutonomousMap,
    scene: &chainsweep_solver::Scene,
    orbit: &AutonomousOrbit,
) -> Entry {
    let mut kept = orbit.clone();
    kept.monodromy = Vec::new();
    let (probes, max, run_error) =
        run_parts(map.orbit_run(scene, orbit).map_err(|e| e.to_string()));
    Entry::Free {
        orbit: Box::new(kept),
        probes,
        max,
        run_error,
    }
}

/// Free orbit `index` of its family as stored: its kind by its place (the first `start`, the one
/// at the last frequency `end`), its stability to the accuracy of its monodromy, and as its
/// largest multiplier the largest but the pair at `+1` that every free orbit has; its arclength
/// the distance in frequency from the first orbit over the range.
pub(super) fn stored_free_point(
    spec: &PeriodicSpec,
    index: usize,
    o: &AutonomousOrbit,
    steady: Option<&[SteadyProbe]>,
    max: Option<&[f64]>,
    probes: usize,
    harmonics: usize,
) -> StoredPoint {
    let frequencies = spec.autonomous.as_deref().unwrap_or_default();
    let (first, last) = (
        frequencies.first().copied().unwrap_or(f64::NAN),
        frequencies.last().copied().unwrap_or(f64::NAN),
    );
    let f = o.frequency_hz();
    let kind = if index == 0 {
        PointKind::Start
    } else if index + 1 == frequencies.len() {
        PointKind::End
    } else {
        PointKind::Regular
    };
    let n = o.positions.len();
    StoredPoint {
        parameter: f,
        kind: 1 + kind.code(),
        stability: if o.stable_to_its_accuracy() { 1 } else { 2 },
        largest_multiplier: o.largest_nontrivial_multiplier(),
        multipliers: o.multipliers.clone(),
        position_m: o.positions.clone(),
        velocity_m_s: vec![0.0; n],
        arclength: (f - first).abs() / (last - first).abs(),
        iterations: i64::from(o.iterations),
        maps: i64::from(o.flows),
        method: 1,
        residual: o.residual,
        ..probe_values(steady, max, probes, harmonics)
    }
}

/// The budget of an `autonomous` block's families: a pilot, the first family's first orbit
/// shot and run as the block does, times the orbits of each family. `seconds_per_map` holds the pilot's shooting
/// and its run of two periods.
pub(super) fn dry_run_free(
    spec: &PeriodicSpec,
    point: &serde_json::Value,
    frequencies: &[f64],
    branches: usize,
    ended: usize,
) -> Result<PeriodicDryRun> {
    let scene = spec.scene_of(point)?;
    let map = AutonomousMap::new(&scene)
        .map_err(|e| Error::input(format!("base.{}", e.field), e.message))?;
    let from = frequencies[0];
    let started = std::time::Instant::now();
    let orbit = map
        .shoot(
            map.first_guess(),
            1.0 / from,
            spec.orbit.tolerance,
            spec.orbit.max_iterations,
        )
        .map_err(|e| {
            Error::input(
                "periodic",
                format!("the first orbit at {from} Hz from the first guess: {e}"),
            )
        })?;
    let shooting = started.elapsed().as_secs_f64();
    let started = std::time::Instant::now();
    map.orbit_run(&scene, &orbit).map_err(|e| {
        Error::input(
            "periodic",
            format!("two periods of the first orbit at {from} Hz: {e}"),
        )
    })?;
    let run = started.elapsed().as_secs_f64();
    Ok(PeriodicDryRun {
        branches,
        ended,
        max_points: frequencies.len() as u32,
        from,
        to: spec.branch.to,
        monodromy: Monodromy::Variational.name(),
        seconds_per_map: (shooting, run),
        settle_seconds: 0.0,
        most_cpu_seconds: (branches - ended) as f64 * frequencies.len() as f64 * (shooting + run),
    })
}
