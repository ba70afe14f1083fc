//! Driven chains: a precompressed linear chain with viscous damping under a harmonic force settles
//! on the steady response the complex linear system `(K − ω²M + iωC) X = F` gives (amplitude and
//! phase of every particle to 1e-6, from its history and from `record.steady_state`); the ledger of a driven chain closes with the drive's work
//! (< 1e-8 of the work put in) for a force, an actuator and a moving base, and for chirps, sums
//! and recordings; an actuator that pulls away loses contact and the chain flies free; a moving
//! base far below the chain's frequencies carries the chain with it; a driven frequency sweep of
//! a long precompressed dimer finds the top of its acoustic band, `√(2K/m_heavy)`, within 1 %;
//! bad drives name the field.

use chainsweep_solver::chain::drive::{
    Chirp, ChirpSpacing, DriveSpec, Harmonic, Recorded, SumOfHarmonics, Tone, Waveform,
};
use chainsweep_solver::chain::model::{Chain, PhysicsSpec};
use chainsweep_solver::chain::sequence::SequenceSpec;
use chainsweep_solver::observe::probes::Probe;
use chainsweep_solver::observe::steady::SteadyStateSpec;
use chainsweep_solver::problems::complex::solve;
use chainsweep_solver::problems::{chain, monodisperse, power_law, rule, sphere, STEEL};
use chainsweep_solver::scene::solve::{run, RunOutput};
use chainsweep_solver::scene::{Excitation, IntegratorSpec, Scene};
use chainsweep_solver::{AdaptiveOptions, ChainSpec};

fn harmonic(amplitude: f64, frequency_hz: f64, ramp_periods: f64) -> Waveform {
    Waveform::Harmonic(Harmonic {
        amplitude,
        frequency_hz,
        phase_rad: 0.0,
        ramp_periods,
    })
}

fn driven(spec: SequenceSpec, physics: PhysicsSpec, drive: DriveSpec, duration: f64) -> Scene {
    let mut s = Scene::excited(spec, Excitation::Drive(drive), duration);
    s.physics = physics;
    s.integrator = IntegratorSpec::Dop853(AdaptiveOptions::new(1e-11));
    s
}

/// `(b, a)` with `y ≈ b sin ωt + a cos ωt` over the samples at `times` from `from` on, summed over
/// whole periods (exact for a signal that holds only the harmonics of ω).
fn fourier(times: &[f64], y: &[f64], omega: f64, from: usize, per_period: usize) -> (f64, f64) {
    let periods = (times.len() - from - 1) / per_period;
    let count = periods * per_period;
    let (mut s, mut c) = (0.0, 0.0);
    for k in from..from + count {
        let (sn, cs) = (omega * times[k]).sin_cos();
        s += y[k] * sn;
        c += y[k] * cs;
    }
    (2.0 * s / count as f64, 2.0 * c / count as f64)
}

