//! Tridiagonal Jacobian of the chain's accelerations, for implicit integrators, exact for every
//! contact law and dissipation model.
//!
//! Contact `c` joins particles `c` and `c+1` with overlap `δ_c = x_c − x_{c+1}` and relative velocity
//! `Δv_c = v_c − v_{c+1}`; with a wall the last contact presses particle `N−1` against `x = 0`
//! (`δ = x_{N−1}`, `Δv = v_{N−1}`). Its force `F_c = A_c δ^{3/2} + μ_c Δv` (the viscous term only
//! with damping) acts while `δ_c > 0`, and pushes particle `c` by `−F_c/m_c` and particle `c+1` by
//! `+F_c/m_{c+1}`. Hence, with `k_c = ∂F_c/∂δ_c = 3/2 A_c δ_c^{1/2}` and `η_c = ∂F_c/∂Δv_c = μ_c`,
//!
//! ```text
//! ∂a_c/∂x_c     = −k_c/m_c        ∂a_c/∂x_{c+1}     = +k_c/m_c
//! ∂a_{c+1}/∂x_c = +k_c/m_{c+1}    ∂a_{c+1}/∂x_{c+1} = −k_c/m_{c+1}
//! ```
//!
//! and the same with `η_c` for `kv`. An open contact (`δ_c ≤ 0`) contributes nothing, nor does a
//! contact whose net force is clipped to zero (`CLIP` and `F_c ≤ 0`): on those pieces the force is
//! identically zero. The wall contact touches only the last diagonal entry. Gravity is constant and
//! contributes nothing. Both matrices therefore have non-positive diagonals and non-negative
//! off-diagonals, with `|diag| = Σ off-diagonal` except at the wall row: `I − a kv − b kx` is a
//! strictly diagonally dominant M-matrix for any `a, b ≥ 0`, which is what makes the implicit
//! solves of [`crate::integrate::Ros34pw2`] pivot-free.

use crate::contact::{general_derivatives, paper_contact_derivatives};
use crate::integrate::Tridiagonal;
use crate::motion::general::GeneralChainSystem;
use crate::motion::system::ChainSystem;

/// Makes `m` a tridiagonal matrix of order `n` filled with zeros (allocates only if the order differs).
fn reset(m: &mut Tridiagonal, n: usize) {
    let off = n.saturating_sub(1);
    m.lower.clear();
    m.lower.resize(off, 0.0);
    m.diag.clear();
    m.diag.resize(n, 0.0);
    m.upper.clear();
    m.upper.resize(off, 0.0);
}

impl<const G: bool, const D: bool, const W: bool, const C: bool> ChainSystem<G, D, W, C> {
    /// Writes `kx = ∂a/∂x` and `kv = ∂a/∂v` at state `y` (both of order `N`; resized if they are
    /// not), exactly, on the smooth piece of the right-hand side that contains `y`: open contacts
    /// and clipped ones contribute nothing, and without damping (`D = false`) `kv` is zero.
    pub fn jacobian(&self, _t: f64, y: &[f64], kx: &mut Tridiagonal, kv: &mut Tridiagonal) {
        let im = self.inverse_masses();
        let n = im.len();
        reset(kx, n);
        reset(kv, n);
        let (x, v) = (&y[..n], &y[n..2 * n]);
        for c in 0..n.saturating_sub(1) {
            let (a, mu) = self.contact_parameters(c);
            let (k, eta) =
                paper_contact_derivatives::<D, C>(a, mu, x[c] - x[c + 1], v[c] - v[c + 1]);
            if k != 0.0 {
                kx.diag[c] -= k * im[c];
                kx.upper[c] += k * im[c];
                kx.lower[c] += k * im[c + 1];
                kx.diag[c + 1] -= k * im[c + 1];
            }
            if D && eta != 0.0 {
                kv.diag[c] -= eta * im[c];
                kv.upper[c] += eta * im[c];
                kv.lower[c] += eta * im[c + 1];
                kv.diag[c + 1] -= eta * im[c + 1];
            }
        }
        if W && n > 0 {
            let (a, mu) = self.contact_parameters(n - 1);
            let (k, eta) = paper_contact_derivatives::<D, C>(a, mu, x[n - 1], v[n - 1]);
            kx.diag[n - 1] -= k * im[n - 1];
            if D {
                kv.diag[n - 1] -= eta * im[n - 1];
            }
        }
    }
}

