//! Space–time fields (`record.fields`): every contact's force, every particle's displacement and
//! velocity on a coarse time grid, sampled exactly as probe histories are — a field at the
//! history interval is bitwise the histories of probes on the same contacts and particles — and
//! costing nothing (changing no other result) when not asked for.

use chainsweep_solver::observe::probes::{samples_in, FieldQuantity, FieldSpec, Fields, Preload};
use chainsweep_solver::scene::solve::{run, RunOutput};
use chainsweep_solver::scene::{IntegratorSpec, Scene};
use chainsweep_solver::{AdaptiveOptions, ChainSpec, Probe};

const ALL: [FieldQuantity; 3] = FieldQuantity::ALL;

/// The paper's 0.55 chain of `cylinders` cylinders (μ = 6 kg/s, 1.3 m/s, gravity, wall),
/// `duration` s, DOP853 at 1e-8.
fn scene(cylinders: usize, duration: f64) -> Scene {
    let mut s = Scene::new(ChainSpec::chain_055(cylinders), 1.3, duration);
    s.physics.damping_kg_s = 6.0;
    s.integrator = IntegratorSpec::Dop853(AdaptiveOptions::new(1e-8));
    s
}

/// `scene` with a probe on every contact and particle for each quantity, histories every
/// `interval`, and the fields of every quantity at the same interval.
fn probes_and_fields(mut s: Scene, interval: f64) -> (Scene, usize, usize) {
    let chain = s.validate().unwrap();
    let (n_p, n_c) = (chain.n_particles(), chain.n_contacts());
    s.record.probes = ALL
        .iter()
        .flat_map(|q| {
            let width = if q.per_contact() { n_c } else { n_p };
            (1..=width).map(move |k| q.probe(k))
        })
        .collect();
    s.record.history = true;
    s.record.history_interval_s = interval;
    s.record.fields = Some(FieldSpec {
        quantities: ALL.to_vec(),
        interval_s: interval,
    });
    (s, n_p, n_c)
}

/// Asserts that the fields of `out` are bitwise its probes' histories (probes in the order of
/// [`probes_and_fields`]).
fn assert_bitwise(out: &RunOutput, n_p: usize, n_c: usize) -> usize {
    let h = out.history.as_ref().unwrap();
    let f: &Fields = out.fields.as_ref().unwrap();
    assert_eq!(f.time_s.len(), h.time_s.len());
    for (a, b) in f.time_s.iter().zip(&h.time_s) {
        assert_eq!(a.to_bits(), b.to_bits());
    }
    let samples = f.time_s.len();
    let mut probe = 0;
    let mut compared = 0;
    for s in &f.series {
        let width = if s.quantity.per_contact() { n_c } else { n_p };
        assert_eq!(s.width, width);
        assert_eq!(s.values.len(), samples * width);
        for k in 0..width {
            let series = &h.values[probe];
            for (i, v) in series.iter().enumerate() {
                let w = s.values[i * width + k];
                assert_eq!(
                    w.to_bits(),
                    v.to_bits(),
                    "{} {} at sample {i}: field {w:e}, probe {v:e}",
                    s.quantity.name(),
                    k + 1
                );
                compared += 1;
            }
            probe += 1;
        }
    }
    compared
}

#[test]
fn fields_are_bitwise_the_probes_on_the_same_contacts_and_particles() {
    // Gravity and the wall; then the preload subtracted from the forces.
    for preload in [Preload::Include, Preload::Subtract] {
        let mut s = scene(20, 3e-4);
        s.record.preload = preload;
        let (s, n_p, n_c) = probes_and_fields(s, 2e-6);
        let out = run(&s).unwrap();
        let compared = assert_bitwise(&out, n_p, n_c);
        assert_eq!(compared, 151 * (n_c + 2 * n_p));
        // The pulse reached the far end: the fields are not a resting chain's.
        let force = &out.fields.as_ref().unwrap().series[0];
        let peak = force.values.iter().fold(0.0f64, |m, &x| m.max(x));
        assert!(peak > 50.0, "{peak}");
    }
}