/// Three particles with a linear law (`n = 1`) on a wall, precompressed so that no contact opens,
/// with viscous damping: driven by a harmonic force on the first particle, each particle settles
/// on `Im(X e^{iωt})` with `(K − ω²M + iωC) X = F e₁`, amplitude and phase to 1e-6.
#[test]
fn a_linear_chain_settles_on_the_closed_form_steady_response() {
    let (k, mu, n) = (2e7, 40.0, 3);
    let spec = monodisperse(n, Some(power_law(k, 1.0)), false);
    let physics = PhysicsSpec {
        gravity: false,
        wall: true,
        damping_kg_s: mu,
        precompression_force_n: 50.0,
        ..PhysicsSpec::default()
    };
    let chain = Chain::build(&ChainSpec::Sequence(spec.clone()), &physics).unwrap();
    let m = chain.mass[0];
    let omega1 = (k / m).sqrt();
    let omega = 0.6 * omega1;
    let f = omega / std::f64::consts::TAU;
    let period = 1.0 / f;
    // Damping proportional to stiffness: mode j decays at μ ω_j² / (2k), the slowest (ω₁² ≈ 0.2
    // k/m) at about 1.9e3 /s: 200 periods (21 ms) leave e^{-40} of the transient.
    let amplitude = 1.0;
    let settle = 200.0 * period;
    let window = 20.0 * period;
    let per_period = 64;
    let mut s = driven(
        spec,
        physics,
        DriveSpec::ForceN(harmonic(amplitude, f, 4.0)),
        settle + window,
    );
    for particle in 1..=n {
        s.record.probes.push(Probe::Displacement { particle });
    }
    s.record.history = true;
    s.record.history_interval_s = period / per_period as f64;
    // The same window read by `record.steady_state`, at the drive's own frequency.
    s.record.steady_state = Some(SteadyStateSpec {
        frequency_hz: None,
        settle_periods: 200,
        window_periods: 20,
        harmonics: 2,
        samples_per_period: 64,
        settled_tolerance: 1e-6,
        reference_probe: 0,
    });
    let out = run(&s).unwrap();
    let h = out.history.clone().unwrap();
    let from = h.time_s.iter().position(|&t| t >= settle - 1e-15).unwrap();
    let steady = out.steady_state.clone().expect("recorded");
    assert_eq!(steady.frequency_hz, f);

    // K − ω²M + iωC: every contact (the wall's included) a spring k and a dashpot μ.
    let mut a = vec![vec![(0.0, 0.0); n]; n];
    for c in 0..n {
        let (i, j) = (c, c + 1);
        for (p, q, sign) in [(i, i, 1.0), (i, j, -1.0), (j, i, -1.0), (j, j, 1.0)] {
            if p < n && q < n {
                a[p][q].0 += sign * k;
                a[p][q].1 += sign * omega * mu;
            }
        }
    }
    for (i, row) in a.iter_mut().enumerate() {
        row[i].0 -= omega * omega * m;
    }
    let mut b = vec![(0.0, 0.0); n];
    b[0] = (amplitude, 0.0);
    let x = solve(a, b);
    for (i, xi) in x.iter().enumerate() {
        let (sin_part, cos_part) = fourier(&h.time_s, &h.values[i], omega, from, per_period);
        let got = (sin_part * sin_part + cos_part * cos_part).sqrt();
        let want = (xi.0 * xi.0 + xi.1 * xi.1).sqrt();
        assert!(
            (got - want).abs() < 1e-6 * want,
            "particle {}: amplitude {got:e} against {want:e}",
            i + 1
        );
        // y = Im(X e^{iωt}) = X_re sin ωt + X_im cos ωt.
        let phase_got = cos_part.atan2(sin_part);
        let phase_want = xi.1.atan2(xi.0);
        assert!(
            (phase_got - phase_want).abs() < 1e-6,
            "particle {}: phase {phase_got} against {phase_want}",
            i + 1
        );
        // The steady state's `A cos(ωt + φ)`: φ = arg X − π/2; settled, its second harmonic nil.
        let p = &steady.probes[i];
        assert!((p.amplitude[0] - want).abs() < 1e-6 * want, "{p:?}");
        let dphi = (p.phase_rad[0] - (phase_want - std::f64::consts::FRAC_PI_2))
            .rem_euclid(std::f64::consts::TAU);
        assert!(dphi.min(std::f64::consts::TAU - dphi) < 1e-6, "{p:?}");
        assert!(p.settled && p.amplitude[1] < 1e-6 * want, "{p:?}");
        let x0 = (x[0].0 * x[0].0 + x[0].1 * x[0].1).sqrt();
        assert!(
            (p.transmission_db - 20.0 * (want / x0).log10()).abs() < 1e-5,
            "{p:?}"
        );
    }
    assert!(out.energy_drift_max < 1e-8, "{}", out.energy_drift_max);
    assert!(
        out.momentum_residual_max < 1e-8,
        "{}",
        out.momentum_residual_max
    );
}

/// The work the drive has done by the end, from the ledger's external term (no other external
/// force acts on these scenes).
fn work_put_in(out: &RunOutput) -> f64 {
    -out.final_energy.external
}

/// The ledger closes with the drive's work: a driven run's drift is the largest departure of
/// `E(t) − W(t)` from its start against the larger of the excitation's energy scale and the work
/// put in so far; here the work dwarfs the scale, so the drift is against the work.
fn assert_ledger_closes(out: &RunOutput, what: &str) {
    let work = work_put_in(out);
    assert!(
        work > 10.0 * out.impact_energy_j,
        "{what}: the drive did little work ({work:e} J against a scale of {:e} J)",
        out.impact_energy_j
    );
    assert!(
        out.energy_drift_max < 1e-8,
        "{what}: ledger off by {:e} of the work put in",
        out.energy_drift_max
    );
}

