//! A wall on a spring and a dashpot under the chain (`chain.wall_mount`, a load cell or a soft
//! support): a precompressed linear chain driven by a harmonic force settles on the closed-form
//! response of the chain with the wall as one more body, `(K − ω²M + iωC) X = F`, particles, wall
//! and load-cell force alike (1e-6); the linear spectrum of a chain whose mount is one more
//! identical mass and spring is the fixed–free chain's closed form (1e-12); a struck chain's
//! ledger closes with the wall's energy and its dashpot's work (1e-8), elastic, dissipative and
//! plastic; ROS34PW2 (a W-method that leaves the wall out of its Jacobian) agrees with DOP853; a
//! stiff, light mount tends to the rigid wall; bad mounts name the field.

use chainsweep_solver::chain::drive::{DriveSpec, Harmonic, Waveform};
use chainsweep_solver::chain::model::{Chain, PhysicsSpec};
use chainsweep_solver::chain::mount::WallMount;
use chainsweep_solver::chain::sequence::SequenceSpec;
use chainsweep_solver::contact::LawSpec;
use chainsweep_solver::observe::probes::Probe;
use chainsweep_solver::observe::steady::SteadyStateSpec;
use chainsweep_solver::problems::complex::{abs, mul, solve};
use chainsweep_solver::problems::{monodisperse, power_law, rule};
use chainsweep_solver::scene::solve::{run, RunOutput};
use chainsweep_solver::scene::{Excitation, IntegratorSpec, Scene};
use chainsweep_solver::spectrum::LinearChain;
use chainsweep_solver::{AdaptiveOptions, ChainSpec};

fn mounted(mut spec: SequenceSpec, mount: WallMount) -> SequenceSpec {
    spec.wall_mount = Some(mount);
    spec
}

/// Three particles with a linear law on a mounted wall, precompressed so that no contact opens,
/// every contact and the mount with a dashpot, driven by a harmonic force on the first particle:
/// each particle, the wall and the load cell settle on the response of the four-body system.
#[test]
fn a_driven_chain_on_a_load_cell_settles_on_the_closed_form_response() {
    let (k, mu, n) = (2e7, 40.0, 3);
    let mount = WallMount {
        mass_kg: 5e-3,
        stiffness_n_m: 8e6,
        damping_kg_s: 25.0,
    };
    let spec = mounted(monodisperse(n, Some(power_law(k, 1.0)), false), mount);
    let physics = PhysicsSpec {
        gravity: false,
        wall: true,
        damping_kg_s: mu,
        precompression_force_n: 50.0,
        ..PhysicsSpec::default()
    };
    let chain = Chain::build(&ChainSpec::Sequence(spec.clone()), &physics).unwrap();
    let m = chain.mass[0];
    let omega = 0.7 * (k / m).sqrt();
    let f = omega / std::f64::consts::TAU;
    let amplitude = 1.0;
    let (settle, window) = (300, 20);
    let mut s = Scene::excited(
        spec,
        Excitation::Drive(DriveSpec::ForceN(Waveform::Harmonic(Harmonic {
            amplitude,
            frequency_hz: f,
            phase_rad: 0.0,
            ramp_periods: 4.0,
        }))),
        (settle + window) as f64 / f,
    );
    s.physics = physics;
    s.integrator = IntegratorSpec::Dop853(AdaptiveOptions::new(1e-11));
    for particle in 1..=n {
        s.record.probes.push(Probe::Displacement { particle });
    }
    s.record.probes.push(Probe::MountDisplacement);
    s.record.probes.push(Probe::MountForce);
    s.record.steady_state = Some(SteadyStateSpec {
        frequency_hz: None,
        settle_periods: settle,
        window_periods: window,
        harmonics: 2,
        samples_per_period: 64,
        settled_tolerance: 1e-6,
        reference_probe: 0,
    });
    let out = run(&s).unwrap();
    let steady = out.steady_state.clone().expect("recorded");

    // Rows 0..n the particles, row n the wall: contact c joins rows c and c + 1 (the last one the
    // wall's), the mount joins the wall to the ground.
    let rows = n + 1;
    let mut a = vec![vec![(0.0, 0.0); rows]; rows];
    for c in 0..n {
        for (p, q, sign) in [
            (c, c, 1.0),
            (c, c + 1, -1.0),
            (c + 1, c, -1.0),
            (c + 1, c + 1, 1.0),
        ] {
            a[p][q].0 += sign * k;
            a[p][q].1 += sign * omega * mu;
        }
    }
    a[n][n].0 += mount.stiffness_n_m;
    a[n][n].1 += omega * mount.damping_kg_s;
    for (i, row) in a.iter_mut().enumerate() {
        row[i].0 -= omega * omega * if i < n { m } else { mount.mass_kg };
    }
    let mut b = vec![(0.0, 0.0); rows];
    b[0] = (amplitude, 0.0);
    let x = solve(a, b);
    // The load cell reads `F_s + (k_m + iω c_m) X_wall`.
    let cell = mul((mount.stiffness_n_m, omega * mount.damping_kg_s), x[n]);
    let want: Vec<(f64, f64)> = x.iter().copied().chain([cell]).collect();
    for (i, w) in want.iter().enumerate() {
        let p = &steady.probes[i];
        let amp = abs(*w);
        assert!(
            (p.amplitude[0] - amp).abs() < 1e-6 * amp,
            "probe {i}: amplitude {:e} against {amp:e}",
            p.amplitude[0]
        );
        // `A cos(ωt + φ)` of `Im(X e^{iωt})`: φ = arg X − π/2.
        let dphi = (p.phase_rad[0] - (w.1.atan2(w.0) - std::f64::consts::FRAC_PI_2))
            .rem_euclid(std::f64::consts::TAU);
        assert!(
            dphi.min(std::f64::consts::TAU - dphi) < 1e-6,
            "probe {i}: {p:?}"
        );
        assert!(p.settled, "probe {i}: {p:?}");
    }
    // The load cell's mean is the static force it carries, the precompression.
    let cell_mean = steady.probes[n + 1].mean;
    assert!((cell_mean - 50.0).abs() < 1e-6 * 50.0, "{cell_mean}");
    assert!(out.energy_drift_max < 1e-8, "{}", out.energy_drift_max);
    assert!(
        out.momentum_residual_max < 1e-8,
        "{}",
        out.momentum_residual_max
    );
}

