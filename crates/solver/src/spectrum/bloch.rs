//! The Bloch dispersion of a periodic chain: the unit cell's `p × p` Hermitian dynamical matrix
//! `D(q)` at each wavenumber `q ∈ [0, π]` (per cell), its frequencies, the bands and the gaps.
//!
//! With cell particles `0..p`, masses `m_i` and contact stiffnesses `k_i` (contact `i` joins cell
//! particle `i` and `i + 1`, contact `p − 1` the cell's last particle and the next cell's first)
//! and displacements `u_{n,i} = U_i e^{i(q n − ω t)}`, the linearised equations are
//! `ω² U = D(q) U` in mass-scaled coordinates:
//!
//! ```text
//! D_ii = (k_{i−1} + k_i)/m_i        (k_{−1} = k_{p−1}, the previous cell's last contact)
//! D_{i,i+1} = D_{i+1,i} = −k_i/√(m_i m_{i+1}),   i < p − 1
//! D_{p−1,0} += −k_{p−1} e^{iq}/√(m_{p−1} m_0),   D_{0,p−1} its conjugate
//! ```
//!
//! (`p = 1`: `ω² = 2k(1 − cos q)/m`). The Hermitian matrix is solved as the real symmetric
//! `[[Re D, −Im D], [Im D, Re D]]`, whose eigenvalues are `D`'s, each twice, by cyclic Jacobi.
//! Each band of a periodic Jacobi matrix is a monotone function of `q` on `[0, π]` (the
//! discriminant `Δ(ω²) = 2 cos q` of Floquet theory, e.g. Teschl, *Jacobi Operators and Completely
//! Integrable Nonlinear Lattices*, ch. 7), so its edges are its values at `q = 0` and `q = π`.

use crate::spec::{spec_err, SpecError};

/// A unit cell of a periodic chain, linearised.
#[derive(Debug, Clone, PartialEq)]
pub struct UnitCell {
    /// Masses of the cell's particles, kg.
    pub mass: Vec<f64>,
    /// Stiffness of contact `i`, between cell particles `i` and `i + 1` (the last one: between
    /// the cell's last particle and the next cell's first), N/m.
    pub stiffness: Vec<f64>,
}

/// One band of the dispersion: its lowest and highest angular frequency, rad/s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Band {
    /// Lower edge, rad/s.
    pub lower_rad_s: f64,
    /// Upper edge, rad/s.
    pub upper_rad_s: f64,
}

impl UnitCell {
    /// A cell of masses `mass` and stiffnesses `stiffness` (one each per particle, all > 0);
    /// `field` is named in the error.
    pub fn new(mass: Vec<f64>, stiffness: Vec<f64>, field: &str) -> Result<Self, SpecError> {
        if mass.is_empty() || mass.len() != stiffness.len() {
            return Err(spec_err(
                field,
                format!(
                    "a unit cell needs one mass and one contact stiffness per particle, got {} and {}",
                    mass.len(),
                    stiffness.len()
                ),
            ));
        }
        for (i, (&m, &k)) in mass.iter().zip(&stiffness).enumerate() {
            if !(m.is_finite() && m > 0.0) {
                return Err(spec_err(
                    field,
                    format!("cell particle {i} has mass {m} kg"),
                ));
            }
            if !(k.is_finite() && k > 0.0) {
                return Err(spec_err(
                    field,
                    format!(
                        "contact {i} of the unit cell has linear stiffness {k} N/m: a contact without static compression carries no linear wave, so the chain has no bands"
                    ),
                ));
            }
        }
        Ok(UnitCell { mass, stiffness })
    }

    /// Particles per cell `p`.
    pub fn len(&self) -> usize {
        self.mass.len()
    }

    /// Whether the cell is empty (never: [`UnitCell::new`] refuses it).
    pub fn is_empty(&self) -> bool {
        self.mass.is_empty()
    }