fn hertz_between_walls(n: usize) -> SequenceSpec {
    let mut spec = monodisperse(n, None, false);
    spec.top_wall_material = Some(spec.wall_material);
    spec
}

fn damped(precompression_force_n: f64) -> PhysicsSpec {
    PhysicsSpec {
        gravity: false,
        wall: true,
        damping_kg_s: 3.0,
        precompression_force_n,
        ..PhysicsSpec::default()
    }
}

/// Every drive and waveform, on damped Hertz chains, closes the ledger with its work.
#[test]
fn driven_ledgers_close_with_the_drives_work() {
    let f = 3000.0;
    let waves = [
        ("harmonic", harmonic(1.0, f, 2.0)),
        (
            "linear chirp",
            Waveform::Chirp(Chirp {
                amplitude: 1.0,
                start_hz: 1000.0,
                end_hz: 8000.0,
                duration_s: 2e-3,
                spacing: ChirpSpacing::Linear,
                ramp_periods: 1.0,
            }),
        ),
        (
            "logarithmic chirp",
            Waveform::Chirp(Chirp {
                amplitude: 1.0,
                start_hz: 1000.0,
                end_hz: 8000.0,
                duration_s: 2e-3,
                spacing: ChirpSpacing::Logarithmic,
                ramp_periods: 0.0,
            }),
        ),
        (
            "sum",
            Waveform::Sum(SumOfHarmonics {
                tones: vec![
                    Tone {
                        amplitude: 0.7,
                        frequency_hz: 2000.0,
                        phase_rad: 0.0,
                    },
                    Tone {
                        amplitude: 0.3,
                        frequency_hz: 5000.0,
                        phase_rad: 1.0,
                    },
                ],
                ramp_periods: 1.0,
            }),
        ),
        (
            "recorded",
            Waveform::Recorded(Recorded {
                times_s: (0..=400).map(|k| k as f64 * 1e-5).collect(),
                values: (0..=400)
                    .map(|k| {
                        let t = k as f64 * 1e-5;
                        (1.0 - (-t / 2e-4f64).exp()) * (std::f64::consts::TAU * f * t).sin()
                    })
                    .collect(),
                ..Recorded::default()
            }),
        ),
    ];
    let duration = 3e-3;
    for (name, wave) in waves {
        // A force of a tenth of the precompression, and a displacement of a tenth of the static
        // overlap under it, so that contacts breathe without opening (and at the base, open).
        let force = DriveSpec::ForceN(scaled(&wave, 5.0));
        let chain =
            Chain::build(&ChainSpec::Sequence(hertz_between_walls(20)), &damped(50.0)).unwrap();
        let static_overlap = chain.static_overlap[0];
        let actuator = DriveSpec::ActuatorM(scaled(&wave, 0.3 * static_overlap));
        let base = DriveSpec::BaseM(scaled(&wave, 0.3 * static_overlap));
        for (drive, spec) in [
            (force, monodisperse(20, None, false)),
            (actuator, hertz_between_walls(20)),
            (base, monodisperse(20, None, false)),
        ] {
            let what = format!("{name} {:?}", drive.point());
            let s = driven(spec, damped(50.0), drive, duration);
            let out = run(&s).unwrap_or_else(|e| panic!("{what}: {e}"));
            assert_ledger_closes(&out, &what);
            assert!(
                out.momentum_residual_max < 1e-8,
                "{what}: {}",
                out.momentum_residual_max
            );
        }
    }
}

/// `wave` with its amplitude scaled to `amplitude` (a recording's values times it).
fn scaled(wave: &Waveform, amplitude: f64) -> Waveform {
    let mut w = wave.clone();
    match &mut w {
        Waveform::Harmonic(h) => h.amplitude *= amplitude,
        Waveform::Chirp(c) => c.amplitude *= amplitude,
        Waveform::Sum(s) => s.tones.iter_mut().for_each(|t| t.amplitude *= amplitude),
        Waveform::Recorded(r) => r.values.iter_mut().for_each(|v| *v *= amplitude),
    }
    w
}

