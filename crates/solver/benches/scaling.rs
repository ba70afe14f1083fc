//! `make bench`: the cost of a long chain against its moving part: the reference scene
//! (`benches/reference.rs`: the 0.55 chain, μ = 6 kg/s, v0 = 1.3 m/s, 1 ms, gauges in cylinders 4
//! and 21) at the scene's default DOP853 tolerance (rtol 1e-9), with 50, 1 000 and 5 000
//! cylinders. The pulse reaches about 45 cylinders in 1 ms.
//!
//! It uses only the solver's long-standing public interface, so that `scripts/bench_compare.py`
//! can build the same file at a base revision and run the two side by side.

use chainsweep_solver::{run, AdaptiveOptions, ChainSpec, IntegratorSpec, Scene};
use criterion::{black_box, criterion_group, criterion_main, Criterion};

#[allow(dead_code)]
mod reference;
use reference::reference_scene;

/// The reference scene with `cylinders` cylinders at rtol 1e-9.
fn scaling_scene(cylinders: usize) -> Scene {
    let mut scene = reference_scene(1e-9);
    scene.chain = ChainSpec::chain_055(cylinders);
    scene.integrator = IntegratorSpec::Dop853(AdaptiveOptions::new(1e-9));
    scene
}

fn bench_scaling(c: &mut Criterion) {
    let mut group = c.benchmark_group("scaling");
    group.sample_size(10);
    for cylinders in [50, 1000, 5000] {
        let scene = scaling_scene(cylinders);
        let out = run(&scene).unwrap();
        eprintln!(
            "{cylinders} cylinders: {} steps, {} rhs evals, peak F21 = {:.9} N",
            out.stats.steps, out.stats.rhs_evals, out.probes[1].leading_peak
        );
        group.bench_function(format!("chain055_{cylinders}cyl_mu6_1ms"), |b| {
            b.iter(|| run(black_box(&scene)).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, bench_scaling);
criterion_main!(benches);