#[test]
fn fields_of_a_plastic_chain_are_bitwise_its_probes() {
    // Thornton's contacts (their force reads each contact's plastic history from the state), at
    // 3 m/s: far above yield, with damping-free dents left behind.
    let scene: Scene = serde_json::from_str(
        r#"{"chain": {"particles": {
              "ball": {"sphere": {"diameter_m": 0.008, "mass_kg": 0.002085,
                       "material": {"youngs_modulus_pa": 2e11, "poisson_ratio": 0.28}}},
              "tall": {"cylinder": {"diameter_m": 0.008, "height_m": 0.0096, "density_kg_m3": 7813,
                       "material": {"youngs_modulus_pa": 1.93e11, "poisson_ratio": 0.29}}}},
            "sequence": [{"repeat": 10, "of": ["ball", "tall"]}, "ball"], "striker": "ball",
            "contacts": [
              {"between": ["ball", "ball"], "law": {"thornton": {"yield_pressure_pa": 1.5e9}}},
              {"between": ["ball", "tall"], "law": {"thornton": {"yield_pressure_pa": 1.5e9}}},
              {"between": ["ball", "wall"], "law": {"thornton": {"yield_pressure_pa": 1.5e9}}}]},
           "physics": {"gravity": true, "damping_kg_s": 0.0, "wall": true},
           "striker_velocity_m_s": 3.0, "duration_s": 3e-4,
           "integrator": {"method": "dop853", "rtol": 1e-8}}"#,
    )
    .unwrap();
    assert!(scene.validate().unwrap().has_plasticity());
    let (s, n_p, n_c) = probes_and_fields(scene, 2e-6);
    let out = run(&s).unwrap();
    assert_bitwise(&out, n_p, n_c);
}

#[test]
fn fields_of_a_long_chain_integrated_only_where_it_moves_are_bitwise_its_probes() {
    // 602 particles: only the moving part is integrated, the fields read the rest at rest.
    let (s, n_p, n_c) = probes_and_fields(scene(300, 1e-4), 5e-6);
    assert!(chainsweep_solver::integrates_moving_part(&s));
    let out = run(&s).unwrap();
    assert!(out.active_particles.unwrap() < n_p);
    assert_bitwise(&out, n_p, n_c);
}

#[test]
fn fields_change_nothing_else_and_cost_nothing_when_off() {
    let mut base = scene(20, 3e-4);
    base.record.probes = vec![
        Probe::GaugeForce { cylinder: 4 },
        Probe::GaugeForce { cylinder: 15 },
    ];
    base.record.history = true;
    base.record.min_overlap = true;
    let off = run(&base).unwrap();
    assert!(off.fields.is_none());
    let mut on = base.clone();
    on.record.fields = Some(FieldSpec {
        quantities: vec![FieldQuantity::Velocity, FieldQuantity::ContactForce],
        interval_s: 1e-5,
    });
    let mut with = run(&on).unwrap();
    let fields = with.fields.take().unwrap();
    // Everything else bitwise the same (the same steps, the same summaries).
    assert_eq!(off.stats, with.stats);
    // (As text: a NaN leading peak is the same result.)
    assert_eq!(format!("{:?}", off.probes), format!("{:?}", with.probes));
    assert_eq!(off.history, with.history);
    assert_eq!(off.min_overlap_m, with.min_overlap_m);
    assert_eq!(
        off.energy_drift_max.to_bits(),
        with.energy_drift_max.to_bits()
    );
    // In the order asked for; the instants 0, 10 µs, … up to 300 µs (30 × 1e-5 rounds above
    // 3e-4, so 30 of them, as the histories count them).
    assert_eq!(fields.series[0].quantity, FieldQuantity::Velocity);
    assert_eq!(fields.series[1].quantity, FieldQuantity::ContactForce);
    assert_eq!(fields.time_s.len(), 30);
    assert_eq!(samples_in(0.0, 1e-5, 3e-4), 30);
    for (i, t) in fields.time_s.iter().enumerate() {
        assert_eq!(t.to_bits(), (i as f64 * 1e-5).to_bits());
    }
    // The striker's velocity at t = 0 is the impact velocity; every other particle rests.
    let v = &fields.series[0];
    assert_eq!(v.values[0], 1.3);
    assert!(v.values[1..v.width].iter().all(|&x| x == 0.0));
    // At rest under gravity, the contact forces at t = 0 are the static loads, growing down the
    // chain (the striker's contact is open).
    let f = &fields.series[1];
    assert_eq!(f.values[0], 0.0);
    assert!(f.values[1..f.width].windows(2).all(|w| w[1] > w[0]));
}

#[test]
fn fields_of_a_run_stopped_after_its_leading_pulses_end_with_it() {
    let mut s = scene(20, 1e-3);
    s.record.probes = vec![Probe::GaugeForce { cylinder: 4 }];
    s.record.stop_after_leading_pulses = true;
    s.record.fields = Some(FieldSpec {
        quantities: vec![FieldQuantity::Displacement],
        interval_s: 1e-6,
    });
    s.record.history = true;
    s.record.history_interval_s = 1e-6;
    let out = run(&s).unwrap();
    let f = out.fields.unwrap();
    assert!(out.t_end_s < 2e-4, "{}", out.t_end_s);
    // The fields end where the record does, at the summary instant at which the leading pulse
    // was seen to pass (within the last step, not at its end): with the histories.
    let h = out.history.unwrap();
    assert_eq!(f.time_s, h.time_s);
    let last = *f.time_s.last().unwrap();
    assert!(last <= out.t_end_s, "{last} {}", out.t_end_s);
    assert!(last >= out.probes[0].leading_peak_time_s);
}

