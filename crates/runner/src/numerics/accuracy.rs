//! Work-precision studies (`chainsweep accuracy`), and the measurements `integrator: auto`
//! ([`super::auto`]) shares with them.
//!
//! A study runs one scene with every integrator over a ladder of settings (DOP853, Verner's
//! 6(5) and ROS34PW2: `rtol`; RK4 and Verlet: `dt_s`, the two-body contact duration / 10 … /
//! 100 000, skipping settings estimated to run longer than `--max-run-seconds` and stopping a
//! ladder at a run that reaches it), and compares the leading-peak force and time at every probe
//! with a reference solution: DOP853 at rtol 1e-12, or
//! ROS34PW2 at rtol 1e-10 when damping dominates (the stiffness ratio `μ τ / m_min` of the
//! largest damping coefficient, the contact duration and the lightest particle exceeds
//! [`STIFF_RATIO`]). The reference is confirmed by the tightest setting of the other adaptive
//! method; their agreement is reported. Each setting's wall time is the median of repeats.

use std::path::Path;

use chainsweep_solver::{AdaptiveOptions, IntegratorSpec, Method, RunOutput, Scene};

use super::{max_ignoring_nan, probe_errors, round3};
use crate::error::{Error, Result};
use crate::exec;
use crate::store::hdf5::plain::PlainFile;
use crate::sweep::auto::{adaptive, setting_of};

/// Above this stiffness ratio `μ τ / m_min` a scene counts as damping-dominated: the reference
/// is ROS34PW2 and `auto` tries ROS34PW2 first.
pub const STIFF_RATIO: f64 = 100.0;

/// Natural scales of a scene that the ladders and the choice of methods are built from.
#[derive(Debug, Clone, Copy)]
pub struct SceneScales {
    /// Two-body contact duration of the striker on the first sphere, s.
    pub contact_time_s: f64,
    /// `μ_max τ / m_min`: how strongly damping dominates the lightest particle within a contact.
    pub stiffness_ratio: f64,
}

/// The natural scales of a (valid) scene.
pub fn scene_scales(scene: &Scene) -> Result<SceneScales> {
    let chain = scene
        .validate()
        .map_err(|e| Error::input(e.field.clone(), e.message.clone()))?;
    let s = scene.impact_scales(&chain);
    let tau = s.contact_duration_s();
    let m_min = chain.mass.iter().cloned().fold(f64::INFINITY, f64::min);
    let mu = chain.damping.iter().cloned().fold(0.0, f64::max);
    Ok(SceneScales {
        contact_time_s: tau,
        stiffness_ratio: mu * tau / m_min,
    })
}

/// One measured run.
#[derive(Debug, Clone)]
pub struct Measurement {
    /// The integrator.
    pub spec: IntegratorSpec,
    /// The output (None when the run failed).
    pub out: Option<RunOutput>,
    /// Why it failed.
    pub reason: String,
    /// Wall time of each repeat, s.
    pub walls: Vec<f64>,
}

impl Measurement {
    /// Median wall time, s.
    pub fn wall_median(&self) -> f64 {
        let mut w = self.walls.clone();
        w.sort_by(|a, b| a.total_cmp(b));
        if w.is_empty() {
            f64::NAN
        } else if w.len() % 2 == 1 {
            w[w.len() / 2]
        } else {
            0.5 * (w[w.len() / 2 - 1] + w[w.len() / 2])
        }
    }
}

/// Runs `scene` with `spec` `repeats` times (at least once; failures are not repeated), each run
/// stopped (and failed) once it has run `limit.0` seconds, a limit set by `limit.1`.
pub fn measure(
    scene: &Scene,
    spec: IntegratorSpec,
    repeats: usize,
    limit: (f64, &str),
) -> Measurement {
    let mut s = scene.clone();
    s.integrator = spec;
    s.record.history = false;
    s.record.min_overlap = false;
    s.record.energy_flow = false;
    s.record.fields = None;
    let mut walls = Vec::new();
    let mut out = None;
    let mut reason = String::new();
    for _ in 0..repeats.max(1) {
        let (r, wall) = exec::run_guarded(&s, limit);
        walls.push(wall);
        match r {
            Ok(o) => out = Some(o),
            Err(e) => {
                reason = e;
                break;
            }
        }
    }
    if !reason.is_empty() {
        out = None;
    }
    Measurement {
        spec,
        out,
        reason,
        walls,
    }
}

