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
reference: steps 1321 rejected 591 events 167 rhs 26986 t_end 3f50624dd2f1a9fc drift 3ea68568298e40a2 3ea68458e9de6f6c momentum 3ce70ef84d726c54 max_overlap 3ee42fd1fecd20b0 impact 3f5cdda13066d01a warnings 0\n\
reference: energy 3f399a54854d0d4a 3f32666960ccaaa7 bf14cc95b340f602 3f52a4bd7ff16f48\n\
reference: probe 0 405ae1b89c000528 3f1999eed5dd0bc6 405ae1b89c000528 3f1999eed5dd0bc6\n\
reference: probe 1 404c308aafffef09 3f414fc266f67079 404c308aafffef09 3f414fc266f67079\n\
chain_098_probes: steps 674 rejected 206 events 151 rhs 12982 t_end 3f43a92a30553261 drift 3e20e118df0175cc 3e20c5b18f07f6d6 momentum 3ce1c8f61e9a4fab max_overlap 3ee24a8612905af1 impact 3f533102b4eebd40 warnings 0\n\
chain_098_probes: energy 3f4554da6001b43c 3f41945939feb773 bef5f00bfa418292 0000000000000000\n\
chain_098_probes: probe 0 405ccbe9eb77ed57 3f17c733e11dcb61 405ccbe9eb77ed57 3f17c733e11dcb61\n\
chain_098_probes: probe 1 405d313aa1592803 3f3caa6cf37fdf0c 405d313aa1592803 3f3caa6cf37fdf0c\n\
chain_098_probes: probe 2 406517b8feab2ca5 3ee9cf25ef36e7fc 406517b8feab2ca5 3ee9cf25ef36e7fc\n\
chain_098_probes: probe 3 3edc8088bdfde7fd 3f1bcb558d1df0a5 3edc8088bdfde7fd 3f1bcb558d1df0a5\n\
chain_098_probes: probe 4 3eea6a9c98ecbe75 3f2e00c8805bdc77 3eea6a9c98ecbe75 3f2e00c8805bdc77\n\
chain_098_probes: probe 5 3fe7dff5794d32da 3ef2fad154c44073 3fe7dff5794d32da 3ef2fad154c44073\n\
chain_098_probes: probe 6 7ff8000000000000 7ff8000000000000 3ff3ea91c8ae809d 3f43a92a30553261\n\
chain_098_probes: min_overlap 65754cadec9587f9\n\
chain_098_subtract_history: steps 634 rejected 251 events 24 rhs 12369 t_end 3f43a92a30553261 drift 3e1534249c484417 3e1534249c484417 momentum 3ced46013a524388 max_overlap 3ee1d32934d22894 impact 3f533102b4eebd40 warnings 0\n\
chain_098_subtract_history: energy 3f278b64ae1bf242 3f24d44e9bd55fbb bef5f00c05a65a17 3f4bd146c855a92a\n\
chain_098_subtract_history: probe 0 4058c3ac01d9a776 3f17bc4ea2d19206 4058c3ac01d9a776 3f17bc4ea2d19206\n\
chain_098_subtract_history: probe 1 404e9cc2bd869ec9 3f3dc89a77018b0d 404e9cc2bd869ec9 3f3dc89a77018b0d\n\
chain_098_subtract_history: probe 2 40643bd6803ca0a2 3ee9487704f68bd0 40643bd6803ca0a2 3ee9487704f68bd0\n\
chain_098_subtract_history: probe 3 3ed8ca0e665773e6 3f1bda9b623d1230 3ed8ca0e665773e6 3f1bda9b623d1230\n\
chain_098_subtract_history: probe 4 7ff8000000000000 7ff8000000000000 3eed3d916aa6a8be 3f43a92a30553261\n\
chain_098_subtract_history: probe 5 3fe6d9fa04cd19df 3ef2c3fb7f2820ab 3fe6d9fa04cd19df 3ef2c3fb7f2820ab\n\
chain_098_subtract_history: probe 6 7ff8000000000000 7ff8000000000000 3ed468ac9a340000 3f43a92a30553261\n\
chain_098_subtract_history: min_overlap 82037d0b11392add\n\
chain_098_subtract_history: history 120 3b8b30f11b22f768\n\
light_ros34pw2_clip: steps 988 rejected 266 events 257 rhs 4752 t_end 3f33a92a30553261 drift 3ec591e023719b01 3eb69ce352c0e3dd momentum 3e71243e5db97b1c max_overlap 3ee673af1782ba11 impact 3f5cdda13066d01a warnings 0\n\
light_ros34pw2_clip: energy 3f29e5217ad971cd 3f192a32226501a8 8000000000000000 3f580e575228c789\n\
light_ros34pw2_clip: probe 0 404390474e4f9da6 3f110d72fcba43d2 404390474e4f9da6 3f110d72fcba43d2\n\
light_ros34pw2_clip: probe 1 402bbb37058461d6 3f32eee51420d337 402bbb37058461d6 3f32eee51420d337\n\
free_rk4: steps 10000 rejected 0 events 0 rhs 40001 t_end 3f2a36e2eb1c432d drift 3e0d4f2a3063df57 3e0c417c5a7d7a36 momentum 3cf617da48ff4b1e max_overlap 3ee22dee69810491 impact 3f533102b4eebd40 warnings 0\n\
free_rk4: energy 3f40124698a7d62b 3f3a6000a04411ba 8000000000000000 3f323f7d01181469\n\
free_rk4: probe 0 405aed30c02f9de3 3f12602d77a6e331 405aed30c02f9de3 3f12602d77a6e331\n\
free_rk4: probe 1 3fe4f2331d624b5c 3f2000bcb963f840 3fe4f2331d624b5c 3f2000bcb963f840\n\
free_verlet: steps 20000 rejected 0 events 0 rhs 20001 t_end 3f2a36e2eb1c432d drift 3e80834d8fd971bf 3e5515818f407770 momentum 3d110301adf7c6a4 max_overlap 3ee2703f511c9d7c impact 3f533102b4eebd40 warnings 0\n\
free_verlet: energy 3f44fa25630f2514 3f4167dffa2945c7 8000000000000000 0000000000000000\n\
free_verlet: probe 0 405c9fc56a038610 3f126c5f63337353 405c9fc56a038610 3f126c5f63337353\n\
free_verlet: probe 1 3fe727d777dcb86c 3f1ff2c12eeaea19 3fe727d777dcb86c 3f1ff2c12eeaea19\n\
heavy_stop_early: steps 680 rejected 244 events 27 rhs 12994 t_end 3f42ccde18f5483f drift 3e2ca4bd424479de 3e265bbdc34f2506 momentum 3ce17164a8ee4805 max_overlap 3ee62d8b930148ec impact 3f61f4a7dd293b62 warnings 0\n\
heavy_stop_early: energy 3f37deca34ae05d0 3f31abd7dc45b06e bf125a5cec4ad1e3 3f5a260879358998\n\
heavy_stop_early: probe 0 4048654001622751 3f415f72e8544a0d 4048654001622751 3f415f72e8544a0d\n\
chain_098_vern6: steps 678 rejected 212 events 82 rhs 9402 t_end 3f43a92a30553261 drift 3e9052630e8aaf95 3e9052630c3fc1fd momentum 3d20b53d140110cf max_overlap 3ee1e535d5052568 impact 3f533102b4eebd40 warnings 0\n\
chain_098_vern6: energy 3f278b64b476e2e0 3f24d44e86a35695 bef5f00c05a65a78 3f4bd146303840bf\n\
chain_098_vern6: probe 0 4058cd65fcaefb75 3f17bc4e9e4bf518 4058cd65fcaefb75 3f17bc4e9e4bf518\n\
chain_098_vern6: probe 1 404f085493958f29 3f3dc89a6ea53997 404f085493958f29 3f3dc89a6ea53997\n\
chain_098_vern6: probe 2 3fe6d9fa7c5a69a9 3ef2c3fb73ae1982 3fe6d9fa7c5a69a9 3ef2c3fb73ae1982\n\
chain_098_vern6: history 120 c8821081e927eaff\n\
chain_098_dop853_predict: steps 226 rejected 56 events 53 rhs 4052 t_end 3f43a92a30553261 drift 3e8fcb3c90e84860 3e8fcb3c90e84860 momentum 3ce8be8e145120ee max_overlap 3ee1ed004b12dce8 impact 3f533102b4eebd40 warnings 0\n\
chain_098_dop853_predict: energy 3f278b65660590d2 3f24d44f10131030 bef5f00c05a65a19 3f4bd145e58c5d84\n\
chain_098_dop853_predict: probe 0 4058cd663fba81ea 3f17bc4e9cfffb10 4058cd663fba81ea 3f17bc4e9cfffb10\n\
chain_098_dop853_predict: probe 1 404f0855184619cb 3f3dc89a69cbfe7a 404f0855184619cb 3f3dc89a69cbfe7a\n\
chain_098_dop853_predict: probe 2 3fe6d9faf923cf91 3ef2c3fbdeb758d9 3fe6d9faf923cf91 3ef2c3fbdeb758d9\n\
chain_098_dop853_predict: history 120 8fd8e3c9a0c5c902\n\
";

#[test]
fn paper_chains_and_runs_are_bitwise_unchanged() {
    let got = fingerprint();
    assert!(
        got == PINNED,
        "the paper's numbers changed; new fingerprint:\n{got}"
    );
}
