//! The built chain against the closed forms of `docs/MODEL.md`: every expected value is computed
//! here from the paper's numbers (masses, moduli, radii), never read back from the code under
//! test, so that a change in how a chain is built shows up as a number that no longer agrees.

use super::*;
use crate::chain::sequence::{CylinderType, ParticleType, SequenceItem};
use crate::contact::DissipationSpec;
use crate::problems::{chain, repeat, sphere, STEEL};

/// 440C steel of the spheres and the striker: E, ν.
const E_S: f64 = 200e9;
const NU_S: f64 = 0.28;
/// SS304 steel of the cylinders and the default wall: E, ν.
const E_C: f64 = 193e9;
const NU_C: f64 = 0.29;
/// The paper's sphere: radius (8 mm diameter) and mass.
const R_S: f64 = 4e-3;
const M_S: f64 = 2.085e-3;
/// Standard gravity, m/s².
const G: f64 = 9.81;

/// Eq. (1) (Eq. (5) for the striker): `4 E₁E₂ / (3 [E₁(1−ν₂²) + E₂(1−ν₁²)]) · √(R₁R₂/(R₁+R₂))`.
fn hertz_two_spheres(e1: f64, nu1: f64, r1: f64, e2: f64, nu2: f64, r2: f64) -> f64 {
    4.0 * e1 * e2 / (3.0 * (e1 * (1.0 - nu2 * nu2) + e2 * (1.0 - nu1 * nu1)))
        * (r1 * r2 / (r1 + r2)).sqrt()
}

/// Eq. (4), a sphere on a flat (a cylinder's face or a wall):
/// `4 E_C E_S √R_S / (3 [E_S(1−ν_C²) + E_C(1−ν_S²)])`.
fn hertz_sphere_on_flat(e_flat: f64, nu_flat: f64, e_s: f64, nu_s: f64, r_s: f64) -> f64 {
    4.0 * e_flat * e_s * r_s.sqrt()
        / (3.0 * (e_s * (1.0 - nu_flat * nu_flat) + e_flat * (1.0 - nu_s * nu_s)))
}

/// The overlap at which a Hertz contact of coefficient `a` carries `force`: `(F/A)^{2/3}`.
fn hertz_overlap(force: f64, a: f64) -> f64 {
    ((force / a) * (force / a)).cbrt()
}

#[track_caller]
fn assert_close(actual: f64, expected: f64, rel: f64, what: &str) {
    assert!(
        (actual - expected).abs() <= rel * expected.abs(),
        "{what}: {actual:e}, expected {expected:e} (relative difference {:e})",
        (actual - expected).abs() / expected.abs()
    );
}

fn build(spec: impl Into<ChainSpec>, physics: &PhysicsSpec) -> Chain {
    Chain::build(&spec.into(), physics).unwrap()
}

fn one(name: &str) -> SequenceItem {
    SequenceItem::Type(name.to_string())
}

#[test]
fn presets_have_the_papers_masses_and_numbering() {
    for (spec, m_c, h) in [
        (DimerSpec::chain_055(5), 3.77e-3, 9.6e-3),
        (DimerSpec::chain_098(5), 2.043e-3, 5.3e-3),
    ] {
        let chain = build(spec, &PhysicsSpec::default());
        // N = 2n + 2 particles, and with the wall as many contacts.
        assert_eq!((chain.n_particles(), chain.n_contacts()), (12, 12));
        for p in 1..=12 {
            let (kind, mass) = match p {
                1 => (ParticleKind::Striker, M_S),
                p if p % 2 == 0 => (ParticleKind::Sphere, M_S),
                _ => (ParticleKind::Cylinder, m_c),
            };
            assert_eq!(
                (chain.kind[p - 1], chain.mass[p - 1]),
                (kind, mass),
                "particle {p}"
            );
        }
        // Cylinder k is particle 2k + 1 (index 2k).
        assert_eq!(chain.cylinders(), vec![2, 4, 6, 8, 10]);
        // The cell is a cylinder's height and a sphere's diameter, the distance between the
        // centres of two spheres either side of a cylinder.
        assert_eq!(chain.cell_length_m, Some(h + 8e-3));
        assert_close(chain.center_distance_m(1, 3), h + 8e-3, 1e-15, "cell");
        // Striker, first sphere, first cylinder: 1.5 d + h/2 from the striker's centre.
        assert_close(
            chain.center_distance_m(2, 0),
            1.5 * 8e-3 + 0.5 * h,
            1e-15,
            "centres",
        );
        assert!(chain.striker && chain.is_paper_physics());
    }
}

