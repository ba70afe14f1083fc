//! Time of the linear spectrum of a long chain at its static state: every natural frequency, then
//! every frequency with its mode shape, of a gravity-loaded, precompressed chain of spheres on the
//! wall (minimum of a few repeats, robust to a loaded machine), with the largest error of the
//! frequencies against the fixed–free closed form of the same chain without gravity:
//! `cargo run --release -p chainsweep-solver --example spectrum_timing -- [N] [repeats]`.
use chainsweep_solver::chain::model::{hertz_coefficient, Chain, ChainSpec, PhysicsSpec};
use chainsweep_solver::problems::{monodisperse, power_law, STEEL};
use chainsweep_solver::spectrum::LinearChain;
use std::time::Instant;

fn best_of<T>(repeats: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut best = f64::INFINITY;
    let mut out = None;
    for _ in 0..repeats {
        let t = Instant::now();
        let r = f();
        best = best.min(t.elapsed().as_secs_f64());
        out = Some(r);
    }
    (best, out.unwrap())
}

fn main() {
    let mut args = std::env::args().skip(1);
    let n: usize = args.next().map_or(10_000, |a| a.parse().expect("N"));
    let repeats: usize = args.next().map_or(3, |a| a.parse().expect("repeats"));
    let (a, m, f0) = (
        hertz_coefficient(STEEL, Some(4e-3), STEEL, Some(4e-3)),
        2.085e-3,
        10.0,
    );
    let spec = ChainSpec::Sequence(monodisperse(n, Some(power_law(a, 1.5)), false));
    let loaded = PhysicsSpec {
        precompression_force_n: f0,
        ..PhysicsSpec::default()
    };
    let chain = Chain::build(&spec, &loaded).unwrap();
    let lin = LinearChain::of(&chain).unwrap();
    let (t_values, s) = best_of(repeats, || lin.spectrum(false));
    let (t_modes, s_modes) = best_of(repeats, || lin.spectrum(true));
    assert_eq!(s.angular_frequency_rad_s, s_modes.angular_frequency_rad_s);
    println!(
        "N = {n}, gravity + {f0} N: {:.3} s for all frequencies, {:.3} s with mode shapes (minimum of {repeats}); ω from {:.6e} to {:.6e} rad/s",
        t_values,
        t_modes,
        s.angular_frequency_rad_s[0],
        s.angular_frequency_rad_s[n - 1]
    );
    // The closed form, gravity off: ω_j = 2 √(K/m) sin((2j − 1)π/(2(2N + 1))).
    let plain = PhysicsSpec {
        gravity: false,
        ..loaded
    };
    let lin = LinearChain::of(&Chain::build(&spec, &plain).unwrap()).unwrap();
    let k = 1.5 * a.powf(2.0 / 3.0) * f0.powf(1.0 / 3.0);
    let worst = lin
        .spectrum(false)
        .angular_frequency_rad_s
        .iter()
        .enumerate()
        .map(|(j, w)| {
            let theta = (2 * j + 1) as f64 * std::f64::consts::PI / (2 * (2 * n + 1)) as f64;
            (w / (2.0 * (k / m).sqrt() * theta.sin()) - 1.0).abs()
        })
        .fold(0.0, f64::max);
    println!("gravity off: largest relative error against the closed form {worst:.2e}");
}
