//! A chain between two walls starts in static equilibrium whatever its walls are made of: every
//! contact force at t = 0 is the load it carries (the precompression and the weight of the
//! particles above it, 1e-12), for unequal walls under Hertz's law and under power laws, with and
//! without gravity, undriven and under every drive; an actuator-driven chain between unequal
//! walls settles on the closed-form response of the chain linearised about that preload (1e-6); a
//! small free vibration of such a chain runs at the lowest frequency `record.spectrum` gives
//! (1e-6).

use chainsweep_solver::chain::drive::{DriveSpec, Harmonic, Waveform};
use chainsweep_solver::chain::model::{Chain, Material, PhysicsSpec};
use chainsweep_solver::chain::sequence::SequenceSpec;
use chainsweep_solver::observe::probes::{Preload, Probe};
use chainsweep_solver::observe::steady::SteadyStateSpec;
use chainsweep_solver::problems::complex::solve;
use chainsweep_solver::problems::{monodisperse, power_law, rule};
use chainsweep_solver::scene::solve::run;
use chainsweep_solver::scene::{Excitation, InitialState, IntegratorSpec, ParticleStart, Scene};
use chainsweep_solver::spectrum::LinearChain;
use chainsweep_solver::{AdaptiveOptions, ChainSpec};

/// A softer wall at the top than the SS304 wall under the chain (an aluminium face).
const ALUMINIUM: Material = Material {
    youngs_modulus_pa: 70e9,
    poisson_ratio: 0.33,
};

/// `n` 8 mm 440C spheres between an SS304 wall below and an aluminium wall above; with
/// `power_laws`, the two walls' contacts follow power laws of their own instead of Hertz's.
fn unequal_walls(n: usize, power_laws: bool) -> SequenceSpec {
    let mut spec = monodisperse(n, None, false);
    spec.top_wall_material = Some(ALUMINIUM);
    if power_laws {
        spec.contacts = vec![
            rule("ball", "wall", Some(power_law(3e9, 1.4)), None),
            rule("ball", "top_wall", Some(power_law(8e8, 1.6)), None),
        ];
    }
    spec
}

fn physics(precompression_force_n: f64, gravity: bool, damping_kg_s: f64) -> PhysicsSpec {
    PhysicsSpec {
        gravity,
        wall: true,
        damping_kg_s,
        precompression_force_n,
        ..PhysicsSpec::default()
    }
}

fn harmonic(amplitude: f64, frequency_hz: f64, ramp_periods: f64) -> Waveform {
    Waveform::Harmonic(Harmonic {
        amplitude,
        frequency_hz,
        phase_rad: 0.0,
        ramp_periods,
    })
}

/// Every contact force at the first sample (t = 0), preload included.
fn forces_at_start(mut s: Scene, contacts: usize) -> Vec<f64> {
    s.record.probes = (1..=contacts)
        .map(|contact| Probe::ContactForce { contact })
        .collect();
    s.record.preload = Preload::Include;
    s.record.history = true;
    s.record.history_interval_s = 1e-6;
    s.duration_s = 2e-6;
    let out = run(&s).unwrap();
    let h = out.history.unwrap();
    h.values.iter().map(|v| v[0]).collect()
}

#[test]
fn a_chain_between_unequal_walls_starts_at_the_load_each_contact_carries() {
    let n = 4;
    for power_laws in [false, true] {
        for (force, gravity) in [(5.0, false), (0.0, true), (5.0, true)] {
            let drives: [Option<DriveSpec>; 4] = [
                None,
                Some(DriveSpec::ForceN(harmonic(0.1, 2e3, 2.0))),
                Some(DriveSpec::ActuatorM(harmonic(1e-8, 2e3, 2.0))),
                Some(DriveSpec::BaseM(harmonic(1e-8, 2e3, 2.0))),
            ];
            for drive in drives {
                let spec = unequal_walls(n, power_laws);
                let p = physics(force, gravity, 0.0);
                let chain = Chain::build(&ChainSpec::Sequence(spec.clone()), &p).unwrap();
                let g = chain.gravity_m_s2;
                // Contact j (below particle j) carries the precompression and the weight of
                // particles 1..=j; contact N (the wall under the chain) all of it; the wall at the
                // top the precompression alone.
                let mut expected: Vec<f64> = (0..n)
                    .map(|j| force + g * chain.mass[..=j].iter().sum::<f64>())
                    .collect();
                expected.push(force);
                let what = format!(
                    "power laws {power_laws}, precompression {force} N, gravity {gravity}, drive {:?}",
                    drive.as_ref().map(|d| format!("{d:?}"))
                );
                let mut s = match drive {
                    None => Scene::excited(
                        spec,
                        Excitation::InitialState(InitialState {
                            particles: vec![ParticleStart {
                                particle: 2,
                                velocity_m_s: 1e-6,
                                displacement_m: 0.0,
                            }],
                            random_velocity: None,
                        }),
                        1e-3,
                    ),
                    Some(d) => Scene::excited(spec, Excitation::Drive(d), 1e-3),
                };
                s.physics = p;
                s.integrator = IntegratorSpec::Dop853(AdaptiveOptions::new(1e-10));
                let got = forces_at_start(s, n + 1);
                for (c, (&f, &want)) in got.iter().zip(&expected).enumerate() {
                    let scale = want.max(1e-3);
                    assert!(
                        (f - want).abs() <= 1e-12 * scale,
                        "{what}: contact {} carries {f:e} N at t = 0, its load is {want:e} N",
                        c + 1
                    );
                }
            }
        }
    }
}