/// Adds contact `c`'s derivatives `k = ∂F/∂δ`, `eta = ∂F/∂δ̇` to the matrices: between particles
/// `c` and `c+1`, or (`wall`) between particle `c` and the wall.
#[inline(always)]
fn add_contact(
    kx: &mut Tridiagonal,
    kv: &mut Tridiagonal,
    im: &[f64],
    c: usize,
    wall: bool,
    k: f64,
    eta: f64,
) {
    if wall {
        kx.diag[c] -= k * im[c];
        kv.diag[c] -= eta * im[c];
        return;
    }
    if k != 0.0 {
        kx.diag[c] -= k * im[c];
        kx.upper[c] += k * im[c];
        kx.lower[c] += k * im[c + 1];
        kx.diag[c + 1] -= k * im[c + 1];
    }
    if eta != 0.0 {
        kv.diag[c] -= eta * im[c];
        kv.upper[c] += eta * im[c];
        kv.lower[c] += eta * im[c + 1];
        kv.diag[c + 1] -= eta * im[c + 1];
    }
}

impl<const LAW: u8, const D: bool, const T: bool> GeneralChainSystem<LAW, D, T> {
    /// Writes `kx = ∂a/∂x` and `kv = ∂a/∂v` at state `y`, exactly, on the smooth piece of the
    /// right-hand side that contains `y`. For `F = A δ^n + (μ + γ δ^{n−1} + λ δ^n) δ̇`:
    /// `∂F/∂δ = n A δ^{n−1} + ((n−1) γ δ^{n−2} + n λ δ^{n−1}) δ̇` and
    /// `∂F/∂δ̇ = μ + γ δ^{n−1} + λ δ^n`. Unlike the paper's law, `∂F/∂δ` may be negative (a
    /// contact unloading fast under Kuwabara–Kono or Hunt–Crossley damping), so the iteration
    /// matrix is not always an M-matrix; the factorisation pivots where needed. The external
    /// forces depend on time only and contribute nothing.
    pub fn jacobian(&self, t: f64, y: &[f64], kx: &mut Tridiagonal, kv: &mut Tridiagonal) {
        let im = self.inverse_masses();
        let n = im.len();
        reset(kx, n);
        reset(kv, n);
        let (x, v) = (&y[..n], &y[n..2 * n]);
        let clip = self.clips();
        let ((base_u, base_du), (top_u, top_du)) = self.wall_motion(t, y);
        for c in 0..n.saturating_sub(1) {
            let p = self.contact_parameters(c);
            let (k, eta) =
                general_derivatives::<LAW, D, T>(&p, x[c] - x[c + 1], v[c] - v[c + 1], clip);
            add_contact(kx, kv, im, c, false, k, eta);
        }
        if self.has_wall() && n > 0 {
            let p = self.contact_parameters(n - 1);
            let (k, eta) =
                general_derivatives::<LAW, D, T>(&p, x[n - 1] - base_u, v[n - 1] - base_du, clip);
            add_contact(kx, kv, im, n - 1, true, k, eta);
        }
        if self.is_ring() {
            // The closing contact couples the two ends, outside the tridiagonal band: only its
            // diagonal terms are kept (a W-method needs only an approximation of the Jacobian).
            let p = self.contact_parameters(n - 1);
            let (k, eta) =
                general_derivatives::<LAW, D, T>(&p, x[n - 1] - x[0], v[n - 1] - v[0], clip);
            add_contact(kx, kv, im, n - 1, true, k, eta);
            add_contact(kx, kv, im, 0, true, k, eta);
        }
        if let Some((c, position)) = self.top_wall() {
            let p = self.contact_parameters(c);
            let (k, eta) =
                general_derivatives::<LAW, D, T>(&p, position + top_u - x[0], top_du - v[0], clip);
            add_contact(kx, kv, im, 0, true, k, eta);
        }
    }
}

