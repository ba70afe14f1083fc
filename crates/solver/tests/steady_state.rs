//! Steady-state observables (`record.steady_state`) against closed forms. Five equal masses on
//! linear springs (power law n = 1) between two walls, held compressed by a precompression, no
//! gravity, no damping, started in one normal mode of the fixed–fixed chain (displacements
//! `d sin(jπi/(N+1))`, at rest): every particle then moves as `a_i cos(ω_j t)` exactly, with
//! `ω_j = 2√(k/m) sin(jπ/(2(N+1)))`, so each probe's mean, RMS, amplitude and phase are known
//! (1e-8) and its harmonics vanish; two modes together, analysed at the first, leave the window's
//! halves different (not settled, a warning); bad values name the field.

use std::f64::consts::{FRAC_PI_2, PI};

use chainsweep_solver::observe::steady::{SteadyState, SteadyStateSpec};
use chainsweep_solver::scene::solve::{run, RunOutput};
use chainsweep_solver::scene::Scene;
use serde_json::json;

const N: usize = 5;
const MASS_KG: f64 = 0.004;
const STIFFNESS_N_PER_M: f64 = 1e6;
const PRELOAD_N: f64 = 10.0;
/// Displacement amplitude of a mode, m: a fifth of the static overlap, so that no contact opens.
const D_M: f64 = 2e-6;

fn omega(mode: usize) -> f64 {
    2.0 * (STIFFNESS_N_PER_M / MASS_KG).sqrt() * (mode as f64 * PI / (2.0 * (N + 1) as f64)).sin()
}

/// Mode `j`'s displacement of particle `i` (1-based), per unit amplitude.
fn shape(mode: usize, i: usize) -> f64 {
    (mode as f64 * i as f64 * PI / (N + 1) as f64).sin()
}

/// The chain started with displacements `Σ amplitude · shape(mode, i)` over `modes`, recording
/// `probes` with `steady` (as JSON) for `duration_s`.
fn scene(
    modes: &[(usize, f64)],
    probes: serde_json::Value,
    steady: serde_json::Value,
    duration_s: f64,
) -> Scene {
    let linear = json!({"power_law": {"coefficient": STIFFNESS_N_PER_M, "exponent": 1.0}});
    let steel = json!({"youngs_modulus_pa": 2e11, "poisson_ratio": 0.3});
    let particles: Vec<serde_json::Value> = (1..=N)
        .map(|i| {
            let d: f64 = modes.iter().map(|&(j, a)| a * shape(j, i)).sum();
            json!({"particle": i, "displacement_m": d})
        })
        .collect();
    serde_json::from_value(json!({
        "chain": {
            "particles": {"ball": {"sphere": {"diameter_m": 0.01, "mass_kg": MASS_KG, "material": steel}}},
            "sequence": [{"repeat": N, "of": ["ball"]}],
            "top_wall_material": steel,
            "contacts": [
                {"between": ["ball", "ball"], "law": linear},
                {"between": ["ball", "wall"], "law": linear},
                {"between": ["ball", "top_wall"], "law": linear}
            ]
        },
        "physics": {"gravity": false, "damping_kg_s": 0.0, "wall": true, "precompression_force_n": PRELOAD_N},
        "excitation": {"initial_state": {"particles": particles}},
        "duration_s": duration_s,
        "integrator": {"method": "dop853", "rtol": 1e-13},
        "record": {"probes": probes, "steady_state": steady}
    }))
    .expect("a valid scene")
}

fn steady(out: &RunOutput) -> &SteadyState {
    out.steady_state.as_ref().expect("recorded")
}

/// The phase difference `a − b` wrapped into (−π, π].
fn phase_diff(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(2.0 * PI);
    if d > PI {
        d - 2.0 * PI
    } else {
        d
    }
}