#[test]
fn bad_fields_are_refused_naming_the_field() {
    let bad = |quantities: Vec<FieldQuantity>, interval_s: f64| {
        let mut s = scene(20, 1e-3);
        s.record.fields = Some(FieldSpec {
            quantities,
            interval_s,
        });
        s.validate().unwrap_err()
    };
    for dt in [0.0, -1e-6, f64::NAN, f64::INFINITY] {
        let e = bad(vec![FieldQuantity::ContactForce], dt);
        assert_eq!(e.field, "record.fields.interval_s", "{dt}: {e}");
    }
    assert_eq!(bad(vec![], 1e-6).field, "record.fields.quantities");
    let e = bad(vec![FieldQuantity::Velocity, FieldQuantity::Velocity], 1e-6);
    assert_eq!(e.field, "record.fields.quantities[1]");
    // More than ten million values in one run: 42 particles × 1e6 samples.
    let e = bad(vec![FieldQuantity::Velocity], 1e-9);
    assert_eq!(e.field, "record.fields.interval_s");
    assert!(e.message.contains("at least"), "{e}");
    // A fine interval within the bound is accepted.
    let mut s = scene(20, 1e-3);
    s.record.fields = Some(FieldSpec {
        quantities: vec![FieldQuantity::Velocity],
        interval_s: 1e-7,
    });
    s.validate().unwrap();
}

#[test]
fn a_scene_without_fields_serialises_as_before() {
    // The record block of scenes without fields (and so their run hashes) is unchanged.
    let s = scene(20, 1e-3);
    let json = serde_json::to_string(&s).unwrap();
    assert!(!json.contains("fields"), "{json}");
    let mut with = s.clone();
    with.record.fields = Some(FieldSpec {
        quantities: vec![FieldQuantity::ContactForce],
        interval_s: 1e-6,
    });
    let json = serde_json::to_string(&with).unwrap();
    assert!(
        json.contains(r#""fields":{"quantities":["contact_force"],"interval_s":1e-6}"#),
        "{json}"
    );
    let back: Scene = serde_json::from_str(&json).unwrap();
    assert_eq!(back.record.fields, with.record.fields);
    let unknown = json.replace("contact_force", "pressure");
    assert!(serde_json::from_str::<Scene>(&unknown).is_err());
}

#[test]
fn fields_of_a_chain_too_long_for_a_whole_batch_of_instants_are_bitwise_its_probes() {
    // 20 002 particles: 40 000 interpolated components per instant, so that a batch holds fewer
    // than the probes' 32 instants; the values do not depend on the batch.
    let mut s = scene(10_000, 5e-5);
    s.record.probes = vec![
        Probe::ContactForce { contact: 1 },
        Probe::ContactForce { contact: 4 },
        Probe::Velocity { particle: 30 },
        Probe::ContactForce { contact: 20_002 },
    ];
    s.record.history = true;
    s.record.history_interval_s = 4e-7;
    s.record.fields = Some(FieldSpec {
        quantities: vec![FieldQuantity::ContactForce, FieldQuantity::Velocity],
        interval_s: 4e-7,
    });
    let out = run(&s).unwrap();
    let (h, f) = (out.history.unwrap(), out.fields.unwrap());
    assert_eq!(f.time_s.len() as u64, samples_in(0.0, 4e-7, 5e-5));
    assert!(f.time_s.len() >= 125);
    let (force, velocity) = (&f.series[0], &f.series[1]);
    assert_eq!((force.width, velocity.width), (20_002, 20_002));
    let column = |s: &chainsweep_solver::observe::probes::FieldSeries, k: usize| -> Vec<u64> {
        (0..f.time_s.len())
            .map(|i| s.values[i * s.width + k - 1].to_bits())
            .collect()
    };
    let bits = |v: &[f64]| -> Vec<u64> { v.iter().map(|x| x.to_bits()).collect() };
    assert_eq!(column(force, 1), bits(&h.values[0]));
    assert_eq!(column(force, 4), bits(&h.values[1]));
    assert_eq!(column(velocity, 30), bits(&h.values[2]));
    assert_eq!(column(force, 20_002), bits(&h.values[3]));
    // The pulse reached contact 4 (the wall, 10 000 cylinders down, still rests under the chain).
    assert!(column(force, 4).iter().any(|&b| f64::from_bits(b) > 50.0));
}
