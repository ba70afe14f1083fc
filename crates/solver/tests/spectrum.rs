//! The linear spectrum at the static state against closed forms: a fixed–free monodisperse chain
//! under a static force, a diatomic chain's Bloch band edges, a damped oscillator; mode shapes
//! orthonormal in the mass inner product and solving `K v = ω² M v`; bad input refused naming the
//! field.

use chainsweep_solver::chain::model::{hertz_coefficient, Chain, PhysicsSpec};
use chainsweep_solver::chain::sequence::{RepeatBlock, SequenceItem, SequenceSpec};
use chainsweep_solver::contact::{DissipationSpec, LawSpec};
use chainsweep_solver::problems::{chain, monodisperse, power_law, repeat, rule, sphere, STEEL};
use chainsweep_solver::spectrum::{DampedMethod, LinearChain};
use chainsweep_solver::ChainSpec;

/// Gravity off, the wall on, a static force `f0` on the top particle.
fn precompressed(f0: f64) -> PhysicsSpec {
    PhysicsSpec {
        gravity: false,
        precompression_force_n: f0,
        ..PhysicsSpec::default()
    }
}

fn linear(spec: SequenceSpec, physics: &PhysicsSpec) -> LinearChain {
    LinearChain::of(&Chain::build(&ChainSpec::Sequence(spec), physics).unwrap()).unwrap()
}

/// The Hertz coefficient of two 8 mm 440C spheres, the law of every pair and of the wall.
fn hertz_a() -> f64 {
    hertz_coefficient(STEEL, Some(4e-3), STEEL, Some(4e-3))
}

#[test]
fn fixed_free_chain_matches_the_closed_form() {
    // N particles under F0 at the top on a wall whose law is the pairs': every contact has
    // K = (3/2) A^{2/3} F0^{1/3}, and ω_j = 2 √(K/m) sin((2j − 1)π/(2(2N + 1))).
    let (a, m) = (hertz_a(), 2.085e-3);
    for n in [10, 100, 1000] {
        for f0 in [0.1, 10.0, 1000.0] {
            let lin = linear(
                monodisperse(n, Some(power_law(a, 1.5)), false),
                &precompressed(f0),
            );
            let k = 1.5 * a.powf(2.0 / 3.0) * f0.powf(1.0 / 3.0);
            let omega = lin.spectrum(false).angular_frequency_rad_s;
            assert_eq!(omega.len(), n);
            let mut worst = 0.0f64;
            for (j, w) in omega.iter().enumerate() {
                let theta = (2 * j + 1) as f64 * std::f64::consts::PI / (2 * (2 * n + 1)) as f64;
                let exact = 2.0 * (k / m).sqrt() * theta.sin();
                worst = worst.max((w / exact - 1.0).abs());
            }
            println!("N = {n}, F0 = {f0} N: largest relative error {worst:.2e}");
            assert!(worst < 1e-8, "N = {n}, F0 = {f0}: {worst}");
        }
    }
}

#[test]
fn frequencies_follow_the_sixth_root_of_the_force() {
    let (a, n) = (hertz_a(), 50);
    let at = |f0: f64| {
        linear(
            monodisperse(n, Some(power_law(a, 1.5)), false),
            &precompressed(f0),
        )
        .spectrum(false)
        .angular_frequency_rad_s
    };
    let (w1, w2) = (at(1.0), at(64.0));
    for (x, y) in w1.iter().zip(&w2) {
        assert!((y / x / 2.0 - 1.0).abs() < 1e-12, "{x} {y}");
    }
}

/// Sum over rows of `|K v − ω² M v|` against `‖K‖ ‖v‖`, both max norms.
fn residual(lin: &LinearChain, w: f64, v: &[f64]) -> f64 {
    let n = lin.len();
    let k = |i: usize| {
        if i + 1 < n {
            lin.stiffness[i]
        } else {
            lin.wall_stiffness
        }
    };
    let k_norm = (0..n)
        .map(|i| 2.0 * (if i > 0 { lin.stiffness[i - 1] } else { 0.0 }) + 2.0 * k(i))
        .fold(0.0, f64::max);
    let v_norm = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let mut worst = 0.0f64;
    for i in 0..n {
        let above = if i > 0 { lin.stiffness[i - 1] } else { 0.0 };
        let mut kv = (above + k(i)) * v[i];
        if i > 0 {
            kv -= above * v[i - 1];
        }
        if i + 1 < n {
            kv -= lin.stiffness[i] * v[i + 1];
        }
        worst = worst.max((kv - w * w * lin.mass[i] * v[i]).abs());
    }
    worst / (k_norm * v_norm)
}

