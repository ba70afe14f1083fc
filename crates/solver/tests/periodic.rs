//! Periodic orbits by shooting and their continuation: a damped linear chain's branch equals the
//! closed-form frequency response `(K − ω²M + iωC) X = F` to 1e-8 at every point and its Floquet
//! multipliers equal `exp(λ T)` of the damped eigenvalues to 1e-8; the variational monodromy
//! equals central differences of the period map; a precompressed Hertzian chain between walls,
//! driven hard, bends its resonance into two folds, located where the tangent turns, the branch
//! between them unstable, and time-integration sweeps up and down jump within a sweep step of
//! them; a sphere on a wall shaken near twice its frequency period-doubles, supercritically
//! where its branch enters the parametric tongue (the doubled branch's split growing as the square
//! root of the distance, time integration settling on the doubled orbit to 1e-8) and
//! subcritically where it leaves; a precompressed dimer's breather in the gap, centred on a light
//! sphere, has tails that fall by the linear chain's evanescent factor `exp(−Im q)` to 1e-3; a
//! pressed sphere's backbone follows the normal form `ω₀ (1 − A²/(24 δ₀²))` to its order; a
//! family of free orbits resumed from its journaled orbits is bitwise the uninterrupted one, and
//! the static state is refused as an orbit; bad options name the field.

