//! The linear spectrum of a chain at its static state: natural frequencies and mode shapes of the
//! chain linearised about its precompressed or gravity-loaded equilibrium, its damped eigenvalues,
//! and, for a periodic chain, the Bloch dispersion of its unit cell, its bands and gaps. No time
//! integration: see `docs/CHAINS.md`, "The linear spectrum at the static state".
//!
//! **What is linearised.** The rows are the chain's particles at rest, `f..N` (`f` the first
//! chain particle: a striker is a projectile, not part of the static chain, and is left out).
//! Each contact `c` between two of them, and the wall's, contributes its stiffness
//! `k_c = ∂F/∂δ` and damping `c_c = ∂F/∂δ̇` at its static overlap `δ_{c,0}` and `δ̇ = 0`, exactly
//! the derivatives the stiff integrator's Jacobian uses ([`crate::contact`]): `k = n A δ₀^{n−1}`
//! (Hertz: `(3/2) A δ₀^{1/2} = (3/2) A^{2/3} L^{1/3}` under the load `L`), and
//! `c = μ + γ δ₀^{n−1} + λ δ₀^n + β δ₀^{(n−1)/2}` (every dissipation model of the engine is linear in
//! `δ̇` at a fixed overlap). A contact with zero static overlap (none is compressed without gravity
//! or precompression, or without a wall) has zero linear stiffness (the force law is not
//! differentiable there and its one-sided stiffness vanishes for `n > 1`): its modes are zero
//! modes, so a chain with no compressed contact is refused. The precompression force is constant,
//! so the top is free; the wall contributes its contact's stiffness to the last particle. A wall on
//! a spring and a dashpot (`chain.wall_mount`) is a body of the linear chain: one more row, the
//! wall's mass, joined to the last particle by the wall contact and to the ground by the mount.
//!
//! `K` and `C` are tridiagonal (`K_ii = k_{i−1} + k_i`, `K_{i,i+1} = −k_i`), `M` diagonal; the
//! symmetric problem `K v = ω² M v` is reduced to `A u = ω² u` with the symmetric tridiagonal
//! `A = M^{−1/2} K M^{−1/2}`, `v = M^{−1/2} u`, and solved by [`tridiagonal`].

pub mod bloch;
mod damped;
pub mod tridiagonal;

pub(crate) use damped::real_eigenvalues;

use crate::chain::model::Chain;
use crate::contact::{general_derivatives, POWER};
use crate::spec::{spec_err, SpecError};
use bloch::UnitCell;
use tridiagonal::SymTridiagonal;

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

/// Largest chain whose damped eigenvalues are found by the dense companion-matrix solve (when the
/// damping is not proportional to the stiffness).
pub const DENSE_DAMPED_LIMIT: usize = 200;

/// Damping proportional to stiffness (`c_c = α k_c` on every contact) within this relative error
/// is solved mode by mode.
const PROPORTIONAL_TOLERANCE: f64 = 1e-12;

/// Masses and contact stiffnesses of consecutive cells equal within this relative difference
/// make a periodic chain.
pub const PERIODIC_TOLERANCE: f64 = 1e-9;

/// What a run records of the linear spectrum (`record.spectrum`): the lowest and highest natural
/// frequency of the chain and, with `cell_particles`, the band edges of the periodic chain whose
/// unit cell is the first `cell_particles` chain particles.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct SpectrumSpec {
    /// Particles in the unit cell of a periodic chain (from the first chain particle): the chain's
    /// masses and static contact stiffnesses must repeat with this period. Absent: no bands.
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Option::is_none")
    )]
    pub cell_particles: Option<usize>,
}

/// What a run records of its linear spectrum (`record.spectrum`), Hz (`f = ω/2π`).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize))]
pub struct SpectrumSummary {
    /// The chain's lowest natural frequency, Hz.
    pub lowest_frequency_hz: f64,
    /// The chain's highest natural frequency, Hz.
    pub highest_frequency_hz: f64,
    /// Lower edge of the periodic chain's first band gap (the top of the acoustic band), Hz; NaN
    /// without `cell_particles` or without a gap.
    pub gap_lower_hz: f64,
    /// Upper edge of the first band gap (the bottom of the next band), Hz; NaN where the lower is.
    pub gap_upper_hz: f64,
    /// Top of the periodic chain's highest band (its cut-off), Hz; NaN without `cell_particles`.
    pub band_top_hz: f64,
}

