//! Grid expansion: the product of the sweep's dimensions, each point a complete scene with its
//! run hash.
//!
//! Points are numbered in row-major (C) order: the last dimension varies fastest. Each point's
//! run hash is [`crate::identity::run_hash`] of its scene.

use serde_json::Value;

use chainsweep_solver::observe::probes::{samples_in, FieldSpec};
use chainsweep_solver::{Probe, Scene};

use crate::error::{Error, Result};
use crate::identity::{run_hash_with, RunHash};
use crate::sweep::{from_ref_at, from_value_at, set_path, split_path, Sweep};

/// The expanded grid of a sweep.
#[derive(Debug, Clone)]
pub struct Grid {
    /// Shape, outermost dimension first.
    pub shape: Vec<usize>,
    /// Run hash of every point, in row-major order.
    pub hashes: Vec<RunHash>,
    /// The probes every point records (the same for all points).
    pub probes: Vec<Probe>,
    /// Whether points record full histories.
    pub history: bool,
    /// Whether points record minimum overlaps.
    pub min_overlap: bool,
    /// Whether points record the energy flow (`record.energy_flow`).
    pub energy_flow: bool,
    /// Whether points record the linear spectrum at the static state (`record.spectrum`).
    pub spectrum: bool,
    /// Whether the points are driven (`excitation.drive`, as the first point is).
    pub driven: bool,
    /// Whether points record the energy ledger's terms (`record.energy_ledger`).
    pub energy_ledger: bool,
    /// Harmonics of the steady state every point records (`record.steady_state.harmonics`; 0
    /// without it).
    pub steady_harmonics: usize,
    /// Largest number of history samples any point records (0 without histories).
    pub max_history_samples: usize,
    /// The history interval every point shares, s (`None`: the points' intervals differ, or
    /// there are no histories): the output file then stores one time axis for every run.
    pub history_interval_s: Option<f64>,
    /// Largest number of contacts of any point (for minimum overlaps and contact fields).
    pub max_contacts: usize,
    /// The space–time fields every point records (`record.fields`, the same at every point:
    /// one time axis `i · interval_s` for every run).
    pub fields: Option<FieldSpec>,
    /// Largest number of field samples any point records (0 without fields).
    pub max_field_samples: usize,
    /// Largest number of particles of any point (for particle fields).
    pub max_particles: usize,
    /// Whether some point integrates only the moving part of its chain
    /// ([`chainsweep_solver::integrates_moving_part`]): the output file then says, per run, how
    /// much of its chain each run integrated.
    pub moving_part: bool,
    /// Particles of every point's chain, striker included (row-major): what a run that
    /// integrated its whole chain integrated.
    pub particles: Vec<u32>,
    /// The first [`LISTED_WARNINGS`] points whose scene looks physically absurd before it runs
    /// ([`chainsweep_solver::Scene::plausibility_warnings`]), with their warnings.
    pub warnings: Vec<(usize, Vec<String>)>,
    /// How many points have such warnings.
    pub warned_points: usize,
    /// The points of a search's grid: each a point of the sweep's own grid with the searched
    /// fields set (`None` for a sweep's own grid).
    pub searched: Option<Searched>,
}

/// Where the points of a search's grid come from.
#[derive(Debug, Clone, PartialEq)]
pub struct Searched {
    /// The searched fields (dotted paths).
    pub fields: Vec<String>,
    /// Their names.
    pub names: Vec<String>,
    /// Per point: its point of the sweep's own grid and the searched fields' values (empty:
    /// no run at this point).
    pub points: Vec<(usize, Vec<f64>)>,
}

/// How many points with warnings a grid lists (it counts them all).
pub const LISTED_WARNINGS: usize = 10;

/// Multi-index of flat point `index` in a grid of `shape`.
pub fn multi_index(shape: &[usize], mut index: usize) -> Vec<usize> {
    let mut out = vec![0; shape.len()];
    for (d, &n) in shape.iter().enumerate().rev() {
        out[d] = index % n;
        index /= n;
    }
    out
}

