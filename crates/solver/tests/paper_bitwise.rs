//! The paper's chains give bitwise the same numbers as the engine that produced the pinned values
//! below: the built chain (masses, Hertz coefficients, damping, static overlaps, equilibrium
//! positions) and whole runs through every integrator and physics switch (peaks, peak times,
//! ledger, step counts).
//!
//! The pins change only with a change MEANT to change the paper's numbers (an integrator change,
//! with a bump of the runner's NUMERICS_VERSION); the failure message prints the new fingerprint
//! to paste here after checking the differences.

use chainsweep_solver::chain::model::{Chain, ChainSpec, CylinderMass, PhysicsSpec};
use chainsweep_solver::observe::probes::{Preload, Probe};
use chainsweep_solver::scene::solve::run;
use chainsweep_solver::scene::{IntegratorSpec, Scene};
use chainsweep_solver::AdaptiveOptions;

#[path = "../benches/reference.rs"]
mod reference;

/// FNV-1a over the bits of a sequence of numbers: one line per array in the fingerprint.
fn digest(values: impl IntoIterator<Item = f64>) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for v in values {
        for b in v.to_bits().to_le_bytes() {
            h ^= b as u64;
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    }
    h
}

fn chain_fingerprint(name: &str, chain: &Chain, out: &mut String) {
    let d = |v: &[f64]| digest(v.iter().copied());
    out.push_str(&format!(
        "{name}: mass {:016x} stiffness {:016x} damping {:016x} static_overlap {:016x} equilibrium {:016x} g {:016x}\n",
        d(&chain.mass),
        d(&chain.stiffness),
        d(&chain.damping),
        d(&chain.static_overlap),
        d(&chain.equilibrium_position),
        chain.gravity_m_s2.to_bits(),
    ));
}

fn run_fingerprint(name: &str, scene: &Scene, out: &mut String) {
    let o = run(scene).unwrap();
    let s = o.stats;
    out.push_str(&format!(
        "{name}: steps {} rejected {} events {} rhs {} t_end {:016x} drift {:016x} {:016x} momentum {:016x} max_overlap {:016x} impact {:016x} warnings {}\n",
        s.steps, s.rejected, s.events, s.rhs_evals, o.t_end_s.to_bits(), o.energy_drift_max.to_bits(),
        o.energy_drift_final.to_bits(), o.momentum_residual_max.to_bits(), o.max_overlap_m.to_bits(),
        o.impact_energy_j.to_bits(), o.warnings.len()
    ));
    let e = o.final_energy;
    out.push_str(&format!(
        "{name}: energy {:016x} {:016x} {:016x} {:016x}\n",
        e.kinetic.to_bits(),
        e.elastic.to_bits(),
        e.gravitational.to_bits(),
        e.dissipated.to_bits()
    ));
    for (k, p) in o.probes.iter().enumerate() {
        out.push_str(&format!(
            "{name}: probe {k} {:016x} {:016x} {:016x} {:016x}\n",
            p.leading_peak.to_bits(),
            p.leading_peak_time_s.to_bits(),
            p.record_max.to_bits(),
            p.record_max_time_s.to_bits()
        ));
    }
    if let Some(m) = &o.min_overlap_m {
        out.push_str(&format!(
            "{name}: min_overlap {:016x}\n",
            digest(m.iter().copied())
        ));
    }
    if let Some(h) = &o.history {
        out.push_str(&format!(
            "{name}: history {} {:016x}\n",
            h.time_s.len(),
            digest(h.values.iter().flatten().copied())
        ));
    }
}

fn dop(rtol: f64) -> IntegratorSpec {
    IntegratorSpec::Dop853(AdaptiveOptions::new(rtol))
}

