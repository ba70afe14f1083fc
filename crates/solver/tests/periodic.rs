//! Periodic orbits by shooting and their continuation: a damped linear chain's branch equals the
//! closed-form frequency response `(K − ω²M + iωC) X = F` to 1e-8 at every point and its Floquet
//! multipliers equal `exp(λ T)` of the damped eigenvalues to 1e-8; the variational monodromy
//! equals central differences of the period map; a precompressed Hertzian chain between walls,
//! driven hard, bends its resonance into two folds, located where the tangent turns, the branch
//! between them unstable, and time-integration sweeps up and down jump within a sweep step of
//! them; bad options name the field.

use chainsweep_solver::chain::drive::{DriveSpec, Harmonic, Waveform};
use chainsweep_solver::chain::model::{Chain, PhysicsSpec};
use chainsweep_solver::chain::sequence::SequenceSpec;
use chainsweep_solver::periodic::{
    continue_branch, continue_period_doubled, period_doubling_vector, BranchOptions, Monodromy,
    PeriodMap, PeriodicOptions, PointKind,
};
use chainsweep_solver::problems::complex::solve;
use chainsweep_solver::problems::{monodisperse, power_law};
use chainsweep_solver::scene::{Excitation, IntegratorSpec, Scene};
use chainsweep_solver::spectrum::LinearChain;
use chainsweep_solver::{AdaptiveOptions, ChainSpec};

fn harmonic(amplitude: f64, frequency_hz: f64) -> Waveform {
    Waveform::Harmonic(Harmonic {
        amplitude,
        frequency_hz,
        phase_rad: 0.0,
        ramp_periods: 5.0,
    })
}

/// Three particles with a linear law (`n = 1`, `k`) on a wall, precompressed so that no contact
/// opens, with viscous damping `μ`, driven by a harmonic force of 1 N on the first particle.
fn linear_chain(k: f64, mu: f64, frequency_hz: f64) -> Scene {
    let spec = monodisperse(3, Some(power_law(k, 1.0)), false);
    let mut s = Scene::excited(
        spec,
        Excitation::Drive(DriveSpec::ForceN(harmonic(1.0, frequency_hz))),
        1.0,
    );
    s.physics = PhysicsSpec {
        gravity: false,
        wall: true,
        damping_kg_s: mu,
        precompression_force_n: 50.0,
        ..PhysicsSpec::default()
    };
    s.integrator = IntegratorSpec::Dop853(AdaptiveOptions::new(1e-12));
    s
}

/// `X` of `(K − ω²M + iωC) X = F e₁` for the linear chain (every contact, the wall's included, a
/// spring `k` and a dashpot `μ`).
fn closed_form(k: f64, mu: f64, m: f64, omega: f64, n: usize) -> Vec<(f64, f64)> {
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
    b[0] = (1.0, 0.0);
    solve(a, b)
}