/// Maps an error at scene field `field` of point `index` to the axis that set it, if any.
fn locate(sweep: &Sweep, shape: &[usize], index: usize, field: &str, message: &str) -> Error {
    let segs = split_path(field);
    let mi = multi_index(shape, index);
    for (d, dim) in sweep.dims.iter().enumerate() {
        for axis in &dim.axes {
            let a = split_path(&axis.field);
            let n = a.len().min(segs.len());
            if a[..n] == segs[..n] {
                // A misspelt field is the axis's field at fault, whatever its values.
                if message.starts_with("unknown field") {
                    return Error::input(
                        format!("{}.field", axis.origin),
                        format!("`{}` is no field of the scene: {message}", axis.field),
                    );
                }
                let j = mi[d];
                // An ensemble's values are drawn, not listed: its input's distribution is at
                // fault.
                if axis.origin.starts_with("ensemble") {
                    return Error::input(
                        axis.origin.clone(),
                        format!(
                            "its distribution reaches values the scene refuses (narrow or truncate it): member {j} sets `{}` to {}: `{field}` {message}",
                            axis.field, axis.values[j]
                        ),
                    );
                }
                return Error::input(
                    format!("{}.values[{j}]", axis.origin),
                    format!(
                        "sets `{}` to {}: `{field}` {message}",
                        axis.field, axis.values[j]
                    ),
                );
            }
        }
    }
    // Not set by an axis: a base field (the record block is given at the top level), invalid at
    // this point because of the other axis values, which the message lists.
    let name = if field == "record" || field.starts_with("record.") || field.starts_with("record[")
    {
        field.to_string()
    } else {
        format!("base.{field}")
    };
    let mut labels = Vec::new();
    for (d, dim) in sweep.dims.iter().enumerate() {
        for axis in &dim.axes {
            labels.push(format!("{}={}", axis.name, axis.values[mi[d]]));
        }
    }
    Error::input(
        name,
        format!("{message} (at grid point {index}: {})", labels.join(", ")),
    )
}

/// Points a worker expands at a time, at most (and between two calls of the progress callback).
const CHUNK_POINTS: usize = 4096;
/// Chunks each thread takes on average when a grid is shared out, so that a thread slow to start
/// leaves only a few chunks to the others to take up.
const CHUNKS_PER_THREAD: usize = 4;
/// The fewest points a chunk of a shared-out grid holds (about 0.25 ms of work).
const MIN_CHUNK_POINTS: usize = 16;
/// Grids of fewer points are expanded on the calling thread alone. A point takes about 15 µs
/// (its scene read, validated and hashed), so the Fig. 8 sweep's 182 took 2.8 ms on one thread
/// before its first run started. A helper thread takes 0.1 ms or more to start: a grid of fewer
/// than about 15 points would not win that back, and a one-point run from Python never pays it.
const PARALLEL_MIN_POINTS: usize = 64;

/// What the points of one chunk add to the grid beside their hashes and particle counts.
#[derive(Default)]
struct ChunkInfo {
    max_history_samples: usize,
    /// The first history interval seen, and whether another differed from it.
    history_interval_s: Option<f64>,
    history_intervals_differ: bool,
    max_contacts: usize,
    max_field_samples: usize,
    moving_part: bool,
    warnings: Vec<(usize, Vec<String>)>,
    warned_points: usize,
}

/// What every point must share with the first: the record block (one layout for the arrays).
struct Record<'a> {
    probes: &'a [Probe],
    history: bool,
    min_overlap: bool,
    energy_flow: bool,
    spectrum: bool,
    fields: &'a Option<FieldSpec>,
    steady_harmonics: usize,
    energy_ledger: bool,
}

/// The steady state's harmonics a record block asks for (0 without `steady_state`).
fn steady_harmonics(record: &chainsweep_solver::RecordSpec) -> usize {
    record
        .steady_state
        .as_ref()
        .map_or(0, |s| s.harmonics as usize)
}