#[test]
fn mass_ratio_conventions_set_the_cylinder_mass_and_its_height() {
    let ratio = 0.4;
    for (mass, expected) in [
        (
            CylinderMass::HeavyCylinders { mass_ratio: ratio },
            M_S / ratio,
        ),
        (
            CylinderMass::LightCylinders { mass_ratio: ratio },
            ratio * M_S,
        ),
        (CylinderMass::Explicit { mass_kg: 5e-3 }, 5e-3),
    ] {
        let mut spec = DimerSpec::chain_055(3);
        spec.cylinder.mass = mass;
        spec.cylinder.height_m = None;
        let chain = build(spec, &PhysicsSpec::default());
        assert_close(chain.mass[2], expected, 1e-15, &format!("{mass:?}"));
        // No height given: the one its mass has at the tall cylinder's density, 7813 kg/m³.
        let height = expected / (7813.0 * std::f64::consts::PI * 4e-3 * 4e-3);
        let Shape::Cylinder {
            diameter_m,
            height_m,
        } = chain.shape[2]
        else {
            panic!("particle 3 is a cylinder")
        };
        assert_eq!(diameter_m, 8e-3);
        assert_close(height_m, height, 1e-14, &format!("height, {mass:?}"));
    }
}

#[test]
fn hertz_coefficients_are_those_of_eqs_1_4_and_5() {
    let chain = build(DimerSpec::chain_055(4), &PhysicsSpec::default());
    // Striker on the first sphere (Eq. 5), equal spheres: effective radius R/2, and the
    // coefficient reduces to (2E/(3(1 − ν²))) √(R/2).
    let striker = hertz_two_spheres(E_S, NU_S, R_S, E_S, NU_S, R_S);
    assert_close(
        striker,
        2.0 * E_S / (3.0 * (1.0 - NU_S * NU_S)) * (0.5 * R_S).sqrt(),
        1e-15,
        "Eq. 5 for equal spheres",
    );
    assert_close(chain.stiffness[0], striker, 1e-14, "striker contact");
    // Every sphere–cylinder contact, and the last sphere on the default SS304 wall (Eq. 7 uses
    // the same A): Eq. (4).
    let face = hertz_sphere_on_flat(E_C, NU_C, E_S, NU_S, R_S);
    for c in 1..chain.n_contacts() {
        assert_close(
            chain.stiffness[c],
            face,
            1e-14,
            &format!("contact {}", c + 1),
        );
    }
    assert!(chain.exponent.iter().all(|&n| n == 1.5));
    // A softer wall changes the wall's contact alone.
    let aluminium = Material {
        youngs_modulus_pa: 7e10,
        poisson_ratio: 0.33,
    };
    let mut spec = DimerSpec::chain_055(4);
    spec.wall_material = aluminium;
    let soft = build(spec, &PhysicsSpec::default());
    let last = soft.n_contacts() - 1;
    assert_close(
        soft.stiffness[last],
        hertz_sphere_on_flat(7e10, 0.33, E_S, NU_S, R_S),
        1e-14,
        "soft wall",
    );
    assert_eq!(soft.stiffness[..last], chain.stiffness[..last]);
    // Without the wall the last sphere has no contact below it.
    let free = build(
        DimerSpec::chain_055(4),
        &PhysicsSpec {
            wall: false,
            ..PhysicsSpec::default()
        },
    );
    assert_eq!(free.stiffness[..], chain.stiffness[..last]);
}

#[test]
fn the_static_state_carries_the_weight_above_each_contact() {
    // chain_055(3): striker, then sphere, cylinder, … , the last sphere on the wall.
    let m_c = 3.77e-3;
    let masses = [M_S, M_S, m_c, M_S, m_c, M_S, m_c, M_S];
    let face = hertz_sphere_on_flat(E_C, NU_C, E_S, NU_S, R_S);
    for precompression in [0.0, 5.0] {
        let physics = PhysicsSpec {
            precompression_force_n: precompression,
            ..PhysicsSpec::default()
        };
        let chain = build(DimerSpec::chain_055(3), &physics);
        // The striker touches the first sphere without overlap; contact j (1-based, j ≥ 2)
        // carries the precompression and the weight of the chain particles 2..=j above it.
        let mut expected = [0.0; 8];
        for j in 1..8 {
            let load = precompression + G * masses[1..=j].iter().sum::<f64>();
            expected[j] = hertz_overlap(load, face);
            assert_close(chain.static_force(j), load, 1e-12, "static force");
        }
        for (c, (&got, &want)) in chain.static_overlap.iter().zip(&expected).enumerate() {
            if want == 0.0 {
                assert_eq!(got, 0.0, "contact {}", c + 1);
            } else {
                assert_close(got, want, 1e-12, &format!("overlap of contact {}", c + 1));
            }
        }
        // Positions from the undeformed chain touching the wall: x_N = δ_N, x_j = x_{j+1} + δ_j.
        let mut x = 0.0;
        for i in (0..8).rev() {
            x += expected[i];
            assert_close(
                chain.equilibrium_position[i],
                x,
                1e-12,
                &format!("position of particle {}", i + 1),
            );
        }
    }
    // Without gravity and precompression nothing is loaded.
    let weightless = build(
        DimerSpec::chain_055(3),
        &PhysicsSpec {
            gravity: false,
            ..PhysicsSpec::default()
        },
    );
    assert!(weightless.static_overlap.iter().all(|&d| d == 0.0));
    assert_eq!(weightless.gravity_m_s2, 0.0);
}

