//! Running one grid point: the solver under `catch_unwind`, its output checked and turned into a
//! [`RunRecord`].
//!
//! A run fails, with its reason recorded, when the solver panics, returns an error (invalid
//! scene, NaN or infinite state, step budget exceeded, step size collapsed), produces a non-finite
//! number in what is stored, or exceeds the sweep's energy-drift limit.

use std::cell::RefCell;
use std::panic::{self, AssertUnwindSafe};
use std::sync::Once;
use std::time::Instant;

use chainsweep_solver::{run, Scene};

use crate::identity::RunHash;
use crate::record::RunRecord;
use crate::sweep::Limits;

thread_local! {
    static LAST_PANIC: RefCell<Option<String>> = const { RefCell::new(None) };
}

static HOOK: Once = Once::new();

/// Installs a panic hook that records a panic's message and location for the failed run's reason
/// instead of printing it over the progress display. Panics outside runs are printed as usual.
pub fn install_panic_hook() {
    HOOK.call_once(|| {
        let default = panic::take_hook();
        panic::set_hook(Box::new(move |info| {
            let msg = if let Some(s) = info.payload().downcast_ref::<&str>() {
                (*s).to_string()
            } else if let Some(s) = info.payload().downcast_ref::<String>() {
                s.clone()
            } else {
                "non-string panic payload".to_string()
            };
            let loc = info
                .location()
                .map(|l| format!(" at {}:{}", l.file(), l.line()))
                .unwrap_or_default();
            let in_run = LAST_PANIC.with(|p| {
                let mut p = p.borrow_mut();
                if p.as_deref() == Some("") {
                    *p = Some(format!("panic{loc}: {msg}"));
                    true
                } else {
                    false
                }
            });
            if !in_run {
                default(info);
            }
        }));
    });
}

/// Environment variable naming grid points (flat indices, comma separated) whose run panics on
/// purpose: a testing aid for failure isolation.
pub const INJECT_PANIC_ENV: &str = "CHAINSWEEP_INJECT_PANIC";

fn injected_panic(index: usize) -> bool {
    std::env::var(INJECT_PANIC_ENV)
        .map(|v| v.split(',').any(|s| s.trim().parse::<usize>() == Ok(index)))
        .unwrap_or(false)
}

/// Runs the scene of grid point `index` and records the outcome.
pub fn execute(scene: &Scene, hash: RunHash, limits: &Limits, index: usize) -> RunRecord {
    execute_inner(scene, hash, limits, Some(index))
}

/// Runs a verification scene (see [`crate::numerics::verify`]) and records the outcome under `hash`.
pub fn execute_verification(scene: &Scene, hash: RunHash, limits: &Limits) -> RunRecord {
    execute_inner(scene, hash, limits, None)
}

/// Runs a pilot scene of `integrator: auto` (see [`crate::numerics::auto`]); the record carries no hash.
pub fn execute_pilot(scene: &Scene, limits: &Limits) -> RunRecord {
    execute_inner(scene, [0u8; 32], limits, None)
}

fn execute_inner(scene: &Scene, hash: RunHash, limits: &Limits, index: Option<usize>) -> RunRecord {
    let start = Instant::now();
    LAST_PANIC.with(|p| *p.borrow_mut() = Some(String::new()));
    let result = panic::catch_unwind(AssertUnwindSafe(|| {
        if let Some(index) = index.filter(|&i| injected_panic(i)) {
            panic!("injected panic for grid point {index} ({INJECT_PANIC_ENV})");
        }
        run(scene)
    }));
    let panic_msg = LAST_PANIC.with(|p| p.borrow_mut().take());
    let wall = start.elapsed().as_secs_f64();
    let out = match result {
        Err(payload) => {
            let msg = panic_msg.filter(|m| !m.is_empty()).unwrap_or_else(|| {
                payload
                    .downcast_ref::<&str>()
                    .map(|s| format!("panic: {s}"))
                    .or_else(|| {
                        payload
                            .downcast_ref::<String>()
                            .map(|s| format!("panic: {s}"))
                    })
                    .unwrap_or_else(|| "panic".to_string())
            });
            return RunRecord::failed(hash, msg, wall);
        }
        Ok(Err(e)) => return RunRecord::failed(hash, e.to_string(), wall),
        Ok(Ok(out)) => out,
    };

    let mut bad: Vec<String> = Vec::new();
    for (name, x) in [
        ("t_end_s", out.t_end_s),
        ("energy_drift_max", out.energy_drift_max),
        ("energy_drift_final", out.energy_drift_final),
        ("momentum_residual_max", out.momentum_residual_max),
        ("max_overlap_m", out.max_overlap_m),
    ] {
        if !x.is_finite() {
            bad.push(format!("{name} = {x}"));
        }
    }
    for (p, s) in scene.record.probes.iter().zip(&out.probes) {
        if !s.record_max.is_finite() {
            bad.push(format!("{} record maximum = {}", p.name(), s.record_max));
        }
    }
    if let Some(h) = &out.history {
        for (p, series) in scene.record.probes.iter().zip(&h.values) {
            if let Some(x) = series.iter().find(|x| !x.is_finite()) {
                bad.push(format!("{} history holds {x}", p.name()));
            }
        }
    }
    if let Some(m) = &out.min_overlap_m {
        if m.iter().any(|x| !x.is_finite()) {
            bad.push("min_overlap_m holds a non-finite value".to_string());
        }
    }
    if !bad.is_empty() {
        return RunRecord::failed(hash, format!("non-finite result: {}", bad.join(", ")), wall);
    }
    if let Some(limit) = limits.energy_drift_max {
        if out.energy_drift_max > limit {
            return RunRecord::failed(
                hash,
                format!(
                    "energy drift {:.3e} exceeds the limit {limit:.3e} (limits.energy_drift_max)",
                    out.energy_drift_max
                ),
                wall,
            );
        }
    }
    RunRecord {
        hash,
        ok: true,
        reason: String::new(),
        steps: out.stats.steps,
        rejected: out.stats.rejected,
        rhs_evals: out.stats.rhs_evals,
        events: out.stats.events,
        t_end_s: out.t_end_s,
        energy_drift_max: out.energy_drift_max,
        energy_drift_final: out.energy_drift_final,
        momentum_residual_max: out.momentum_residual_max,
        impact_energy_j: out.impact_energy_j,
        wall_time_s: wall,
        max_overlap_m: out.max_overlap_m,
        warnings: out.warnings.join("\n"),
        probes: out.probes,
        min_overlap_m: out.min_overlap_m,
        history: out.history,
    }
}