#[test]
fn a_linear_chain_s_branch_is_its_closed_form_response_with_exp_lambda_t_multipliers() {
    let (k, mu, n) = (2e7, 40.0, 3);
    let probe = linear_chain(k, mu, 1.0);
    let chain = probe.validate().unwrap();
    let m = chain.mass[0];
    let omega1 = (k / m).sqrt() / std::f64::consts::TAU;
    let (from, to) = (0.2 * omega1, 1.6 * omega1);
    let scene_at = move |f: f64| Ok(linear_chain(k, mu, f));
    let options = PeriodicOptions {
        tolerance: 1e-10,
        settle_periods: 10,
        ..PeriodicOptions::default()
    };
    let mut seen = 0;
    let branch = continue_branch(
        &scene_at,
        from,
        &options,
        &BranchOptions::new(to),
        &mut |_| seen += 1,
    )
    .unwrap();
    assert_eq!(seen, branch.points.len());
    assert!(branch.end.contains("end of the range"), "{}", branch.end);
    assert!(branch.points.len() > 20, "{}", branch.points.len());
    let last = branch.points.last().unwrap();
    assert_eq!(last.kind, PointKind::End);
    assert!((last.parameter - to).abs() < 1e-9 * to);
    // A linear response has no fold: the parameter only grows.
    assert!(branch.points.iter().all(|p| !p.kind.is_special()));
    assert!(branch
        .points
        .windows(2)
        .all(|w| w[1].parameter > w[0].parameter));

    let lin = LinearChain::of(&chain).unwrap();
    let (eigen, _) = lin.damped_eigenvalues("spectrum").unwrap();
    let rest = PeriodMap::new(&probe, &options).unwrap().rest_state();
    let mut worst: f64 = 0.0;
    for p in &branch.points {
        let omega = std::f64::consts::TAU * p.parameter;
        let x = closed_form(k, mu, m, omega, n);
        let amplitude = x.iter().map(|z| z.0.hypot(z.1)).fold(0.0, f64::max);
        // y = static + Im(X e^{iωt}): at t = 0 the position is static + Im X, the velocity ω Re X.
        for i in 0..n {
            let dx = p.orbit.state[i] - (rest[i] + x[i].1);
            let dv = p.orbit.state[n + i] - omega * x[i].0;
            worst = worst
                .max(dx.abs() / amplitude)
                .max(dv.abs() / (omega * amplitude));
        }
        assert!(p.orbit.stable());
        assert_eq!(p.orbit.method, Monodromy::Variational);
        // The multipliers exp(λ T), each matched to the nearest computed one.
        let period = 1.0 / p.parameter;
        for e in &eigen {
            let (r, a) = ((e.re * period).exp(), e.im * period);
            let want = (r * a.cos(), r * a.sin());
            let err = p
                .orbit
                .multipliers
                .iter()
                .map(|m| (m.0 - want.0).hypot(m.1 - want.1))
                .fold(f64::INFINITY, f64::min);
            assert!(
                err < 1e-8,
                "at {} Hz: {want:?} off by {err:e}: {:?}",
                p.parameter,
                p.orbit.multipliers
            );
        }
    }
    assert!(worst < 1e-8, "orbit off the closed form by {worst:e}");
}

/// Eight 8 mm steel spheres between two steel walls under 2 N, damped, the top wall shaken by
/// `stroke_m`: a Hertzian chain whose first resonance (about 3.24 kHz) stiffens with the stroke.
fn hertz_chain(stroke_m: f64, frequency_hz: f64) -> Scene {
    let mut spec: SequenceSpec = monodisperse(8, None, false);
    let steel = chainsweep_solver::problems::STEEL;
    spec.wall_material = steel;
    spec.top_wall_material = Some(steel);
    let mut s = Scene::excited(
        ChainSpec::Sequence(spec),
        Excitation::Drive(DriveSpec::ActuatorM(harmonic(stroke_m, frequency_hz))),
        1.0,
    );
    s.physics = PhysicsSpec {
        gravity: false,
        wall: true,
        damping_kg_s: 3.0,
        precompression_force_n: 2.0,
        ..PhysicsSpec::default()
    };
    s.integrator = IntegratorSpec::Dop853(AdaptiveOptions::new(1e-10));
    s
}

#[test]
fn the_variational_monodromy_equals_central_differences() {
    let scene = hertz_chain(3e-8, 3300.0);
    let fd = PeriodicOptions {
        monodromy: Monodromy::FiniteDifference,
        ..PeriodicOptions::default()
    };
    let map = PeriodMap::new(&scene, &PeriodicOptions::default()).unwrap();
    let x = PeriodMap::settle(&scene, 3300.0, 30).unwrap();
    let var = map.map(&x, true).unwrap();
    assert_eq!(var.method, Monodromy::Variational);
    let diff = PeriodMap::new(&scene, &fd).unwrap().map(&x, true).unwrap();
    assert_eq!(diff.method, Monodromy::FiniteDifference);
    assert_eq!(diff.maps as usize, 1 + 2 * map.dim());
    let (a, b) = (var.monodromy.unwrap(), diff.monodromy.unwrap());
    let m = map.dim();
    let s = map.scales();
    let mut worst: f64 = 0.0;
    for i in 0..m {
        for j in 0..m {
            // Compared in the scaled variables, where entries are of order one.
            worst = worst.max((a[i * m + j] - b[i * m + j]).abs() * s[j] / s[i]);
        }
    }
    assert!(
        worst < 1e-5,
        "variational against central differences: {worst:e}"
    );
    assert!(map.scaled_distance(&var.end, &diff.end) < 1e-8);
}

