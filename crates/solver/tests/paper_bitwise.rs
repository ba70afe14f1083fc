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

use crate::reference;

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
reference: steps 897 rejected 419 events 155 rhs 18696 t_end 3f50624dd2f1a9fc drift 3ead19643d2b077b 3ea8d7613b0dcf88 momentum 3ce9f0d75720b9df max_overlap 3ee5233058383a14 impact 3f5cdda13066d01a warnings 0\n\
reference: energy 3f399a5662dc3e82 3f326668da6fe667 bf14cc95b340f606 3f52a4bd0898cd2f\n\
reference: probe 0 405ae1b956007383 3f1999ede1482446 405ae1b956007383 3f1999ede1482446\n\
reference: probe 1 404c308a7c4a3264 3f414fc26ae8e538 404c308a7c4a3264 3f414fc26ae8e538\n\
chain_098_probes: steps 640 rejected 204 events 145 rhs 12432 t_end 3f43a92a30553261 drift 3e34436c99222bae 3e34436c99222bae momentum 3cfeee319965692a max_overlap 3ee27176c48b8ce5 impact 3f533102b4eebd40 warnings 0\n\
chain_098_probes: energy 3f4554da5f745947 3f41945938c4303f bef5f00bfa418285 0000000000000000\n\
chain_098_probes: probe 0 405ccbe9eab893d8 3f17c733e17b012c 405ccbe9eab893d8 3f17c733e17b012c\n\
chain_098_probes: probe 1 405d313aa0a48690 3f3caa6cf39f6e25 405d313aa0a48690 3f3caa6cf39f6e25\n\
chain_098_probes: probe 2 406517b8fd3c0392 3ee9cf25e8c2c18f 406517b8fd3c0392 3ee9cf25e8c2c18f\n\
chain_098_probes: probe 3 3edc8088bd964ef4 3f1bcb558d03d8cb 3edc8088bd964ef4 3f1bcb558d03d8cb\n\
chain_098_probes: probe 4 3eea6a9c986fc2d6 3f2e00c8807e621b 3eea6a9c986fc2d6 3f2e00c8807e621b\n\
chain_098_probes: probe 5 3fe7dff5787094b0 3ef2fad156baa62c 3fe7dff5787094b0 3ef2fad156baa62c\n\
chain_098_probes: probe 6 7ff8000000000000 7ff8000000000000 3ff3ea91c8904585 3f43a92a30553261\n\
chain_098_probes: min_overlap ff417f5a8853b54b\n\
chain_098_subtract_history: steps 515 rejected 152 events 23 rhs 9497 t_end 3f43a92a30553261 drift 3e31788768fd6508 3e31788768fd6508 momentum 3ce65069449b7245 max_overlap 3ee1eeb5319461e5 impact 3f533102b4eebd40 warnings 0\n\
chain_098_subtract_history: energy 3f278b64aa5e3a1a 3f24d44e99825cdc bef5f00c05a65a19 3f4bd146c806ba45\n\
chain_098_subtract_history: probe 0 4058c3abffd962a9 3f17bc4ea3adc661 4058c3abffd962a9 3f17bc4ea3adc661\n\
chain_098_subtract_history: probe 1 404e9cc2baec4676 3f3dc89a774f7493 404e9cc2baec4676 3f3dc89a774f7493\n\
chain_098_subtract_history: probe 2 40643bd67ca7608c 3ee94876fe216cca 40643bd67ca7608c 3ee94876fe216cca\n\
chain_098_subtract_history: probe 3 3ed8ca0e64f635dc 3f1bda9b60c99c40 3ed8ca0e64f635dc 3f1bda9b60c99c40\n\
chain_098_subtract_history: probe 4 7ff8000000000000 7ff8000000000000 3eed3d916b5c9c5e 3f43a92a30553261\n\
chain_098_subtract_history: probe 5 3fe6d9fa02529f67 3ef2c3fb810e7ab8 3fe6d9fa02529f67 3ef2c3fb810e7ab8\n\
chain_098_subtract_history: probe 6 7ff8000000000000 7ff8000000000000 3ed468ac77980000 3f43a92a30553261\n\
chain_098_subtract_history: min_overlap 37b3e542e5da0400\n\
chain_098_subtract_history: history 120 3c4ec93bbf43bdf9\n\
light_ros34pw2_clip: steps 447 rejected 42 events 29 rhs 1920 t_end 3f33a92a30553261 drift 3ec513bf36891fbe 3eb65dffd0b9c6e2 momentum 3e7124192e640085 max_overlap 3ee673cbf17c4c82 impact 3f5cdda13066d01a warnings 0\n\
light_ros34pw2_clip: energy 3f29e5219cb5c290 3f192a322fd8e17b 8000000000000000 3f580e57542d53ac\n\
light_ros34pw2_clip: probe 0 4043904750f54864 3f110d729d9334eb 4043904750f54864 3f110d729d9334eb\n\
light_ros34pw2_clip: probe 1 402bbb370e476266 3f32eee5380bca22 402bbb370e476266 3f32eee5380bca22\n\
free_rk4: steps 10000 rejected 0 events 0 rhs 40001 t_end 3f2a36e2eb1c432d drift 3e0d4f2a3063df57 3e0c417c5a7d7a36 momentum 3cf617da48ff4b1e max_overlap 3ee22dee84dbd9ce impact 3f533102b4eebd40 warnings 0\n\
free_rk4: energy 3f40124698a7d62b 3f3a6000a04411ba 8000000000000000 3f323f7d01181469\n\
free_rk4: probe 0 405aed30c02f2676 3f12602d77ec8c88 405aed30c02f2676 3f12602d77ec8c88\n\
free_rk4: probe 1 3fe4f2331d614b69 3f2000bcb9604094 3fe4f2331d614b69 3f2000bcb9604094\n\
free_verlet: steps 20000 rejected 0 events 0 rhs 20001 t_end 3f2a36e2eb1c432d drift 3e80834d8fd971bf 3e5515818f407770 momentum 3d110301adf7c6a4 max_overlap 3ee2703f6bdf3c26 impact 3f533102b4eebd40 warnings 0\n\
free_verlet: energy 3f44fa25630f2514 3f4167dffa2945c7 8000000000000000 0000000000000000\n\
free_verlet: probe 0 405c9fc56a05bec0 3f126c5f633add68 405c9fc56a05bec0 3f126c5f633add68\n\
free_verlet: probe 1 3fe727d777dddec7 3f1ff2c12ead126a 3fe727d777dddec7 3f1ff2c12ead126a\n\
heavy_stop_early: steps 496 rejected 161 events 28 rhs 9332 t_end 3f42c37ead0e76ec drift 3e5d7bcd90643007 3e595225a4494362 momentum 3ce3618c49ec5005 max_overlap 3ee637332709bc94 impact 3f61f4a7dd293b62 warnings 0\n\
heavy_stop_early: energy 3f37ec46ef19ed63 3f31a8d07f8cf6cc bf1258216add12ac 3f5a23475d0e1cac\n\
heavy_stop_early: probe 0 4048653fff20a341 3f415f72ed66d851 4048653fff20a341 3f415f72ed66d851\n\
chain_098_vern6: steps 575 rejected 129 events 43 rhs 7494 t_end 3f43a92a30553261 drift 3e887f87c3fec453 3e887f87c3fec453 momentum 3d2112e9e4bbb1a7 max_overlap 3ee1eeb53077f38c impact 3f533102b4eebd40 warnings 0\n\
chain_098_vern6: energy 3f278b643c538195 3f24d44e3db56094 bef5f00c05a65ac4 3f4bd14687914c65\n\
chain_098_vern6: probe 0 4058cd65b543287c 3f17bc4ea2680fef 4058cd65b543287c 3f17bc4ea2680fef\n\
chain_098_vern6: probe 1 404f0854494065de 3f3dc89a7935005e 404f0854494065de 3f3dc89a7935005e\n\
chain_098_vern6: probe 2 3fe6d9f9ffc645b6 3ef2c3fb85a7b97a 3fe6d9f9ffc645b6 3ef2c3fb85a7b97a\n\
chain_098_vern6: history 120 5e8339e5634c40ef\n\
chain_098_dop853_predict: steps 200 rejected 53 events 54 rhs 3510 t_end 3f43a92a30553261 drift 3e98ee4cd6808307 3e98ee4cd6808307 momentum 3cec477dce13935a max_overlap 3ee1eeb4f539231c impact 3f533102b4eebd40 warnings 0\n\
chain_098_dop853_predict: energy 3f278b6439881ff2 3f24d44e4a2c7db0 bef5f00c05a65a1b 3f4bd1460b758329\n\
chain_098_dop853_predict: probe 0 4058cd658f7337b3 3f17bc4ea450830c 4058cd658f7337b3 3f17bc4ea450830c\n\
chain_098_dop853_predict: probe 1 404f085429464658 3f3dc89a8561fddd 404f085429464658 3f3dc89a8561fddd\n\
chain_098_dop853_predict: probe 2 3fe6d9f9cb3dce60 3ef2c3fbbf051d7d 3fe6d9f9cb3dce60 3ef2c3fbbf051d7d\n\
chain_098_dop853_predict: history 120 111a6795407f832b\n";

#[test]
fn paper_chains_and_runs_are_bitwise_unchanged() {
    let got = fingerprint();
    assert!(
        got == PINNED,
        "the paper's numbers changed; new fingerprint:\n{got}"
    );
}