use chainsweep_solver::chain::drive::{DriveSpec, Harmonic, Waveform};
use chainsweep_solver::chain::model::{Chain, PhysicsSpec};
use chainsweep_solver::chain::sequence::SequenceSpec;
use chainsweep_solver::periodic::{
    continue_autonomous, continue_branch, continue_period_doubled, period_doubling_vector,
    resume_autonomous, AutonomousMap, BranchOptions, Monodromy, PeriodMap, PeriodicOptions,
    PointKind, ShootingError,
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
    // A chain longer than the dense monodromy allows is refused, naming the chain.
    let mut long = hertz_chain(1e-8, 3000.0);
    if let ChainSpec::Sequence(spec) = &mut long.chain {
        spec.sequence = monodisperse(401, None, false).sequence;
    }
    let e = PeriodMap::new(&long, &PeriodicOptions::default()).unwrap_err();
    assert_eq!(e.field, "chain");
    assert!(e.message.contains("at most 400 particles"), "{}", e.message);
    // Autonomous orbits: a driven scene, a damped chain.
    assert_eq!(AutonomousMap::new(&scene).unwrap_err().field, "excitation");
    let mut damped = dimer(3, &[(2, 1e-8)]);
    damped.physics.damping_kg_s = 1.0;
    assert_eq!(
        AutonomousMap::new(&damped).unwrap_err().field,
        "physics.damping_kg_s"
    );
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

/// A dimer of `cells` × [heavy 8 mm sphere, light 5 mm sphere] on a steel wall (the last, light,
/// on it), every contact the same Hertz law, pressed by 10 N, no gravity, no damping, set off
/// from its static state by `displacements` (particle, metres).
fn dimer(cells: usize, displacements: &[(usize, f64)]) -> Scene {
    use chainsweep_solver::chain::sequence::{RepeatBlock, SequenceItem};
    use chainsweep_solver::problems::{chain, rule, sphere, STEEL};
    use chainsweep_solver::scene::{InitialState, ParticleStart};
    let law = Some(power_law(DIMER_A, 1.5));
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
    let state = InitialState {
        particles: displacements
            .iter()
            .map(|&(particle, d)| ParticleStart {
                particle,
                velocity_m_s: 0.0,
                displacement_m: d,
            })
            .collect(),
        random_velocity: None,
    };
    let mut s = Scene::excited(
        ChainSpec::Sequence(spec),
        Excitation::InitialState(state),
        1.0,
    );
    s.physics = PhysicsSpec {
        gravity: false,
        wall: true,
        damping_kg_s: 0.0,
        precompression_force_n: DIMER_FORCE,
        ..PhysicsSpec::default()
    };
    s.integrator = IntegratorSpec::Dop853(AdaptiveOptions::new(1e-11));
    s
}
const DIMER_A: f64 = 8e9;
const DIMER_FORCE: f64 = 10.0;

/// The first guess of a breather centred on the light sphere of the middle cell of a dimer of
/// `cells` cells (its 1-based particle number, returned): that sphere displaced by 0.6 δ₀, the
/// light spheres beside it back by 0.61 of that, the next ones forward by 0.61².
fn breather_guess(cells: usize) -> (usize, [(usize, f64); 5]) {
    let centre = 2 * (cells / 2) + 2;
    let delta0 = (DIMER_FORCE / DIMER_A).powf(2.0 / 3.0);
    let (a, e) = (0.6 * delta0, 0.61);
    (
        centre,
        [
            (centre, a),
            (centre - 2, -e * a),
            (centre + 2, -e * a),
            (centre - 4, e * e * a),
            (centre + 4, e * e * a),
        ],
    )
}

/// A breather of a precompressed dimer (60 cells of an 8 mm and a 5 mm steel sphere on a wall,
/// no damping): found at 0.99 of the optical band's lower edge from a guess (`breather_guess`)
/// by shooting on time-reversal symmetry, continued in frequency up towards the edge and down into the gap between the acoustic and optical bands. Centred on the
/// light sphere (its profile symmetric about it) and localised; its amplitude falls towards the
/// edge (breathers bifurcate from the optical band's lower edge into the gap, as Theocharis et
/// al., Phys. Rev. E 82, 056604, 2010, found); far from its centre its tails fall from cell to
/// cell, in antiphase, by the linear chain's evanescent factor `exp(−Im q)` at its frequency,
/// from the cell's transfer matrix, to 1e-3.
#[test]
fn a_dimer_s_breather_in_the_gap_decays_as_the_linear_chain_s_evanescent_wave() {
    let cells = 60;
    // The light sphere of cell 31 (1-based particle 62).
    let (centre, guess) = breather_guess(cells);
    let delta0 = (DIMER_FORCE / DIMER_A).powf(2.0 / 3.0);
    let map = AutonomousMap::new(&dimer(cells, &guess)).unwrap();
    let cell = LinearChain::of(map.chain())
        .unwrap()
        .unit_cell(2, "cell")
        .unwrap();
    let bands = cell.bands();
    let (acoustic_top, optical_bottom) = (bands[0].upper_rad_s, bands[1].lower_rad_s);
    // The gap of a dimer of equal contacts: √(2K/M) to √(2K/m).
    let k = 1.5 * DIMER_A.powf(2.0 / 3.0) * DIMER_FORCE.powf(1.0 / 3.0);
    assert!((acoustic_top / (2.0 * k / 2.085e-3).sqrt() - 1.0).abs() < 1e-9);
    assert!((optical_bottom / (2.0 * k / 0.5e-3).sqrt() - 1.0).abs() < 1e-9);
    let edge_hz = optical_bottom / std::f64::consts::TAU;
    let at = |ratios: &[f64]| -> Vec<f64> { ratios.iter().map(|r| r * edge_hz).collect() };
    let (towards_edge, stop) = continue_autonomous(
        &map,
        map.first_guess(),
        &at(&[0.99, 0.9915, 0.993, 0.9945]),
        1e-10,
        30,
        &mut |_| {},
    );
    assert!(stop.is_none(), "{stop:?}");
    let (into_gap, stop) = continue_autonomous(
        &map,
        &towards_edge[0].positions,
        &at(&[0.99, 0.985, 0.98, 0.97, 0.96]),
        1e-10,
        30,
        &mut |_| {},
    );
    assert!(stop.is_none(), "{stop:?}");
    let family: Vec<_> = towards_edge.iter().rev().chain(&into_gap[1..]).collect();
    let c = centre - 1;
    let mut amplitudes = Vec::new();
    for o in &family {
        let omega = std::f64::consts::TAU * o.frequency_hz();
        assert!(omega > acoustic_top && omega < optical_bottom);
        let odd = o.odd_part();
        let peak = odd[c].abs();
        // Not the static state, which is an orbit of every period: a breather on the light
        // sphere, symmetric about it, the largest motion there, below a thousandth of it
        // twenty-five cells away.
        assert!(peak > 0.1 * delta0, "{peak:e}");
        assert!(odd.iter().all(|x| x.abs() <= peak), "{odd:?}");
        for d in 1..10 {
            let (l, r) = (odd[c - 2 * d], odd[c + 2 * d]);
            assert!((l / r - 1.0).abs() < 1e-4, "{d}: {l:e} {r:e}");
        }
        assert!(odd[c + 50].abs() < 1e-3 * peak && odd[c - 50].abs() < 1e-3 * peak);
        // Far from the centre the tails are linear: the ratio of successive cells' light
        // spheres is −exp(−Im q), measured where the nonlinear part of the tail, falling by
        // exp(−2 Im q) a cell relative to it, has fallen below 1e-4.
        let (re_q, im_q) = cell.bloch_wavenumber(omega);
        assert_eq!(re_q, std::f64::consts::PI);
        let decay = (-im_q).exp();
        let d = (1e-4f64.ln() / (2.0 * decay.ln())).ceil() as usize;
        let ratio = odd[c + 2 * (d + 1)] / odd[c + 2 * d];
        println!(
            "{:.4} of the edge: centre {:.4} δ0, cells {d} to {}: ratio {ratio:.6}, exp(−Im q) {decay:.6} (relative error {:.1e}); multipliers: the pair at +1 off by {:.1e}, largest other {:.6}",
            omega / optical_bottom,
            peak / delta0,
            d + 1,
            -ratio / decay - 1.0,
            o.trivial_pair_error(),
            o.largest_nontrivial_multiplier()
        );
        assert!(ratio < 0.0, "{ratio}");
        assert!(
            (-ratio / decay - 1.0).abs() < 1e-3,
            "{ratio} against {decay}"
        );
        // The monodromy's pair at +1 (shift along the orbit, change of energy), a Jordan block
        // whose computed eigenvalues split by about the square root of the monodromy's error.
        assert!(o.trivial_pair_error() < 1e-3, "{:?}", o.multipliers);
        amplitudes.push((omega, peak));
    }
    // The amplitude grows from the edge into the gap.
    assert!(
        amplitudes
            .windows(2)
            .all(|w| w[1].0 < w[0].0 && w[1].1 > w[0].1),
        "{amplitudes:?}"
    );
}

/// The free oscillation of a sphere pressed on a wall by a static force (no gravity, no damping):
/// its frequency against its amplitude (the backbone curve, autonomous orbits continued in
/// frequency) against the weakly nonlinear oscillator `u'' + ω₀² u + a₂ u² + a₃ u³ = 0` that
/// the Hertz force `A (δ₀ + u)^{3/2}` about the static overlap gives (`u` towards the wall:
/// `a₂ = 3A/(8m√δ₀)`, `a₃ = −A/(16 m δ₀^{3/2})`, `ω₀² = 3A√δ₀/(2m)`), whose frequency is
/// `ω = ω₀ + (3a₃/(8ω₀) − 5a₂²/(12ω₀³)) A² = ω₀ (1 − A²/(24 δ₀²))` (Lindstedt–Poincaré), `A` the
/// fundamental's amplitude. With `A` the peak displacement `u(0)` (which is
/// `A − A²/(12δ₀)` to second order) the relative error of the shift is `ε/6` to leading order,
/// `ε = A/δ₀`: it falls like the amplitude; with the fundamental (the odd part of the motion)
/// it falls like its square.
#[test]
fn a_pressed_sphere_s_backbone_follows_the_normal_form_to_its_order() {
    use chainsweep_solver::scene::{InitialState, ParticleStart};
    let single = |d: f64| {
        let mut spec: SequenceSpec = monodisperse(1, None, false);
        spec.wall_material = chainsweep_solver::problems::STEEL;
        let start = ParticleStart {
            particle: 1,
            velocity_m_s: 0.0,
            displacement_m: d,
        };
        let mut s = Scene::excited(
            ChainSpec::Sequence(spec),
            Excitation::InitialState(InitialState {
                particles: vec![start],
                random_velocity: None,
            }),
            1.0,
        );
        s.physics = PhysicsSpec {
            gravity: false,
            wall: true,
            damping_kg_s: 0.0,
            precompression_force_n: 10.0,
            ..PhysicsSpec::default()
        };
        s.integrator = IntegratorSpec::Dop853(AdaptiveOptions::new(1e-13));
        s
    };
    let eps = [1e-3, 2e-3, 5e-3, 1e-2, 2e-2];
    let map = AutonomousMap::new(&single(eps[0] * 1e-6)).unwrap();
    let chain = map.chain();
    let (d0, m) = (chain.static_overlap[0], chain.mass[0]);
    let a = 10.0 / d0.powf(1.5);
    let w0 = (1.5 * a * d0.sqrt() / m).sqrt();
    let linear = LinearChain::of(chain)
        .unwrap()
        .spectrum(false)
        .angular_frequency_rad_s[0];
    assert!((w0 / linear - 1.0).abs() < 1e-12);
    let (a2, a3) = (
        3.0 * a / (8.0 * m * d0.sqrt()),
        -a / (16.0 * m * d0.powf(1.5)),
    );
    let kappa = 3.0 * a3 / (8.0 * w0) - 5.0 * a2 * a2 / (12.0 * w0.powi(3));
    assert!((kappa / (-w0 / (24.0 * d0 * d0)) - 1.0).abs() < 1e-12);
    // The orbit at the frequency where the normal form puts the amplitude ε δ₀, from a turning
    // point ε δ₀ towards the wall (each from its own guess: the orbit through the other turning
    // point, the same motion half a period on, is as near to a neighbour's).
    let orbits: Vec<_> = eps
        .iter()
        .map(|e| {
            let hz = w0 * (1.0 - e * e / 24.0) / std::f64::consts::TAU;
            let guess = [map.rest_positions()[0] + e * d0];
            map.shoot(&guess, 1.0 / hz, 1e-13, 30).unwrap()
        })
        .collect();
    let mut by_odd = Vec::new();
    for (o, &e) in orbits.iter().zip(&eps) {
        let shift = std::f64::consts::TAU * o.frequency_hz() - w0;
        let peak = o.positions[0] - map.rest_positions()[0];
        let odd = o.odd_part()[0];
        let error_peak = (shift - kappa * peak * peak) / shift;
        let error_odd = (shift - kappa * odd * odd) / shift;
        println!(
            "ε {e:.0e}: peak {:.6} δ0, shift error by the peak {error_peak:.4e} (ε/6 = {:.4e}), by the fundamental {error_odd:.3e} ({:.3} ε²); multipliers {:?}",
            peak / d0,
            e / 6.0,
            error_odd / (e * e),
            o.multipliers
        );
        assert!((peak / d0 / e - 1.0).abs() < 0.01, "{peak}");
        assert!(
            (error_peak / (e / 6.0) - 1.0).abs() < 0.05,
            "{error_peak:e} at {e}"
        );
        assert!(o.trivial_pair_error() < 1e-5, "{:?}", o.multipliers);
        by_odd.push((e, error_odd));
    }
    // Where the shift (ε²/24 of ω₀) stands far enough above the integration's error: the error
    // by the fundamental over ε² is the same constant to 5 % from ε = 5e-3 to 2e-2.
    let c: Vec<f64> = by_odd[2..].iter().map(|(e, x)| x / (e * e)).collect();
    assert!(
        c.iter().all(|x| (x / c[0] - 1.0).abs() < 0.05 && *x > 0.0),
        "{c:?}"
    );
}

/// A continuation stopped by its flag after some points, then resumed from its last accepted
/// point, gives bitwise the points, the kinds and the period-map counts of one that ran through;
/// a resumption from a located special point is refused.
#[test]
fn a_stopped_branch_resumes_from_its_last_point_bitwise() {
    use chainsweep_solver::periodic::{continue_branch_stoppable, resume_branch};
    use std::sync::atomic::{AtomicBool, Ordering};
    let stroke = 6e-8;
    let scene_at = move |f: f64| Ok(hertz_chain(stroke, f));
    let options = PeriodicOptions {
        settle_periods: 100,
        ..PeriodicOptions::default()
    };
    let branch_options = BranchOptions {
        step: Some(10.0),
        ..BranchOptions::new(3500.0)
    };
    let mut whole = Vec::new();
    let full = continue_branch(&scene_at, 2900.0, &options, &branch_options, &mut |p| {
        whole.push(p.clone())
    })
    .unwrap();
    assert!(whole.iter().any(|p| p.kind == PointKind::Fold));
    // Stopped once the first fold has been given: past it, the last accepted point is the one
    // stepped to after the fold.
    let stop = AtomicBool::new(false);
    let mut given = Vec::new();
    let first = continue_branch_stoppable(
        &scene_at,
        2900.0,
        &options,
        &branch_options,
        Some(&stop),
        &mut |p| {
            given.push(p.clone());
            if p.kind == PointKind::Fold {
                stop.store(true, Ordering::Relaxed);
            }
        },
    )
    .unwrap();
    assert!(
        first.stopped && first.end.contains("stopped"),
        "{}",
        first.end
    );
    let last = given
        .iter()
        .rev()
        .find(|p| !p.kind.is_special())
        .unwrap()
        .clone();
    // What a journal keeps: the points up to the last accepted one.
    given.truncate(given.iter().rposition(|p| !p.kind.is_special()).unwrap() + 1);
    let rest = resume_branch(
        &scene_at,
        2900.0,
        &options,
        &branch_options,
        &last,
        None,
        &mut |p| given.push(p.clone()),
    )
    .unwrap();
    assert!(!rest.stopped);
    assert_eq!(rest.end, full.end);
    assert_eq!(rest.maps, full.maps);
    assert_eq!(given.len(), whole.len());
    for (a, b) in given.iter().zip(&whole) {
        assert_eq!(a.kind, b.kind);
        assert_eq!(a.parameter.to_bits(), b.parameter.to_bits());
        assert_eq!(a.progress, b.progress);
        assert!(a
            .orbit
            .state
            .iter()
            .zip(&b.orbit.state)
            .all(|(x, y)| x.to_bits() == y.to_bits()));
    }
    let fold = whole.iter().find(|p| p.kind == PointKind::Fold).unwrap();
    let err = resume_branch(
        &scene_at,
        2900.0,
        &options,
        &branch_options,
        fold,
        None,
        &mut |_| {},
    )
    .unwrap_err();
    assert_eq!(err.field, "periodic");
}

/// A family of free orbits resumed after its first two orbits (as a sweep's journal resumes it)
/// is bitwise the family continued without a stop; a set stop flag stops it before any orbit;
/// a guess that Newton's method takes onto the static state (an orbit of every period) is
/// refused, not returned as an orbit.
#[test]
fn a_resumed_family_of_free_orbits_is_the_uninterrupted_one_and_the_static_state_is_refused() {
    let cells = 20;
    let (_, guess) = breather_guess(cells);
    let map = AutonomousMap::new(&dimer(cells, &guess)).unwrap();
    let frequencies = [35_830.0, 35_630.0, 35_430.0, 35_230.0, 35_030.0];
    let (whole, end) =
        continue_autonomous(&map, map.first_guess(), &frequencies, 1e-9, 30, &mut |_| {});
    assert!(end.is_none(), "{end:?}");
    // After the first two orbits, through the other three.
    let resume =
        |stop: Option<&std::sync::atomic::AtomicBool>,
         on_orbit: &mut dyn FnMut(&chainsweep_solver::periodic::AutonomousOrbit)| {
            resume_autonomous(
                &map,
                map.first_guess(),
                &whole[..2],
                &frequencies[2..],
                1e-9,
                30,
                stop,
                on_orbit,
            )
        };
    let mut seen = 0;
    let resumed = resume(None, &mut |_| seen += 1);
    assert!(!resumed.stopped && resumed.end.is_none() && seen == 3);
    for (a, b) in whole[2..].iter().zip(&resumed.orbits) {
        assert_eq!(a.positions, b.positions);
        assert_eq!(a.multipliers, b.multipliers);
        assert_eq!(a.period_s, b.period_s);
    }
    let stop = std::sync::atomic::AtomicBool::new(true);
    let stopped = resume(Some(&stop), &mut |_| {
        unreachable!("stopped before any orbit")
    });
    assert!(stopped.stopped && stopped.orbits.is_empty());
    // Far from any orbit of that frequency (a tenth of the amplitude, 0.8 of the band edge):
    // the breather's guess falls onto the static state.
    let small: Vec<(usize, f64)> = guess.iter().map(|&(p, d)| (p, 0.1 * d)).collect();
    let map = AutonomousMap::new(&dimer(cells, &small)).unwrap();
    match map.shoot(map.first_guess(), 1.0 / 29_000.0, 1e-9, 30) {
        Err(ShootingError::StaticState { motion }) => assert!(motion <= 1e-9, "{motion}"),
        other => panic!("{:?}", other.map(|o| o.positions)),
    }
}