impl Grid {
    /// Whether the leading pulse is a question this grid's runs ask: not where they are driven or
    /// record a steady state (a NaN leading peak there calls for no remedy, and none is offered).
    pub fn asks_leading_pulses(&self) -> bool {
        !self.driven && self.steady_harmonics == 0
    }

    /// Whether the grid's runs record arrays of their own beside the summaries: histories,
    /// minimum overlaps, space–time fields or the energy flow (in layouts 4 and earlier, a group
    /// under `runs/`).
    pub fn has_run_arrays(&self) -> bool {
        self.history || self.min_overlap || self.fields.is_some() || self.energy_flow
    }

    /// Expands and validates every point of the sweep: an invalid point is an input error naming
    /// the field and the axis value that made it (the first such point in grid order).
    pub fn new(sweep: &Sweep) -> Result<Grid> {
        Grid::expand(sweep, &|_| {})
    }

    /// [`Grid::new`] and the scene of its first point, which the expansion builds anyway: what a
    /// one-point sweep (a scene run from Python) runs, without reading its JSON again. `read`:
    /// that scene, where the caller has read it already from the sweep as it is (the base scene
    /// [`Sweep::of_scene`] gives beside the sweep); it is not read again.
    pub fn with_first_scene(sweep: &Sweep, read: Option<Scene>) -> Result<(Grid, Scene)> {
        Grid::expand_keeping_first(sweep, &|_| {}, read, None)
    }

    /// [`Grid::new`], calling `progress` with the number of points expanded so far after each
    /// chunk of at most a few thousand points (from the threads expanding them). A grid of more
    /// than a few dozen points is expanded in chunks by this thread and helpers made for it; the
    /// grid is the same as a sequential expansion's, whatever the threads (every value is
    /// computed per point, and the chunks' findings are merged in grid order).
    pub fn expand(sweep: &Sweep, progress: &(dyn Fn(usize) + Sync)) -> Result<Grid> {
        Grid::expand_keeping_first(sweep, progress, None, None).map(|(grid, _)| grid)
    }