/// An actuator that pulls away faster than the chain can follow loses contact: the force it
/// exerts is zero while the gap is open (it pushes, it never pulls), and the contact closes again.
#[test]
fn an_actuator_loses_contact_and_never_pulls() {
    let spec = hertz_between_walls(10);
    let physics = PhysicsSpec {
        gravity: false,
        wall: true,
        precompression_force_n: 20.0,
        ..PhysicsSpec::default()
    };
    let chain = Chain::build(&ChainSpec::Sequence(spec.clone()), &physics).unwrap();
    let n = chain.n_particles();
    // Ten static overlaps of stroke at 20 kHz: the actuator leaves the chain behind on each
    // return stroke.
    let amplitude = 10.0 * chain.static_overlap[0];
    let mut s = driven(
        spec,
        physics,
        DriveSpec::ActuatorM(harmonic(amplitude, 20_000.0, 0.0)),
        4e-4,
    );
    // The top wall's contact is the last one, N + 1 with the wall under the chain.
    s.record.probes = vec![
        Probe::ContactForce { contact: n + 1 },
        Probe::Overlap { contact: n + 1 },
    ];
    s.record.history = true;
    s.record.history_interval_s = 2e-7;
    let out = run(&s).unwrap();
    let h = out.history.unwrap();
    let (force, overlap) = (&h.values[0], &h.values[1]);
    let open = overlap.iter().filter(|&&d| d < 0.0).count();
    assert!(
        open > 100,
        "the actuator never left the chain ({open} samples open)"
    );
    for (f, d) in force.iter().zip(overlap) {
        if *d < 0.0 {
            assert_eq!(*f, 0.0, "an open contact carries {f} N");
        }
        assert!(*f >= 0.0, "the actuator pulled: {f} N");
    }
    assert!(force.iter().cloned().fold(0.0, f64::max) > 100.0);
}

/// A base oscillating far below the chain's lowest natural frequency carries the chain with it:
/// under a constant force at the top, every particle's displacement is the base's, to within the
/// inertial correction (the particles' `m ω² u` summed down the chain over the contacts'
/// stiffness, a few parts in a thousand here).
#[test]
fn a_slow_base_carries_the_chain_with_it() {
    let spec = monodisperse(5, None, false);
    let physics = PhysicsSpec {
        gravity: false,
        wall: true,
        precompression_force_n: 20.0,
        ..PhysicsSpec::default()
    };
    let chain = Chain::build(&ChainSpec::Sequence(spec.clone()), &physics).unwrap();
    let amplitude = 0.2 * chain.static_overlap[0];
    let f = 200.0;
    let mut s = driven(
        spec,
        physics,
        DriveSpec::BaseM(harmonic(amplitude, f, 3.0)),
        10.0 / f,
    );
    s.record.probes = (1..=5)
        .map(|particle| Probe::Displacement { particle })
        .collect();
    s.record.history = true;
    s.record.history_interval_s = 1e-5;
    let out = run(&s).unwrap();
    let h = out.history.unwrap();
    let w = std::f64::consts::TAU * f;
    for (k, &t) in h.time_s.iter().enumerate() {
        if t < 3.0 / f {
            continue;
        }
        let base = amplitude * (w * t).sin();
        for series in &h.values {
            assert!(
                (series[k] - base).abs() < 1e-2 * amplitude,
                "at {t}: {} against {base}",
                series[k]
            );
        }
    }
}

/// Bad drives exit naming the field.
#[test]
fn bad_drives_name_the_field() {
    let field = |scene: &Scene| scene.validate().unwrap_err().field;
    let s = driven(
        monodisperse(5, None, false),
        damped(10.0),
        DriveSpec::ForceN(harmonic(1.0, -5.0, 0.0)),
        1e-3,
    );
    assert_eq!(field(&s), "excitation.drive.force_n.harmonic.frequency_hz");
    let s = driven(
        monodisperse(5, None, false),
        damped(10.0),
        DriveSpec::ActuatorM(harmonic(1e-7, 5.0, 0.0)),
        1e-3,
    );
    assert_eq!(field(&s), "excitation.drive.actuator_m");
    let mut physics = damped(0.0);
    physics.wall = false;
    let s = driven(
        monodisperse(5, None, false),
        physics,
        DriveSpec::BaseM(harmonic(1e-7, 5.0, 0.0)),
        1e-3,
    );
    assert_eq!(field(&s), "excitation.drive.base_m");
    let s = driven(
        monodisperse(5, None, false),
        damped(10.0),
        DriveSpec::ForceN(Waveform::Recorded(Recorded {
            times_s: vec![0.0, 1e-4, 5e-4],
            values: vec![0.0, 1.0, 0.0],
            ..Recorded::default()
        })),
        1e-3,
    );
    assert_eq!(field(&s), "excitation.drive.force_n.recorded.times_s");
    let s = driven(
        monodisperse(5, None, false),
        damped(10.0),
        DriveSpec::ForceN(Waveform::Recorded(Recorded {
            times_s: vec![0.0, 1e-3, 1e-3, 2e-3],
            values: vec![0.0; 4],
            ..Recorded::default()
        })),
        1e-3,
    );
    assert_eq!(field(&s), "excitation.drive.force_n.recorded.times_s[2]");
}

