//! Chains between two walls, rings and any initial state: two identical solitary waves running
//! head-on into each other between two walls stay mirror-symmetric (1e-10); Hertz particles
//! rattling between two fixed walls share their energy as the virial theorem says (mean kinetic
//! over total energy → 5/9 for a potential of degree 5/2, within 1 %); a solitary wave runs as
//! fast on a ring as on an open chain (1e-4) and passes the ring's closing contact; the ledgers of
//! all of them close; a wall at the top carries the precompression; bad values name the field.

use chainsweep_solver::chain::model::{Chain, Material, PhysicsSpec};
use chainsweep_solver::chain::sequence::SequenceSpec;
use chainsweep_solver::observe::probes::Probe;
use chainsweep_solver::problems::monodisperse;
use chainsweep_solver::scene::solve::{run, RunOutput};
use chainsweep_solver::scene::{
    Excitation, InitialState, IntegratorSpec, ParticleStart, RandomVelocity, Scene,
};
use chainsweep_solver::{AdaptiveOptions, ChainSpec};

/// No gravity, no damping, the wall under the chain as given.
fn bare(wall: bool) -> PhysicsSpec {
    PhysicsSpec {
        gravity: false,
        wall,
        ..PhysicsSpec::default()
    }
}

fn between_walls(n: usize) -> SequenceSpec {
    let mut spec = monodisperse(n, None, false);
    spec.top_wall_material = Some(spec.wall_material);
    spec
}

fn start(particle: usize, velocity_m_s: f64) -> ParticleStart {
    ParticleStart {
        particle,
        velocity_m_s,
        displacement_m: 0.0,
    }
}

/// The energy ledger within 1e-8 of the energy put in, and the momentum balance (the walls'
/// impulse included) within 1e-8 of the momentum scale, over the whole run.
fn assert_ledgers_close(out: &RunOutput) {
    assert!(out.energy_drift_max < 1e-8, "{}", out.energy_drift_max);
    assert!(
        out.momentum_residual_max < 1e-8,
        "{}",
        out.momentum_residual_max
    );
}

fn scene(spec: SequenceSpec, physics: PhysicsSpec, state: InitialState, duration: f64) -> Scene {
    let mut s = Scene::excited(spec, Excitation::InitialState(state), duration);
    s.physics = physics;
    s.integrator = IntegratorSpec::Dop853(AdaptiveOptions::new(1e-11));
    s
}

#[test]
fn colliding_solitary_waves_between_two_walls_stay_mirror_symmetric() {
    let n = 40;
    let state = InitialState {
        particles: vec![start(1, 0.5), start(n, -0.5)],
        random_velocity: None,
    };
    let mut s = scene(between_walls(n), bare(true), state, 6e-4);
    // Each particle of the upper half and its mirror image, displacement and velocity.
    for i in 1..=n / 2 {
        for particle in [i, n + 1 - i] {
            s.record.probes.push(Probe::Displacement { particle });
            s.record.probes.push(Probe::Velocity { particle });
        }
    }
    s.record.history = true;
    s.record.history_interval_s = 1e-6;
    let out = run(&s).unwrap();
    let h = out.history.clone().unwrap();
    let peak = |k: usize| h.values[k].iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let (x_scale, v_scale) = (peak(0), peak(1));
    assert!(v_scale >= 0.5 && x_scale > 1e-6, "{x_scale} {v_scale}");
    let mut worst = 0.0f64;
    for pair in 0..n / 2 {
        let k = 4 * pair;
        for (quantity, scale) in [(0, x_scale), (1, v_scale)] {
            let (a, b) = (&h.values[k + quantity], &h.values[k + 2 + quantity]);
            for (u, w) in a.iter().zip(b) {
                worst = worst.max((u + w).abs() / scale);
            }
        }
    }
    assert!(worst <= 1e-10, "mirror asymmetry {worst:e}");
    // The waves met in the middle, reached both walls and came back: the middle pair moved.
    let middle = 4 * (n / 2 - 1);
    assert!(peak(middle + 1) > 0.1 * v_scale);
    assert_ledgers_close(&out);
}