    /// [`Grid::expand`], returning the first point's scene too, on `threads` threads (`None`:
    /// one for a grid of fewer than [`PARALLEL_MIN_POINTS`], else one per CPU).
    fn expand_keeping_first(
        sweep: &Sweep,
        progress: &(dyn Fn(usize) + Sync),
        read: Option<Scene>,
        threads: Option<usize>,
    ) -> Result<(Grid, Scene)> {
        use std::sync::atomic::{AtomicUsize, Ordering};
        use std::sync::Mutex;
        let shape = sweep.shape();
        let n = shape.iter().try_fold(1usize, |acc, &x| acc.checked_mul(x));
        let n = match n {
            Some(n) if n <= crate::sweep::MAX_GRID_POINTS => n,
            _ => {
                return Err(Error::input(
                    "axes",
                    format!(
                        "the grid {} has more than {} points",
                        shape
                            .iter()
                            .map(|x| x.to_string())
                            .collect::<Vec<_>>()
                            .join(" × "),
                        crate::sweep::MAX_GRID_POINTS
                    ),
                ))
            }
        };
        let mut grid = Grid {
            shape,
            hashes: vec![[0; 32]; n],
            probes: Vec::new(),
            history: false,
            min_overlap: false,
            energy_flow: false,
            spectrum: false,
            driven: false,
            energy_ledger: false,
            steady_harmonics: 0,
            max_history_samples: 0,
            history_interval_s: None,
            max_contacts: 0,
            fields: None,
            max_field_samples: 0,
            max_particles: 0,
            moving_part: false,
            particles: vec![0; n],
            warnings: Vec::new(),
            warned_points: 0,
            searched: None,
        };
        // The first point sets the record block every point must share.
        let first = match read {
            Some(scene) => scene,
            None => grid.build(sweep, 0)?,
        };
        grid.probes = first.record.probes.clone();
        grid.history = first.record.history;
        grid.min_overlap = first.record.min_overlap;
        grid.energy_flow = first.record.energy_flow;
        grid.spectrum = first.record.spectrum.is_some();
        grid.driven = matches!(
            first.excitation,
            Some(chainsweep_solver::scene::Excitation::Drive(_))
        );
        grid.fields = first.record.fields.clone();
        grid.energy_ledger = first.record.energy_ledger;
        grid.steady_harmonics = steady_harmonics(&first.record);
        let fields = grid.fields.clone();
        let record = Record {
            probes: &grid.probes,
            history: grid.history,
            min_overlap: grid.min_overlap,
            energy_flow: grid.energy_flow,
            spectrum: grid.spectrum,
            fields: &fields,
            steady_harmonics: grid.steady_harmonics,
            energy_ledger: grid.energy_ledger,
        };
        let shape = &grid.shape;
        let done = AtomicUsize::new(0);
        // A grid of fewer than PARALLEL_MIN_POINTS is expanded on this thread; a larger one by
        // this thread and one more per further CPU this process may use, gone after (no thread
        // outlives it). (The CPUs are asked only for such a grid: on Linux the answer reads the
        // cgroup's quota files, tens of microseconds that a one-point run from Python would pay.)
        // What the chunks find is merged in grid order, so the grid is the same whatever the
        // chunks and threads.
        let threads = threads.unwrap_or_else(|| {
            if n < PARALLEL_MIN_POINTS {
                1
            } else {
                std::thread::available_parallelism().map_or(1, |t| t.get())
            }
        });
        let chunk_points = if threads == 1 {
            n.max(1)
        } else {
            n.div_ceil(threads * CHUNKS_PER_THREAD)
                .clamp(MIN_CHUNK_POINTS, CHUNK_POINTS)
        };
        let expand_chunk = |c: usize, hashes: &mut [RunHash], particles: &mut [u32]| {
            let start = c * chunk_points;
            let mut info = ChunkInfo::default();
            // One copy of the base scene per chunk, every axis value set in it per point (every
            // point sets every axis, in the same order, so it equals a fresh copy's); made only
            // where a point is read from it.
            let mut value: Option<Value> = None;
            for (k, (hash, parts)) in hashes.iter_mut().zip(particles.iter_mut()).enumerate() {
                let i = start + k;
                // The first point was read above: its scene is not read from its JSON twice.
                let read;
                let scene = if i == 0 {
                    &first
                } else {
                    let value = value.get_or_insert_with(|| sweep.base.clone());
                    read = Grid::read_point(sweep, shape, i, value)?;
                    &read
                };
                Grid::check_point(sweep, shape, i, &record, scene, hash, parts, &mut info)?;
            }
            let total = done.fetch_add(hashes.len(), Ordering::Relaxed) + hashes.len();
            progress(total);
            Ok(info)
        };
        let chunks: Vec<Result<ChunkInfo>> = if threads == 1 || n <= chunk_points {
            vec![expand_chunk(0, &mut grid.hashes, &mut grid.particles)]
        } else {
            // Chunks are handed out one at a time, in grid order, to whichever thread asks next:
            // this one starts at once, and a helper slow to start (a loaded machine; measured at
            // up to 1.4 ms on two shared CPUs) takes fewer of them rather than holding back the
            // rest.
            let work = Mutex::new(
                grid.hashes
                    .chunks_mut(chunk_points)
                    .zip(grid.particles.chunks_mut(chunk_points))
                    .enumerate(),
            );
            let found = Mutex::new(Vec::new());
            let expand_chunks = || loop {
                let next = work
                    .lock()
                    .expect("no chunk is taken while panicking")
                    .next();
                let Some((c, (hashes, particles))) = next else {
                    break;
                };
                let info = expand_chunk(c, hashes, particles);
                found
                    .lock()
                    .expect("no chunk is stored while panicking")
                    .push((c, info));
            };
            std::thread::scope(|s| {
                // (No more helpers than there are chunks for them.)
                let chunks = n.div_ceil(chunk_points);
                for _ in 1..threads.min(chunks) {
                    // A helper that cannot be started leaves its chunks to the others.
                    let _ = std::thread::Builder::new().spawn_scoped(s, expand_chunks);
                }
                expand_chunks();
            });
            let mut found = found.into_inner().expect("every helper has ended");
            found.sort_unstable_by_key(|&(c, _)| c);
            found.into_iter().map(|(_, info)| info).collect()
        };
        let mut intervals_differ = false;
        for c in chunks {
            let c = c?;
            grid.max_history_samples = grid.max_history_samples.max(c.max_history_samples);
            intervals_differ |= c.history_intervals_differ;
            if let Some(dt) = c.history_interval_s {
                match grid.history_interval_s {
                    None => grid.history_interval_s = Some(dt),
                    Some(d) if d.to_bits() != dt.to_bits() => intervals_differ = true,
                    Some(_) => {}
                }
            }
            grid.max_contacts = grid.max_contacts.max(c.max_contacts);
            grid.max_field_samples = grid.max_field_samples.max(c.max_field_samples);
            grid.moving_part |= c.moving_part;
            grid.warned_points += c.warned_points;
            for w in c.warnings {
                if grid.warnings.len() < LISTED_WARNINGS {
                    grid.warnings.push(w);
                }
            }
        }
        if intervals_differ {
            grid.history_interval_s = None;
        }
        grid.max_particles = grid.particles.iter().max().map_or(0, |&p| p as usize);
        if let Some(c) = sweep.continuation {
            // A point continues from its predecessor's bodies: every point of a line has the same
            // particles, plastic contacts, walls and mount (an axis that changes them, a chain's
            // length, a wall on or off, Thornton's law to Hertz's, is refused here, not point by
            // point as the runs fail).
            let bodies = (0..n)
                .map(|i| {
                    let chain = grid
                        .build(sweep, i)
                        .and_then(|s| s.validate().map_err(|e| Error::input(e.field, e.message)))?;
                    Ok((
                        chain.n_particles(),
                        chain.wall,
                        chain.top_wall_m.is_some(),
                        chain.ring,
                        chain
                            .plastic_contacts()
                            .iter()
                            .map(|p| p.0)
                            .collect::<Vec<_>>(),
                        chain.wall_mount.is_some(),
                    ))
                })
                .collect::<Result<Vec<_>>>()?;
            for p in 0..n {
                if let Some(q) = c.predecessor(&grid.shape, p) {
                    if bodies[p] != bodies[q] {
                        return Err(Error::input(
                            "continuation.axis",
                            format!(
                                "a point continues from the final state of the point before it on its line, so every point of a line must have the same bodies (particles, walls, plastic contacts, a mounted wall): point {p} ({}) differs from point {q} ({})",
                                grid.point_label(sweep, p),
                                grid.point_label(sweep, q)
                            ),
                        ));
                    }
                }
            }
            // Each point's identity takes in its predecessor's, already continued: points are
            // visited in the line's own order, so the predecessor always comes first.
            let order: Vec<usize> = if c.downwards {
                (0..n).rev().collect()
            } else {
                (0..n).collect()
            };
            for p in order {
                if let Some(q) = c.predecessor(&grid.shape, p) {
                    grid.hashes[p] =
                        crate::identity::continued_hash(&grid.hashes[p], &grid.hashes[q]);
                }
            }
        }
        Ok((grid, first))
    }