fn fingerprint() -> String {
    let mut out = String::new();
    // Built chains: both presets, both mass-ratio conventions, every physics switch.
    let light = {
        let mut s = ChainSpec::chain_055(20);
        if let ChainSpec::Dimer(d) = &mut s {
            d.cylinder.mass = CylinderMass::LightCylinders { mass_ratio: 0.3 };
            d.cylinder.height_m = None;
        }
        s
    };
    let heavy = {
        let mut s = ChainSpec::chain_055(50);
        if let ChainSpec::Dimer(d) = &mut s {
            d.cylinder.mass = CylinderMass::HeavyCylinders { mass_ratio: 0.55 };
            d.cylinder.height_m = None;
        }
        s
    };
    let damped = PhysicsSpec {
        damping_kg_s: 6.0,
        striker_damping_kg_s: Some(2.5),
        ..PhysicsSpec::default()
    };
    let free = PhysicsSpec {
        gravity: false,
        wall: false,
        damping_kg_s: 3.0,
        ..PhysicsSpec::default()
    };
    for (name, spec, physics) in [
        (
            "chain_098",
            ChainSpec::chain_098(50),
            PhysicsSpec::default(),
        ),
        ("chain_055", ChainSpec::chain_055(50), damped),
        ("light", light.clone(), damped),
        ("heavy", heavy.clone(), PhysicsSpec::default()),
        ("free", ChainSpec::chain_098(10), free),
    ] {
        chain_fingerprint(name, &Chain::build(&spec, &physics).unwrap(), &mut out);
    }

    // Runs: the benchmark's reference run, then every integrator and switch.
    run_fingerprint(
        "reference",
        &reference::reference_scene(reference::REFERENCE_RTOL),
        &mut out,
    );
    let mut s = Scene::new(ChainSpec::chain_098(30), 1.06, 6e-4);
    s.integrator = dop(1e-10);
    s.record.probes = vec![
        Probe::GaugeForce { cylinder: 4 },
        Probe::GaugeForce { cylinder: 21 },
        Probe::ContactForce { contact: 1 },
        Probe::Overlap { contact: 10 },
        Probe::Displacement { particle: 20 },
        Probe::Velocity { particle: 2 },
        Probe::WallForce,
    ];
    s.record.min_overlap = true;
    run_fingerprint("chain_098_probes", &s, &mut out);
    s.record.preload = Preload::Subtract;
    s.record.history = true;
    s.record.history_interval_s = 5e-6;
    s.physics.damping_kg_s = 6.0;
    run_fingerprint("chain_098_subtract_history", &s, &mut out);

    let mut s = Scene::new(light.clone(), 1.3, 3e-4);
    s.physics = PhysicsSpec {
        gravity: false,
        damping_kg_s: 300.0,
        striker_damping_kg_s: Some(2.0),
        clip_tensile: true,
        ..PhysicsSpec::default()
    };
    s.integrator = IntegratorSpec::Ros34pw2(AdaptiveOptions::new(1e-7));
    s.record.probes = vec![
        Probe::GaugeForce { cylinder: 4 },
        Probe::GaugeForce { cylinder: 15 },
    ];
    run_fingerprint("light_ros34pw2_clip", &s, &mut out);

    let mut s = Scene::new(ChainSpec::chain_098(10), 1.06, 2e-4);
    s.physics = free;
    s.integrator = IntegratorSpec::Rk4 { dt_s: 2e-8 };
    s.record.probes = vec![
        Probe::GaugeForce { cylinder: 3 },
        Probe::Velocity { particle: 12 },
    ];
    run_fingerprint("free_rk4", &s, &mut out);
    s.integrator = IntegratorSpec::Verlet { dt_s: 1e-8 };
    s.physics.damping_kg_s = 0.0;
    run_fingerprint("free_verlet", &s, &mut out);

    let mut s = Scene::new(heavy, 1.45, 1e-3);
    s.physics.damping_kg_s = 15.0;
    s.integrator = dop(1e-9);
    s.record.probes = vec![Probe::GaugeForce { cylinder: 21 }];
    s.record.stop_after_leading_pulses = true;
    run_fingerprint("heavy_stop_early", &s, &mut out);

    // Verner 6(5) and DOP853 with switch prediction, each through its dense output (probes and
    // history) and its event location.
    let mut s = Scene::new(ChainSpec::chain_098(30), 1.06, 6e-4);
    s.physics.damping_kg_s = 6.0;
    s.record.probes = vec![
        Probe::GaugeForce { cylinder: 4 },
        Probe::GaugeForce { cylinder: 21 },
        Probe::Velocity { particle: 2 },
    ];
    s.record.history = true;
    s.record.history_interval_s = 5e-6;
    s.integrator = IntegratorSpec::Vern6(AdaptiveOptions::new(1e-8));
    run_fingerprint("chain_098_vern6", &s, &mut out);
    let mut predict = AdaptiveOptions::new(1e-8);
    predict.predict_switches = true;
    s.integrator = IntegratorSpec::Dop853(predict);
    run_fingerprint("chain_098_dop853_predict", &s, &mut out);
    out
}