    /// The `p` angular frequencies (rad/s, increasing) at wavenumber `q` (radians per cell).
    pub fn frequencies_at(&self, q: f64) -> Vec<f64> {
        let p = self.len();
        // D(q) as (re, im), row-major.
        let mut re = vec![0.0; p * p];
        let mut im = vec![0.0; p * p];
        let mut add = |i: usize, j: usize, zr: f64, zi: f64| {
            re[i * p + j] += zr;
            im[i * p + j] += zi;
            re[j * p + i] += zr;
            im[j * p + i] -= zi;
        };
        for i in 0..p {
            let prev = self.stiffness[(i + p - 1) % p];
            // Half on each of (i, i) and its "conjugate" (i, i): add() writes both.
            let d = 0.5 * (prev + self.stiffness[i]) / self.mass[i];
            add(i, i, d, 0.0);
        }
        for i in 0..p - 1 {
            let c = -self.stiffness[i] / (self.mass[i] * self.mass[i + 1]).sqrt();
            add(i + 1, i, c, 0.0);
        }
        let c = -self.stiffness[p - 1] / (self.mass[p - 1] * self.mass[0]).sqrt();
        add(p - 1, 0, c * q.cos(), c * q.sin());
        // The real symmetric embedding [[Re, −Im], [Im, Re]].
        let n = 2 * p;
        let mut s = vec![0.0; n * n];
        for i in 0..p {
            for j in 0..p {
                let (r, m) = (re[i * p + j], im[i * p + j]);
                s[i * n + j] = r;
                s[(i + p) * n + (j + p)] = r;
                s[i * n + (j + p)] = -m;
                s[(i + p) * n + j] = m;
            }
        }
        let mut w = jacobi_eigenvalues(&mut s, n);
        w.sort_by(f64::total_cmp);
        // Each eigenvalue of D appears twice.
        (0..p)
            .map(|b| 0.5 * (w[2 * b] + w[2 * b + 1]))
            .map(|l| l.max(0.0).sqrt())
            .collect()
    }

    /// The dispersion on `points` wavenumbers evenly spaced over `[0, π]` (`points ≥ 2`): the
    /// wavenumbers and the frequencies, `omega[k * p + b]` band `b` at `q[k]`, rad/s.
    pub fn dispersion(&self, points: usize) -> (Vec<f64>, Vec<f64>) {
        let points = points.max(2);
        let q: Vec<f64> = (0..points)
            .map(|k| std::f64::consts::PI * k as f64 / (points - 1) as f64)
            .collect();
        let omega = q.iter().flat_map(|&q| self.frequencies_at(q)).collect();
        (q, omega)
    }

    /// The `p` bands, from the lowest (the acoustic band, from 0): each band's edges are its
    /// frequencies at `q = 0` and `q = π`.
    pub fn bands(&self) -> Vec<Band> {
        let at0 = self.frequencies_at(0.0);
        let at_pi = self.frequencies_at(std::f64::consts::PI);
        at0.iter()
            .zip(&at_pi)
            .map(|(&a, &b)| Band {
                lower_rad_s: a.min(b),
                upper_rad_s: a.max(b),
            })
            .collect()
    }

    /// The gaps between consecutive bands, `(lower, upper)` edges in rad/s, lowest first; bands
    /// that touch (to 1e-12 of their frequency, e.g. a dimer of equal masses) have no gap.
    pub fn gaps(&self) -> Vec<(f64, f64)> {
        self.bands()
            .windows(2)
            .filter(|w| w[1].lower_rad_s > w[0].upper_rad_s * (1.0 + 1e-12))
            .map(|w| (w[0].upper_rad_s, w[1].lower_rad_s))
            .collect()
    }
}

impl UnitCell {
    /// The transfer matrix of the cell at angular frequency `omega` (rad/s), row-major `2 × 2`:
    /// it takes `(u_0, u_{−1})` (the cell's first particle and the previous cell's last) to
    /// `(u_p, u_{p−1})` (the next cell's first and this cell's last) for a motion `u e^{−iωt}` of
    /// the linearised chain, the product of each particle's step
    /// `u_{i+1} = ((k_{i−1} + k_i − m_i ω²) u_i − k_{i−1} u_{i−1}) / k_i`. Its determinant is 1
    /// and its trace `2 cos q`, `q` the Bloch wavenumber.
    pub fn transfer_matrix(&self, omega: f64) -> [f64; 4] {
        let p = self.len();
        let mut t = [1.0, 0.0, 0.0, 1.0];
        for i in 0..p {
            let (k_prev, k) = (self.stiffness[(i + p - 1) % p], self.stiffness[i]);
            let step = [
                (k_prev + k - self.mass[i] * omega * omega) / k,
                -k_prev / k,
                1.0,
                0.0,
            ];
            t = [
                step[0] * t[0] + step[1] * t[2],
                step[0] * t[1] + step[1] * t[3],
                step[2] * t[0] + step[3] * t[2],
                step[2] * t[1] + step[3] * t[3],
            ];
        }
        t
    }

    /// The complex Bloch wavenumber `q = re + i im` (per cell, `re ∈ [0, π]`, `im ≥ 0`) at angular
    /// frequency `omega`, from the transfer matrix's trace `2 cos q`: in a band `im = 0`; in a
    /// gap the waves are evanescent, `re` is `0` or `π` (`π`: successive cells in antiphase) and
    /// the decaying one falls by `exp(−im)` a cell, `im = acosh(|tr| / 2)`.
    pub fn bloch_wavenumber(&self, omega: f64) -> (f64, f64) {
        let t = self.transfer_matrix(omega);
        let half = 0.5 * (t[0] + t[3]);
        if half.abs() <= 1.0 {
            (half.acos(), 0.0)
        } else if half < 0.0 {
            (std::f64::consts::PI, (-half).acosh())
        } else {
            (0.0, half.acosh())
        }
    }
}