    /// The errors of a sweep's grid points, each distinct error once, at most `most`: what
    /// [`Grid::new`] would refuse, for every point rather than the first (`chainsweep validate`).
    /// Points are checked in grid order on this thread, and the check ends at `most` errors.
    pub fn point_errors(sweep: &Sweep, most: usize) -> Vec<Error> {
        let first = match Grid::new(sweep) {
            Ok(_) => return Vec::new(),
            Err(e) => e,
        };
        let shape = sweep.shape();
        let n: usize = shape.iter().product();
        if n > crate::sweep::MAX_GRID_POINTS {
            return vec![first];
        }
        // The record block every point must share: the first point's that can be read (as in
        // `expand`), else the base scene's.
        let mut value = sweep.base.clone();
        let reference: Option<chainsweep_solver::RecordSpec> = (0..n)
            .find_map(|i| {
                Grid::set_point(sweep, &shape, i, &mut value);
                from_ref_at::<Scene>(&value, "").ok().map(|s| s.record)
            })
            .or_else(|| from_ref_at::<Scene>(&sweep.base, "").ok().map(|s| s.record));
        let Some(reference) = reference else {
            return vec![first];
        };
        let record = Record {
            probes: &reference.probes,
            history: reference.history,
            min_overlap: reference.min_overlap,
            energy_flow: reference.energy_flow,
            spectrum: reference.spectrum.is_some(),
            fields: &reference.fields,
            steady_harmonics: steady_harmonics(&reference),
            energy_ledger: reference.energy_ledger,
        };
        // A base field's error is the same at many points, told apart only by the point named
        // at its end: listed once, with the number of points it holds at.
        let key = |e: &Error| match e {
            Error::Input { field, message, .. } => {
                let m = message.split(" (at grid point ").next().unwrap_or(message);
                format!("{field}\u{0}{m}")
            }
            other => other.to_string(),
        };
        let mut errors: Vec<(Error, usize)> = Vec::new();
        let mut index: std::collections::HashMap<String, usize> = Default::default();
        for i in 0..n {
            let (mut hash, mut parts, mut info) = ([0; 32], 0, ChunkInfo::default());
            let r = Grid::read_point(sweep, &shape, i, &mut value).and_then(|scene| {
                Grid::check_point(
                    sweep, &shape, i, &record, &scene, &mut hash, &mut parts, &mut info,
                )
            });
            if let Err(e) = r {
                match index.entry(key(&e)) {
                    std::collections::hash_map::Entry::Occupied(o) => errors[*o.get()].1 += 1,
                    std::collections::hash_map::Entry::Vacant(v) => {
                        if errors.len() >= most {
                            break;
                        }
                        v.insert(errors.len());
                        errors.push((e, 1));
                    }
                }
            }
        }
        if errors.is_empty() {
            return vec![first];
        }
        errors
            .into_iter()
            .map(|(e, points)| match e {
                Error::Input {
                    file,
                    field,
                    message,
                } if points > 1 => Error::Input {
                    file,
                    field,
                    message: format!("{message}; the same at {points} grid points"),
                },
                e => e,
            })
            .collect()
    }

