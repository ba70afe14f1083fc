//! Contact laws and dissipation models, the one place their formulas live: the right-hand sides,
//! the Jacobian, the energy ledger and the probes all call these functions.
//!
//! Every contact `c` carries an elastic power law and up to three dissipative terms, all acting
//! only while the contact is compressed (overlap `δ > 0`):
//!
//! ```text
//! F = A δ^n + (μ + γ δ^{n−1} + λ δ^n + β δ^{(n−1)/2}) δ̇
//! ```
//!
//! - `A δ^n`, `n ≥ 1`: Hertz (`n = 3/2`, `A` from the geometry, Eqs. 1 and 4 of the paper) or an
//!   explicit power law (`n = 1`: a linear spring that cannot pull);
//! - `μ δ̇`: the paper's linear viscous term (Eqs. 8–12);
//! - `γ δ^{n−1} δ̇` with `γ = τ n A`: the viscoelastic (Kuwabara–Kono) term, `τ · dF_el/dt`; for
//!   Hertz contacts `(3/2) τ A δ^{1/2} δ̇`, the form of Kuwabara & Kono (1987) and Brilliantov et
//!   al. (1996), whose dissipative constant is `τ`;
//! - `λ δ^n δ̇` with `λ = α A`: Hunt & Crossley (1975), `α` from a coefficient of restitution at a
//!   reference impact velocity ([`hunt_crossley_alpha`]);
//! - `β δ^{(n−1)/2} δ̇` with `β = α √(m* A)` (`m*` the two bodies' reduced mass): Tsuji et al.
//!   (1992), whose two-body coefficient of restitution is the same at every impact velocity;
//!   `α` from that restitution ([`tsuji_alpha`]). For `n = 1` it is a constant, folded into `μ`.
//!
//! The specification of a contact's elastic law ([`LawSpec`]) and the closed forms shared by every
//! law are here; the rest lives in a file per family, apart because each is read and checked on
//! its own: `power_law` (the elastic power law `A δ^n`, Hertz's among them, and the force kernels
//! the right-hand sides, the Jacobian, the ledger and the probes call), `dissipation` (the
//! dissipation models and the two-body relations that calibrate them) and `thornton` (Thornton's
//! elastic–plastic law).

mod dissipation;
mod power_law;
mod thornton;

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

pub use dissipation::{
    hunt_crossley_alpha, hunt_crossley_restitution, tsuji_alpha, tsuji_restitution, Damping,
    DissipationSpec, TSUJI_INVERSION_TOLERANCE,
};
pub(crate) use power_law::{
    elastic_force, general_derivatives, general_force, general_force_on_side, hertz_force,
    hertz_potential_unscaled, overlap_at_force, paper_contact_derivatives, paper_contact_force,
    paper_contact_force_on_side, potential, ContactParams, HERTZ, LINEAR, POWER,
};
pub use thornton::{thornton_restitution, Thornton};

/// Elastic law of a contact, when the geometry's Hertz law is not wanted.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(
    feature = "serde",
    serde(rename_all = "snake_case", deny_unknown_fields)
)]
pub enum LawSpec {
    /// Hertz's law from the two bodies' radii of curvature and materials (Eqs. 1 and 4): the
    /// default for sphere–sphere and sphere–flat pairs.
    Hertz,
    /// `F = A δ^n`.
    PowerLaw {
        /// Coefficient `A`, N/m^n.
        coefficient: f64,
        /// Exponent `n`, in [1, 10] (1: a linear spring that cannot pull).
        exponent: f64,
    },
    /// Thornton's elastic–perfectly-plastic law (J. Appl. Mech. 64, 383, 1997) on the pair's
    /// Hertz geometry (sphere–sphere or sphere–flat): Hertz until the largest contact pressure
    /// reaches the yield pressure, then `F = F_y + π p_y R* (δ − δ_y)`; unloading and reloading
    /// along a Hertz curve of larger radius from the residual indentation, which the contact
    /// keeps. Exactly one of the two fields is given.
    Thornton {
        /// Limiting contact pressure `p_y`, Pa (> 0).
        #[cfg_attr(
            feature = "serde",
            serde(default, skip_serializing_if = "Option::is_none")
        )]
        yield_pressure_pa: Option<f64>,
        /// Relative impact velocity at which a two-body impact of the contact's bodies just
        /// reaches yield, m/s (> 0): `½ m* V_y² = ∫₀^{δ_y} F dδ = (2/5) F_y δ_y`, `m*` their
        /// reduced mass (the particle's mass at the wall).
        #[cfg_attr(
            feature = "serde",
            serde(default, skip_serializing_if = "Option::is_none")
        )]
        yield_velocity_m_s: Option<f64>,
    },
}