/// `A cos(ωt + φ)` against `Im(X e^{iωt})`: the amplitude and the phase `arg X − π/2`.
fn assert_harmonic(amplitude: f64, phase_rad: f64, x: (f64, f64), what: &str) {
    let want = (x.0 * x.0 + x.1 * x.1).sqrt();
    assert!(
        (amplitude - want).abs() < 1e-6 * want,
        "{what}: amplitude {amplitude:e} against {want:e}"
    );
    let dphi = (phase_rad - (x.1.atan2(x.0) - std::f64::consts::FRAC_PI_2))
        .rem_euclid(std::f64::consts::TAU);
    assert!(
        dphi.min(std::f64::consts::TAU - dphi) < 1e-6,
        "{what}: phase {phase_rad} against {}",
        x.1.atan2(x.0) - std::f64::consts::FRAC_PI_2
    );
}

#[test]
fn an_actuator_between_unequal_walls_drives_the_linearised_preloaded_chain() {
    let n = 3;
    let mu = 20.0;
    let spec = unequal_walls(n, false);
    let p = physics(5.0, true, mu);
    let chain = Chain::build(&ChainSpec::Sequence(spec.clone()), &p).unwrap();
    let lin = LinearChain::of(&chain).unwrap();
    let f1 = lin.spectrum(false).angular_frequency_rad_s[0] / std::f64::consts::TAU;
    let f = 0.8 * f1;
    let omega = std::f64::consts::TAU * f;
    // An amplitude 3e-4 of the top wall's static overlap: the response's departure from the
    // linear one is of its square.
    let amplitude = 3e-4 * chain.static_overlap[n];
    let (settle, window) = (400, 20);
    let mut s = Scene::excited(
        spec,
        Excitation::Drive(DriveSpec::ActuatorM(harmonic(amplitude, f, 4.0))),
        (settle + window) as f64 / f,
    );
    s.physics = p;
    s.integrator = IntegratorSpec::Dop853(AdaptiveOptions::new(1e-12));
    s.record.probes = (1..=n)
        .map(|particle| Probe::Displacement { particle })
        .collect();
    s.record.steady_state = Some(SteadyStateSpec {
        frequency_hz: None,
        settle_periods: settle,
        window_periods: window,
        harmonics: 1,
        samples_per_period: 64,
        settled_tolerance: 1e-7,
        reference_probe: 0,
    });
    let out = run(&s).unwrap();
    let steady = out.steady_state.expect("recorded");

    // (K − ω²M + iωC) X = (k_top + iωc_top) U e₁: the wall at the top moves by U into the chain.
    let mut a = vec![vec![(0.0, 0.0); n]; n];
    for i in 0..n {
        let above = if i == 0 {
            (lin.top_stiffness, lin.top_damping)
        } else {
            (lin.stiffness[i - 1], lin.damping[i - 1])
        };
        let below = if i + 1 < n {
            (lin.stiffness[i], lin.damping[i])
        } else {
            (lin.wall_stiffness, lin.wall_damping)
        };
        a[i][i] = (
            above.0 + below.0 - omega * omega * lin.mass[i],
            omega * (above.1 + below.1),
        );
        if i + 1 < n {
            a[i][i + 1] = (-lin.stiffness[i], -omega * lin.damping[i]);
            a[i + 1][i] = a[i][i + 1];
        }
    }
    let mut b = vec![(0.0, 0.0); n];
    b[0] = (
        lin.top_stiffness * amplitude,
        omega * lin.top_damping * amplitude,
    );
    let x = solve(a, b);
    for (i, xi) in x.iter().enumerate() {
        let p = &steady.probes[i];
        assert!(p.settled, "particle {}: {p:?}", i + 1);
        assert_harmonic(
            p.amplitude[0],
            p.phase_rad[0],
            *xi,
            &format!("particle {}", i + 1),
        );
    }
}