/// A precompressed dimer of 40 × [8 mm sphere, 5 mm sphere] on a wall, every contact the same
/// Hertz law, lightly damped, driven at the top by a small harmonic force: in its acoustic band
/// the response reaches the middle of the chain (cells 15 to 25) at the drive's own amplitude or
/// more; 1 % above the band's top, `√(2K/m_heavy)` with `K = (3/2) A^{2/3} F^{1/3}`, the chain
/// is in its gap and the response there is ten times smaller and more: the driven sweep finds the
/// edge the Bloch dispersion gives, within 1 %.
#[test]
fn a_driven_frequency_sweep_finds_the_top_of_the_acoustic_band() {
    use chainsweep_solver::chain::sequence::{RepeatBlock, SequenceItem};
    let (a, force, mu, cells) = (8e9, 10.0, 0.3, 40);
    let law = Some(power_law(a, 1.5));
    let mut spec = chain(
        &[
            ("heavy", sphere(STEEL, 8e-3, 2.085e-3)),
            ("light", sphere(STEEL, 5e-3, 0.5e-3)),
        ],
        vec![SequenceItem::Repeat(RepeatBlock {
            repeat: cells,
            of: vec![
                SequenceItem::Type("heavy".into()),
                SequenceItem::Type("light".into()),
            ],
        })],
        None,
        vec![
            rule("heavy", "light", law, None),
            rule("light", "wall", law, None),
        ],
    );
    spec.wall_material = STEEL;
    let physics = PhysicsSpec {
        gravity: false,
        wall: true,
        damping_kg_s: mu,
        precompression_force_n: force,
        ..PhysicsSpec::default()
    };
    let stiffness = 1.5 * a.powf(2.0 / 3.0) * force.powf(1.0 / 3.0);
    let edge_hz = (2.0 * stiffness / 2.085e-3).sqrt() / std::f64::consts::TAU;
    let transmission = |ratio: f64| {
        let f = ratio * edge_hz;
        let period = 1.0 / f;
        // 25 ms: near the band edge the group velocity vanishes and the chain settles at the
        // damping's pace (m/μ ≈ 7 ms).
        let settle = (25e-3 / period).round() * period;
        let window = 20.0 * period;
        let mut s = driven(
            spec.clone(),
            physics,
            DriveSpec::ForceN(harmonic(1e-3, f, 10.0)),
            settle + window,
        );
        s.integrator = IntegratorSpec::Dop853(AdaptiveOptions::new(1e-9));
        s.record.probes = std::iter::once(1)
            .chain(30..=50)
            .map(|particle| Probe::Displacement { particle })
            .collect();
        s.record.history = true;
        s.record.history_interval_s = period / 32.0;
        let out = run(&s).unwrap();
        let h = out.history.unwrap();
        let from = h.time_s.iter().position(|&t| t >= settle - 1e-12).unwrap();
        let omega = std::f64::consts::TAU * f;
        let amplitude = |k: usize| {
            let (b, c) = fourier(&h.time_s, &h.values[k], omega, from, 32);
            (b * b + c * c).sqrt()
        };
        let driven = amplitude(0);
        (1..h.values.len()).map(amplitude).fold(0.0, f64::max) / driven
    };
    for ratio in [0.97, 0.99] {
        let t = transmission(ratio);
        assert!(t > 0.3, "inside the band at {ratio} of the edge: {t}");
    }
    for ratio in [1.01, 1.03] {
        let t = transmission(ratio);
        assert!(t < 0.1, "in the gap at {ratio} of the edge: {t}");
    }
}

