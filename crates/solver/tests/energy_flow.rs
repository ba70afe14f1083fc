//! `record.energy_flow`: the energy through every contact and each particle's largest kinetic
//! energy. Two equal spheres exchange their energy exactly (`m v0²/2` through the contact, 1e-9);
//! the energy through each contact of a chain on a mounted wall equals the trapezoidal integral of
//! finely sampled force and velocity histories (1e-6), and each particle's largest kinetic energy
//! the largest of a finely sampled velocity history, never less; a solitary wave in a damped chain
//! carries less energy past each contact than past the one before; the moving part gives what the
//! whole chain gives.

use chainsweep_solver::chain::mount::WallMount;
use chainsweep_solver::chain::sequence::SequenceSpec;
use chainsweep_solver::observe::probes::Probe;
use chainsweep_solver::problems::monodisperse;
use chainsweep_solver::scene::solve::run;
use chainsweep_solver::scene::{IntegratorSpec, Scene};
use chainsweep_solver::{ActiveRegion, AdaptiveOptions};

fn scene(spec: SequenceSpec, v0: f64, duration_s: f64) -> Scene {
    let mut s = Scene::new(spec, v0, duration_s);
    s.integrator = IntegratorSpec::Dop853(AdaptiveOptions::new(1e-11));
    s.record.energy_flow = true;
    s
}

/// A striker on one free sphere of its own mass: the striker gives all its energy through the
/// contact and stops, the other leaves with it.
#[test]
fn two_equal_spheres_exchange_their_energy_through_the_contact() {
    let v0 = 0.7;
    let mut s = scene(monodisperse(1, None, true), v0, 60e-6);
    s.physics.wall = false;
    s.physics.gravity = false;
    let out = run(&s).unwrap();
    let flow = out.energy_flow.expect("recorded");
    let m = 2.085e-3;
    let e = 0.5 * m * v0 * v0;
    assert_eq!(flow.energy_passed_max_j.len(), 1);
    for w in [flow.energy_passed_max_j[0], flow.energy_passed_final_j[0]] {
        assert!((w - e).abs() < 1e-8 * e, "{w:e} against {e:e}");
    }
    for k in &flow.max_kinetic_energy_j {
        assert!((k - e).abs() < 1e-8 * e, "{k:e} against {e:e}");
    }
}

/// Trapezoidal `∫ f g dt` of two histories sampled together, its running value's largest and last.
fn trapezoid(t: &[f64], f: &[f64], g: &[f64], sign: f64) -> (f64, f64) {
    let (mut w, mut top) = (0.0f64, 0.0f64);
    for k in 1..t.len() {
        w += sign * 0.5 * (t[k] - t[k - 1]) * (f[k] * g[k] + f[k - 1] * g[k - 1]);
        top = top.max(w);
    }
    (top, w)
}

/// A struck sphere chain on a load cell with a dashpot: each contact's energy against the
/// histories of its force and of the velocity of the particle above it, sampled every nanosecond
/// (the contacts without a viscous term, whose jump at an opening the trapezoidal rule would
/// smear).
#[test]
fn the_energy_through_each_contact_is_the_integral_of_force_times_velocity() {
    let n = 6;
    let mut spec = monodisperse(n, None, true);
    spec.wall_mount = Some(WallMount {
        mass_kg: 0.02,
        stiffness_n_m: 3e8,
        damping_kg_s: 50.0,
    });
    let s = &mut scene(spec, 1.2, 120e-6);
    let particles = n + 1;
    s.record.probes = (1..=particles)
        .map(|contact| Probe::ContactForce { contact })
        .chain((1..=particles).map(|particle| Probe::Velocity { particle }))
        .collect();
    s.record.history = true;
    s.record.history_interval_s = 1e-9;
    let out = run(s).unwrap();
    let flow = out.energy_flow.clone().expect("recorded");
    let h = out.history.expect("recorded");
    assert_eq!(flow.energy_passed_max_j.len(), particles);
    let scale = out.impact_energy_j;
    for c in 0..particles {
        // Contact c + 1 has particle c + 1 above it (the wall's, the last, particle N).
        let (top, last) = trapezoid(&h.time_s, &h.values[c], &h.values[particles + c], 1.0);
        let (got_top, got_last) = (flow.energy_passed_max_j[c], flow.energy_passed_final_j[c]);
        assert!(
            (got_top - top).abs() < 1e-6 * scale && (got_last - last).abs() < 1e-6 * scale,
            "contact {}: ({got_top:e}, {got_last:e}) against ({top:e}, {last:e})",
            c + 1
        );
    }
    // The striker's contact passes on most of the impact energy; the wall receives some of it.
    assert!(flow.energy_passed_max_j[0] > 0.5 * scale);
    assert!(flow.energy_passed_max_j[particles - 1] > 1e-3 * scale);
    for i in 0..particles {
        let sampled = h.values[particles + i]
            .iter()
            .map(|v| 0.5 * 2.085e-3 * v * v)
            .fold(0.0, f64::max);
        let got = flow.max_kinetic_energy_j[i];
        assert!(
            got >= sampled * (1.0 - 1e-9) && got - sampled < 1e-6 * sampled,
            "particle {}: {got:e} against sampled {sampled:e}",
            i + 1
        );
    }
}

/// A solitary wave in a viscously damped chain loses energy as it goes: each contact passes less
/// than the one before it, before any reflection comes back.
#[test]
fn a_damped_solitary_wave_passes_less_energy_at_each_contact() {
    let mut s = scene(monodisperse(40, None, true), 1.0, 150e-6);
    s.physics.gravity = false;
    s.physics.damping_kg_s = 2.0;
    let flow = run(&s).unwrap().energy_flow.expect("recorded");
    let w = &flow.energy_passed_max_j;
    // The wave has passed eleven contacts in 150 µs, and is crossing the twelfth.
    for c in 1..11 {
        assert!(
            w[c] < w[c - 1],
            "contact {}: {:e} after {:e}",
            c + 1,
            w[c],
            w[c - 1]
        );
    }
    assert!(
        w[10] > 0.8 * w[0],
        "the wave still carries energy: {:e}",
        w[10]
    );
    assert!(
        w[20] < 1e-12 * w[0],
        "the wave has not come this far: {:e}",
        w[20]
    );
}

/// The moving part (a long chain of which the wave reaches about a hundred particles) records the
/// same flow as the whole chain, to the tolerance.
#[test]
fn the_moving_part_records_the_whole_chains_flow() {
    let mut s = scene(monodisperse(1200, None, true), 1.0, 100e-6);
    s.integrator = IntegratorSpec::Dop853(AdaptiveOptions::new(1e-9));
    let part = run(&s).unwrap();
    assert!(
        part.active_particles.is_some(),
        "the moving part was integrated"
    );
    s.active_region = ActiveRegion::Off;
    let whole = run(&s).unwrap();
    let (a, b) = (part.energy_flow.unwrap(), whole.energy_flow.unwrap());
    let scale = whole.impact_energy_j;
    for (x, y) in a
        .energy_passed_max_j
        .iter()
        .zip(&b.energy_passed_max_j)
        .chain(a.max_kinetic_energy_j.iter().zip(&b.max_kinetic_energy_j))
    {
        // The two differ by what each one's tolerance allows (a few 1e-7 here); the far end
        // frozen at rest would miss the whole wave.
        assert!((x - y).abs() < 1e-5 * scale, "{x:e} against {y:e}");
    }
}
