//! Run-time CPU dispatch (`chainsweep-cpu`): every code path this CPU supports is forced in turn,
//! and the runs compared. The fused levels (AVX+FMA, AVX2+FMA, AVX-512) must agree bit for bit,
//! whatever their vector width; the portable level (separate multiply and add, what a CPU without
//! FMA runs) rounds differently and must agree to the runs' accuracy.
//!
//! This file holds a single test: forcing a level is process-wide, and the test harness runs the
//! tests of one file in parallel threads.

use chainsweep_solver::chain::model::{ChainSpec, CylinderMass};
use chainsweep_solver::cpu::{self, Level};
use chainsweep_solver::observe::probes::Probe;
use chainsweep_solver::scene::solve::{run, RunOutput};
use chainsweep_solver::scene::{IntegratorSpec, Scene};

fn scenes() -> Vec<(&'static str, Scene)> {
    let spec = |s: &str| -> IntegratorSpec { serde_json::from_str(s).unwrap() };
    let mut out = Vec::new();
    for (name, integrator) in [
        ("reference, dop853", r#"{"method":"dop853","rtol":5e-8}"#),
        (
            "reference, ros34pw2",
            r#"{"method":"ros34pw2","rtol":1e-6}"#,
        ),
        ("reference, rk4", r#"{"method":"rk4","dt_s":5e-8}"#),
        ("reference, verlet", r#"{"method":"verlet","dt_s":2e-8}"#),
    ] {
        let mut s = Scene::new(ChainSpec::chain_055(50), 1.3, 1e-3);
        s.physics.damping_kg_s = 6.0;
        s.integrator = spec(integrator);
        s.record.probes = vec![
            Probe::GaugeForce { cylinder: 4 },
            Probe::GaugeForce { cylinder: 21 },
            Probe::WallForce,
        ];
        s.record.history = true;
        s.record.min_overlap = true;
        out.push((name, s));
    }
    let mut light = Scene::new(ChainSpec::chain_098(20), 1.0, 3e-4);
    let dimer = light.chain.dimer_mut().expect("chain_098 is a dimer");
    dimer.cylinder.mass = CylinderMass::LightCylinders { mass_ratio: 0.05 };
    dimer.cylinder.height_m = None;
    light.physics.damping_kg_s = 1000.0;
    light.record.probes = vec![Probe::GaugeForce { cylinder: 4 }, Probe::WallForce];
    light.integrator = spec(r#"{"method":"ros34pw2","rtol":1e-8}"#);
    out.push(("stiff light chain, ros34pw2", light.clone()));
    light.integrator = spec(r#"{"method":"dop853","rtol":1e-9}"#);
    out.push(("stiff light chain, dop853", light));
    let mut bare = Scene::new(ChainSpec::chain_098(30), 1.06, 5e-4);
    bare.physics.gravity = false;
    bare.record.probes = vec![Probe::Velocity { particle: 40 }];
    out.push(("no gravity, no damping, dop853", bare));
    out
}

/// Every number a run reports, as bits.
fn fingerprint(o: &RunOutput) -> Vec<u64> {
    let mut v = vec![
        o.stats.steps,
        o.stats.rejected,
        o.stats.events,
        o.stats.rhs_evals,
        o.t_end_s.to_bits(),
        o.energy_drift_max.to_bits(),
        o.energy_drift_final.to_bits(),
        o.momentum_residual_max.to_bits(),
        o.max_overlap_m.to_bits(),
        o.final_energy.total().to_bits(),
    ];
    for p in &o.probes {
        v.extend(
            [
                p.leading_peak,
                p.leading_peak_time_s,
                p.record_max,
                p.record_max_time_s,
            ]
            .map(f64::to_bits),
        );
    }
    if let Some(h) = &o.history {
        v.extend(h.values.iter().flatten().map(|x| x.to_bits()));
    }
    if let Some(m) = &o.min_overlap_m {
        v.extend(m.iter().map(|x| x.to_bits()));
    }
    v
}

#[test]
fn fused_levels_agree_bit_for_bit_and_portable_to_the_tolerance() {
    let levels = Level::supported();
    eprintln!("levels supported here: {levels:?}");
    let scenes = scenes();
    let mut results: Vec<(Level, Vec<RunOutput>)> = Vec::new();
    for &level in &levels {
        cpu::force(level).unwrap();
        assert_eq!(cpu::level(), level);
        let outs = scenes.iter().map(|(_, s)| run(s).unwrap()).collect();
        results.push((level, outs));
    }
    let fused: Vec<_> = results.iter().filter(|(l, _)| l.fused()).collect();
    for pair in fused.windows(2) {
        let ((a, ra), (b, rb)) = (pair[0], pair[1]);
        for (k, (name, _)) in scenes.iter().enumerate() {
            assert_eq!(
                fingerprint(&ra[k]),
                fingerprint(&rb[k]),
                "{name}: {a} and {b} differ"
            );
        }
    }
    let (_, portable) = &results[0];
    assert_eq!(results[0].0, Level::Portable);
    if let Some((level, reference)) = fused.first() {
        let mut differs = false;
        for (k, (name, _)) in scenes.iter().enumerate() {
            differs |= fingerprint(&portable[k]) != fingerprint(&reference[k]);
            for (p, (a, b)) in portable[k]
                .probes
                .iter()
                .zip(&reference[k].probes)
                .enumerate()
            {
                let rel = (a.record_max / b.record_max - 1.0).abs();
                eprintln!(
                    "{name}, probe {p}: portable vs {level}: record maximum differs by {rel:.1e}"
                );
                assert!(rel < 1e-6, "{name}, probe {p}: {rel:e}");
            }
            let drift = (portable[k].energy_drift_max - reference[k].energy_drift_max).abs();
            assert!(drift < 1e-6, "{name}: energy drift differs by {drift:e}");
        }
        // The pin took effect: separate multiply-adds round differently somewhere.
        assert!(differs, "portable and {level} agree bit for bit");
    }
    cpu::force(Level::best()).unwrap();
}