    /// Sets every axis value of point `i` in `value` (the base scene, or a copy that every axis
    /// has been set in: every point sets every axis, in the same order).
    fn set_point(sweep: &Sweep, shape: &[usize], i: usize, value: &mut Value) {
        let mi = multi_index(shape, i);
        for (d, dim) in sweep.dims.iter().enumerate() {
            for axis in &dim.axes {
                set_path(value, &axis.field, axis.values[mi[d]].clone());
            }
        }
    }

    /// Point `i`'s scene: every axis value of the point set in `value` (see [`Grid::set_point`]),
    /// read from that JSON; errors name the point.
    fn read_point(sweep: &Sweep, shape: &[usize], i: usize, value: &mut Value) -> Result<Scene> {
        Grid::set_point(sweep, shape, i, value);
        from_ref_at::<Scene>(value, "").map_err(|e| match e {
            Error::Input { field, message, .. } => locate(sweep, shape, i, &field, &message),
            other => other,
        })
    }

    /// Validates point `i`'s `scene` and writes its run hash and particle count; what it adds to
    /// the chunk goes to `info`.
    #[allow(clippy::too_many_arguments)]
    fn check_point(
        sweep: &Sweep,
        shape: &[usize],
        i: usize,
        record: &Record<'_>,
        scene: &Scene,
        hash: &mut RunHash,
        particles: &mut u32,
        info: &mut ChunkInfo,
    ) -> Result<()> {
        let chain = scene
            .validate()
            .map_err(|e| locate(sweep, shape, i, &e.field, &e.message))?;
        if scene.record.probes != record.probes
            || scene.record.history != record.history
            || scene.record.min_overlap != record.min_overlap
            || scene.record.energy_flow != record.energy_flow
            || scene.record.spectrum.is_some() != record.spectrum
            || scene.record.fields != *record.fields
            || steady_harmonics(&scene.record) != record.steady_harmonics
            || scene.record.energy_ledger != record.energy_ledger
        {
            return Err(locate(
                sweep,
                shape,
                i,
                "record",
                "must be the same at every grid point (probes, history, min_overlap, energy_flow, fields, whether spectrum is recorded, whether steady_state is and its harmonics): the stored arrays and columns share one layout",
            ));
        }
        if scene.record.history {
            let dt = scene.record.history_interval_s;
            let samples = samples_in(0.0, dt, scene.duration_s) as usize;
            info.max_history_samples = info.max_history_samples.max(samples);
            match info.history_interval_s {
                None => info.history_interval_s = Some(dt),
                Some(d) if d.to_bits() != dt.to_bits() => info.history_intervals_differ = true,
                Some(_) => {}
            }
        }
        info.max_contacts = info.max_contacts.max(chain.n_contacts());
        if let Some(f) = &scene.record.fields {
            let samples = samples_in(0.0, f.interval_s, scene.duration_s) as usize;
            info.max_field_samples = info.max_field_samples.max(samples);
        }
        // At most MAX_PARTICLES (2 000 002), checked by validate.
        *particles = chain.n_particles() as u32;
        let warnings = scene.plausibility_warnings(&chain);
        if !warnings.is_empty() {
            info.warned_points += 1;
            if info.warnings.len() < LISTED_WARNINGS {
                info.warnings.push((i, warnings));
            }
        }
        let moving_part = chainsweep_solver::integrates_moving_part_of(scene, &chain);
        info.moving_part |= moving_part;
        *hash = run_hash_with(scene, sweep.limits.energy_drift_max, moving_part);
        Ok(())
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.hashes.len()
    }