#[test]
fn dissipation_coefficients_follow_each_contacts_law_and_bodies() {
    let spec = || DimerSpec::chain_055(3);
    let face = hertz_sphere_on_flat(E_C, NU_C, E_S, NU_S, R_S);
    let striker = hertz_two_spheres(E_S, NU_S, R_S, E_S, NU_S, R_S);
    let law = |c: usize| if c == 0 { striker } else { face };
    // The paper's linear term: μ₁ on the striker's contact, μ on every other one.
    let viscous = build(
        spec(),
        &PhysicsSpec {
            damping_kg_s: 6.0,
            striker_damping_kg_s: Some(2.0),
            ..PhysicsSpec::default()
        },
    );
    assert_eq!(
        viscous.damping,
        vec![2.0, 6.0, 6.0, 6.0, 6.0, 6.0, 6.0, 6.0]
    );
    assert!(viscous.has_damping() && viscous.is_paper_physics());
    // Kuwabara–Kono: γ = τ n A.
    let tau = 1e-6;
    let kk = build(
        spec(),
        &PhysicsSpec {
            dissipation: Some(DissipationSpec::KuwabaraKono {
                relaxation_time_s: tau,
            }),
            ..PhysicsSpec::default()
        },
    );
    for c in 0..kk.n_contacts() {
        assert_close(kk.viscoelastic_damping[c], tau * 1.5 * law(c), 1e-14, "γ");
        assert_eq!(kk.damping[c], 0.0);
    }
    assert!(!kk.is_paper_physics());
    // Tsuji: β = α √(m* A), one α for every contact (it depends on e and n alone) and m* the
    // reduced mass of the contact's two bodies, the last sphere's own mass at the wall.
    let tsuji = build(
        spec(),
        &PhysicsSpec {
            dissipation: Some(DissipationSpec::Tsuji { restitution: 0.8 }),
            ..PhysicsSpec::default()
        },
    );
    let m_c = 3.77e-3;
    let masses = [M_S, M_S, m_c, M_S, m_c, M_S, m_c, M_S];
    let alpha = crate::contact::tsuji_alpha(0.8, 1.5, false);
    for c in 0..tsuji.n_contacts() {
        let reduced = match masses.get(c + 1) {
            Some(&below) => masses[c] * below / (masses[c] + below),
            None => masses[c],
        };
        assert_close(
            tsuji.tsuji_damping[c],
            alpha * (reduced * law(c)).sqrt(),
            1e-14,
            &format!("β of contact {}", c + 1),
        );
    }
}