#[test]
fn mode_shapes_are_mass_orthonormal_eigenvectors() {
    // A gravity-loaded, precompressed dimer of unequal spheres: unequal masses and stiffnesses.
    let spec = chain(
        &[
            ("big", sphere(STEEL, 8e-3, 2.085e-3)),
            ("small", sphere(STEEL, 5e-3, 0.51e-3)),
        ],
        vec![SequenceItem::Repeat(RepeatBlock {
            repeat: 150,
            of: vec![
                SequenceItem::Type("big".into()),
                SequenceItem::Type("small".into()),
            ],
        })],
        None,
        vec![],
    );
    let physics = PhysicsSpec {
        precompression_force_n: 5.0,
        ..PhysicsSpec::default()
    };
    let lin = linear(spec, &physics);
    let n = lin.len();
    let s = lin.spectrum(true);
    let modes = s.modes.as_ref().unwrap();
    let (mut worst_res, mut worst_orth) = (0.0f64, 0.0f64);
    for j in 0..n {
        let v = &modes[j * n..(j + 1) * n];
        worst_res = worst_res.max(residual(&lin, s.angular_frequency_rad_s[j], v));
        for l in 0..=j {
            let u = &modes[l * n..(l + 1) * n];
            let d: f64 = (0..n).map(|i| u[i] * lin.mass[i] * v[i]).sum();
            let want = if l == j { 1.0 } else { 0.0 };
            worst_orth = worst_orth.max((d - want).abs());
        }
    }
    println!("N = {n}: residual {worst_res:.2e}, M-orthonormality {worst_orth:.2e}");
    assert!(worst_res < 1e-10, "{worst_res}");
    assert!(worst_orth < 1e-10, "{worst_orth}");
    // A range of the spectrum is the same numbers.
    let part = lin.spectrum_range(10, 5, false).angular_frequency_rad_s;
    assert_eq!(&part[..], &s.angular_frequency_rad_s[10..15]);
}