#[test]
fn a_stiffening_resonance_folds_twice_unstable_between_where_sweeps_jump() {
    let stroke = 1.5e-7;
    let scene_at = move |f: f64| Ok(hertz_chain(stroke, f));
    let options = PeriodicOptions {
        settle_periods: 100,
        ..PeriodicOptions::default()
    };
    let branch = continue_branch(
        &scene_at,
        2900.0,
        &options,
        &BranchOptions {
            step: Some(10.0),
            ..BranchOptions::new(3700.0)
        },
        &mut |_| {},
    )
    .unwrap();
    assert!(branch.end.contains("end of the range"), "{}", branch.end);
    let folds: Vec<_> = branch
        .points
        .iter()
        .filter(|p| p.kind == PointKind::Fold)
        .collect();
    assert_eq!(
        folds.len(),
        2,
        "{:?}",
        branch
            .points
            .iter()
            .map(|p| (p.parameter, p.kind))
            .collect::<Vec<_>>()
    );
    let (upper, lower) = (folds[0].parameter, folds[1].parameter);
    assert!(
        upper > lower,
        "the branch turns back at {upper} and forward at {lower}"
    );
    // At a fold the tangent's parameter component vanishes (located), and a multiplier is 1.
    for f in &folds {
        assert!(f.tangent_parameter.abs() < 1e-3, "{}", f.tangent_parameter);
        assert!(
            (f.orbit.largest_multiplier() - 1.0).abs() < 1e-2,
            "{:?}",
            f.orbit.multipliers
        );
    }
    // Between the folds (in arclength) the orbits are unstable, elsewhere stable.
    let (s0, s1) = (folds[0].arclength, folds[1].arclength);
    for p in &branch.points {
        if p.kind.is_special() {
            continue;
        }
        let inside = p.arclength > s0 && p.arclength < s1;
        assert_eq!(
            !p.orbit.stable(),
            inside,
            "at {} Hz ({}): {:?}",
            p.parameter,
            p.arclength,
            p.orbit.multipliers
        );
    }

    // Time integration up and down in steps of 2 Hz, each point settled over 400 periods from
    // the state the one before it left: the response jumps where its branch ends, the way up
    // past the upper fold, the way down past the lower one (a hardening resonance).
    let step = 2.0;
    let frequencies: Vec<f64> = (0..=30).map(|k| 3414.0 + step * k as f64).collect();
    let sweep = |order: &mut dyn Iterator<Item = &f64>| -> Vec<(f64, f64)> {
        let mut x: Option<Vec<f64>> = None;
        let mut out = Vec::new();
        for &f in order {
            let map = PeriodMap::new(&hertz_chain(stroke, f), &options).unwrap();
            let mut y = x
                .take()
                .unwrap_or_else(|| PeriodMap::settle(&hertz_chain(stroke, f), f, 100).unwrap());
            for _ in 0..400 {
                y = map.map(&y, false).unwrap().end;
            }
            // The first particle's displacement amplitude, from its position and velocity.
            let rest = map.rest_state();
            let n = map.n_particles();
            let omega = std::f64::consts::TAU * f;
            out.push((f, (y[0] - rest[0]).hypot(y[n] / omega)));
            x = Some(y);
        }
        out
    };
    let jump = |s: &[(f64, f64)]| -> (f64, f64) {
        let k = (1..s.len())
            .max_by(|&i, &j| {
                let d = |k: usize| (s[k].1 - s[k - 1].1).abs();
                d(i).total_cmp(&d(j))
            })
            .unwrap();
        (s[k - 1].0, s[k].0)
    };
    let up = jump(&sweep(&mut frequencies.iter()));
    let down = jump(&sweep(&mut frequencies.iter().rev()));
    // Past a fold the state lingers near the orbit that vanished there (a slow passage), so a
    // sweep jumps at the first of its points past the fold or, so close to it, one step later.
    assert!(
        upper <= up.1 && up.0 <= upper + step,
        "up jumps over {up:?}, the fold at {upper}"
    );
    assert!(
        down.1 <= lower && down.0 >= lower - step,
        "down jumps over {down:?}, the fold at {lower}"
    );
}