/// Relative errors of a run against a reference, per probe: leading peak, its time, record max.
pub fn errors_against(out: &RunOutput, reference: &RunOutput) -> Vec<[f64; 3]> {
    probe_errors(&out.probes, &reference.probes)
}

/// Options of a study.
#[derive(Debug, Clone)]
pub struct StudyOptions {
    /// Repeats per setting (wall time = median).
    pub repeats: usize,
    /// Settings whose estimated run time exceeds this are skipped, and a run of a ladder is
    /// stopped (failed) when it reaches it, s.
    pub max_run_s: f64,
    /// Wall-time limit of the reference run and of its confirmation, s (the sweep file's
    /// `limits.max_run_seconds`).
    pub reference_limit_s: f64,
    /// Methods to study.
    pub methods: Vec<String>,
}

/// Result of one method's ladder.
pub struct MethodResult {
    /// Method name.
    pub method: String,
    /// Name of the setting (`rtol` or `dt_s`).
    pub setting_name: &'static str,
    /// Measurements, one per setting.
    pub runs: Vec<Measurement>,
    /// Settings skipped as too expensive.
    pub skipped: Vec<f64>,
}

/// A finished study.
pub struct Study {
    /// The scene studied.
    pub scene: Scene,
    /// Its scales.
    pub scales: SceneScales,
    /// The reference run.
    pub reference: Measurement,
    /// The run confirming the reference (another method).
    pub confirmation: Measurement,
    /// Largest relative difference of the confirmation's summaries from the reference's.
    pub agreement: f64,
    /// One result per method.
    pub methods: Vec<MethodResult>,
}

/// Rungs of the adaptive ladders.
pub const DOP853_LADDER: &[f64] = &[1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11];
/// Rungs of the Verner 6(5) ladder (rounding limits it near 1e-12: its weights reach ±176).
pub const VERN6_LADDER: &[f64] = &[1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11];
/// Rungs of the ROS34PW2 ladder.
pub const ROS34PW2_LADDER: &[f64] = &[1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9];
/// Fixed steps as fractions of the contact duration.
pub const DT_DIVISORS: &[f64] = &[
    10.0, 30.0, 100.0, 300.0, 1000.0, 3000.0, 10000.0, 30000.0, 100000.0,
];

/// The name of DOP853 with `predict_switches` among the methods a study compares.
const DOP853_PREDICT: &str = "dop853-predict";

/// The names of the methods a study can compare (`--methods`): every integration method, and
/// `dop853-predict`, DOP853 with `predict_switches`.
pub fn method_names() -> Vec<&'static str> {
    let mut names: Vec<&str> = Method::ALL.iter().map(|m| m.name()).collect();
    names.insert(1, DOP853_PREDICT);
    names
}

/// A method a study compares: the integration method, and whether it predicts contact switches.
fn study_method(name: &str) -> Result<(Method, bool)> {
    if name == DOP853_PREDICT {
        return Ok((Method::Dop853, true));
    }
    Method::parse(name).map(|m| (m, false)).map_err(|_| {
        Error::input(
            "--methods",
            format!(
                "unknown method `{name}`; allowed: {}",
                method_names().join(", ")
            ),
        )
    })
}

