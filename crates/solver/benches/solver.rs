//! `make bench`: right-hand-side cost per contact (the paper's specialised kernel, and the general
//! kernel under every contact law and dissipation model), the cost of one reference run, the cost
//! per drive period of a driven 100-particle chain and the linear spectrum of a 10⁴-particle
//! chain.
//!
//! The reference run is the issue's: the 0.55 chain (3.77 g cylinders, 50 cylinders), μ = 6 kg/s,
//! v0 = 1.3 m/s, 1 ms simulated, DOP853 with `predict_switches` at the tolerance whose leading peak
//! in cylinder 21 is within 1e-6 of a tight reference (checked by `tests/accuracy.rs`); beside it
//! the same run under DOP853's default settings.

use chainsweep_solver::chain::model::{Chain, ChainSpec, Material, PhysicsSpec};
use chainsweep_solver::contact::{DissipationSpec, LawSpec};
use chainsweep_solver::integrate::OdeSystem;
use chainsweep_solver::motion::general::{
    law, GeneralChainSystem, HERTZ_LAW, LINEAR_LAW, POWER_LAW,
};
use chainsweep_solver::motion::plastic::PlasticChainSystem;
use chainsweep_solver::motion::system::ChainSystem;
use chainsweep_solver::scene::solve::run;
use criterion::measurement::WallTime;
use criterion::{
    black_box, criterion_group, criterion_main, BenchmarkGroup, Criterion, Throughput,
};

mod reference;
use reference::{benchmark_scene, reference_scene, REFERENCE_RTOL};

fn mid_pulse_state(chain: &Chain) -> Vec<f64> {
    // A state with every contact compressed or open in a realistic pattern: a travelling bump of
    // overlap on top of the static preload, and velocities of order 1 m/s.
    let n = chain.n_particles();
    let mut y = chain.equilibrium_position.clone();
    let mut shift = 0.0;
    for i in (0..n).rev() {
        let phase = i as f64 * 0.37;
        shift += 4e-6 * (phase.sin() + 0.3);
        y[i] += shift;
    }
    y.extend((0..n).map(|i| (i as f64 * 0.91).cos()));
    y.extend([0.0, 0.0]);
    y
}

fn bench_rhs(c: &mut Criterion) {
    let spec = ChainSpec::chain_055(50);
    let mut group = c.benchmark_group("rhs");
    let cases: [(&str, bool, f64); 2] = [
        ("full_physics", true, 6.0),
        ("no_gravity_no_damping", false, 0.0),
    ];
    for (name, gravity, mu) in cases {
        let physics = PhysicsSpec {
            gravity,
            damping_kg_s: mu,
            ..PhysicsSpec::default()
        };
        let chain = Chain::build(&spec, &physics).unwrap();
        let contacts = chain.n_contacts() as u64;
        group.throughput(Throughput::Elements(contacts));
        let mut y = mid_pulse_state(&chain);
        if gravity {
            let mut sys = ChainSystem::<true, true, true, false>::new(&chain);
            let mut dy = vec![0.0; OdeSystem::dim(&sys)];
            y.truncate(OdeSystem::dim(&sys));
            group.bench_function(name, |b| {
                b.iter(|| sys.rhs(0.0, black_box(&y), black_box(&mut dy)))
            });
        } else {
            let mut sys = ChainSystem::<false, false, true, false>::new(&chain);
            let mut dy = vec![0.0; OdeSystem::dim(&sys)];
            y.truncate(OdeSystem::dim(&sys));
            group.bench_function(name, |b| {
                b.iter(|| sys.rhs(0.0, black_box(&y), black_box(&mut dy)))
            });
        }
    }
    group.finish();
}

fn bench_run(c: &mut Criterion) {
    let scene = benchmark_scene();
    let default = reference_scene(REFERENCE_RTOL);
    for (what, s) in [("reference run", &scene), ("default DOP853", &default)] {
        let out = run(s).unwrap();
        eprintln!(
            "{what}: {} steps, {} rejected, {} events, {} rhs evals, peak F21 = {:.9} N, energy drift {:.2e}",
            out.stats.steps,
            out.stats.rejected,
            out.stats.events,
            out.stats.rhs_evals,
            out.probes[1].leading_peak,
            out.energy_drift_max
        );
    }
    let mut group = c.benchmark_group("run");
    group.sample_size(30);
    group.bench_function("chain055_50cyl_mu6_1ms", |b| {
        b.iter(|| run(black_box(&scene)).unwrap())
    });
    // The same run under DOP853's default settings (no switch prediction): what sweeps that do
    // not ask for prediction get.
    group.bench_function("chain055_50cyl_mu6_1ms_default_dop853", |b| {
        b.iter(|| run(black_box(&default)).unwrap())
    });
    group.finish();
}

