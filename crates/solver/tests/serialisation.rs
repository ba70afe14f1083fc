//! The serialised form of a scene is part of every run's identity: the sweep runner hashes
//! `serde_json::to_string(&scene)`, and sweep files are written in this form. These tests pin it
//! byte for byte, so that a refactoring of the integrator settings cannot change a run hash or
//! break a sweep file.

use chainsweep_solver::chain::model::ChainSpec;
use chainsweep_solver::scene::{IntegratorSpec, Scene};

fn json<T: serde::Serialize>(v: &T) -> String {
    serde_json::to_string(v).unwrap()
}

#[test]
fn adaptive_specs_serialise_as_before() {
    let dop = IntegratorSpec::default();
    assert_eq!(
        json(&dop),
        r#"{"method":"dop853","rtol":1e-9,"atol":null,"max_step_s":null,"locate_events":true}"#
    );
    let dop: IntegratorSpec = serde_json::from_str(
        r#"{"method":"dop853","rtol":3e-8,"atol":1e-10,"max_step_s":2e-7,"locate_events":false}"#,
    )
    .unwrap();
    assert_eq!(
        json(&dop),
        r#"{"method":"dop853","rtol":3e-8,"atol":1e-10,"max_step_s":2e-7,"locate_events":false}"#
    );
    // `predict_switches` appears only when on, so scenes without it keep their form and hash.
    let explicit_off: IntegratorSpec =
        serde_json::from_str(r#"{"method":"dop853","rtol":1e-9,"predict_switches":false}"#)
            .unwrap();
    assert_eq!(json(&explicit_off), json(&IntegratorSpec::default()));
    let predicting: IntegratorSpec =
        serde_json::from_str(r#"{"method":"dop853","rtol":5e-8,"predict_switches":true}"#).unwrap();
    assert_eq!(
        json(&predicting),
        r#"{"method":"dop853","rtol":5e-8,"atol":null,"max_step_s":null,"locate_events":true,"predict_switches":true}"#
    );
    let ros: IntegratorSpec = serde_json::from_str(r#"{"method":"ros34pw2","rtol":1e-8}"#).unwrap();
    assert_eq!(
        json(&ros),
        r#"{"method":"ros34pw2","rtol":1e-8,"atol":null,"max_step_s":null,"locate_events":true}"#
    );
    let ros: IntegratorSpec = serde_json::from_str(
        r#"{"method":"ros34pw2","rtol":1e-6,"atol":1e-9,"max_step_s":1e-6,"locate_events":false}"#,
    )
    .unwrap();
    assert_eq!(
        json(&ros),
        r#"{"method":"ros34pw2","rtol":1e-6,"atol":1e-9,"max_step_s":1e-6,"locate_events":false}"#
    );
    // Verner's 6(5) takes the same options, in the same form.
    let vern: IntegratorSpec =
        serde_json::from_str(r#"{"method":"vern6","rtol":1e-8,"predict_switches":true}"#).unwrap();
    assert_eq!(vern.method_name(), "vern6");
    assert_eq!(
        json(&vern),
        r#"{"method":"vern6","rtol":1e-8,"atol":null,"max_step_s":null,"locate_events":true,"predict_switches":true}"#
    );
    for fixed in [
        r#"{"method":"rk4","dt_s":1e-8}"#,
        r#"{"method":"verlet","dt_s":2.5e-9}"#,
    ] {
        let spec: IntegratorSpec = serde_json::from_str(fixed).unwrap();
        assert_eq!(json(&spec), fixed);
    }
}

#[test]
fn adaptive_specs_refuse_unknown_and_missing_fields() {
    for (bad, needle) in [
        (r#"{"method":"dop853","rtol":1e-8,"rtool":1}"#, "rtool"),
        (r#"{"method":"ros34pw2","rtol":1e-8,"dt_s":1e-9}"#, "dt_s"),
        (r#"{"method":"dop853","atol":1e-8}"#, "rtol"),
        (r#"{"method":"rk45","rtol":1e-8}"#, "rk45"),
        (r#"{"method":"vern6","rtol":1e-8,"dt_s":1e-9}"#, "dt_s"),
    ] {
        let e = serde_json::from_str::<IntegratorSpec>(bad)
            .unwrap_err()
            .to_string();
        assert!(e.contains(needle), "{bad}: {e}");
    }
    // An unknown method's error lists the allowed ones.
    let e = serde_json::from_str::<IntegratorSpec>(r#"{"method":"rk45","rtol":1e-8}"#)
        .unwrap_err()
        .to_string();
    for allowed in ["verlet", "rk4", "dop853", "ros34pw2", "vern6"] {
        assert!(e.contains(allowed), "{e}");
    }
}

#[test]
fn scene_serialises_as_before() {
    let mut scene = Scene::new(ChainSpec::chain_055(3), 1.3, 1e-3);
    scene.physics.damping_kg_s = 6.0;
    assert_eq!(
        json(&scene),
        concat!(
            r#"{"chain":{"cylinders":3,"sphere":{"material":{"youngs_modulus_pa":200000000000.0,"poisson_ratio":0.28},"#,
            r#""diameter_m":0.008,"mass_kg":0.002085},"cylinder":{"material":{"youngs_modulus_pa":193000000000.0,"#,
            r#""poisson_ratio":0.29},"diameter_m":0.008,"mass":{"explicit":{"mass_kg":0.00377}},"height_m":0.0096,"#,
            r#""density_kg_m3":7813.0},"striker":{"material":{"youngs_modulus_pa":200000000000.0,"poisson_ratio":0.28},"#,
            r#""diameter_m":0.008,"mass_kg":0.002085},"wall_material":{"youngs_modulus_pa":193000000000.0,"#,
            r#""poisson_ratio":0.29}},"physics":{"gravity":true,"gravity_m_s2":9.81,"damping_kg_s":6.0,"#,
            r#""striker_damping_kg_s":null,"wall":true,"clip_tensile":false},"striker_velocity_m_s":1.3,"#,
            r#""duration_s":0.001,"integrator":{"method":"dop853","rtol":1e-9,"atol":null,"max_step_s":null,"#,
            r#""locate_events":true},"max_steps":100000000,"record":{"probes":[],"history":false,"#,
            r#""history_interval_s":1e-6,"summary_interval_s":2e-7,"min_overlap":false,"preload":"include","#,
            r#""leading_pulse":{"arrival_fraction":0.01,"release_fraction":0.5},"stop_after_leading_pulses":false}}"#
        )
    );
    let back: Scene = serde_json::from_str(&json(&scene)).unwrap();
    assert_eq!(back, scene);
}
