//! Minimum-of-repeats timing of one right-hand-side evaluation of the 50-cylinder 0.55 chain,
//! robust to a loaded machine (the minimum is the run least disturbed):
//! `cargo run --release -p chainsweep-solver --example rhs_timing`.
use chainsweep_solver::chain::model::{Chain, ChainSpec, PhysicsSpec};
use chainsweep_solver::integrate::OdeSystem;
use chainsweep_solver::motion::system::ChainSystem;
use std::hint::black_box;

fn state(chain: &Chain, dim: usize) -> Vec<f64> {
    let n = chain.n_particles();
    let mut y = chain.equilibrium_position.clone();
    let mut shift = 0.0;
    for i in (0..n).rev() {
        shift += 4e-6 * ((i as f64 * 0.37).sin() + 0.3);
        y[i] += shift;
    }
    y.extend((0..n).map(|i| (i as f64 * 0.91).cos()));
    y.resize(dim, 0.0);
    y
}

fn time<S: OdeSystem>(mut sys: S, y: &[f64]) -> f64 {
    let mut dy = vec![0.0; y.len()];
    let mut best = f64::INFINITY;
    for _ in 0..30 {
        let t = std::time::Instant::now();
        for _ in 0..20_000 {
            sys.rhs(0.0, black_box(y), black_box(&mut dy));
        }
        best = best.min(t.elapsed().as_secs_f64() / 20_000.0);
    }
    best * 1e9
}

fn main() {
    let spec = ChainSpec::chain_055(50);
    let full = Chain::build(
        &spec,
        &PhysicsSpec {
            damping_kg_s: 6.0,
            ..PhysicsSpec::default()
        },
    )
    .unwrap();
    let bare = Chain::build(
        &spec,
        &PhysicsSpec {
            gravity: false,
            ..PhysicsSpec::default()
        },
    )
    .unwrap();
    let contacts = full.n_contacts() as f64;
    let s1 = ChainSystem::<true, true, true, false>::new(&full);
    let y1 = state(&full, OdeSystem::dim(&s1));
    let s2 = ChainSystem::<false, false, true, false>::new(&bare);
    let y2 = state(&bare, OdeSystem::dim(&s2));
    let a = time(s1, &y1);
    let b = time(s2, &y2);
    println!(
        "full physics (gravity, damping, wall): {a:.1} ns per evaluation, {:.2} ns per contact",
        a / contacts
    );
    println!(
        "no gravity, no damping (wall):         {b:.1} ns per evaluation, {:.2} ns per contact",
        b / contacts
    );
}