/// The eigenvalues of the real symmetric `n × n` matrix `a` (row-major, destroyed) by the cyclic
/// Jacobi method, to a few units in the last place of its norm.
pub(crate) fn jacobi_eigenvalues(a: &mut [f64], n: usize) -> Vec<f64> {
    for _sweep in 0..100 {
        let off: f64 = (0..n)
            .flat_map(|i| (0..n).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| a[i * n + j] * a[i * n + j])
            .sum();
        let diag: f64 = (0..n).map(|i| a[i * n + i] * a[i * n + i]).sum();
        if off <= f64::EPSILON * f64::EPSILON * 1e-4 * diag || off == 0.0 {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                let apq = a[p * n + q];
                if apq == 0.0 {
                    continue;
                }
                let (app, aqq) = (a[p * n + p], a[q * n + q]);
                let theta = (aqq - app) / (2.0 * apq);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..n {
                    let (akp, akq) = (a[k * n + p], a[k * n + q]);
                    a[k * n + p] = c * akp - s * akq;
                    a[k * n + q] = s * akp + c * akq;
                }
                for k in 0..n {
                    let (apk, aqk) = (a[p * n + k], a[q * n + k]);
                    a[p * n + k] = c * apk - s * aqk;
                    a[q * n + k] = s * apk + c * aqk;
                }
            }
        }
    }
    (0..n).map(|i| a[i * n + i]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn monatomic_chain_is_one_sine_band() {
        let cell = UnitCell::new(vec![2.0], vec![8.0], "cell").unwrap();
        for q in [0.0, 0.3, 1.0, std::f64::consts::PI] {
            let w = cell.frequencies_at(q)[0];
            let exact = 2.0 * (8.0f64 / 2.0).sqrt() * (0.5 * q).sin();
            assert!((w - exact).abs() < 1e-14 * 4.0, "{q} {w} {exact}");
        }
        assert!(cell.gaps().is_empty());
    }

    #[test]
    fn bands_are_monotone_between_their_edges() {
        let cell = UnitCell::new(vec![1.0, 0.3, 2.5], vec![3.0, 1.0, 7.0], "cell").unwrap();
        let bands = cell.bands();
        let (_, omega) = cell.dispersion(201);
        for (b, band) in bands.iter().enumerate() {
            for k in 0..201 {
                let w = omega[k * 3 + b];
                assert!(w >= band.lower_rad_s * (1.0 - 1e-13) - 1e-13);
                assert!(w <= band.upper_rad_s * (1.0 + 1e-13));
            }
        }
        assert_eq!(cell.gaps().len(), 2);
    }

    #[test]
    fn transfer_matrix_gives_the_band_s_wavenumber_and_the_gap_s_decay() {
        let (m, big, k) = (0.5, 2.085, 3.0);
        let cell = UnitCell::new(vec![big, m], vec![k, k], "cell").unwrap();
        // In the bands, the wavenumber whose frequencies these are.
        for q in [0.3, 1.2, 2.9] {
            for w in cell.frequencies_at(q) {
                let t = cell.transfer_matrix(w);
                assert!((t[0] * t[3] - t[1] * t[2] - 1.0).abs() < 1e-12);
                let (re, im) = cell.bloch_wavenumber(w);
                assert!((re - q).abs() < 1e-6 && im == 0.0, "{q}: {re} {im}");
            }
        }
        // In the gap of the diatomic chain, cos q = 1 − m M λ(2s − λ)/2 with λ = ω²/k and
        // s = 1/m + 1/M (the dispersion ω² = k s ± k √(s² − 4 sin²(q/2)/(m M)) solved for q):
        // q = π + iκ, cosh κ = m M λ(2s − λ)/2 − 1.
        let (lo, hi) = cell.gaps()[0];
        let s = 1.0 / m + 1.0 / big;
        for f in [0.1, 0.5, 0.9] {
            let w = lo + f * (hi - lo);
            let l = w * w / k;
            let kappa = (m * big * l * (2.0 * s - l) / 2.0 - 1.0).acosh();
            let (re, im) = cell.bloch_wavenumber(w);
            assert_eq!(re, std::f64::consts::PI);
            assert!((im - kappa).abs() < 1e-12 * kappa.max(1.0), "{im} {kappa}");
        }
        // Above the top band the waves decay too, in antiphase.
        let top = cell.bands()[1].upper_rad_s;
        assert!(cell.bloch_wavenumber(1.1 * top).1 > 0.0);
    }
}