/// Runs a work-precision study of `scene`; `log` receives progress lines.
pub fn study(scene: &Scene, opts: &StudyOptions, mut log: impl FnMut(&str)) -> Result<Study> {
    // Before any run: a misspelt method must not cost the ladders before it.
    let chosen = opts
        .methods
        .iter()
        .map(|m| study_method(m))
        .collect::<Result<Vec<_>>>()?;
    let scales = scene_scales(scene)?;
    let stiff = scales.stiffness_ratio > STIFF_RATIO;
    let mut scene = scene.clone();
    scene.record.history = false;
    scene.record.min_overlap = false;
    scene.record.energy_flow = false;
    scene.record.fields = None;
    // Generous budget: the ladders decide the cost, not the step budget.
    scene.max_steps = scene.max_steps.max(1_000_000_000);
    let (ref_spec, conf_spec) = if stiff {
        (
            adaptive(Method::Ros34pw2, 1e-10),
            adaptive(Method::Dop853, 1e-12),
        )
    } else {
        (
            adaptive(Method::Dop853, 1e-12),
            adaptive(Method::Ros34pw2, 1e-9),
        )
    };
    log(&format!(
        "contact time {:.3e} s, stiffness ratio mu*tau/m_min = {:.3e} ({}): reference {} rtol {:.0e}, confirmed by {} rtol {:.0e}",
        scales.contact_time_s,
        scales.stiffness_ratio,
        if stiff { "damping-dominated" } else { "not stiff" },
        ref_spec.method_name(),
        setting_of(&ref_spec).0,
        conf_spec.method_name(),
        setting_of(&conf_spec).0
    ));
    let reference_limit = (opts.reference_limit_s, "limits.max_run_seconds");
    let reference = measure(&scene, ref_spec, 1, reference_limit);
    let Some(ref_out) = reference.out.clone() else {
        return Err(Error::Other(format!(
            "the reference run failed: {}",
            reference.reason
        )));
    };
    let confirmation = measure(&scene, conf_spec, 1, reference_limit);
    let agreement = match &confirmation.out {
        Some(o) => max_ignoring_nan(errors_against(o, &ref_out).into_iter().flatten()),
        None => f64::NAN,
    };
    let confirmed = if confirmation.out.is_some() {
        format!("confirmation differs by {agreement:.2e} (largest relative difference of the probe summaries)")
    } else {
        format!("confirmation failed: {}", confirmation.reason)
    };
    log(&format!(
        "reference: {} RHS evals, {:.3} s; {confirmed}",
        ref_out.stats.rhs_evals,
        reference.wall_median(),
    ));
    let t_rhs = reference.wall_median() / ref_out.stats.rhs_evals.max(1) as f64;
    let mut methods = Vec::new();
    for (m, &(method, predict)) in opts.methods.iter().zip(&chosen) {
        let mut runs = Vec::new();
        let mut skipped = Vec::new();
        let (settings, setting_name): (Vec<IntegratorSpec>, &'static str) = if method.is_adaptive()
        {
            let ladder = match method {
                Method::Dop853 => DOP853_LADDER,
                Method::Vern6 => VERN6_LADDER,
                _ => ROS34PW2_LADDER,
            };
            // With prediction on DOP853's ladder, so that the two lines of the diagram
            // compare like with like.
            let options = |r| AdaptiveOptions {
                predict_switches: predict,
                ..AdaptiveOptions::new(r)
            };
            (
                ladder
                    .iter()
                    .filter_map(|&r| method.with_options(options(r)))
                    .collect(),
                "rtol",
            )
        } else {
            (
                DT_DIVISORS
                    .iter()
                    .filter_map(|&k| method.fixed(round3(scales.contact_time_s / k)))
                    .collect(),
                "dt_s",
            )
        };
        for spec in settings {
            let (x, _) = setting_of(&spec);
            if setting_name == "dt_s" {
                let evals_per_step = method.rhs_per_fixed_step().unwrap_or(1.0);
                let est = scene.duration_s / x * evals_per_step * t_rhs;
                if est > opts.max_run_s {
                    log(&format!(
                        "{m} dt {x:.3e} s: skipped (estimated {est:.1} s per run > --max-run-seconds)"
                    ));
                    skipped.push(x);
                    continue;
                }
            }
            let meas = measure(
                &scene,
                spec,
                opts.repeats,
                (opts.max_run_s, "--max-run-seconds"),
            );
            match &meas.out {
                Some(o) => {
                    let e = errors_against(o, &ref_out);
                    log(&format!(
                        "{m:<14} {setting_name} {x:.3e}: leading-peak error {:.2e}, time error {:.2e}, drift {:.2e}, {} RHS evals, {:.4} s",
                        max_ignoring_nan(e.iter().map(|v| v[0])),
                        max_ignoring_nan(e.iter().map(|v| v[1])),
                        o.energy_drift_max,
                        o.stats.rhs_evals,
                        meas.wall_median()
                    ));
                }
                None => log(&format!(
                    "{m:<14} {setting_name} {x:.3e}: failed: {}",
                    meas.reason
                )),
            }
            // An adaptive ladder that takes too long stops there (so does one whose run was
            // stopped at the limit: it ran at least as long).
            let slow = meas.wall_median() >= opts.max_run_s;
            runs.push(meas);
            if slow {
                log(&format!(
                    "{m}: stopping the ladder (a run took more than --max-run-seconds)"
                ));
                break;
            }
        }
        methods.push(MethodResult {
            method: m.clone(),
            setting_name,
            runs,
            skipped,
        });
    }
    Ok(Study {
        scene,
        scales,
        reference,
        confirmation,
        agreement,
        methods,
    })
}

/// Writes a study to HDF5: root attributes describing the scene, the reference and its
/// confirmation; one group per method with `setting`, `error`, `error_leading_peak`,
/// `error_leading_peak_time`, `energy_drift`, `wall_time`, `wall_times`, `rhs_evals`, `steps`,
/// `ok` and `reason`.
pub fn write_study(path: &Path, st: &Study, probe_names: &[String], source: &str) -> Result<()> {
    write_study_file(path, st, probe_names, source)
        .map_err(|e| e.hdf5_context(|| format!("writing {}", path.display())))
}

fn write_study_file(path: &Path, st: &Study, probe_names: &[String], source: &str) -> Result<()> {
    let file = PlainFile::create(path)?;
    let f = file.root();
    f.attr_str("engine", "chainsweep accuracy")?;
    f.attr_str("engine_version", crate::ENGINE_VERSION)?;
    f.attr_str("git_revision", crate::git_revision())?;
    f.attr_str("source", source)?;
    f.attr_str(
        "scene",
        &serde_json::to_string(&st.scene).expect("Scene serialises"),
    )?;
    f.attr("contact_time_s", st.scales.contact_time_s)?;
    f.attr("stiffness_ratio", st.scales.stiffness_ratio)?;
    let ref_out = st.reference.out.as_ref().expect("reference ran");
    let (rs, rn) = setting_of(&st.reference.spec);
    f.attr_str(
        "reference",
        &format!("{} {rn} {rs:.0e}", st.reference.spec.method_name()),
    )?;
    let (cs, cn) = setting_of(&st.confirmation.spec);
    f.attr_str(
        "confirmation",
        &format!("{} {cn} {cs:.0e}", st.confirmation.spec.method_name()),
    )?;
    f.attr("reference_agreement", st.agreement)?;
    f.attr("reference_wall_time_s", st.reference.wall_median())?;
    f.attr("reference_rhs_evals", ref_out.stats.rhs_evals as i64)?;
    f.attr("reference_energy_drift", ref_out.energy_drift_max)?;
    f.attr_str("probes", &serde_json::to_string(probe_names).expect("json"))?;
    let lp: Vec<f64> = ref_out.probes.iter().map(|p| p.leading_peak).collect();
    let lpt: Vec<f64> = ref_out
        .probes
        .iter()
        .map(|p| p.leading_peak_time_s)
        .collect();
    let np = lp.len();
    let d = f.dataset("reference_leading_peak", &[np], &lp)?;
    d.attr_str("units", "see probes")?;
    let d = f.dataset("reference_leading_peak_time_s", &[np], &lpt)?;
    d.attr_str("units", "s")?;
    f.attr_str("error_definition",
        "error: largest relative error of the leading-peak force over the probes, against the reference",
    )?;
    for m in &st.methods {
        let g = f.group(&m.method)?;
        g.attr_str("setting_name", m.setting_name)?;
        g.attr_str(
            "setting_units",
            if m.setting_name == "rtol" { "1" } else { "s" },
        )?;
        let n = m.runs.len();
        let mut setting = Vec::with_capacity(n);
        let mut error = Vec::with_capacity(n);
        let mut e_lp = Vec::with_capacity(n * np);
        let mut e_lpt = Vec::with_capacity(n * np);
        let mut drift = Vec::with_capacity(n);
        let mut wall = Vec::with_capacity(n);
        let reps = m.runs.iter().map(|r| r.walls.len()).max().unwrap_or(1);
        let mut walls = Vec::with_capacity(n * reps);
        let mut rhs = Vec::with_capacity(n);
        let mut steps = Vec::with_capacity(n);
        let mut ok = Vec::with_capacity(n);
        let mut reason = Vec::with_capacity(n);
        for r in &m.runs {
            setting.push(setting_of(&r.spec).0);
            wall.push(r.wall_median());
            for k in 0..reps {
                walls.push(r.walls.get(k).copied().unwrap_or(f64::NAN));
            }
            match &r.out {
                Some(o) => {
                    let e = errors_against(o, ref_out);
                    error.push(max_ignoring_nan(e.iter().map(|v| v[0])));
                    e_lp.extend(e.iter().map(|v| v[0]));
                    e_lpt.extend(e.iter().map(|v| v[1]));
                    drift.push(o.energy_drift_max);
                    rhs.push(o.stats.rhs_evals as i64);
                    steps.push(o.stats.steps as i64);
                    ok.push(1u8);
                    reason.push(String::new());
                }
                None => {
                    error.push(f64::NAN);
                    e_lp.extend(std::iter::repeat(f64::NAN).take(np));
                    e_lpt.extend(std::iter::repeat(f64::NAN).take(np));
                    drift.push(f64::NAN);
                    rhs.push(-1);
                    steps.push(-1);
                    ok.push(0u8);
                    reason.push(r.reason.clone());
                }
            }
        }
        let d = g.dataset("setting", &[n], &setting)?;
        d.attr_str("units", if m.setting_name == "rtol" { "1" } else { "s" })?;
        let d = g.dataset("error", &[n], &error)?;
        d.attr_str("units", "1")?;
        d.attr_str(
            "long_name",
            "largest relative error of the leading-peak force over the probes",
        )?;
        let d = g.dataset("error_leading_peak", &[n, np], &e_lp)?;
        d.attr_str("units", "1")?;
        let d = g.dataset("error_leading_peak_time", &[n, np], &e_lpt)?;
        d.attr_str("units", "1")?;
        d.attr_str("long_name", "relative error of the leading-peak time")?;
        let d = g.dataset("energy_drift", &[n], &drift)?;
        d.attr_str("units", "1")?;
        d.attr_str(
            "long_name",
            "largest energy-ledger drift relative to the impact energy",
        )?;
        let d = g.dataset("wall_time", &[n], &wall)?;
        d.attr_str("units", "s")?;
        d.attr_str("long_name", "median wall time of the repeats")?;
        let d = g.dataset("wall_times", &[n, reps], &walls)?;
        d.attr_str("units", "s")?;
        let d = g.dataset("rhs_evals", &[n], &rhs)?;
        d.attr_str("units", "1")?;
        let d = g.dataset("steps", &[n], &steps)?;
        d.attr_str("units", "1")?;
        g.dataset("ok", &[n], &ok)?;
        g.str_dataset("reason", &[n], &reason)?;
        g.dataset("skipped_settings", &[m.skipped.len()], &m.skipped)?;
    }
    file.close()?;
    Ok(())
}

/// Cost of reaching `target` relative error with one method: the cheapest run of its ladder
/// whose error is at most `target` (wall time s, RHS evals, setting), if any.
pub fn cost_of(m: &MethodResult, reference: &RunOutput, target: f64) -> Option<(f64, u64, f64)> {
    m.runs
        .iter()
        .filter_map(|r| {
            let o = r.out.as_ref()?;
            let e = max_ignoring_nan(errors_against(o, reference).iter().map(|v| v[0]));
            (e <= target).then(|| (r.wall_median(), o.stats.rhs_evals, setting_of(&r.spec).0))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
}
