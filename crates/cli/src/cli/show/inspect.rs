//! `inspect`: one grid point, and a work-precision study.

use std::path::Path;

use chainsweep::engine::inspect::Point;
use chainsweep::grid::{multi_index, Grid};
use chainsweep::identity::hex;
use chainsweep::numerics::accuracy::{cost_of, Study};

/// `point`: the scene and, when run, the results, as JSON.
pub fn point(grid: &Grid, index: usize, p: &Point) -> String {
    let mut out = serde_json::json!({
        "index": index,
        "grid_index": multi_index(&grid.shape, index),
        "run_hash": hex(&p.hash),
        "scene": serde_json::to_value(&p.scene).expect("Scene serialises"),
    });
    if let Some(rec) = &p.record {
        let num = |x: f64| {
            if x.is_finite() {
                serde_json::json!(x)
            } else {
                serde_json::Value::Null
            }
        };
        let probes: Vec<serde_json::Value> = rec
            .probes
            .iter()
            .zip(&grid.probes)
            .map(|(s, p)| {
                serde_json::json!({
                    "probe": p.name(),
                    "leading_peak": num(s.leading_peak),
                    "leading_peak_time_s": num(s.leading_peak_time_s),
                    "record_max": num(s.record_max),
                    "record_max_time_s": num(s.record_max_time_s),
                })
            })
            .collect();
        out["result"] = serde_json::json!({
            "ok": rec.ok,
            "reason": rec.reason,
            "steps": rec.steps,
            "rejected_steps": rec.rejected,
            "rhs_evals": rec.rhs_evals,
            "events": rec.events,
            "max_overlap_m": num(rec.max_overlap_m),
            "integrated_particles": rec.integrated_particles,
            "moving_part": rec.moving_part,
            "warnings": rec.warnings.lines().collect::<Vec<_>>(),
            "t_end_s": num(rec.t_end_s),
            "energy_drift_max": num(rec.energy_drift_max),
            "energy_drift_final": num(rec.energy_drift_final),
            "momentum_residual_max": num(rec.momentum_residual_max),
            "impact_energy_j": num(rec.impact_energy_j),
            "probes": probes,
            "history_samples": rec.history.as_ref().map(|h| h.time_s.len()),
        });
        // Only where fields are recorded, so that the result of every other run reads as it did.
        if let Some(f) = &rec.fields {
            out["result"]["field_samples"] = f.time_s.len().into();
        }
        if let Some(s) = &rec.spectrum {
            out["result"]["spectrum"] = serde_json::json!({
                "lowest_frequency_hz": num(s.lowest_frequency_hz),
                "highest_frequency_hz": num(s.highest_frequency_hz),
                "gap_lower_hz": num(s.gap_lower_hz),
                "gap_upper_hz": num(s.gap_upper_hz),
                "band_top_hz": num(s.band_top_hz),
            });
        }
        if let Some(st) = &rec.steady_state {
            let nums = |v: &[f64]| v.iter().map(|&x| num(x)).collect::<Vec<_>>();
            let probes: Vec<serde_json::Value> = st
                .probes
                .iter()
                .zip(&grid.probes)
                .map(|(s, p)| {
                    serde_json::json!({
                        "probe": p.name(),
                        "mean": num(s.mean),
                        "rms": num(s.rms),
                        "amplitude": nums(&s.amplitude),
                        "phase_rad": nums(&s.phase_rad),
                        "settledness": num(s.settledness),
                        "settled": s.settled,
                        "transmission_db": num(s.transmission_db),
                    })
                })
                .collect();
            out["result"]["steady_state"] = serde_json::json!({
                "frequency_hz": num(st.frequency_hz),
                "probes": probes,
            });
        }
    }
    serde_json::to_string_pretty(&out).expect("json")
}

/// The end of `accuracy`: the cost of each error level per method.
pub fn study(st: &Study, output: &Path) {
    let reference = st.reference.out.as_ref().expect("reference ran");
    let confirmation = if st.confirmation.out.is_some() {
        format!(
            "confirmed by {} to {:.1e}",
            st.confirmation.spec.method_name(),
            st.agreement
        )
    } else {
        format!(
            "not confirmed: the {} run failed",
            st.confirmation.spec.method_name()
        )
    };
    outln!(
        "reference {} ({confirmation}); cost of a leading-peak relative error:",
        st.reference.spec.method_name(),
    );
    outln!(
        "{:<14} {:>22} {:>22} {:>22}",
        "method",
        "<= 1e-4",
        "<= 1e-6",
        "<= 1e-8"
    );
    for m in &st.methods {
        let cell = |target: f64| match cost_of(m, reference, target) {
            Some((w, e, x)) => format!("{:.2} ms/{}@{x:.0e}", w * 1e3, e),
            None => "not reached".to_string(),
        };
        outln!(
            "{:<14} {:>22} {:>22} {:>22}",
            m.method,
            cell(1e-4),
            cell(1e-6),
            cell(1e-8)
        );
    }
    outln!(
        "(wall time per run / RHS evaluations @ setting) → {}",
        output.display()
    );
}
