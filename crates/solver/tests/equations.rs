//! The fast right-hand side against a literal, slow transcription of the paper's Eqs. (2)–(12).

use chainsweep_solver::chain::model::{hertz_coefficient, Chain, ChainSpec, Material, PhysicsSpec};
use chainsweep_solver::integrate::OdeSystem;
use chainsweep_solver::motion::system::ChainSystem;

/// Deterministic pseudo-random numbers (xorshift) so failures reproduce.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
}

fn pos(z: f64) -> f64 {
    if z > 0.0 {
        z
    } else {
        0.0
    }
}

/// Eqs. (2)–(12) written out particle by particle, 1-based as in the paper, in terms of the static
/// displacements (u_{i,0}, υ_{i,0}) and dynamic displacements (u_i, υ_i). Returns accelerations.
#[allow(clippy::too_many_arguments)]
fn paper_accelerations(
    n_particles: usize,
    m_imp: f64,
    m_s: f64,
    m_c: f64,
    a: f64,
    a1: f64,
    a_wall: f64,
    mu: f64,
    mu1: f64,
    g: f64,
    static_pos: &[f64],
    dynamic: &[f64],
    vel: &[f64],
) -> Vec<f64> {
    let n = n_particles;
    let s0 = |i: usize| static_pos[i - 1];
    let u = |i: usize| dynamic[i - 1];
    let ud = |i: usize| vel[i - 1];
    let total = |i: usize| s0(i) + u(i);
    let mut acc = vec![0.0; n];
    // "When the particles are separated the viscous term is considered to be equal zero."
    let compressed = |i: usize| -> bool {
        if i == 1 {
            u(1) - u(2) > 0.0
        } else if i < n {
            total(i) - total(i + 1) > 0.0
        } else {
            total(n) > 0.0
        }
    };
    // Force on particle i+1 from the damper between i and i+1 (i = n: the wall).
    let visc = |i: usize, coef: f64| -> f64 {
        let below = if i < n { ud(i + 1) } else { 0.0 };
        if compressed(i) {
            coef * (ud(i) - below)
        } else {
            0.0
        }
    };
    // Eq. (5) with Eq. (8): the impactor.
    acc[0] = (-a1 * pos(u(1) - u(2)).powf(1.5) + m_imp * g - visc(1, mu1)) / m_imp;
    // Eq. (6) with Eq. (9): the first sphere.
    acc[1] = (a1 * pos(u(1) - u(2)).powf(1.5) - a * pos(total(2) - total(3)).powf(1.5)
        + m_s * g
        + visc(1, mu1)
        - visc(2, mu))
        / m_s;
    // Eqs. (2), (3) with (10), (11): cylinders 2i−1 and spheres 2i inside the chain.
    for p in 3..n {
        let m = if p % 2 == 1 { m_c } else { m_s };
        let f_above = a * pos(total(p - 1) - total(p)).powf(1.5);
        let f_below = a * pos(total(p) - total(p + 1)).powf(1.5);
        acc[p - 1] = (f_above - f_below + m * g + visc(p - 1, mu) - visc(p, mu)) / m;
    }
    // Eq. (7) with Eq. (12): the last sphere on the wall.
    acc[n - 1] = (a * pos(total(n - 1) - total(n)).powf(1.5) - a_wall * pos(total(n)).powf(1.5)
        + m_s * g
        + visc(n - 1, mu)
        - visc(n, mu))
        / m_s;
    acc
}