/// A moving base and an actuator under chains whose contacts yield (Thornton's law, 1.5 GPa):
/// the ledger, the plastic work in it, closes with the drive's work; the contacts did yield.
#[test]
fn driven_plastic_chains_close_the_ledger() {
    use chainsweep_solver::contact::LawSpec;
    let thornton = Some(LawSpec::Thornton {
        yield_pressure_pa: Some(1.5e9),
        yield_velocity_m_s: None,
    });
    let mut spec = monodisperse(10, None, false);
    spec.contacts = vec![rule("ball", "ball", thornton, None)];
    let physics = PhysicsSpec {
        gravity: false,
        wall: true,
        precompression_force_n: 5.0,
        ..PhysicsSpec::default()
    };
    let mut between = spec.clone();
    between.top_wall_material = Some(between.wall_material);
    for (drive, spec) in [
        (DriveSpec::BaseM(harmonic(2e-6, 4000.0, 0.0)), spec),
        (DriveSpec::ActuatorM(harmonic(2e-6, 4000.0, 0.0)), between),
    ] {
        let what = format!("{:?}", drive.point());
        let s = driven(spec, physics, drive, 2e-3);
        let out = run(&s).unwrap_or_else(|e| panic!("{what}: {e}"));
        assert!(out.final_energy.plastic > 0.0, "{what}: nothing yielded");
        assert_ledger_closes(&out, &what);
    }
}

/// The energy drift of a driven precompressed chain is measured from its static state and against
/// the energy the motion exchanges, so it falls with the tolerance whatever the drive's size: six
/// spheres on 5 N, 5 kg/s per contact, driven at 5 kHz by 1e-7 N to 1e3 N, each drift at least
/// eight times smaller per hundredfold tighter tolerance from rtol 1e-5 to 1e-9 (and 1e-11 for
/// 1e-3 N and 1e3 N). Measured from the absolute energies, the rounding of the static energy
/// (microjoules) made a 1e-7 N drive's drift 1.6e-2 to 8.7e-2 at every tolerance, and a 1e-9 N
/// drive's 0.25: both failed the default limit of 1e-3. A 1e-9 N drive moves the chain by 1e-16 m,
/// below a billionth of the positions, whose rounding then limits the run itself: its drift stays
/// near 1e-5 (well within the limit at rtol 1e-7), and reports that floor rather than falling.
#[test]
fn a_driven_chain_s_drift_falls_with_the_tolerance_for_drives_of_every_size() {
    let spec = monodisperse(6, None, false);
    let physics = PhysicsSpec {
        gravity: false,
        wall: true,
        damping_kg_s: 5.0,
        precompression_force_n: 5.0,
        ..PhysicsSpec::default()
    };
    let drift = |amplitude: f64, rtol: f64| {
        let mut s = driven(
            spec.clone(),
            physics,
            DriveSpec::ForceN(harmonic(amplitude, 5e3, 0.0)),
            0.01,
        );
        s.integrator = IntegratorSpec::Dop853(AdaptiveOptions::new(rtol));
        s.record.probes = vec![Probe::ContactForce { contact: 1 }];
        run(&s).unwrap().energy_drift_max
    };
    for amplitude in [1e-7, 1e-5, 1e-3, 0.1, 10.0, 1e3] {
        let mut rtols = vec![1e-5, 1e-7, 1e-9];
        if amplitude == 1e-3 || amplitude == 1e3 {
            rtols.push(1e-11);
        }
        let drifts: Vec<f64> = rtols.iter().map(|&r| drift(amplitude, r)).collect();
        println!("{amplitude:e} N: {drifts:?}");
        for pair in drifts.windows(2) {
            assert!(
                pair[1] < pair[0] / 8.0,
                "{amplitude:e} N: drift {drifts:?} at rtol {rtols:?}"
            );
        }
        assert!(drifts[0] < 1e-3, "{amplitude:e} N: {drifts:?}");
    }
    let tiny = drift(1e-9, 1e-7);
    assert!(tiny < 1e-4, "1e-9 N at rtol 1e-7: drift {tiny:e}");
}