/// The paper's 0.55 chain written as a sequence (striker sphere, 50 × [cylinder, sphere], the last
/// sphere on the wall: 101 particles, 101 contacts) with `law` on the sphere–cylinder pairs (Hertz
/// when `None`) and `model` on every contact: the general kernel at the paper's size.
fn general_chain(law: Option<LawSpec>, model: Option<DissipationSpec>) -> Chain {
    use chainsweep_solver::chain::sequence::{
        CylinderType, ParticleType, RepeatBlock, SequenceItem,
    };
    use chainsweep_solver::problems::{chain, rule, sphere, STEEL};
    let cylinder = ParticleType::Cylinder(CylinderType {
        material: Material::STEEL_SS304,
        diameter_m: 8e-3,
        height_m: 9.6e-3,
        mass_kg: Some(3.77e-3),
        density_kg_m3: None,
    });
    let contacts = law
        .map(|l| {
            vec![
                rule("sphere", "cylinder", Some(l), None),
                rule("sphere", "wall", Some(l), None),
            ]
        })
        .unwrap_or_default();
    let spec = chain(
        &[
            ("sphere", sphere(STEEL, 8e-3, 2.085e-3)),
            ("cylinder", cylinder),
        ],
        vec![SequenceItem::Repeat(RepeatBlock {
            repeat: 50,
            of: vec![
                SequenceItem::Type("cylinder".into()),
                SequenceItem::Type("sphere".into()),
            ],
        })],
        Some("sphere"),
        contacts,
    );
    let physics = PhysicsSpec {
        dissipation: model,
        ..PhysicsSpec::default()
    };
    Chain::build(&ChainSpec::Sequence(spec), &physics).unwrap()
}

fn time_general<const LAW: u8, const D: bool, const T: bool>(
    group: &mut BenchmarkGroup<'_, WallTime>,
    name: &str,
    chain: &Chain,
    y: &mut Vec<f64>,
) {
    let mut sys = GeneralChainSystem::<LAW, D, T>::new(chain);
    let dim = OdeSystem::dim(&sys);
    y.resize(dim, 0.0);
    let mut dy = vec![0.0; dim];
    group.bench_function(name, |b| {
        b.iter(|| sys.rhs(0.0, black_box(&y[..]), black_box(&mut dy)))
    });
}

/// The right-hand side of a chain with Thornton's contacts, their histories set so that a third
/// load on the plastic line, a third unload from 1 µm above their overlap and a third from 2 µm.
fn time_plastic(
    group: &mut BenchmarkGroup<'_, WallTime>,
    name: &str,
    chain: &Chain,
    y: &mut Vec<f64>,
) {
    let mut sys = PlasticChainSystem::new(chain);
    let dim = OdeSystem::dim(&sys);
    y.resize(dim, 0.0);
    for (k, (_, _, h)) in chain.plastic_contacts().into_iter().enumerate() {
        y[h] = (k % 3) as f64 * 1e-6;
        y[h + 1] = 1e-6;
    }
    let mut dy = vec![0.0; dim];
    group.bench_function(name, |b| {
        b.iter(|| sys.rhs(0.0, black_box(&y[..]), black_box(&mut dy)))
    });
}

/// RHS cost per contact of the general kernel for each law and dissipation model, on the paper's
/// chain size with gravity and the wall (`rhs/full_physics` is the paper's kernel on the same
/// chain with μ = 6 kg/s).
fn bench_general_rhs(c: &mut Criterion) {
    let power = |n: f64| LawSpec::PowerLaw {
        coefficient: 9e9 * 1e-6f64.powf(1.5 - n),
        exponent: n,
    };
    let linear = Some(DissipationSpec::LinearViscous { damping_kg_s: 6.0 });
    let tsuji = Some(DissipationSpec::Tsuji { restitution: 0.8 });
    let thornton = Some(LawSpec::Thornton {
        yield_pressure_pa: Some(1.5e9),
        yield_velocity_m_s: None,
    });
    let cases: [(&str, Option<LawSpec>, Option<DissipationSpec>); 10] = [
        ("hertz_no_damping", None, None),
        ("hertz_linear_viscous", None, linear),
        (
            "hertz_kuwabara_kono",
            None,
            Some(DissipationSpec::KuwabaraKono {
                relaxation_time_s: 1e-7,
            }),
        ),
        (
            "hertz_hunt_crossley",
            None,
            Some(DissipationSpec::HuntCrossley {
                restitution: 0.8,
                impact_velocity_m_s: 1.0,
            }),
        ),
        ("hertz_tsuji", None, tsuji),
        ("linear_law_linear_viscous", Some(power(1.0)), linear),
        ("power_law_2.5_no_damping", Some(power(2.5)), None),
        ("power_law_2.5_linear_viscous", Some(power(2.5)), linear),
        ("power_law_2.5_tsuji", Some(power(2.5)), tsuji),
        // Thornton's elastic–plastic law on the sphere–cylinder and sphere–wall contacts (every
        // contact: the striker is a sphere too), through its own right-hand side.
        ("thornton_no_damping", thornton, None),
    ];
    let mut group = c.benchmark_group("general_rhs");
    for (name, law_spec, model) in cases {
        let chain = general_chain(law_spec, model);
        group.throughput(Throughput::Elements(chain.n_contacts() as u64));
        let mut y = mid_pulse_state(&chain);
        if chain.has_plasticity() {
            time_plastic(&mut group, name, &chain, &mut y);
            continue;
        }
        // The general kernel itself, also for the two cases that `dispatch_chain_system!` sends to
        // the paper's kernel (Hertz laws with no or linear damping): their difference from
        // `rhs/full_physics` is the price of generality that the dispatch avoids.
        match (law(&chain), chain.has_damping(), chain.has_tsuji_damping()) {
            (HERTZ_LAW, false, _) => {
                time_general::<HERTZ_LAW, false, false>(&mut group, name, &chain, &mut y)
            }
            (HERTZ_LAW, true, false) => {
                time_general::<HERTZ_LAW, true, false>(&mut group, name, &chain, &mut y)
            }
            (HERTZ_LAW, true, true) => {
                time_general::<HERTZ_LAW, true, true>(&mut group, name, &chain, &mut y)
            }
            (LINEAR_LAW, false, _) => {
                time_general::<LINEAR_LAW, false, false>(&mut group, name, &chain, &mut y)
            }
            (LINEAR_LAW, true, _) => {
                time_general::<LINEAR_LAW, true, false>(&mut group, name, &chain, &mut y)
            }
            (_, false, _) => {
                time_general::<POWER_LAW, false, false>(&mut group, name, &chain, &mut y)
            }
            (_, true, false) => {
                time_general::<POWER_LAW, true, false>(&mut group, name, &chain, &mut y)
            }
            (_, true, true) => {
                time_general::<POWER_LAW, true, true>(&mut group, name, &chain, &mut y)
            }
        }
    }
    group.finish();
}