#[test]
fn hertz_particles_between_two_walls_keep_five_ninths_of_their_energy_kinetic() {
    let n = 8;
    let state = InitialState {
        particles: Vec::new(),
        random_velocity: Some(RandomVelocity {
            rms_m_s: 0.1,
            seed: 11,
        }),
    };
    let duration = 0.2;
    let mut s = scene(between_walls(n), bare(true), state, duration);
    s.integrator = IntegratorSpec::Dop853(AdaptiveOptions::new(1e-9));
    s.record.probes = (1..=n)
        .map(|particle| Probe::Velocity { particle })
        .collect();
    s.record.history = true;
    s.record.history_interval_s = 2e-6;
    let chain = s.validate().unwrap();
    let y0 = s.initial_state(&chain);
    let total: f64 = (0..n)
        .map(|i| 0.5 * chain.mass[i] * y0[n + i].powi(2))
        .sum();
    let out = run(&s).unwrap();
    let h = out.history.clone().unwrap();
    let samples = h.time_s.len();
    // The time average over the run (trapezoidal), of the kinetic energy over the total.
    let kinetic = |j: usize| -> f64 {
        (0..n)
            .map(|i| 0.5 * chain.mass[i] * h.values[i][j].powi(2))
            .sum()
    };
    let mut mean = 0.5 * (kinetic(0) + kinetic(samples - 1));
    for j in 1..samples - 1 {
        mean += kinetic(j);
    }
    mean /= (samples - 1) as f64;
    let ratio = mean / total;
    assert!(
        (ratio - 5.0 / 9.0).abs() < 0.01 * 5.0 / 9.0,
        "<K>/E = {ratio}, virial 5/9 = {}",
        5.0 / 9.0
    );
    // Thousands of contacts opening and closing over the run.
    assert!(out.energy_drift_max < 1e-4, "{}", out.energy_drift_max);
}

/// Leading-peak times of the forces of the first two probes, s.
fn arrival(s: &Scene) -> (f64, f64) {
    let out = run(s).unwrap();
    assert_ledgers_close(&out);
    let t = |k: usize| out.probes[k].leading_peak_time_s;
    (t(0), t(1))
}

#[test]
fn a_solitary_wave_runs_as_fast_on_a_ring_as_on_an_open_chain() {
    let n = 60;
    // Kicked forwards, particle 1 recoils into particle N and sends a small wave backwards
    // round the ring: the contacts compared are passed by the main wave well before it.
    let (a, b) = (10, 30);
    let kick = InitialState {
        particles: vec![start(1, 0.5)],
        random_velocity: None,
    };
    let probes = vec![
        Probe::ContactForce { contact: a },
        Probe::ContactForce { contact: b },
        Probe::ContactForce { contact: n },
    ];
    let mut ring_spec = monodisperse(n, None, false);
    ring_spec.ring = true;
    let mut ring = scene(ring_spec, bare(false), kick.clone(), 1.5e-3);
    ring.record.probes = probes.clone();
    ring.record.summary_interval_s = 2e-8;
    let open_spec = monodisperse(n + 1, None, false);
    let mut open = scene(open_spec, bare(false), kick, 1.5e-3);
    open.record.probes = probes;
    open.record.summary_interval_s = 2e-8;
    let (ra, rb) = arrival(&ring);
    let (oa, ob) = arrival(&open);
    let (ring_speed, open_speed) = (1.0 / (rb - ra), 1.0 / (ob - oa));

    assert!(
        (ring_speed / open_speed - 1.0).abs() < 1e-4,
        "ring {ring_speed} open {open_speed} (contacts per second)"
    );
    // The ring's closing contact (contact N, between particles N and 1) carries the main wave
    // on, at its peak force and on time.
    let out = run(&ring).unwrap();
    let (closing, main) = (out.probes[2], out.probes[1]);
    assert!(
        (closing.record_max / main.leading_peak - 1.0).abs() < 0.05,
        "{closing:?} {main:?}"
    );
    let expected = rb + (n - b) as f64 * (rb - ra) / (b - a) as f64;
    assert!(
        (closing.record_max_time_s / expected - 1.0).abs() < 0.01,
        "{} {expected}",
        closing.record_max_time_s
    );
}