    /// Whether the grid has no points (never true for a parsed sweep).
    pub fn is_empty(&self) -> bool {
        self.hashes.is_empty()
    }

    /// Describes point `index` by its axis values: `mass_ratio=0.3 damping_kg_s=6` (and, in a
    /// search's grid, the searched fields' values).
    pub fn point_label(&self, sweep: &Sweep, index: usize) -> String {
        let (own, values) = self.own_point(index);
        let mi = multi_index(&sweep.shape(), own);
        let mut parts = Vec::new();
        for (d, dim) in sweep.dims.iter().enumerate() {
            for a in &dim.axes {
                parts.push(format!("{}={}", a.name, a.values[mi[d]]));
            }
        }
        if let (Some(s), Some(values)) = (&self.searched, values) {
            for (name, x) in s.names.iter().zip(values) {
                parts.push(format!("{name}={x}"));
            }
        }
        parts.join(" ")
    }

    /// The point of the sweep's own grid that point `index` is, and (a search's grid) the
    /// searched values set in it.
    fn own_point(&self, index: usize) -> (usize, Option<&[f64]>) {
        match &self.searched {
            Some(s) => (s.points[index].0, Some(&s.points[index].1[..])),
            None => (index, None),
        }
    }

    /// The scene JSON of point `index`: the base with every axis value applied (and, in a
    /// search's grid, the searched fields' values).
    pub fn point_value(&self, sweep: &Sweep, index: usize) -> Value {
        let (own, values) = self.own_point(index);
        let mi = multi_index(&sweep.shape(), own);
        let mut v = sweep.base.clone();
        for (d, dim) in sweep.dims.iter().enumerate() {
            for axis in &dim.axes {
                set_path(&mut v, &axis.field, axis.values[mi[d]].clone());
            }
        }
        if let (Some(s), Some(values)) = (&self.searched, values) {
            for (field, &x) in s.fields.iter().zip(values) {
                set_path(&mut v, field, Value::from(x));
            }
        }
        v
    }