/// A 100-sphere chain between two walls under 20 N, damped (2 kg/s per contact), its top wall an
/// actuator shaking it harmonically at 5 kHz with a 10 nm stroke (inside the acoustic band):
/// 20 periods, DOP853 at rtol 1e-8, so that the cost per drive period is the time over 20.
fn driven_scene(particles: usize) -> chainsweep_solver::scene::Scene {
    use chainsweep_solver::chain::drive::{DriveSpec, Harmonic, Waveform};
    use chainsweep_solver::problems::monodisperse;
    use chainsweep_solver::scene::{Excitation, IntegratorSpec};
    let mut spec = monodisperse(particles, None, false);
    spec.top_wall_material = Some(spec.wall_material);
    let frequency_hz = 5000.0;
    let mut s = chainsweep_solver::scene::Scene::excited(
        spec,
        Excitation::Drive(DriveSpec::ActuatorM(Waveform::Harmonic(Harmonic {
            amplitude: 1e-8,
            frequency_hz,
            phase_rad: 0.0,
            ramp_periods: 2.0,
        }))),
        DRIVE_PERIODS / frequency_hz,
    );
    s.physics = PhysicsSpec {
        gravity: false,
        damping_kg_s: 2.0,
        precompression_force_n: 20.0,
        ..PhysicsSpec::default()
    };
    s.integrator = IntegratorSpec::Dop853(chainsweep_solver::AdaptiveOptions::new(1e-8));
    s
}

/// Periods of the driven benchmark run.
const DRIVE_PERIODS: f64 = 20.0;

/// The cost per drive period of a driven 100-particle chain, and the linear spectrum of a
/// 10 000-particle chain: its lowest and highest frequencies (what `record.spectrum` records), and
/// every frequency.
fn bench_drive_and_spectrum(c: &mut Criterion) {
    use chainsweep_solver::problems::monodisperse;
    use chainsweep_solver::spectrum::{LinearChain, SpectrumSpec};
    let driven = driven_scene(100);
    let out = run(&driven).unwrap();
    eprintln!(
        "driven 100 spheres, {DRIVE_PERIODS} periods: {} steps, {} rhs evals, energy drift {:.2e}",
        out.stats.steps, out.stats.rhs_evals, out.energy_drift_max
    );
    let mut group = c.benchmark_group("drive");
    group.sample_size(20);
    group.throughput(Throughput::Elements(DRIVE_PERIODS as u64));
    group.bench_function("actuator_100_spheres_per_period", |b| {
        b.iter(|| run(black_box(&driven)).unwrap())
    });
    group.finish();

    let physics = PhysicsSpec {
        gravity: false,
        precompression_force_n: 20.0,
        ..PhysicsSpec::default()
    };
    let chain = Chain::build(
        &ChainSpec::Sequence(monodisperse(10_000, None, false)),
        &physics,
    )
    .unwrap();
    let mut group = c.benchmark_group("spectrum");
    group.sample_size(10);
    group.bench_function("10000_particles_lowest_and_highest", |b| {
        b.iter(|| {
            SpectrumSpec::default()
                .summarise(black_box(&chain))
                .unwrap()
        })
    });
    let linear = LinearChain::of(&chain).unwrap();
    group.bench_function("10000_particles_every_frequency", |b| {
        b.iter(|| black_box(&linear).spectrum(false))
    });
    group.finish();
}

criterion_group!(
    benches,
    bench_rhs,
    bench_general_rhs,
    bench_run,
    bench_drive_and_spectrum
);
criterion_main!(benches);