#[test]
fn bad_periodic_options_and_scenes_name_the_field() {
    let scene = hertz_chain(1e-8, 3000.0);
    let err = |o: PeriodicOptions| PeriodMap::new(&scene, &o).unwrap_err().field;
    assert_eq!(
        err(PeriodicOptions {
            periods: 0,
            ..PeriodicOptions::default()
        }),
        "periodic.periods"
    );
    assert_eq!(
        err(PeriodicOptions {
            tolerance: 0.0,
            ..PeriodicOptions::default()
        }),
        "periodic.tolerance"
    );
    let mut struck = scene.clone();
    struck.excitation = None;
    assert_eq!(
        PeriodMap::new(&struck, &PeriodicOptions::default())
            .unwrap_err()
            .field,
        "excitation.drive"
    );
    let scene_at = move |f: f64| Ok(hertz_chain(1e-8, f));
    let e = continue_branch(
        &scene_at,
        3000.0,
        &PeriodicOptions::default(),
        &BranchOptions::new(3000.0),
        &mut |_| {},
    )
    .unwrap_err();
    assert_eq!(e.field, "periodic.to");
    let _ = Chain::build;
}

/// One 8 mm steel sphere pressed on a steel wall by a static force, damped, driven by a harmonic
/// force of `amplitude_n` at `frequency_hz`.
fn bouncer(amplitude_n: f64, frequency_hz: f64) -> Scene {
    let mut spec: SequenceSpec = monodisperse(1, None, false);
    spec.wall_material = chainsweep_solver::problems::STEEL;
    let mut s = Scene::excited(
        ChainSpec::Sequence(spec),
        Excitation::Drive(DriveSpec::ForceN(harmonic(amplitude_n, frequency_hz))),
        1.0,
    );
    s.physics = PhysicsSpec {
        gravity: false,
        wall: true,
        damping_kg_s: BOUNCER_DAMPING,
        precompression_force_n: 10.0,
        ..PhysicsSpec::default()
    };
    s.integrator = IntegratorSpec::Dop853(AdaptiveOptions::new(1e-11));
    s
}
const BOUNCER_DAMPING: f64 = 0.5;