#[test]
fn one_normal_mode_gives_its_closed_form_amplitudes_phases_and_transmission() {
    let w = omega(1);
    let f = w / (2.0 * PI);
    let (settle, window) = (2, 10);
    let probes = json!([
        {"kind": "displacement", "particle": 2},
        {"kind": "velocity", "particle": 3},
        {"kind": "contact_force", "contact": 1},
        {"kind": "wall_force"}
    ]);
    let spec = json!({"frequency_hz": f, "settle_periods": settle, "window_periods": window,
                      "harmonics": 3, "reference_probe": 1});
    let s = scene(&[(1, D_M)], probes, spec, (settle + window) as f64 / f);
    let out = run(&s).unwrap();
    let st = steady(&out);
    assert_eq!(st.frequency_hz, f);
    // Closed forms: x_i = a_i cos ωt, v_i = a_i ω cos(ωt + π/2), contact j's force
    // F_p + k (a_j − a_{j+1}) cos ωt, the wall's F_p + k a_N cos ωt.
    let a = |i: usize| D_M * shape(1, i);
    let k = STIFFNESS_N_PER_M;
    let expected = [
        (0.0, a(2), 0.0),
        (0.0, a(3) * w, FRAC_PI_2),
        (PRELOAD_N, k * (a(2) - a(1)), PI),
        (PRELOAD_N, k * a(N), 0.0),
    ];
    let mut worst = (0.0f64, 0.0f64, 0.0f64);
    for (p, &(mean, amp, phase)) in st.probes.iter().zip(&expected) {
        let amp_err = (p.amplitude[0] - amp).abs() / amp;
        let rms = (mean * mean + amp * amp / 2.0).sqrt();
        let rms_err = (p.rms - rms).abs() / rms;
        let mean_err = (p.mean - mean).abs() / amp;
        let phase_err = phase_diff(p.phase_rad[0], phase).abs();
        assert!(
            amp_err < 1e-8,
            "amplitude {} against {amp}: {amp_err:e}",
            p.amplitude[0]
        );
        assert!(rms_err < 1e-8, "rms {} against {rms}: {rms_err:e}", p.rms);
        assert!(
            mean_err < 1e-8,
            "mean {} against {mean}: {mean_err:e}",
            p.mean
        );
        assert!(
            phase_err < 1e-8,
            "phase {} against {phase}: {phase_err:e}",
            p.phase_rad[0]
        );
        for h in 1..3 {
            assert!(
                p.amplitude[h] < 1e-8 * amp,
                "harmonic {} of {amp}: {}",
                h + 1,
                p.amplitude[h]
            );
        }
        assert!(
            p.settled && p.settledness < 1e-8,
            "settledness {:e}",
            p.settledness
        );
        worst = (
            worst.0.max(amp_err),
            worst.1.max(phase_err),
            worst.2.max(p.settledness),
        );
    }
    println!(
        "largest amplitude error {:.1e}, phase error {:.1e} rad, settledness {:.1e}",
        worst.0, worst.1, worst.2
    );
    // Transmission against the velocity probe (reference_probe 1): 0 dB there.
    assert_eq!(st.probes[1].transmission_db, 0.0);
    let db = 20.0 * (k * a(N) / (a(3) * w)).log10();
    assert!(
        (st.probes[3].transmission_db - db).abs() < 1e-7,
        "{} against {db}",
        st.probes[3].transmission_db
    );
    assert!(
        out.warnings.iter().all(|w| !w.contains("steady_state")),
        "{:?}",
        out.warnings
    );
}

#[test]
fn a_window_at_the_second_mode_of_the_same_chain_reads_it() {
    // The same chain in mode 2, analysed at its own frequency over 3 periods (an odd window: the
    // halves are its first and last period).
    let w = omega(2);
    let f = w / (2.0 * PI);
    let spec =
        json!({"frequency_hz": f, "window_periods": 3, "harmonics": 1, "samples_per_period": 16});
    let s = scene(
        &[(2, D_M)],
        json!([{"kind": "displacement", "particle": 1}]),
        spec,
        3.0 / f,
    );
    let out = run(&s).unwrap();
    let p = &steady(&out).probes[0];
    let amp = D_M * shape(2, 1);
    assert!(
        (p.amplitude[0] - amp).abs() < 1e-8 * amp,
        "{} against {amp}",
        p.amplitude[0]
    );
    assert!(
        phase_diff(p.phase_rad[0], 0.0).abs() < 1e-8,
        "{}",
        p.phase_rad[0]
    );
    assert!(p.settled);
}

#[test]
fn two_modes_at_once_are_not_settled_and_say_so() {
    // Modes 1 and 2 (frequency ratio 1.93) analysed at mode 1 over 4 periods: the second mode's
    // leakage into the fundamental differs between the window's halves, except at particle 3,
    // a node of mode 2 (sin(2·3π/6) = 0), which moves in mode 1 alone and has settled.
    let f = omega(1) / (2.0 * PI);
    let spec = json!({"frequency_hz": f, "window_periods": 4, "settled_tolerance": 1e-3});
    let probes = json!([
        {"kind": "displacement", "particle": 2},
        {"kind": "velocity", "particle": 1},
        {"kind": "velocity", "particle": 3}
    ]);
    let s = scene(&[(1, D_M), (2, D_M)], probes, spec, 4.0 / f);
    let out = run(&s).unwrap();
    let st = steady(&out);
    for p in &st.probes[..2] {
        assert!(!p.settled, "settledness {:e}", p.settledness);
        assert!(p.settledness > 1e-2, "settledness {:e}", p.settledness);
        println!("settledness {:.3e}", p.settledness);
    }
    let node = &st.probes[2];
    assert!(
        node.settled && node.settledness < 1e-10,
        "{:e}",
        node.settledness
    );
    let amp = D_M * shape(1, 3) * omega(1);
    assert!(
        (node.amplitude[0] - amp).abs() < 1e-8 * amp,
        "{}",
        node.amplitude[0]
    );
    let warning = out
        .warnings
        .iter()
        .find(|w| w.contains("record.steady_state"))
        .expect("a warning");
    assert!(
        warning.contains("displacement_p2") && warning.contains("velocity_p1"),
        "{warning}"
    );
    assert!(!warning.contains("velocity_p3"), "{warning}");
}