#[cfg(test)]
// Dense finite-difference matrices are indexed by row and column.
#[allow(clippy::needless_range_loop)]
mod tests {
    use crate::chain::model::{Chain, ChainSpec, PhysicsSpec};
    use crate::integrate::{OdeSystem, Tridiagonal};
    use crate::motion::system::ChainSystem;

    /// A small deterministic generator of uniform numbers in [0, 1).
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    fn entry(m: &Tridiagonal, i: usize, j: usize) -> f64 {
        if i == j {
            m.diag[i]
        } else if j == i + 1 {
            m.upper[i]
        } else if i == j + 1 {
            m.lower[j]
        } else {
            0.0
        }
    }

    /// Compares the analytic Jacobian with central differences of `rhs` at state `y`; returns the
    /// largest error relative to the largest entry of its row.
    fn check<const G: bool, const D: bool, const W: bool, const C: bool>(
        chain: &Chain,
        y: &[f64],
        dx: f64,
        dv: f64,
    ) -> f64 {
        check_system(&mut ChainSystem::<G, D, W, C>::new(chain), y, dx, dv)
    }

    /// [`check`] for any system.
    fn check_system<S: OdeSystem>(sys: &mut S, y: &[f64], dx: f64, dv: f64) -> f64 {
        let n = sys.n_pos();
        let mut kx = Tridiagonal::zeros(n);
        let mut kv = Tridiagonal::zeros(n);
        assert!(sys.acceleration_jacobian(0.0, y, &mut kx, &mut kv));
        let dim = y.len();
        let (mut fp, mut fm) = (vec![0.0; dim], vec![0.0; dim]);
        let mut yp = y.to_vec();
        let mut worst: f64 = 0.0;
        for (block, (k, eps)) in [(&kx, dx), (&kv, dv)].into_iter().enumerate() {
            // Column j of the finite-difference Jacobian, compared with column j of `k`.
            let mut fd = vec![vec![0.0; n]; n];
            for j in 0..n {
                let idx = block * n + j;
                yp[idx] = y[idx] + eps;
                sys.rhs(0.0, &yp, &mut fp);
                yp[idx] = y[idx] - eps;
                sys.rhs(0.0, &yp, &mut fm);
                yp[idx] = y[idx];
                for i in 0..n {
                    fd[i][j] = (fp[n + i] - fm[n + i]) / (2.0 * eps);
                }
            }
            for i in 0..n {
                let scale = (0..n).map(|j| fd[i][j].abs()).fold(0.0, f64::max);
                for j in 0..n {
                    let e = (entry(k, i, j) - fd[i][j]).abs();
                    if scale > 0.0 {
                        worst = worst.max(e / scale);
                    } else {
                        assert_eq!(entry(k, i, j), 0.0, "block {block} ({i},{j})");
                    }
                }
            }
        }
        worst
    }

    /// Random state: every contact compressed by 0.3–3 µm unless `open` asks for some gaps, random
    /// velocities of ±0.5 m/s, random quadratures.
    fn random_state(chain: &Chain, rng: &mut Lcg, open: bool, dim: usize) -> (Vec<f64>, f64) {
        let n = chain.n_particles();
        let mut y = vec![0.0; dim];
        let mut min_gap: f64 = f64::INFINITY;
        // Build positions from the wall upwards: x_{n-1} = δ_wall, x_c = x_{c+1} + δ_c.
        let mut overlap = |rng: &mut Lcg| {
            let d = 3e-7 + 2.7e-6 * rng.next();
            let d = if open && rng.next() < 0.3 { -d } else { d };
            min_gap = min_gap.min(d.abs());
            d
        };
        y[n - 1] = overlap(rng);
        for c in (0..n - 1).rev() {
            y[c] = y[c + 1] + overlap(rng);
        }
        for i in 0..n {
            y[n + i] = rng.next() - 0.5;
        }
        for q in y.iter_mut().skip(2 * n) {
            *q = rng.next();
        }
        (y, min_gap)
    }