impl SpectrumSummary {
    /// Nothing recorded.
    pub const NAN: SpectrumSummary = SpectrumSummary {
        lowest_frequency_hz: f64::NAN,
        highest_frequency_hz: f64::NAN,
        gap_lower_hz: f64::NAN,
        gap_upper_hz: f64::NAN,
        band_top_hz: f64::NAN,
    };
}

/// The field of `record.spectrum`'s unit cell.
const CELL_FIELD: &str = "record.spectrum.cell_particles";

impl SpectrumSpec {
    /// The chain linearised, and its unit cell when asked for: errors name the field
    /// (`physics.…` where the chain has no static state to linearise about).
    fn linearise(&self, chain: &Chain) -> Result<(LinearChain, Option<UnitCell>), SpecError> {
        let lin = LinearChain::of(chain).map_err(|e| SpecError {
            message: format!(
                "record.spectrum asks for the linear spectrum: {}",
                e.message
            ),
            ..e
        })?;
        let cell = match self.cell_particles {
            Some(p) => Some(lin.unit_cell(p, CELL_FIELD)?),
            None => None,
        };
        Ok((lin, cell))
    }

    /// Checks the record option against a built chain.
    pub fn validate(&self, chain: &Chain) -> Result<(), SpecError> {
        self.linearise(chain).map(|_| ())
    }

    /// The recorded scalars: the lowest and highest natural frequency (two eigenvalues, `O(N)`
    /// each) and, for a periodic chain, the first gap's edges and the top band's upper edge.
    pub fn summarise(&self, chain: &Chain) -> Result<SpectrumSummary, SpecError> {
        let (lin, cell) = self.linearise(chain)?;
        let n = lin.len();
        let hz = |w: f64| w / (2.0 * std::f64::consts::PI);
        let at = |j: usize| hz(lin.spectrum_range(j, 1, false).angular_frequency_rad_s[0]);
        let mut out = SpectrumSummary {
            lowest_frequency_hz: at(0),
            highest_frequency_hz: at(n - 1),
            ..SpectrumSummary::NAN
        };
        if let Some(cell) = cell {
            if let Some(&(lower, upper)) = cell.gaps().first() {
                out.gap_lower_hz = hz(lower);
                out.gap_upper_hz = hz(upper);
            }
            out.band_top_hz = cell.bands().last().map_or(f64::NAN, |b| hz(b.upper_rad_s));
        }
        Ok(out)
    }
}

/// The chain linearised about its static state.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearChain {
    /// Index (0-based, in the chain) of the particle of row 0: 1 after a striker, else 0.
    pub first_particle: usize,
    /// Mass of each row's particle, kg.
    pub mass: Vec<f64>,
    /// Stiffness `k_i` of the contact between rows `i` and `i + 1`, N/m.
    pub stiffness: Vec<f64>,
    /// Damping `c_i` of the contact between rows `i` and `i + 1`, kg/s.
    pub damping: Vec<f64>,
    /// Stiffness of the last particle's wall contact, N/m (0 without a wall).
    pub wall_stiffness: f64,
    /// Damping of the wall contact, kg/s.
    pub wall_damping: f64,
    /// Stiffness of the first particle's contact with a wall at the top, N/m (0 without one).
    pub top_stiffness: f64,
    /// Damping of the top wall's contact, kg/s.
    pub top_damping: f64,
    /// Whether the last row is a mounted wall ([`crate::chain::mount::WallMount`]): its contact
    /// with the last particle is then `stiffness`'s last entry, and `wall_stiffness` and
    /// `wall_damping` its spring and dashpot.
    pub mounted_wall: bool,
}