/// A chain whose mount is one more of its masses and springs is a uniform fixed–free chain of
/// `N + 1` masses: `ω_j = 2 √(k/m) sin((2j − 1)π / (2(2N + 3)))`.
#[test]
fn the_spectrum_counts_the_mounted_wall_as_a_body() {
    let (k, n) = (3e7, 6);
    let spec = monodisperse(n, Some(power_law(k, 1.0)), false);
    let m = 2.085e-3;
    let spec = mounted(
        spec,
        WallMount {
            mass_kg: m,
            stiffness_n_m: k,
            damping_kg_s: 0.0,
        },
    );
    let physics = PhysicsSpec {
        gravity: false,
        wall: true,
        precompression_force_n: 10.0,
        ..PhysicsSpec::default()
    };
    let chain = Chain::build(&ChainSpec::Sequence(spec), &physics).unwrap();
    let linear = LinearChain::of(&chain).unwrap();
    assert_eq!(linear.len(), n + 1);
    let got = linear.spectrum(false).angular_frequency_rad_s;
    let rows = (n + 1) as f64;
    for (j, w) in got.iter().enumerate() {
        let want = 2.0
            * (k / m).sqrt()
            * (((2 * j + 1) as f64) * std::f64::consts::PI / (2.0 * (2.0 * rows + 1.0))).sin();
        assert!(
            (w - want).abs() < 1e-12 * want,
            "mode {j}: {w} against {want}"
        );
    }
}

fn struck(spec: SequenceSpec, rtol: f64) -> Scene {
    let mut s = Scene::new(spec, 2.0, 150e-6);
    s.integrator = IntegratorSpec::Dop853(AdaptiveOptions::new(rtol));
    s.record.probes = vec![Probe::WallForce, Probe::MountForce];
    s
}

fn assert_closes(out: &RunOutput, what: &str) {
    assert!(
        out.energy_drift_max < 1e-8,
        "{what}: energy drift {:e}",
        out.energy_drift_max
    );
    assert!(
        out.momentum_residual_max < 1e-8,
        "{what}: momentum residual {:e}",
        out.momentum_residual_max
    );
}

/// A sphere chain struck on a load cell: the ledger closes with the wall's kinetic and spring
/// energy and its dashpot's work, for elastic, viscous and plastic contacts, under gravity.
#[test]
fn a_struck_chain_on_a_load_cell_closes_its_ledger() {
    let mount = WallMount {
        mass_kg: 0.05,
        stiffness_n_m: 2e8,
        damping_kg_s: 300.0,
    };
    let elastic = mounted(monodisperse(10, None, true), mount);
    let out = run(&struck(elastic.clone(), 1e-11)).unwrap();
    assert_closes(&out, "elastic");
    assert!(
        out.final_energy.dissipated > 1e-3 * out.impact_energy_j,
        "the dashpot works"
    );
    // The wall's energy is in the ledger: the chain alone would not close.
    let mut viscous = elastic.clone();
    viscous.contacts = vec![];
    let mut physics = PhysicsSpec {
        damping_kg_s: 5.0,
        ..PhysicsSpec::default()
    };
    let mut s = struck(viscous, 1e-11);
    s.physics = physics;
    assert_closes(&run(&s).unwrap(), "viscous");

    let mut plastic = elastic;
    let thornton = LawSpec::Thornton {
        yield_pressure_pa: Some(1.0e9),
        yield_velocity_m_s: None,
    };
    plastic.contacts = vec![
        rule("ball", "ball", Some(thornton), None),
        rule("ball", "wall", Some(thornton), None),
    ];
    physics.damping_kg_s = 0.0;
    let mut s = struck(plastic, 1e-11);
    s.physics = physics;
    let out = run(&s).unwrap();
    assert!(out.final_energy.plastic > 0.0, "the contacts yield");
    assert_closes(&out, "plastic");
}