    macro_rules! check_all {
        ($($g:literal $d:literal $w:literal $c:literal),* $(,)?) => {$({
            let physics = PhysicsSpec {
                gravity: $g,
                damping_kg_s: if $d { 37.0 } else { 0.0 },
                striker_damping_kg_s: if $d { Some(11.0) } else { None },
                wall: $w,
                clip_tensile: $c,
                ..PhysicsSpec::default()
            };
            let chain = Chain::build(&ChainSpec::chain_055(4), &physics).unwrap();
            let dim = 2 * chain.n_particles() + $d as usize + $w as usize;
            let mut rng = Lcg(0x5eed + dim as u64);
            for trial in 0..6 {
                let open = trial >= 3;
                let (y, min_gap) = random_state(&chain, &mut rng, open, dim);
                // Steps far below the smallest overlap, so no difference crosses a kink.
                let e = check::<$g, $d, $w, $c>(&chain, &y, 1e-4 * min_gap, 1e-3);
                assert!(
                    e < 1e-6,
                    "G={} D={} W={} C={} trial {trial}: relative error {e:e}",
                    $g, $d, $w, $c
                );
            }
        })*};
    }

    #[test]
    fn jacobian_matches_central_differences() {
        check_all!(
            false false false false,
            false false false true,
            false false true false,
            false true false false,
            false true true true,
            true false true false,
            true true false true,
            true true true false,
            true true true true,
        );
    }

    #[test]
    fn clipped_and_open_contacts_contribute_nothing() {
        let physics = PhysicsSpec {
            damping_kg_s: 100.0,
            clip_tensile: true,
            ..PhysicsSpec::default()
        };
        let chain = Chain::build(&ChainSpec::chain_055(1), &physics).unwrap();
        let sys = ChainSystem::<true, true, true, true>::new(&chain);
        let n = chain.n_particles();
        assert_eq!(n, 4);
        // Contact 0 open, contact 1 compressed but pulled apart fast (clipped), contact 2
        // compressed and closing, wall contact compressed.
        let x = [1.0e-6, 2.0e-6, 1.5e-6, 1.0e-6];
        let v = [0.0, -5.0, 5.0, 0.1];
        let mut y = x.to_vec();
        y.extend_from_slice(&v);
        y.extend_from_slice(&[0.0, 0.0]);
        let mut kx = Tridiagonal::default();
        let mut kv = Tridiagonal::default();
        sys.jacobian(0.0, &y, &mut kx, &mut kv);
        assert_eq!(kx.diag.len(), n);
        assert_eq!(kx.upper[0], 0.0);
        assert_eq!(kx.lower[0], 0.0);
        assert_eq!(kv.upper[1], 0.0);
        assert_eq!(kx.upper[1], 0.0);
        assert!(kx.upper[2] > 0.0 && kv.upper[2] > 0.0);
        let (a, mu) = chain.stiffness[2..3]
            .iter()
            .zip(&chain.damping[2..3])
            .map(|(a, m)| (*a, *m))
            .next()
            .unwrap();
        let im2 = 1.0 / chain.mass[2];
        assert!((kx.upper[2] - 1.5 * a * (0.5e-6f64).sqrt() * im2).abs() <= 1e-12 * kx.upper[2]);
        assert!((kv.upper[2] - mu * im2).abs() <= 1e-12 * kv.upper[2]);
        // The wall only touches the last diagonal entry.
        let im3 = 1.0 / chain.mass[3];
        let (aw, muw) = (chain.stiffness[3], chain.damping[3]);
        let wall_kx = 1.5 * aw * (1e-6f64).sqrt() * im3;
        assert!((kx.diag[3] + kx.lower[2] + wall_kx).abs() <= 1e-12 * wall_kx);
        assert!((kv.diag[3] + kv.lower[2] + muw * im3).abs() <= 1e-12 * muw * im3);
    }