/// A diatomic chain of `cells` × [heavy, light] under `f0`, every contact the same law.
fn diatomic(cells: usize, m_heavy: f64, m_light: f64, f0: f64) -> LinearChain {
    let law = Some(power_law(hertz_a(), 1.5));
    let spec = chain(
        &[
            ("heavy", sphere(STEEL, 8e-3, m_heavy)),
            ("light", sphere(STEEL, 8e-3, m_light)),
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
    linear(spec, &precompressed(f0))
}

#[test]
fn diatomic_band_edges_match_the_closed_form() {
    for (m1, m2) in [(2.085e-3, 0.6e-3), (1e-3, 0.999e-3), (5e-3, 0.1e-3)] {
        for f0 in [0.5, 20.0] {
            let lin = diatomic(20, m1, m2, f0);
            let k = 1.5 * hertz_a().powf(2.0 / 3.0) * f0.powf(1.0 / 3.0);
            let cell = lin.unit_cell(2, "record.spectrum.cell_particles").unwrap();
            let bands = cell.bands();
            let acoustic_top = (2.0 * k / m1).sqrt();
            let optical_bottom = (2.0 * k / m2).sqrt();
            let optical_top = (2.0 * k * (1.0 / m1 + 1.0 / m2)).sqrt();
            let rel = |x: f64, y: f64| (x / y - 1.0).abs();
            assert!(bands[0].lower_rad_s.abs() < 1e-6 * acoustic_top);
            for (got, want) in [
                (bands[0].upper_rad_s, acoustic_top),
                (bands[1].lower_rad_s, optical_bottom),
                (bands[1].upper_rad_s, optical_top),
            ] {
                assert!(rel(got, want) < 1e-8, "{m1} {m2} {f0}: {got} vs {want}");
            }
            let gaps = cell.gaps();
            assert_eq!(gaps.len(), 1);
            assert!(rel(gaps[0].0, acoustic_top) < 1e-8 && rel(gaps[0].1, optical_bottom) < 1e-8);
            // The finite chain's frequencies lie in the bands (the wall adds no defect mode here:
            // its law is the pairs').
            let top = lin.spectrum(false).angular_frequency_rad_s;
            assert!(*top.last().unwrap() <= optical_top * (1.0 + 1e-12));
        }
    }
}

#[test]
fn damped_single_oscillator() {
    // One sphere on the wall under F0 with a linear viscous contact (behind a striker, which is
    // left out of the static chain): ω = √(k/m), ζ = c/(2√(km)), λ = −ζω ± iω√(1 − ζ²).
    let (a, m, f0) = (hertz_a(), 2.085e-3, 10.0);
    for mu in [0.5, 5.0, 50.0] {
        let spec = chain(
            &[("ball", sphere(STEEL, 8e-3, m))],
            vec![repeat(1, "ball")],
            Some("ball"),
            vec![rule(
                "ball",
                "wall",
                Some(power_law(a, 1.5)),
                Some(DissipationSpec::LinearViscous { damping_kg_s: mu }),
            )],
        );
        let lin = linear(spec, &precompressed(f0));
        assert_eq!(lin.len(), 1);
        let k = 1.5 * a.powf(2.0 / 3.0) * f0.powf(1.0 / 3.0);
        let w = (k / m).sqrt();
        let zeta = mu / (2.0 * (k * m).sqrt());
        assert!(zeta < 1.0);
        let (re, im) = (-zeta * w, w * (1.0 - zeta * zeta).sqrt());
        let (modal, method) = lin.damped_eigenvalues("spectrum").unwrap();
        assert_eq!(method, DampedMethod::Proportional);
        let dense = lin.companion_eigenvalues("spectrum").unwrap();
        assert_eq!(dense.len(), 2);
        let mut dense = dense;
        dense.sort_by(|x, y| x.im.total_cmp(&y.im));
        for got in [&modal, &dense] {
            assert!((got[0].re / re - 1.0).abs() < 1e-12 && (got[1].re / re - 1.0).abs() < 1e-12);
            assert!((got[0].im / -im - 1.0).abs() < 1e-12 && (got[1].im / im - 1.0).abs() < 1e-12);
        }
    }
}

#[test]
fn damped_chains_proportional_and_not() {
    // Kuwabara–Kono damping is τ dF/dt: c = τ k on every contact, proportional whatever the
    // loads; the dense solve agrees with the modal one.
    let spec = monodisperse(40, None, false);
    let physics = PhysicsSpec {
        precompression_force_n: 3.0,
        dissipation: Some(DissipationSpec::KuwabaraKono {
            relaxation_time_s: 2e-6,
        }),
        ..PhysicsSpec::default()
    };
    let lin = linear(spec.clone(), &physics);
    let (modal, method) = lin.damped_eigenvalues("spectrum").unwrap();
    assert_eq!(method, DampedMethod::Proportional);
    let mut dense = lin.companion_eigenvalues("spectrum").unwrap();
    dense.sort_by(|x, y| x.im.total_cmp(&y.im).then(y.re.total_cmp(&x.re)));
    let scale = modal.iter().fold(0.0f64, |m, l| m.max(l.im.abs()));
    for (x, y) in modal.iter().zip(&dense) {
        assert!(
            (x.re - y.re).abs() < 1e-11 * scale && (x.im - y.im).abs() < 1e-11 * scale,
            "{x:?} {y:?}"
        );
    }
    // Linear viscous damping under gravity: the stiffnesses grow down the chain, the damping
    // does not, so it is not proportional. The companion's eigenvalues keep the invariants
    // Σ λ = −tr(M⁻¹C) and Π |λ| = det(M⁻¹K) = Π ω_j², and every mode decays.
    let physics = PhysicsSpec {
        damping_kg_s: 3.0,
        ..PhysicsSpec::default()
    };
    let lin = linear(spec, &physics);
    let (lambda, method) = lin.damped_eigenvalues("spectrum").unwrap();
    assert_eq!(method, DampedMethod::Companion);
    assert_eq!(lambda.len(), 80);
    let n = lin.len();
    let trace: f64 = (0..n)
        .map(|i| {
            let above = if i > 0 { lin.damping[i - 1] } else { 0.0 };
            let below = if i + 1 < n {
                lin.damping[i]
            } else {
                lin.wall_damping
            };
            (above + below) / lin.mass[i]
        })
        .sum();
    let sum_re: f64 = lambda.iter().map(|l| l.re).sum();
    let sum_im: f64 = lambda.iter().map(|l| l.im).sum();
    assert!((sum_re / -trace - 1.0).abs() < 1e-10, "{sum_re} {trace}");
    assert!(sum_im.abs() < 1e-9 * scale);
    let log_det: f64 = lambda.iter().map(|l| l.re.hypot(l.im).ln()).sum();
    let log_w2: f64 = lin
        .spectrum(false)
        .angular_frequency_rad_s
        .iter()
        .map(|w| 2.0 * w.ln())
        .sum();
    assert!(
        (log_det - log_w2).abs() < 1e-9 * log_w2.abs(),
        "{log_det} {log_w2}"
    );
    assert!(lambda.iter().all(|l| l.re < 0.0));
    // Beyond the dense limit the error names the field.
    let big = linear(monodisperse(300, None, false), &physics);
    let err = big.damped_eigenvalues("damped").unwrap_err();
    assert_eq!(err.field, "damped");
    assert!(err.message.contains("200"), "{err}");
}

#[test]
fn bad_input_is_refused_naming_the_field() {
    // No static compression: no gravity, no precompression.
    let spec = monodisperse(10, None, false);
    let physics = PhysicsSpec {
        gravity: false,
        ..PhysicsSpec::default()
    };
    let chain0 = Chain::build(&ChainSpec::Sequence(spec.clone()), &physics).unwrap();
    let err = LinearChain::of(&chain0).unwrap_err();
    assert_eq!(err.field, "physics.precompression_force_n", "{err}");
    // No wall: nothing holds the chain.
    let physics = PhysicsSpec {
        wall: false,
        ..PhysicsSpec::default()
    };
    let chain0 = Chain::build(&ChainSpec::Sequence(spec.clone()), &physics).unwrap();
    assert_eq!(LinearChain::of(&chain0).unwrap_err().field, "physics.wall");
    // A unit cell that is not periodic: a monodisperse chain under gravity (the loads grow down
    // the chain), a dimer asked for a cell of 3, a cell longer than half the chain.
    let lin = linear(spec, &PhysicsSpec::default());
    let err = lin
        .unit_cell(1, "record.spectrum.cell_particles")
        .unwrap_err();
    assert_eq!(err.field, "record.spectrum.cell_particles");
    assert!(err.message.contains("not periodic"), "{err}");
    let dimer = diatomic(10, 2e-3, 1e-3, 1.0);
    assert!(dimer.unit_cell(2, "cell").is_ok());
    assert!(dimer
        .unit_cell(3, "cell")
        .unwrap_err()
        .message
        .contains("not periodic"));
    assert!(dimer.unit_cell(11, "cell").is_err());
    assert!(dimer.unit_cell(0, "cell").is_err());
    // Hertz between unequal laws: the striker is left out of the spectrum.
    let struck = Chain::build(
        &ChainSpec::Sequence(monodisperse(10, None, true)),
        &precompressed(1.0),
    )
    .unwrap();
    let lin = LinearChain::of(&struck).unwrap();
    assert_eq!((lin.first_particle, lin.len()), (1, 10));
}

#[test]
fn law_for_any_exponent_uses_the_contact_derivative() {
    // A linear law (n = 1): k = A at any load; a power law n: k = n A δ0^{n−1}.
    for (n, a) in [(1.0, 2e7), (2.5, 4e15)] {
        let lin = linear(
            monodisperse(
                5,
                Some(LawSpec::PowerLaw {
                    coefficient: a,
                    exponent: n,
                }),
                false,
            ),
            &precompressed(7.0),
        );
        let delta0 = (7.0f64 / a).powf(1.0 / n);
        let k = n * a * delta0.powf(n - 1.0);
        for &got in lin.stiffness.iter().chain([&lin.wall_stiffness]) {
            assert!((got / k - 1.0).abs() < 1e-12, "{got} {k}");
        }
    }
}