/// A sphere pressed on a wall (`F₀` = 10 N), lightly damped, shaken by a force of 6 N near twice
/// its natural frequency `f₀`: the quadratic term of the Hertz force makes the stiffness pump at
/// the drive's frequency, a parametric resonance whose tongue the branch of single-period orbits
/// crosses, losing stability at one period doubling and regaining it at another. Continued down
/// in frequency, the first doubling is supercritical (the Hertz contact softens): the doubled
/// branch bends into the tongue, stable, its split `x(T) − x(0)` growing as the square root of
/// the distance from the doubling; time integration inside the tongue settles on it.
#[test]
fn a_shaken_sphere_period_doubles_onto_the_doubled_branch_that_time_integration_finds() {
    let probe = bouncer(6.0, 1.0);
    let chain = probe.validate().unwrap();
    let f0 = LinearChain::of(&chain)
        .unwrap()
        .spectrum(false)
        .angular_frequency_rad_s[0]
        / std::f64::consts::TAU;
    let scene_at = move |f: f64| Ok(bouncer(6.0, f));
    let options = PeriodicOptions {
        settle_periods: 200,
        tolerance: 1e-9,
        ..PeriodicOptions::default()
    };
    let branch = continue_branch(
        &scene_at,
        2.2 * f0,
        &options,
        &BranchOptions::new(1.8 * f0),
        &mut |_| {},
    )
    .unwrap();
    assert!(branch.end.contains("end of the range"), "{}", branch.end);
    let doublings: Vec<_> = branch
        .points
        .iter()
        .filter(|p| p.kind == PointKind::PeriodDoubling)
        .collect();
    assert_eq!(doublings.len(), 2, "{:?}", branch.warnings);
    let (upper, lower) = (doublings[0], doublings[1]);
    assert!(upper.parameter > lower.parameter);
    // The tongue lies about twice f₀ (1.96 f₀ to 2.03 f₀ here, the contact's softening and the
    // damping shifting it).
    assert!(upper.parameter < 2.1 * f0 && lower.parameter > 1.9 * f0);
    let nearest = |p: &chainsweep_solver::periodic::BranchPoint| {
        p.orbit
            .multipliers
            .iter()
            .map(|m| (m.0 + 1.0).hypot(m.1))
            .fold(f64::INFINITY, f64::min)
    };
    for d in &doublings {
        assert!(nearest(d) < 1e-6, "{:?}", d.orbit.multipliers);
    }
    // Stable outside the tongue, unstable inside (a real multiplier below −1).
    for p in branch.points.iter().filter(|p| !p.kind.is_special()) {
        let inside = p.parameter < upper.parameter && p.parameter > lower.parameter;
        assert_eq!(!p.orbit.stable(), inside, "{} f0", p.parameter / f0);
    }

    // The eigenvector of the multiplier −1: M v = −v.
    let scales = &upper.scales()[..2];
    let v = period_doubling_vector(&upper.orbit, scales).unwrap();
    let m = &upper.orbit.monodromy;
    for i in 0..2 {
        let mv = m[2 * i] * v[0] + m[2 * i + 1] * v[1];
        assert!((mv + v[i]).abs() < 1e-6 * scales[i], "{mv} {}", v[i]);
    }

    let mut doubled = Vec::new();
    let to = upper.parameter - 0.05 * f0;
    let b = continue_period_doubled(
        &scene_at,
        upper,
        &options,
        &BranchOptions::new(to),
        &mut |p| doubled.push(p.clone()),
    )
    .unwrap();
    assert!(b.end.contains("end of the range"), "{}", b.end);
    // Supercritical: into the tongue, stable, of twice the period (the split x(T) − x(0) not
    // zero, from T = 1/f: the period-1 map's distance).
    let single = |f: f64| PeriodMap::new(&bouncer(6.0, f), &options).unwrap();
    let split = |p: &chainsweep_solver::periodic::BranchPoint| {
        let map = single(p.parameter);
        map.scaled_distance(&map.map(&p.orbit.state, false).unwrap().end, &p.orbit.state)
    };
    let mut law = Vec::new();
    for p in &doubled {
        assert!(p.parameter < upper.parameter, "{} f0", p.parameter / f0);
        assert!(p.orbit.stable(), "{:?}", p.orbit.multipliers);
        let s = split(p);
        assert!(s > 1e-3, "{} f0: split {s}", p.parameter / f0);
        let distance = (upper.parameter - p.parameter) / f0;
        if distance > 1e-5 && distance < 3e-3 {
            law.push((distance.ln(), s.ln()));
        }
    }
    // split ∝ √(p_PD − p): the slope of log split against log distance, by least squares.
    assert!(law.len() >= 4, "{law:?}");
    let k = law.len() as f64;
    let (mx, my) = (
        law.iter().map(|l| l.0).sum::<f64>() / k,
        law.iter().map(|l| l.1).sum::<f64>() / k,
    );
    let slope = law.iter().map(|l| (l.0 - mx) * (l.1 - my)).sum::<f64>()
        / law.iter().map(|l| (l.0 - mx).powi(2)).sum::<f64>();
    println!("slope {slope} over {} points", law.len());
    assert!((slope - 0.5).abs() < 0.01, "slope {slope}");

    // The other doubling, where the branch leaves the tongue, is subcritical: its doubled
    // branch bends out of the tongue, unstable (a multiplier above +1).
    let sub = continue_period_doubled(
        &scene_at,
        lower,
        &options,
        &BranchOptions::new(lower.parameter - 0.03 * f0),
        &mut |_| {},
    )
    .unwrap();
    for p in &sub.points {
        assert!(p.parameter < lower.parameter, "{} f0", p.parameter / f0);
        assert!(
            p.orbit.largest_multiplier() > 1.0,
            "{:?}",
            p.orbit.multipliers
        );
    }

    // Time integration inside the tongue, from rest through the drive's ramp (which leaves the
    // unstable single-period orbit perturbed), over 8000 periods: it settles on an orbit of
    // twice the period, the doubled branch's at that frequency (either of its two phases).
    let target = doubled
        .iter()
        .min_by(|a, b| {
            (a.parameter - 2.01 * f0)
                .abs()
                .total_cmp(&(b.parameter - 2.01 * f0).abs())
        })
        .unwrap();
    let f = target.parameter;
    let map = single(f);
    let y = PeriodMap::settle(&bouncer(6.0, f), f, 8000).unwrap();
    let y1 = map.map(&y, false).unwrap().end;
    let y2 = map.map(&y1, false).unwrap().end;
    let (d1, d2) = (map.scaled_distance(&y1, &y), map.scaled_distance(&y2, &y));
    let x = &target.orbit.state;
    let px = map.map(x, false).unwrap().end;
    let off = map.scaled_distance(&y, x).min(map.scaled_distance(&y, &px));
    println!(
        "at {} f0: x(T) − x(0) {d1:e}, x(2T) − x(0) {d2:e}, off the branch {off:e}",
        f / f0
    );
    assert!(d1 > 1e-2 && d2 < 1e-9, "{d1:e} {d2:e}");
    assert!(off < 1e-8, "{off:e}");
}