    /// The scene of point `index`.
    pub fn build(&self, sweep: &Sweep, index: usize) -> Result<Scene> {
        let v = self.point_value(sweep, index);
        from_value_at::<Scene>(v, "").map_err(|e| match e {
            Error::Input { field, message, .. } => {
                locate(sweep, &self.shape, index, &field, &message)
            }
            other => other,
        })
    }
}

/// Shard `k` of `n` (`1 <= k <= n`): the part of a grid one machine of `n` runs
/// (which points, is the engine's shard assignment).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// Which shard, from 1.
    pub k: usize,
    /// Number of shards.
    pub n: usize,
}

impl Shard {
    /// Reads `K/N`; an input error naming `field` otherwise.
    pub fn parse(text: &str, field: &str) -> Result<Shard> {
        let bad = || Error::input(field, format!("must be K/N with 1 <= K <= N, got `{text}`"));
        let (k, n) = text.split_once('/').ok_or_else(bad)?;
        let k: usize = k.trim().parse().map_err(|_| bad())?;
        let n: usize = n.trim().parse().map_err(|_| bad())?;
        if k == 0 || n == 0 || k > n {
            return Err(bad());
        }
        Ok(Shard { k, n })
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.k, self.n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid of `values.len()` points along the damping, of a short chain.
    fn damping_sweep(values: &[f64]) -> Sweep {
        let values: Vec<String> = values.iter().map(|v| format!("{v:e}")).collect();
        Sweep::parse(&format!(
            r#"{{"base": {{"chain": {{"preset": "chain_055", "cylinders": 6}},
                 "physics": {{"gravity": true, "damping_kg_s": 0.0, "wall": true}},
                 "striker_velocity_m_s": 1.3, "duration_s": 1e-5,
                 "integrator": {{"method": "dop853", "rtol": 1e-8}}}},
                "axes": [{{"field": "physics.damping_kg_s", "values": [{}]}}]}}"#,
            values.join(", ")
        ))
        .unwrap()
    }

    /// What a grid holds, comparable.
    fn contents(g: &Grid) -> String {
        format!(
            "{:?} {:?} {:?} {} {} {} {}",
            g.hashes,
            g.particles,
            g.warnings,
            g.warned_points,
            g.max_contacts,
            g.max_particles,
            g.moving_part
        )
    }

    /// Expanded on a pool in chunks, a grid is the one expanded on one thread: every run hash and
    /// particle count, the warnings listed and counted, and the first point that fails.
    #[test]
    fn a_grid_expanded_in_chunks_is_the_one_expanded_on_one_thread() {
        // Every seventh point's damping holds an explicit method's steps far below the contact
        // time (a plausibility warning); more of them than are listed.
        let values: Vec<f64> = (0..200)
            .map(|i| if i % 7 == 3 { 1e7 } else { i as f64 * 0.1 })
            .collect();
        let sweep = damping_sweep(&values);
        let expand = |threads| Grid::expand_keeping_first(&sweep, &|_| {}, None, Some(threads));
        let one = expand(1).unwrap().0;
        assert!(one.warned_points > LISTED_WARNINGS, "{}", one.warned_points);
        for threads in [2, 3, 7] {
            assert_eq!(contents(&expand(threads).unwrap().0), contents(&one));
        }
        // Points 130 and 70 are refused: each expansion names the first of them, 70.
        let mut bad = values.clone();
        bad[130] = -1.0;
        bad[70] = -2.0;
        let sweep = damping_sweep(&bad);
        for threads in [1, 2, 3] {
            let e = Grid::expand_keeping_first(&sweep, &|_| {}, None, Some(threads))
                .expect_err("a refused point");
            let text = e.to_string();
            assert!(
                text.contains("values[70]") && text.contains("got -2"),
                "{text}"
            );
        }
    }

    #[test]
    fn multi_index_is_row_major() {
        assert_eq!(multi_index(&[2, 3], 0), vec![0, 0]);
        assert_eq!(multi_index(&[2, 3], 1), vec![0, 1]);
        assert_eq!(multi_index(&[2, 3], 3), vec![1, 0]);
        assert_eq!(multi_index(&[2, 3], 5), vec![1, 2]);
    }
}