#[test]
fn a_wall_at_the_top_carries_the_precompression() {
    let n = 10;
    let force = 20.0;
    let spec = between_walls(n);
    let physics = PhysicsSpec {
        precompression_force_n: force,
        ..bare(true)
    };
    let chain = Chain::build(&ChainSpec::Sequence(spec.clone()), &physics).unwrap();
    assert_eq!(chain.n_contacts(), n + 1);
    let top = chain.n_contacts() - 1;
    for c in 0..chain.n_contacts() {
        let f = chain.static_force(c);
        assert!((f / force - 1.0).abs() < 1e-12, "contact {c}: {f} N");
    }
    assert!(chain.top_wall_m.unwrap() > chain.equilibrium_position[0]);
    // Struck from inside, the chain pushes on both walls; it starts at the top wall's load, and
    // the ledgers close with the walls' impulse and no external force beside them.
    let state = InitialState {
        particles: vec![start(5, -0.05)],
        random_velocity: None,
    };
    let mut s = scene(spec, physics, state, 2e-4);
    s.record.probes = vec![Probe::ContactForce { contact: top + 1 }];
    s.record.preload = chainsweep_solver::observe::probes::Preload::Include;
    s.record.history = true;
    s.record.history_interval_s = 1e-6;
    let out = run(&s).unwrap();
    let h = out.history.clone().unwrap();
    assert!(
        (h.values[0][0] / force - 1.0).abs() < 1e-9,
        "{}",
        h.values[0][0]
    );
    assert!(
        out.probes[0].record_max > 1.1 * force,
        "{}",
        out.probes[0].record_max
    );
    assert_ledgers_close(&out);
}

#[test]
fn bad_boundaries_and_initial_states_name_the_field() {
    let err = |s: &Scene| s.validate().unwrap_err().field;
    let kick = InitialState {
        particles: vec![start(1, 0.5)],
        random_velocity: None,
    };
    let mut ring = monodisperse(2, None, false);
    ring.ring = true;
    assert_eq!(
        err(&scene(ring, bare(false), kick.clone(), 1e-4)),
        "chain.ring"
    );
    let mut ring = monodisperse(5, None, false);
    ring.ring = true;
    assert_eq!(
        err(&scene(ring.clone(), bare(true), kick.clone(), 1e-4)),
        "physics.wall"
    );
    let gravity = PhysicsSpec {
        gravity: true,
        ..bare(false)
    };
    assert_eq!(
        err(&scene(ring, gravity, kick.clone(), 1e-4)),
        "physics.gravity"
    );
    let mut struck = monodisperse(5, None, true);
    struck.top_wall_material = Some(Material::STEEL_SS304);
    let mut s = Scene::new(struck, 0.5, 1e-4);
    s.physics = bare(true);
    assert_eq!(err(&s), "chain.top_wall_material");
    let mut bad_material = between_walls(5);
    bad_material.top_wall_material = Some(Material {
        youngs_modulus_pa: -1.0,
        poisson_ratio: 0.3,
    });
    assert_eq!(
        err(&scene(bad_material, bare(true), kick.clone(), 1e-4)),
        "chain.top_wall_material.youngs_modulus_pa"
    );
    // Particle 5 of a chain hung from a top wall, with no wall under it, has one contact.
    let mut hung = scene(between_walls(5), bare(false), kick.clone(), 1e-4);
    hung.record.probes = vec![Probe::ParticleForce { particle: 5 }];
    assert_eq!(err(&hung), "record.probes[0].particle");
    let mut ring = monodisperse(5, None, false);
    ring.ring = true;
    let mut ring = scene(ring, bare(false), kick.clone(), 1e-4);
    ring.record.probes = vec![Probe::ParticleForce { particle: 5 }];
    assert!(ring.validate().is_ok());
    for (state, field) in [
        (
            InitialState {
                particles: vec![start(6, 0.5)],
                random_velocity: None,
            },
            "excitation.initial_state.particles[0].particle",
        ),
        (
            InitialState {
                particles: vec![start(2, 0.5), start(2, 0.1)],
                random_velocity: None,
            },
            "excitation.initial_state.particles[1].particle",
        ),
        (
            InitialState {
                particles: vec![start(2, f64::NAN)],
                random_velocity: None,
            },
            "excitation.initial_state.particles[0].velocity_m_s",
        ),
        (
            InitialState {
                particles: Vec::new(),
                random_velocity: Some(RandomVelocity {
                    rms_m_s: 0.0,
                    seed: 1,
                }),
            },
            "excitation.initial_state.random_velocity.rms_m_s",
        ),
        (InitialState::default(), "excitation.initial_state"),
    ] {
        assert_eq!(
            err(&scene(between_walls(5), bare(true), state, 1e-4)),
            field
        );
    }
}