/// Times at which `y` crosses `level` upwards, each by the cubic through the four samples around
/// it (Newton on the cubic from the linear estimate).
fn upward_crossings(times: &[f64], y: &[f64], level: f64) -> Vec<f64> {
    let mut out = Vec::new();
    for j in 1..y.len() - 2 {
        let (a, b) = (y[j] - level, y[j + 1] - level);
        if a < 0.0 && b >= 0.0 {
            let v = [y[j - 1], y[j], y[j + 1], y[j + 2]].map(|v| v - level);
            // Lagrange cubic in u (samples at u = -1, 0, 1, 2).
            let p = |u: f64| {
                -v[0] * u * (u - 1.0) * (u - 2.0) / 6.0
                    + v[1] * (u + 1.0) * (u - 1.0) * (u - 2.0) / 2.0
                    - v[2] * (u + 1.0) * u * (u - 2.0) / 2.0
                    + v[3] * (u + 1.0) * u * (u - 1.0) / 6.0
            };
            let mut u = a / (a - b);
            for _ in 0..30 {
                let h = 1e-6;
                let d = (p(u + h) - p(u - h)) / (2.0 * h);
                let step = p(u) / d;
                u -= step;
                if step.abs() < 1e-15 {
                    break;
                }
            }
            let dt = times[j + 1] - times[j];
            out.push(times[j] + u * dt);
        }
    }
    out
}

#[test]
fn a_small_free_vibration_between_unequal_walls_runs_at_the_spectrum_s_lowest_frequency() {
    let n = 5;
    // (Gravity alone leaves the wall at the top touching without load: its contact, stiffless at
    // zero overlap, makes any vibration nonlinear, so every case here is precompressed.)
    for (force, gravity) in [(5.0, false), (2.0, true), (0.5, true)] {
        let spec = unequal_walls(n, false);
        let p = physics(force, gravity, 0.0);
        let chain = Chain::build(&ChainSpec::Sequence(spec.clone()), &p).unwrap();
        let lin = LinearChain::of(&chain).unwrap();
        let sp = lin.spectrum(true);
        let omega1 = sp.angular_frequency_rad_s[0];
        let mode = &sp.modes.as_ref().unwrap()[..n];
        // The lowest mode, its largest displacement 1e-5 of the smallest static overlap.
        let smallest = chain.static_overlap[..=n]
            .iter()
            .copied()
            .filter(|&d| d > 0.0)
            .fold(f64::INFINITY, f64::min);
        let peak = mode.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let scale = 1e-5 * smallest / peak;
        let state = InitialState {
            particles: (0..n)
                .map(|i| ParticleStart {
                    particle: i + 1,
                    velocity_m_s: 0.0,
                    displacement_m: scale * mode[i],
                })
                .collect(),
            random_velocity: None,
        };
        let period = std::f64::consts::TAU / omega1;
        let periods = 60.0;
        let mut s = Scene::excited(
            spec,
            Excitation::InitialState(state),
            (periods + 0.5) * period,
        );
        s.physics = p;
        s.integrator = IntegratorSpec::Dop853(AdaptiveOptions::new(1e-12));
        let k = (0..n)
            .max_by(|&a, &b| mode[a].abs().total_cmp(&mode[b].abs()))
            .unwrap();
        s.record.probes = vec![Probe::Displacement { particle: k + 1 }];
        s.record.history = true;
        s.record.history_interval_s = period / 400.0;
        let out = run(&s).unwrap();
        let h = out.history.unwrap();
        let crossings = upward_crossings(&h.time_s, &h.values[0], 0.0);
        assert!(crossings.len() >= 50, "{} crossings", crossings.len());
        let measured = (crossings.len() - 1) as f64
            / (crossings[crossings.len() - 1] - crossings[0])
            * std::f64::consts::TAU;
        assert!(
            (measured / omega1 - 1.0).abs() < 1e-6,
            "precompression {force} N, gravity {gravity}: free vibration at {measured} rad/s, \
             the spectrum's lowest {omega1} rad/s ({:e} apart)",
            measured / omega1 - 1.0
        );
    }
}