/// Natural frequencies and, when asked for, mode shapes.
#[derive(Debug, Clone, PartialEq)]
pub struct Spectrum {
    /// Index (0-based, in the chain) of the particle of row 0 of each mode.
    pub first_particle: usize,
    /// Angular frequencies `ω_j`, rad/s, increasing.
    pub angular_frequency_rad_s: Vec<f64>,
    /// Mode shapes, mode `j`'s displacement of row `i` at `modes[j * N + i]`, orthonormal in the
    /// mass inner product (`vᵀ M v = 1` kg), their largest component positive.
    pub modes: Option<Vec<f64>>,
}

/// An eigenvalue `λ = re + i·im` of the damped problem, 1/s: a mode `e^{λt}` decays at `−re` and
/// oscillates at `|im|` rad/s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DampedEigenvalue {
    /// Real part, 1/s (negative: decaying).
    pub re: f64,
    /// Imaginary part, rad/s.
    pub im: f64,
}

/// How the damped eigenvalues were found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DampedMethod {
    /// No damping: `±iω_j`.
    Undamped,
    /// `C = α K`: each undamped mode `j` is a damped oscillator of ratio `ζ_j = α ω_j / 2`.
    Proportional,
    /// The dense companion matrix (`N ≤` [`DENSE_DAMPED_LIMIT`]).
    Companion,
}

impl LinearChain {
    /// Linearises a built chain about its static state. Refused, naming the field, when no contact
    /// is statically compressed: without a wall (`physics.wall`: nothing holds the chain still),
    /// or on a wall without gravity or precompression (`physics.precompression_force_n`).
    pub fn of(chain: &Chain) -> Result<LinearChain, SpecError> {
        if chain.ring {
            return Err(spec_err(
                "chain.ring",
                "a ring's stiffness matrix is not tridiagonal (its closing contact couples the ends): the bands of a periodic chain are those of its unit cell: record a straight chain's spectrum with record.spectrum.cell_particles",
            ));
        }
        if !chain.wall {
            return Err(spec_err(
                "physics.wall",
                "the linear spectrum is taken about the static state on the wall; without a wall nothing holds the chain (it falls freely under gravity) and no contact is compressed",
            ));
        }
        let f = chain.first_chain_particle();
        let n = chain.n_particles();
        let linear = |c: usize| {
            let p = chain.contact_params(c);
            general_derivatives::<POWER, true, true>(
                &p,
                chain.static_overlap[c],
                0.0,
                chain.clip_tensile,
            )
        };
        let (mut stiffness, mut damping): (Vec<f64>, Vec<f64>) = (f..n - 1).map(linear).unzip();
        let (mut wall_stiffness, mut wall_damping) = linear(n - 1);
        let (top_stiffness, top_damping) = match chain.top_wall_m {
            Some(_) => linear(chain.n_contacts() - 1),
            None => (0.0, 0.0),
        };
        if wall_stiffness == 0.0 && stiffness.iter().all(|&k| k == 0.0) {
            return Err(spec_err(
                "physics.precompression_force_n",
                "no contact is statically compressed (no precompression and no gravity): a contact's linear stiffness dF/dδ at zero overlap is zero, so every mode would be a zero mode; give physics.precompression_force_n > 0 or turn physics.gravity on",
            ));
        }
        let mut mass = chain.mass[f..].to_vec();
        if let Some(m) = chain.wall_mount {
            stiffness.push(wall_stiffness);
            damping.push(wall_damping);
            mass.push(m.mass_kg);
            (wall_stiffness, wall_damping) = (m.stiffness_n_m, m.damping_kg_s);
        }
        Ok(LinearChain {
            first_particle: f,
            mounted_wall: chain.wall_mount.is_some(),
            mass,
            stiffness,
            damping,
            wall_stiffness,
            wall_damping,
            top_stiffness,
            top_damping,
        })
    }

    /// Rows (particles) `N`.
    pub fn len(&self) -> usize {
        self.mass.len()
    }

    /// Whether there are no rows (never for a built chain).
    pub fn is_empty(&self) -> bool {
        self.mass.is_empty()
    }