const PINNED: &str = "\
chain_098: mass 6dd27ce51d9316f5 stiffness e791e7bd35b10d11 damping b7adcd5caf5292e5 static_overlap 9d9e1c5760e31612 equilibrium 5061affe88d9b027 g 40239eb851eb851f\n\
chain_055: mass 00b12eed96bfcfb5 stiffness e791e7bd35b10d11 damping 8c5015e8f070fde9 static_overlap 39e2139ca244b079 equilibrium c7044ac6dde7044b g 40239eb851eb851f\n\
light: mass ce63221521bbf3c5 stiffness cf2eb3c911fafb69 damping 229f5b70a40e2069 static_overlap e88f5bab6d364abe equilibrium 49720536407c98fc g 40239eb851eb851f\n\
heavy: mass 90c51b7b2fd52675 stiffness e791e7bd35b10d11 damping b7adcd5caf5292e5 static_overlap 64759cea2d88bc7d equilibrium 7b3ade9c254ae345 g 40239eb851eb851f\n\
free: mass 6f273ab86f0203b5 stiffness 4bec91e450f75ad8 damping d248d02ad9aa7fbd static_overlap 35da762063936645 equilibrium ad7f8afd9dfb20e5 g 0000000000000000\n\
reference: steps 1414 rejected 650 events 158 rhs 29004 t_end 3f50624dd2f1a9fc drift 3e997ead380f50e0 3e997ead380f50e0 momentum 3ce59e08c89b458f max_overlap 3ee4db49ffa9a770 impact 3f5cdda13066d01a warnings 0\n\
reference: energy 3f399a59783083dd 3f326669aae4a7e2 bf14cc95b340f5fd 3f52a4bcbdb34f74\n\
reference: probe 0 405ae1bb4f144e0b 3f1999ed41734470 405ae1bb4f144e0b 3f1999ed41734470\n\
reference: probe 1 404c308bddf48bd2 3f414fc24654a941 404c308bddf48bd2 3f414fc24654a941\n\
chain_098_probes: steps 640 rejected 204 events 145 rhs 12432 t_end 3f43a92a30553261 drift 3e34436c99222bae 3e34436c99222bae momentum 3cfeee319965692a max_overlap 3ee26486d449201a impact 3f533102b4eebd40 warnings 0\n\
chain_098_probes: energy 3f4554da5f745947 3f41945938c4303f bef5f00bfa418285 0000000000000000\n\
chain_098_probes: probe 0 405ccbe9eac30038 3f17c733e119b8d0 405ccbe9eac30038 3f17c733e119b8d0\n\
chain_098_probes: probe 1 405d313aa0a422e2 3f3caa6cf3988067 405d313aa0a422e2 3f3caa6cf3988067\n\
chain_098_probes: probe 2 406517b8fd1c508a 3ee9cf25ea003b71 406517b8fd1c508a 3ee9cf25ea003b71\n\
chain_098_probes: probe 3 3edc8088bd965a2f 3f1bcb558cfbdcd7 3edc8088bd965a2f 3f1bcb558cfbdcd7\n\
chain_098_probes: probe 4 3eea6a9c9870e95b 3f2e00c87f970d17 3eea6a9c9870e95b 3f2e00c87f970d17\n\
chain_098_probes: probe 5 3fe7dff5786bc89e 3ef2fad156cb1b7f 3fe7dff5786bc89e 3ef2fad156cb1b7f\n\
chain_098_probes: probe 6 7ff8000000000000 7ff8000000000000 3ff3ea91c8904585 3f43a92a30553261\n\
chain_098_probes: min_overlap ff417f5a8853b54b\n\
chain_098_subtract_history: steps 639 rejected 223 events 22 rhs 12134 t_end 3f43a92a30553261 drift 3e0c0999fb18c1bc 3e0c0999fb18c1bc momentum 3ce9a0ca02c1bd89 max_overlap 3ee1ceb2306972ca impact 3f533102b4eebd40 warnings 0\n\
chain_098_subtract_history: energy 3f278b64ad08acb4 3f24d44e9b195f30 bef5f00c05a65a19 3f4bd146c90e6c82\n\
chain_098_subtract_history: probe 0 4058c3ac013914ec 3f17bc4ea379b95f 4058c3ac013914ec 3f17bc4ea379b95f\n\
chain_098_subtract_history: probe 1 404e9cc2bcabfba1 3f3dc89a7726622a 404e9cc2bcabfba1 3f3dc89a7726622a\n\
chain_098_subtract_history: probe 2 40643bd67f1446f6 3ee94877054bc2fd 40643bd67f1446f6 3ee94877054bc2fd\n\
chain_098_subtract_history: probe 3 3ed8ca0e667fe112 3f1bda9b605dc56b 3ed8ca0e667fe112 3f1bda9b605dc56b\n\
chain_098_subtract_history: probe 4 7ff8000000000000 7ff8000000000000 3eed3d916af6b706 3f43a92a30553261\n\
chain_098_subtract_history: probe 5 3fe6d9fa0479007f 3ef2c3fb7fa4f008 3fe6d9fa0479007f 3ef2c3fb7fa4f008\n\
chain_098_subtract_history: probe 6 7ff8000000000000 7ff8000000000000 3ed468ac8f8c0000 3f43a92a30553261\n\
chain_098_subtract_history: min_overlap 1e5fa52f3e6f2397\n\
chain_098_subtract_history: history 120 04f21e7d92262f17\n\
light_ros34pw2_clip: steps 447 rejected 42 events 29 rhs 1920 t_end 3f33a92a30553261 drift 3ec513bf36891fbe 3eb65dffd0b9c6e2 momentum 3e7124192e640085 max_overlap 3ee673b9fc438bd6 impact 3f5cdda13066d01a warnings 0\n\
light_ros34pw2_clip: energy 3f29e5219cb5c290 3f192a322fd8e17b 8000000000000000 3f580e57542d53ac\n\
light_ros34pw2_clip: probe 0 4043904750cd861b 3f110d728498303b 4043904750cd861b 3f110d728498303b\n\
light_ros34pw2_clip: probe 1 402bbb370e476590 3f32eee538156c71 402bbb370e476590 3f32eee538156c71\n\
free_rk4: steps 10000 rejected 0 events 0 rhs 40001 t_end 3f2a36e2eb1c432d drift 3e0d4f2a3063df57 3e0c417c5a7d7a36 momentum 3cf617da48ff4b1e max_overlap 3ee22dee69810491 impact 3f533102b4eebd40 warnings 0\n\
free_rk4: energy 3f40124698a7d62b 3f3a6000a04411ba 8000000000000000 3f323f7d01181469\n\
free_rk4: probe 0 405aed30c02f9de3 3f12602d77a6e331 405aed30c02f9de3 3f12602d77a6e331\n\
free_rk4: probe 1 3fe4f2331d624b5c 3f2000bcb963f840 3fe4f2331d624b5c 3f2000bcb963f840\n\
free_verlet: steps 20000 rejected 0 events 0 rhs 20001 t_end 3f2a36e2eb1c432d drift 3e80834d8fd971bf 3e5515818f407770 momentum 3d110301adf7c6a4 max_overlap 3ee2703f511c9d7c impact 3f533102b4eebd40 warnings 0\n\
free_verlet: energy 3f44fa25630f2514 3f4167dffa2945c7 8000000000000000 0000000000000000\n\
free_verlet: probe 0 405c9fc56a038610 3f126c5f63337353 405c9fc56a038610 3f126c5f63337353\n\
free_verlet: probe 1 3fe727d777dcb86c 3f1ff2c12eeaea19 3fe727d777dcb86c 3f1ff2c12eeaea19\n\
heavy_stop_early: steps 701 rejected 262 events 29 rhs 13522 t_end 3f42ca205a6516e9 drift 3e2d277d37c92891 3e19873dde2d666b momentum 3ce4ac515feb0006 max_overlap 3ee61dd9cff3980c impact 3f61f4a7dd293b62 warnings 0\n\
heavy_stop_early: energy 3f37e2212c25c134 3f31ab9155f3768b bf1259b5c71bc9e2 3f5a2539ed0fdecc\n\
heavy_stop_early: probe 0 404865400420661f 3f415f72f20ba7b1 404865400420661f 3f415f72f20ba7b1\n\
chain_098_vern6: steps 677 rejected 218 events 82 rhs 9445 t_end 3f43a92a30553261 drift 3e87b08bf4fd22c6 3e87b08bf4fd22c6 momentum 3d1371267dad754e max_overlap 3ee1d554251647a2 impact 3f533102b4eebd40 warnings 0\n\
chain_098_vern6: energy 3f278b6489042f22 3f24d44e71277fac bef5f00c05a65a21 3f4bd1466b69ad65\n\
chain_098_vern6: probe 0 4058cd65deab3d74 3f17bc4ea0ba7407 4058cd65deab3d74 3f17bc4ea0ba7407\n\
chain_098_vern6: probe 1 404f08547eca308e 3f3dc89a74dd2da9 404f08547eca308e 3f3dc89a74dd2da9\n\
chain_098_vern6: probe 2 3fe6d9fa424576bc 3ef2c3fb811816e1 3fe6d9fa424576bc 3ef2c3fb811816e1\n\
chain_098_vern6: history 120 81194bb4a971351f\n\
chain_098_dop853_predict: steps 233 rejected 65 events 53 rhs 4246 t_end 3f43a92a30553261 drift 3e87f2b2b3da411c 3e87f2b2b3da411c momentum 3cd63421c6cd5eb1 max_overlap 3ee1df8c35ca0cdc impact 3f533102b4eebd40 warnings 0\n\
chain_098_dop853_predict: energy 3f278b6513b305c6 3f24d44ed925a725 bef5f00c05a65a1e 3f4bd1462d810b4c\n\
chain_098_dop853_predict: probe 0 4058cd6608bb1659 3f17bc4e9f818823 4058cd6608bb1659 3f17bc4e9f818823\n\
chain_098_dop853_predict: probe 1 404f0854db9cf2d7 3f3dc89a71eff206 404f0854db9cf2d7 3f3dc89a71eff206\n\
chain_098_dop853_predict: probe 2 3fe6d9fa863f69e2 3ef2c3fbbe0fa4d1 3fe6d9fa863f69e2 3ef2c3fbbe0fa4d1\n\
chain_098_dop853_predict: history 120 9f664d344ec8950d\n\
";

#[test]
fn paper_chains_and_runs_are_bitwise_unchanged() {
    let got = fingerprint();
    assert!(
        got == PINNED,
        "the paper's numbers changed; new fingerprint:\n{got}"
    );
}