#[test]
fn analysing_the_steady_state_changes_nothing_else_the_run_computes() {
    let f = omega(1) / (2.0 * PI);
    let probes = json!([{"kind": "velocity", "particle": 3}, {"kind": "wall_force"}]);
    let with = scene(
        &[(1, D_M)],
        probes.clone(),
        json!({"frequency_hz": f, "window_periods": 2}),
        3.0 / f,
    );
    let mut without = with.clone();
    without.record.steady_state = None;
    let (a, b) = (run(&with).unwrap(), run(&without).unwrap());
    // (Debug text: NaN peaks compare equal as the same text.)
    assert_eq!(format!("{:?}", a.probes), format!("{:?}", b.probes));
    assert_eq!(a.stats, b.stats);
    assert_eq!(a.energy_drift_max, b.energy_drift_max);
    assert!(b.steady_state.is_none());
    // A scene without the option serialises as before: no key at all (run hashes unchanged).
    let text = serde_json::to_string(&without).unwrap();
    assert!(!text.contains("steady_state"), "{text}");
    let out = serde_json::to_string(&b).unwrap();
    assert!(!out.contains("steady_state"), "{out}");
}

#[test]
fn bad_values_name_the_field() {
    let f = omega(1) / (2.0 * PI);
    let probes = json!([{"kind": "velocity", "particle": 3}]);
    let base = scene(
        &[(1, D_M)],
        probes,
        json!({"frequency_hz": f, "window_periods": 2}),
        3.0 / f,
    );
    fn spec(s: &mut Scene) -> &mut SteadyStateSpec {
        s.record.steady_state.as_mut().unwrap()
    }
    let field = |edit: &dyn Fn(&mut Scene)| -> String {
        let mut s = base.clone();
        edit(&mut s);
        match run(&s) {
            Err(chainsweep_solver::RunError::Spec(e)) => e.field,
            other => panic!("expected a spec error, got {other:?}"),
        }
    };
    assert_eq!(base.drive_frequency_hz(), None);
    assert_eq!(
        field(&|s| spec(s).frequency_hz = None),
        "record.steady_state.frequency_hz"
    );
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert_eq!(
            field(&|s| spec(s).frequency_hz = Some(bad)),
            "record.steady_state.frequency_hz"
        );
    }
    assert_eq!(
        field(&|s| spec(s).window_periods = 1),
        "record.steady_state.window_periods"
    );
    // The window must fit in the run: 2 settle + 2 window periods in 3 periods' time.
    assert_eq!(
        field(&|s| spec(s).settle_periods = 2),
        "record.steady_state.window_periods"
    );
    assert_eq!(
        field(&|s| spec(s).window_periods = u64::MAX),
        "record.steady_state.window_periods"
    );
    for bad in [0, 65] {
        assert_eq!(
            field(&|s| spec(s).harmonics = bad),
            "record.steady_state.harmonics"
        );
    }
    for bad in [6, 4097] {
        assert_eq!(
            field(&|s| spec(s).samples_per_period = bad),
            "record.steady_state.samples_per_period"
        );
    }
    for bad in [0.0, -1e-3, f64::NAN, f64::INFINITY] {
        assert_eq!(
            field(&|s| spec(s).settled_tolerance = bad),
            "record.steady_state.settled_tolerance"
        );
    }
    assert_eq!(
        field(&|s| spec(s).reference_probe = 1),
        "record.steady_state.reference_probe"
    );
    assert_eq!(field(&|s| s.record.probes.clear()), "record.probes");
    assert_eq!(
        field(&|s| s.record.stop_after_leading_pulses = true),
        "record.stop_after_leading_pulses"
    );
    // Unknown fields are refused by the sweep file's parser.
    let err = serde_json::from_value::<SteadyStateSpec>(json!({"window_periods": 2, "periods": 3}))
        .unwrap_err();
    assert!(err.to_string().contains("periods"), "{err}");
}