    /// A chain of spheres of two sizes and flat cylinders with the given laws on its three
    /// kinds of pair and the wall, and `model` on every contact.
    fn general_chain(
        laws: [f64; 3],
        model: Option<crate::contact::DissipationSpec>,
        clip: bool,
        wall: bool,
    ) -> Chain {
        use crate::chain::sequence::{CylinderType, ParticleType, SequenceItem};
        use crate::problems::{chain, power_law, rule, sphere, STEEL};
        let tall = ParticleType::Cylinder(CylinderType {
            material: crate::chain::model::Material::STEEL_SS304,
            diameter_m: 8e-3,
            height_m: 9.6e-3,
            mass_kg: None,
            density_kg_m3: Some(7813.0),
        });
        let law = |n: f64| (n != 1.5).then(|| power_law(9e9 * 1e-6f64.powf(1.5 - n), n));
        let spec = chain(
            &[
                ("ball", sphere(STEEL, 8e-3, 2.085e-3)),
                ("small", sphere(STEEL, 4e-3, 0.26e-3)),
                ("tall", tall),
            ],
            vec![
                SequenceItem::Type("ball".into()),
                SequenceItem::Type("tall".into()),
                SequenceItem::Type("small".into()),
                SequenceItem::Type("ball".into()),
                SequenceItem::Type("small".into()),
            ],
            Some("ball"),
            vec![
                rule("ball", "tall", law(laws[0]), None),
                rule("tall", "small", law(laws[1]), None),
                rule("ball", "small", law(laws[2]), None),
                rule("small", "wall", law(laws[2]), None),
            ]
            .into_iter()
            .filter(|r| r.law.is_some())
            .collect(),
        );
        let physics = PhysicsSpec {
            gravity: true,
            dissipation: model,
            wall,
            clip_tensile: clip,
            precompression_force_n: if wall { 3.0 } else { 0.0 },
            ..PhysicsSpec::default()
        };
        Chain::build(&crate::chain::model::ChainSpec::Sequence(spec), &physics).unwrap()
    }

    #[test]
    fn general_jacobian_matches_central_differences_for_every_law_and_model() {
        use crate::contact::DissipationSpec;
        let models = [
            None,
            Some(DissipationSpec::LinearViscous { damping_kg_s: 7.0 }),
            Some(DissipationSpec::KuwabaraKono {
                relaxation_time_s: 3e-6,
            }),
            Some(DissipationSpec::HuntCrossley {
                restitution: 0.4,
                impact_velocity_m_s: 0.3,
            }),
            Some(DissipationSpec::Tsuji { restitution: 0.4 }),
        ];
        let mut rng = Lcg(0xfeed);
        for laws in [[1.5; 3], [1.0; 3], [2.5; 3], [1.0, 2.0, 1.5]] {
            for model in models {
                for (clip, wall) in [(false, true), (true, true), (false, false)] {
                    let chain = general_chain(laws, model, clip, wall);
                    let dim = chain.state_len();
                    for trial in 0..6 {
                        let (y, min_gap) = random_state(&chain, &mut rng, trial >= 3, dim);
                        // The forces are linear in the velocities apart from the clipping kink,
                        // which Kuwabara–Kono and Hunt–Crossley damping place at velocities of
                        // the order of the random ones (−1/α for Hunt–Crossley): a small step
                        // keeps the central differences on one smooth piece and costs nothing
                        // in truncation.
                        let (dx, dv) = (1e-4 * min_gap, 1e-6);
                        let e = crate::dispatch_general_system!(&chain, |sys| check_system(
                            &mut sys, &y, dx, dv
                        ));
                        assert!(
                            e < 1e-6,
                            "laws {laws:?} model {model:?} clip {clip} wall {wall} trial {trial}: relative error {e:e}"
                        );
                    }
                }
            }
        }
    }
}