#[test]
fn the_state_lays_out_each_quadrature_after_the_motion() {
    // chain_055(2): N = 6 particles, positions 0..6, velocities 6..12.
    let with = |damping_kg_s: f64, wall: bool| {
        build(
            DimerSpec::chain_055(2),
            &PhysicsSpec {
                damping_kg_s,
                wall,
                ..PhysicsSpec::default()
            },
        )
    };
    let plain = with(0.0, true);
    assert_eq!(
        (
            plain.work_index(),
            plain.wall_impulse_index(),
            plain.state_len()
        ),
        (None, Some(12), 13)
    );
    let damped = with(6.0, true);
    assert_eq!(
        (
            damped.work_index(),
            damped.wall_impulse_index(),
            damped.state_len()
        ),
        (Some(12), Some(13), 14)
    );
    let pulsed = with(6.0, true).with_force_pulse(10.0, 1e-5);
    assert_eq!(
        (pulsed.external_work_index(), pulsed.state_len()),
        (Some(14), 15)
    );
    let free = with(0.0, false);
    assert_eq!((free.wall_impulse_index(), free.state_len()), (None, 12));
    // At rest in its static state, the striker moving at v0, nothing accumulated yet.
    let y = damped.initial_state(1.3);
    assert_eq!(y[..6], damped.equilibrium_position[..]);
    assert_eq!(y[6..], [1.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
}

#[test]
fn the_contact_map_of_a_mixed_sequence_joins_neighbours_then_the_walls() {
    let aluminium = Material {
        youngs_modulus_pa: 7e10,
        poisson_ratio: 0.33,
    };
    let top = Material {
        youngs_modulus_pa: 1.1e11,
        poisson_ratio: 0.3,
    };
    let cylinder = ParticleType::Cylinder(CylinderType {
        material: Material::STEEL_SS304,
        diameter_m: 6e-3,
        height_m: 5e-3,
        mass_kg: Some(1e-3),
        density_kg_m3: None,
    });
    // A 10 mm steel sphere, a 6 mm aluminium one, a cylinder, another small sphere on the wall,
    // and a wall at the top pressed onto the big sphere with 2 N.
    let mut spec = chain(
        &[
            ("big", sphere(STEEL, 10e-3, 4e-3)),
            ("small", sphere(aluminium, 6e-3, 0.3e-3)),
            ("cyl", cylinder),
        ],
        vec![one("big"), one("small"), one("cyl"), one("small")],
        None,
        Vec::new(),
    );
    spec.top_wall_material = Some(top);
    let force = 2.0;
    let physics = PhysicsSpec {
        gravity: false,
        precompression_force_n: force,
        ..PhysicsSpec::default()
    };
    let chain = build(ChainSpec::Sequence(spec.clone()), &physics);
    let n = 4;
    assert_eq!((chain.n_particles(), chain.n_contacts()), (n, 5));
    // Contacts 1–3 join neighbours, 4 is the small sphere on the SS304 wall, 5 the top wall
    // on the big sphere.
    let laws = [
        hertz_two_spheres(E_S, NU_S, 5e-3, 7e10, 0.33, 3e-3),
        hertz_sphere_on_flat(E_C, NU_C, 7e10, 0.33, 3e-3),
        hertz_sphere_on_flat(E_C, NU_C, 7e10, 0.33, 3e-3),
        hertz_sphere_on_flat(E_C, NU_C, 7e10, 0.33, 3e-3),
        hertz_sphere_on_flat(1.1e11, 0.3, E_S, NU_S, 5e-3),
    ];
    for (c, &a) in laws.iter().enumerate() {
        assert_close(chain.stiffness[c], a, 1e-14, &format!("contact {}", c + 1));
    }
    // The top wall carries the precompression through every contact to the wall below.
    let overlaps: Vec<f64> = laws.iter().map(|&a| hertz_overlap(force, a)).collect();
    let x0: f64 = overlaps[..n].iter().sum();
    let top_wall = chain.top_wall_m.expect("a top wall");
    assert_close(top_wall, x0 + overlaps[4], 1e-12, "top wall position");

    let map = ContactMap::of(&chain);
    for c in 0..n - 1 {
        assert_eq!(map.between(c), Some(([c, c + 1], [n + c, n + c + 1])));
    }
    assert_eq!((map.between(n - 1), map.between(n)), (None, None));
    let wall = ContactEnds {
        above: Some(n - 1),
        below: None,
        offset: 0.0,
        wall_state: None,
    };
    let top_ends = ContactEnds {
        above: None,
        below: Some(0),
        offset: top_wall,
        wall_state: None,
    };
    assert_eq!(map.ends(), [wall, top_ends]);
    assert_eq!(
        (chain.contact_ends(n - 1), chain.contact_ends(n)),
        (wall, top_ends)
    );
    // Overlaps and rates read from a state: x_a − x_b between neighbours, the last particle's
    // own position on the wall, the top wall's position less the first particle's.
    let mut y = vec![0.0; chain.state_len()];
    let (x, v) = ([3e-5, 2e-5, 1.5e-5, 4e-6], [0.3, -0.2, 0.1, 0.05]);
    y[..n].copy_from_slice(&x);
    y[n..2 * n].copy_from_slice(&v);
    let expected = [
        (x[0] - x[1], v[0] - v[1]),
        (x[1] - x[2], v[1] - v[2]),
        (x[2] - x[3], v[2] - v[3]),
        (x[3], v[3]),
        (top_wall - x[0], -v[0]),
    ];
    for (c, &(overlap, rate)) in expected.iter().enumerate() {
        assert_eq!(
            map.kinematics(c, |i| y[i]),
            (overlap, rate),
            "contact {}",
            c + 1
        );
        assert_eq!(map.overlap(c, &y), overlap, "contact {}", c + 1);
    }

    // On a mounted wall the wall's contact reads the mount's displacement: x_N − u.
    spec.top_wall_material = None;
    spec.wall_mount = Some(WallMount {
        mass_kg: 0.1,
        stiffness_n_m: 1e6,
        damping_kg_s: 0.0,
    });
    let mounted = build(
        ChainSpec::Sequence(spec),
        &PhysicsSpec {
            gravity: false,
            ..PhysicsSpec::default()
        },
    );
    let u = mounted.mount_state_index().expect("a mount");
    assert_eq!(u, mounted.state_len() - 2);
    let map = ContactMap::of(&mounted);
    assert_eq!(map.ends()[0].wall_state, Some(u));
    let mut y = vec![0.0; mounted.state_len()];
    y[..n].copy_from_slice(&x);
    y[n..2 * n].copy_from_slice(&v);
    (y[u], y[u + 1]) = (1e-6, 0.02);
    assert_eq!(map.kinematics(n - 1, |i| y[i]), (x[3] - 1e-6, v[3] - 0.02));
}

#[test]
fn a_rings_closing_contact_joins_the_last_particle_to_the_first() {
    let mut spec = chain(
        &[("ball", sphere(STEEL, 8e-3, M_S))],
        vec![repeat(4, "ball")],
        None,
        Vec::new(),
    );
    spec.ring = true;
    let physics = PhysicsSpec {
        gravity: false,
        wall: false,
        ..PhysicsSpec::default()
    };
    let ring = build(ChainSpec::Sequence(spec), &physics);
    assert_eq!((ring.n_particles(), ring.n_contacts()), (4, 4));
    let equal = hertz_two_spheres(E_S, NU_S, R_S, E_S, NU_S, R_S);
    for c in 0..4 {
        assert_close(
            ring.stiffness[c],
            equal,
            1e-14,
            &format!("contact {}", c + 1),
        );
    }
    let map = ContactMap::of(&ring);
    assert_eq!(
        map.ends(),
        [ContactEnds {
            above: Some(3),
            below: Some(0),
            offset: 0.0,
            wall_state: None,
        }]
    );
    let y = [1e-5, 2e-5, 4e-5, 7e-5, 0.1, 0.2, 0.3, 0.4];
    assert_eq!(map.kinematics(3, |i| y[i]), (7e-5 - 1e-5, 0.4 - 0.1));
}

#[test]
fn the_slowest_sound_transit_is_the_longest_particles() {
    // Longitudinal speed √(E(1−ν)/(ρ(1+ν)(1−2ν))) at each part's density.
    let speed =
        |e: f64, nu: f64, rho: f64| (e * (1.0 - nu) / (rho * (1.0 + nu) * (1.0 - 2.0 * nu))).sqrt();
    let (d, h, m_c) = (8e-3, 9.6e-3, 3.77e-3);
    let pi = std::f64::consts::PI;
    let sphere = d / speed(E_S, NU_S, M_S / (pi / 6.0 * d * d * d));
    let cylinder = h / speed(E_C, NU_C, m_c / (0.25 * pi * d * d * h));
    let chain = build(DimerSpec::chain_055(3), &PhysicsSpec::default());
    assert_close(
        chain.sound_transit_s(),
        sphere.max(cylinder),
        1e-14,
        "transit",
    );
    assert_eq!(chain.smallest_sphere_radius_m(), Some(R_S));
}

#[test]
fn mass_factors_scale_each_particle_and_bad_specs_name_their_field() {
    let mut spec = DimerSpec::chain_055(1);
    spec.mass_factors = vec![1.0, 2.0, 0.5, 1.25];
    let chain = build(spec.clone(), &PhysicsSpec::default());
    assert_eq!(chain.mass, vec![M_S, 2.0 * M_S, 0.5 * 3.77e-3, 1.25 * M_S]);

    let field = |spec: DimerSpec, physics: PhysicsSpec| {
        Chain::build(&ChainSpec::Dimer(spec), &physics)
            .unwrap_err()
            .field
    };
    spec.mass_factors.pop();
    assert_eq!(field(spec, PhysicsSpec::default()), "chain.mass_factors");
    let unsupported = PhysicsSpec {
        wall: false,
        precompression_force_n: 1.0,
        ..PhysicsSpec::default()
    };
    assert_eq!(
        field(DimerSpec::chain_055(1), unsupported),
        "physics.precompression_force_n"
    );
    let mut heavy = DimerSpec::chain_055(1);
    heavy.cylinder.mass = CylinderMass::HeavyCylinders { mass_ratio: 1.5 };
    assert_eq!(
        field(heavy, PhysicsSpec::default()),
        "chain.cylinder.mass.heavy_cylinders.mass_ratio"
    );
}