impl LawSpec {
    /// Checks the parameters; `field` is the dotted path of the spec (`….law`).
    pub fn validate(&self, field: &str) -> Result<(), crate::spec::SpecError> {
        use crate::spec::spec_err;
        match *self {
            LawSpec::Hertz => {}
            LawSpec::PowerLaw {
                coefficient,
                exponent,
            } => {
                crate::spec::check_positive(&format!("{field}.power_law.coefficient"), coefficient)?;
                if !(exponent.is_finite() && (1.0..=MAX_EXPONENT).contains(&exponent)) {
                    return Err(spec_err(
                        &format!("{field}.power_law.exponent"),
                        format!("must lie in [1, {MAX_EXPONENT}], got {exponent}"),
                    ));
                }
            }
            LawSpec::Thornton {
                yield_pressure_pa,
                yield_velocity_m_s,
            } => match (yield_pressure_pa, yield_velocity_m_s) {
                (Some(p), None) => {
                    if !(p.is_finite() && p > 0.0) {
                        return Err(spec_err(
                            &format!("{field}.thornton.yield_pressure_pa"),
                            format!("must be a finite number > 0, got {p}"),
                        ));
                    }
                }
                (None, Some(v)) => {
                    if !(v.is_finite() && v > 0.0) {
                        return Err(spec_err(
                            &format!("{field}.thornton.yield_velocity_m_s"),
                            format!("must be a finite number > 0, got {v}"),
                        ));
                    }
                }
                _ => {
                    return Err(spec_err(
                        &format!("{field}.thornton"),
                        "give exactly one of yield_pressure_pa (the limiting contact pressure, Pa) and yield_velocity_m_s (the impact velocity at yield, m/s)",
                    ))
                }
            },
        }
        Ok(())
    }
}

/// Largest exponent a power law may have.
pub const MAX_EXPONENT: f64 = 10.0;

/// `2 ∫₀¹ (1 − x^{n+1})^{−1/2} dx`: the duration of a two-body impact under `F = A δ^n` in units
/// of `δ_max / v` (`δ_max` the peak overlap, `v` the approach velocity). With `p = n + 1` it is
/// `2 Γ(1/p) Γ(1/2) / (p Γ(1/p + 1/2))`: π for `n = 1`, 2.943 for Hertz.
pub fn impact_duration_factor(n: f64) -> f64 {
    let p = n + 1.0;
    let ln = ln_gamma(1.0 / p) + 0.5 * std::f64::consts::PI.ln() - ln_gamma(1.0 / p + 0.5);
    2.0 * ln.exp() / p
}

/// `ln Γ(x)` for `x > 0` (Lanczos, g = 7, nine terms; relative error below 1e-14).
pub fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection: Γ(x) Γ(1 − x) = π / sin(πx).
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut s = C[0];
    for (i, &c) in C.iter().enumerate().skip(1) {
        s += c / (x + i as f64);
    }
    let t = x + G + 0.5;
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + s.ln()
}

/// A small, stable pseudo-random generator (SplitMix64, Steele, Lea & Flood 2014): the disorder
/// of a chain depends only on its seed, never on a dependency's version.
#[derive(Debug, Clone)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in [−1, 1), with 53 random bits.
    pub fn symmetric(&mut self) -> f64 {
        let u = (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        2.0 * u - 1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gamma_function_matches_known_values() {
        let pi = std::f64::consts::PI;
        assert!((ln_gamma(0.5) - 0.5 * pi.ln()).abs() < 1e-14);
        assert!((ln_gamma(1.0)).abs() < 1e-14);
        assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-13);
        assert!((ln_gamma(0.4).exp() - 2.218_159_543_757_688).abs() < 1e-13);
    }

    #[test]
    fn impact_duration_factor_closed_forms() {
        // n = 1: half a period of m ẍ = −A x, π δm / v.
        assert!((impact_duration_factor(1.0) - std::f64::consts::PI).abs() < 1e-13);
        // Hertz: (2/5)·2 B(2/5, 1/2) = 2.94304…
        let hertz =
            0.8 * 2.218_159_543_757_688 * std::f64::consts::PI.sqrt() / 1.068_628_702_119_319;
        assert!((impact_duration_factor(1.5) - hertz).abs() < 1e-12);
        // A quadrature of the defining integral for n = 2.5 (x = 1 − s² removes the singularity).
        let n = 2.5;
        let f = |s: f64| {
            let x: f64 = 1.0 - s * s;
            if s == 0.0 {
                2.0 / (n + 1.0f64).sqrt()
            } else {
                2.0 * s / (1.0 - x.powf(n + 1.0)).sqrt()
            }
        };
        let m = 20_000;
        let h = 1.0 / m as f64;
        let mut sum = f(0.0) + f(1.0);
        for i in 1..m {
            sum += f(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        let quad = 2.0 * sum * h / 3.0;
        assert!((impact_duration_factor(n) / quad - 1.0).abs() < 1e-9);
    }

    #[test]
    fn splitmix_is_the_reference_sequence() {
        // First outputs for seed 0 (the published reference values of SplitMix64).
        let mut r = SplitMix64(0);
        assert_eq!(r.next_u64(), 0xe220_a839_7b1d_cdaf);
        assert_eq!(r.next_u64(), 0x6e78_9e6a_a1b9_65f4);
        assert_eq!(r.next_u64(), 0x06c4_5d18_8009_454f);
        let mut r = SplitMix64(7);
        for _ in 0..1000 {
            let u = r.symmetric();
            assert!((-1.0..1.0).contains(&u));
        }
    }
}