    /// `M^{−1/2} X M^{−1/2}` of the tridiagonal `X` of contact coefficients `x` (wall: `x_wall`,
    /// top wall: `x_top`).
    fn scaled(&self, x: &[f64], x_wall: f64, x_top: f64) -> SymTridiagonal {
        let n = self.len();
        let diag = (0..n)
            .map(|i| {
                let above = if i > 0 { x[i - 1] } else { x_top };
                let below = if i + 1 < n { x[i] } else { x_wall };
                (above + below) / self.mass[i]
            })
            .collect();
        let off = (0..n - 1)
            .map(|i| -x[i] / (self.mass[i] * self.mass[i + 1]).sqrt())
            .collect();
        SymTridiagonal::new(diag, off)
    }

    /// The symmetric tridiagonal `A = M^{−1/2} K M^{−1/2}`, whose eigenvalues are `ω²`.
    pub fn reduced_stiffness(&self) -> SymTridiagonal {
        self.scaled(&self.stiffness, self.wall_stiffness, self.top_stiffness)
    }

    /// The natural frequencies of indices `first..first + count` (0 the lowest), with their mode
    /// shapes when `modes`.
    pub fn spectrum_range(&self, first: usize, count: usize, modes: bool) -> Spectrum {
        let a = self.reduced_stiffness();
        let lambdas = a.eigenvalues(first, count);
        let shapes = modes.then(|| {
            let n = self.len();
            let mut u = a.eigenvectors(&lambdas);
            for col in u.chunks_mut(n) {
                for (v, m) in col.iter_mut().zip(&self.mass) {
                    *v /= m.sqrt();
                }
            }
            u
        });
        Spectrum {
            first_particle: self.first_particle,
            angular_frequency_rad_s: lambdas.iter().map(|l| l.max(0.0).sqrt()).collect(),
            modes: shapes,
        }
    }

    /// All `N` natural frequencies, with their mode shapes when `modes`.
    pub fn spectrum(&self, modes: bool) -> Spectrum {
        self.spectrum_range(0, self.len(), modes)
    }

    /// The `2N` eigenvalues of the damped problem `(λ² M + λ C + K) x = 0`, sorted by frequency
    /// (`im`) then decay. With `C = α K` (to 1e-12) exactly, mode by mode: `ζ_j = α ω_j / 2`,
    /// `λ = −ζ_j ω_j ± i ω_j √(1 − ζ_j²)` (overdamped: two real roots `−ζ_j ω_j ± ω_j √(ζ_j² − 1)`),
    /// for any `N`. Otherwise by the dense companion matrix, for `N ≤` [`DENSE_DAMPED_LIMIT`];
    /// beyond it the error names `field`.
    pub fn damped_eigenvalues(
        &self,
        field: &str,
    ) -> Result<(Vec<DampedEigenvalue>, DampedMethod), SpecError> {
        let undamped = self.wall_damping == 0.0
            && self.top_damping == 0.0
            && self.damping.iter().all(|&c| c == 0.0);
        let alpha = self.proportional_damping();
        let (mut out, method) = if undamped || alpha.is_some() {
            let alpha = alpha.unwrap_or(0.0);
            let mut out = Vec::with_capacity(2 * self.len());
            for w in self.spectrum(false).angular_frequency_rad_s {
                let zeta = 0.5 * alpha * w;
                if zeta < 1.0 {
                    let wd = w * (1.0 - zeta * zeta).sqrt();
                    out.push(DampedEigenvalue {
                        re: -zeta * w,
                        im: -wd,
                    });
                    out.push(DampedEigenvalue {
                        re: -zeta * w,
                        im: wd,
                    });
                } else {
                    let s = w * (zeta * zeta - 1.0).sqrt();
                    for re in [-zeta * w - s, -zeta * w + s] {
                        out.push(DampedEigenvalue { re, im: 0.0 });
                    }
                }
            }
            let method = if undamped {
                DampedMethod::Undamped
            } else {
                DampedMethod::Proportional
            };
            (out, method)
        } else {
            (self.companion_eigenvalues(field)?, DampedMethod::Companion)
        };
        out.sort_by(|x, y| x.im.total_cmp(&y.im).then(y.re.total_cmp(&x.re)));
        Ok((out, method))
    }