#[test]
fn random_initial_velocities_depend_on_the_seed_alone() {
    let state = |seed| InitialState {
        particles: vec![start(3, 1.0)],
        random_velocity: Some(RandomVelocity { rms_m_s: 0.2, seed }),
    };
    let s = scene(between_walls(2000), bare(true), state(5), 1e-4);
    let chain = s.validate().unwrap();
    let y = s.initial_state(&chain);
    let n = chain.n_particles();
    let mut v: Vec<f64> = y[n..2 * n].to_vec();
    v[2] -= 1.0;
    let mean = v.iter().sum::<f64>() / n as f64;
    let rms = (v.iter().map(|x| x * x).sum::<f64>() / n as f64).sqrt();
    // 2000 normal draws: the mean within 4σ/√n, the rms within 5 %.
    assert!(mean.abs() < 4.0 * 0.2 / (n as f64).sqrt(), "{mean}");
    assert!((rms / 0.2 - 1.0).abs() < 0.05, "{rms}");
    assert_eq!(y, s.initial_state(&chain));
    let other = scene(between_walls(2000), bare(true), state(6), 1e-4);
    assert_ne!(y, other.initial_state(&chain));
}

#[test]
fn plastic_waves_between_two_walls_close_the_ledger_and_stay_symmetric() {
    use chainsweep_solver::contact::LawSpec;
    use chainsweep_solver::problems::rule;
    let n = 12;
    let mut spec = between_walls(n);
    let thornton = Some(LawSpec::Thornton {
        yield_pressure_pa: None,
        yield_velocity_m_s: Some(0.1),
    });
    spec.contacts = vec![
        rule("ball", "ball", thornton, None),
        rule("ball", "wall", thornton, None),
        rule("ball", "top_wall", thornton, None),
    ];
    let state = InitialState {
        particles: vec![start(1, 2.0), start(n, -2.0)],
        random_velocity: None,
    };
    let mut s = scene(spec, bare(true), state, 3e-4);
    for particle in [1, n, 3, n - 2] {
        s.record.probes.push(Probe::Velocity { particle });
    }
    s.record.history = true;
    s.record.history_interval_s = 1e-6;
    let out = run(&s).unwrap();
    assert!(out.final_energy.plastic > 0.05 * out.impact_energy_j);
    assert_ledgers_close(&out);
    let h = out.history.clone().unwrap();
    for (a, b) in [(0, 1), (2, 3)] {
        for (u, w) in h.values[a].iter().zip(&h.values[b]) {
            assert!((u + w).abs() <= 1e-10 * 2.0, "{u} {w}");
        }
    }
}