#[test]
fn fast_rhs_matches_literal_transcription_of_eqs_2_to_12() {
    let mut rng = Rng(0x9e3779b97f4a7c15);
    for trial in 0..200 {
        let cylinders = 1 + (rng.next() * 30.0) as usize;
        let mu = if trial % 3 == 0 {
            0.0
        } else {
            rng.range(0.5, 100.0)
        };
        let mu1 = if trial % 5 == 0 {
            mu
        } else {
            rng.range(0.0, 20.0)
        };
        let spec = if trial % 2 == 0 {
            ChainSpec::chain_098(cylinders)
        } else {
            ChainSpec::chain_055(cylinders)
        };
        let physics = PhysicsSpec {
            damping_kg_s: mu,
            striker_damping_kg_s: Some(mu1),
            ..PhysicsSpec::default()
        };
        let chain = Chain::build(&spec, &physics).unwrap();
        let n = chain.n_particles();
        // Random dynamic displacements of the size of a strong pulse: some contacts compressed far
        // beyond the preload, some opened.
        let dynamic: Vec<f64> = (0..n).map(|_| rng.range(-8e-6, 8e-6)).collect();
        let vel: Vec<f64> = (0..n).map(|_| rng.range(-1.5, 1.5)).collect();
        let mut y: Vec<f64> = (0..n)
            .map(|i| chain.equilibrium_position[i] + dynamic[i])
            .collect();
        y.extend(&vel);
        let damped = mu != 0.0 || mu1 != 0.0;
        y.extend(if damped { vec![0.0, 0.0] } else { vec![0.0] });
        let mut dy = vec![0.0; y.len()];
        if damped {
            ChainSystem::<true, true, true, false>::new(&chain).rhs(0.0, &y, &mut dy);
        } else {
            ChainSystem::<true, false, true, false>::new(&chain).rhs(0.0, &y, &mut dy);
        }

        let r = 4e-3;
        let a = hertz_coefficient(Material::STEEL_SS304, None, Material::STEEL_440C, Some(r));
        let a1 = hertz_coefficient(Material::STEEL_440C, Some(r), Material::STEEL_440C, Some(r));
        let dimer = spec.dimer().unwrap();
        let lit = paper_accelerations(
            n,
            dimer.striker.mass_kg,
            dimer.sphere.mass_kg,
            dimer.cylinder.mass_kg(dimer.sphere.mass_kg),
            a,
            a1,
            a,
            mu,
            mu1,
            9.81,
            &chain.equilibrium_position,
            &dynamic,
            &vel,
        );
        for i in 0..n {
            let scale = lit[i].abs().max(1e3);
            assert!(
                (dy[n + i] - lit[i]).abs() <= 1e-12 * scale,
                "trial {trial}, particle {}: fast {} vs literal {}",
                i + 1,
                dy[n + i],
                lit[i]
            );
            assert_eq!(dy[i], vel[i], "dx/dt must be the velocity");
        }
        if damped {
            // Dissipated power: Σ μ_j (Δv_j)² over compressed contacts, written out.
            let mut p = 0.0;
            for j in 0..n {
                let (overlap, dv) = if j + 1 < n {
                    (y[j] - y[j + 1], vel[j] - vel[j + 1])
                } else {
                    (y[j], vel[j])
                };
                let coef = if j == 0 { mu1 } else { mu };
                if overlap > 0.0 {
                    p += coef * dv * dv;
                }
            }
            assert!(
                (dy[2 * n] - p).abs() <= 1e-12 * p.abs().max(1e-3),
                "trial {trial}: power {} vs {p}",
                dy[2 * n]
            );
        }
    }
}

#[test]
fn hertz_coefficients_follow_eqs_1_4_5() {
    // Eq. (4): sphere on a flat, A = 4 E_c E_s R^{1/2} / (3 [E_s (1 − ν_c²) + E_c (1 − ν_s²)]).
    let (ec, nc, es, ns, r) = (193e9_f64, 0.29_f64, 200e9_f64, 0.28_f64, 4e-3_f64);
    let a4 = 4.0 * ec * es * r.sqrt() / (3.0 * (es * (1.0 - nc * nc) + ec * (1.0 - ns * ns)));
    let a = hertz_coefficient(Material::STEEL_SS304, None, Material::STEEL_440C, Some(r));
    assert!((a - a4).abs() < 1e-12 * a4);
    // Eq. (5): two equal spheres, (1/R + 1/R)^{-1/2} = (R/2)^{1/2}.
    let a5 = 4.0 * es * es * (2.0 / r).powf(-0.5)
        / (3.0 * (es * (1.0 - ns * ns) + es * (1.0 - ns * ns)));
    let a1 = hertz_coefficient(Material::STEEL_440C, Some(r), Material::STEEL_440C, Some(r));
    assert!((a1 - a5).abs() < 1e-12 * a5);
    // Against a hand computation for 440C on SS304, R = 4 mm: 9.01551e9 N/m^1.5.
    assert!((a / 9.01551e9 - 1.0).abs() < 1e-5, "A = {a}");
}

#[test]
fn static_equilibrium_balances_gravity_exactly() {
    let chain = Chain::build(&ChainSpec::chain_055(50), &PhysicsSpec::default()).unwrap();
    let n = chain.n_particles();
    let mut y = chain.equilibrium_position.clone();
    y.extend(vec![0.0; n]);
    y.push(0.0);
    let mut sys = ChainSystem::<true, false, true, false>::new(&chain);
    let mut dy = vec![0.0; y.len()];
    sys.rhs(0.0, &y, &mut dy);
    // The striker rests on sphere 2 with zero overlap, so it falls at g; every chain particle is
    // balanced to round-off.
    assert!((dy[n] - 9.81).abs() < 1e-12);
    for i in 1..n {
        assert!(
            dy[n + i].abs() < 1e-9 * 9.81,
            "particle {} accelerates at {}",
            i + 1,
            dy[n + i]
        );
    }
    // The wall carries the weight of the chain (particles 2..N).
    let weight: f64 = chain.mass[1..].iter().sum::<f64>() * 9.81;
    assert!((chain.static_force(n - 1) - weight).abs() < 1e-12 * weight);
}
