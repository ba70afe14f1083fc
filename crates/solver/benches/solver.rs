//! `make bench`: right-hand-side cost per contact and the cost of one reference run.
//!
//! The reference run is the issue's: the 0.55 chain (3.77 g cylinders, 50 cylinders), μ = 6 kg/s,
//! v0 = 1.3 m/s, 1 ms simulated, DOP853 at the tolerance whose leading peak in cylinder 21 is within
//! 1e-6 of a tight reference (checked by `tests/accuracy.rs`).

use chainsweep_solver::integrate::OdeSystem;
use chainsweep_solver::model::{Chain, ChainSpec, PhysicsSpec};
use chainsweep_solver::scene::run;
use chainsweep_solver::system::ChainSystem;
use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};

mod reference;
use reference::{reference_scene, REFERENCE_RTOL};

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
    let scene = reference_scene(REFERENCE_RTOL);
    let out = run(&scene).unwrap();
    eprintln!(
        "reference run: {} steps, {} rhs evals, peak F21 = {:.9} N, energy drift {:.2e}",
        out.stats.steps, out.stats.rhs_evals, out.probes[1].leading_peak, out.energy_drift_max
    );
    let mut group = c.benchmark_group("run");
    group.sample_size(30);
    group.bench_function("chain055_50cyl_mu6_1ms", |b| {
        b.iter(|| run(black_box(&scene)).unwrap())
    });
    group.finish();
}

criterion_group!(benches, bench_rhs, bench_run);
criterion_main!(benches);