/// ROS34PW2 leaves the wall out of its Jacobian (a W-method needs only an approximation of it)
/// and still agrees with DOP853 on the load cell's peak.
#[test]
fn the_stiff_integrator_agrees_on_a_load_cell() {
    let mount = WallMount {
        mass_kg: 0.02,
        stiffness_n_m: 5e8,
        damping_kg_s: 100.0,
    };
    let spec = mounted(monodisperse(8, None, true), mount);
    let reference = run(&struck(spec.clone(), 1e-11)).unwrap();
    let mut s = struck(spec, 1e-7);
    s.integrator = IntegratorSpec::Ros34pw2(AdaptiveOptions::new(1e-7));
    let out = run(&s).unwrap();
    for p in 0..2 {
        let (a, b) = (out.probes[p].record_max, reference.probes[p].record_max);
        assert!((a - b).abs() < 1e-4 * b, "probe {p}: {a} against {b}");
    }
    // A third-order method at rtol 1e-7: its ledger closes to the tolerance's order.
    assert!(out.energy_drift_max < 1e-4, "{}", out.energy_drift_max);
}

/// A light wall on a stiff spring tends to the rigid wall: the wall force's peak approaches the
/// rigid wall's as the mount stiffens, by roughly the ratio of their compliances.
#[test]
fn a_stiff_light_mount_tends_to_the_rigid_wall() {
    let chain = monodisperse(6, None, true);
    let mut s = struck(chain.clone(), 1e-10);
    s.record.probes = vec![Probe::WallForce];
    let rigid = run(&s).unwrap().probes[0].record_max;
    let mut last = f64::INFINITY;
    for stiffness_n_m in [1e9, 1e10, 1e11] {
        let spec = mounted(
            chain.clone(),
            WallMount {
                mass_kg: 1e-4,
                stiffness_n_m,
                damping_kg_s: 0.0,
            },
        );
        let mut s = struck(spec, 1e-10);
        s.record.probes = vec![Probe::WallForce];
        let got = run(&s).unwrap().probes[0].record_max;
        let gap = (got - rigid).abs() / rigid;
        assert!(gap < last, "k = {stiffness_n_m:e}: {gap:e} after {last:e}");
        last = gap;
    }
    assert!(last < 2e-3, "{last:e}");
}

/// Bad mounts and what they exclude name the field.
#[test]
fn bad_mounts_name_the_field() {
    let ok = WallMount {
        mass_kg: 0.01,
        stiffness_n_m: 1e8,
        damping_kg_s: 0.0,
    };
    let cases = [
        (WallMount { mass_kg: 0.0, ..ok }, "chain.wall_mount.mass_kg"),
        (
            WallMount {
                stiffness_n_m: -1.0,
                ..ok
            },
            "chain.wall_mount.stiffness_n_m",
        ),
        (
            WallMount {
                damping_kg_s: f64::NAN,
                ..ok
            },
            "chain.wall_mount.damping_kg_s",
        ),
    ];
    for (mount, field) in cases {
        let s = Scene::new(mounted(monodisperse(4, None, true), mount), 1.0, 1e-4);
        assert_eq!(s.validate().unwrap_err().field, field);
    }
    let mut s = Scene::new(mounted(monodisperse(4, None, true), ok), 1.0, 1e-4);
    s.physics.wall = false;
    s.physics.gravity = false;
    assert_eq!(s.validate().unwrap_err().field, "chain.wall_mount");

    let mut ring = mounted(monodisperse(4, None, false), ok);
    ring.ring = true;
    let mut s = Scene::excited(ring, Excitation::Impulse { velocity_m_s: 1.0 }, 1e-4);
    s.physics.wall = false;
    s.physics.gravity = false;
    assert_eq!(s.validate().unwrap_err().field, "chain.ring");

    let mut s = Scene::excited(
        mounted(monodisperse(4, None, false), ok),
        Excitation::Drive(DriveSpec::BaseM(Waveform::Harmonic(Harmonic {
            amplitude: 1e-7,
            frequency_hz: 1e3,
            phase_rad: 0.0,
            ramp_periods: 0.0,
        }))),
        1e-3,
    );
    s.physics.gravity = false;
    assert_eq!(s.validate().unwrap_err().field, "excitation.drive.base_m");

    let mut s = Scene::new(monodisperse(4, None, true), 1.0, 1e-4);
    s.record.probes = vec![Probe::MountForce];
    assert_eq!(s.validate().unwrap_err().field, "record.probes[0].kind");
}