    /// `α` with `c = α k` on every contact (the wall's included), when there is one.
    fn proportional_damping(&self) -> Option<f64> {
        let pairs = || {
            self.stiffness.iter().zip(&self.damping).chain([
                (&self.wall_stiffness, &self.wall_damping),
                (&self.top_stiffness, &self.top_damping),
            ])
        };
        let (k0, c0) = pairs().find(|(&k, _)| k > 0.0)?;
        let alpha = c0 / k0;
        pairs()
            .all(|(&k, &c)| {
                (c - alpha * k).abs() <= PROPORTIONAL_TOLERANCE * c.abs().max(alpha * k)
            })
            .then_some(alpha)
    }

    /// The damped eigenvalues from the companion matrix of the mass-scaled problem.
    pub fn companion_eigenvalues(&self, field: &str) -> Result<Vec<DampedEigenvalue>, SpecError> {
        let n = self.len();
        if n > DENSE_DAMPED_LIMIT {
            return Err(spec_err(
                field,
                format!(
                    "the damping is not proportional to the stiffness (c = α k on every contact), so the damped eigenvalues need the dense companion matrix, limited to {DENSE_DAMPED_LIMIT} particles; the chain has {n}"
                ),
            ));
        }
        let a = self.reduced_stiffness();
        let c = self.scaled(&self.damping, self.wall_damping, self.top_damping);
        let m = 2 * n;
        let mut z = vec![0.0; m * m];
        for i in 0..n {
            z[i * m + n + i] = 1.0;
            z[(n + i) * m + i] = -a.diag[i];
            z[(n + i) * m + n + i] = -c.diag[i];
            if i + 1 < n {
                z[(n + i) * m + i + 1] = -a.off[i];
                z[(n + i + 1) * m + i] = -a.off[i];
                z[(n + i) * m + n + i + 1] = -c.off[i];
                z[(n + i + 1) * m + n + i] = -c.off[i];
            }
        }
        let w = damped::real_eigenvalues(&mut z, m).ok_or_else(|| {
            spec_err(
                field,
                "the QR iteration for the damped eigenvalues did not converge",
            )
        })?;
        Ok(w.into_iter()
            .map(|(re, im)| DampedEigenvalue { re, im })
            .collect())
    }

    /// The unit cell of `particles` particles from row 0, checked against the whole chain: every
    /// row's mass and every contact's stiffness (the wall's aside, a boundary) must equal those one
    /// period earlier to [`PERIODIC_TOLERANCE`], over at least two cells. The error names `field`.
    pub fn unit_cell(&self, particles: usize, field: &str) -> Result<UnitCell, SpecError> {
        // A mounted wall's row is a boundary, as a rigid wall is.
        let n = self.len() - self.mounted_wall as usize;
        let p = particles;
        if p == 0 || 2 * p > n {
            return Err(spec_err(
                field,
                format!(
                    "a unit cell needs at least 1 particle and the chain at least two cells of it ({n} chain particles), got {p}"
                ),
            ));
        }
        let differs = |x: f64, y: f64| (x - y).abs() > PERIODIC_TOLERANCE * x.abs().max(y.abs());
        let first = self.first_particle + 1;
        for i in p..n {
            if differs(self.mass[i], self.mass[i - p]) {
                return Err(spec_err(
                    field,
                    format!(
                        "the chain is not periodic with a cell of {p} particles: particle {} has mass {} kg, particle {} (one cell earlier) {} kg",
                        i + first,
                        self.mass[i],
                        i - p + first,
                        self.mass[i - p]
                    ),
                ));
            }
        }
        for i in p..n - 1 {
            if differs(self.stiffness[i], self.stiffness[i - p]) {
                return Err(spec_err(
                    field,
                    format!(
                        "the chain is not periodic with a cell of {p} particles: contact {} has static stiffness {} N/m, contact {} (one cell earlier) {} N/m (gravity loads the contacts unequally; taper and disorder break the period)",
                        i + first,
                        self.stiffness[i],
                        i - p + first,
                        self.stiffness[i - p]
                    ),
                ));
            }
        }
        // The cell's last contact joins it to the next cell's first particle: with two cells or
        // more it is a contact between particles, never the wall's.
        UnitCell::new(self.mass[..p].to_vec(), self.stiffness[..p].to_vec(), field)
    }
}
