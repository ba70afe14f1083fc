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

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

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

/// A dissipation model of a contact.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(
    feature = "serde",
    serde(rename_all = "snake_case", deny_unknown_fields)
)]
pub enum DissipationSpec {
    /// The paper's linear viscous term `μ δ̇` (Eqs. 8–12).
    LinearViscous {
        /// Coefficient μ, kg/s.
        damping_kg_s: f64,
    },
    /// Viscoelastic (Kuwabara–Kono) damping `τ · dF_el/dt = τ n A δ^{n−1} δ̇`; for Hertz contacts
    /// `(3/2) τ A δ^{1/2} δ̇`.
    KuwabaraKono {
        /// Dissipative (relaxation) time τ, s: Brilliantov et al.'s material constant `A`.
        relaxation_time_s: f64,
    },
    /// Hunt–Crossley damping `λ δ^n δ̇`, `λ = α A`, with `α` such that a two-body impact at
    /// `impact_velocity_m_s` has the given coefficient of restitution.
    HuntCrossley {
        /// Coefficient of restitution at the reference velocity, in (0, 1].
        restitution: f64,
        /// Reference impact (approach) velocity, m/s.
        impact_velocity_m_s: f64,
    },
    /// Tsuji et al.'s damping `α √(m* A) δ^{(n−1)/2} δ̇` (`m*` the reduced mass of the contact's
    /// two bodies, the particle's mass at the wall), with `α` such that a two-body impact has the
    /// given coefficient of restitution at every impact velocity.
    Tsuji {
        /// Coefficient of restitution, in (0, 1], the same at every impact velocity.
        restitution: f64,
    },
}

impl DissipationSpec {
    /// Checks the parameters; `field` is the dotted path of the spec.
    pub fn validate(&self, field: &str) -> Result<(), crate::spec::SpecError> {
        use crate::spec::spec_err;
        match *self {
            DissipationSpec::LinearViscous { damping_kg_s: v } => {
                if !(v.is_finite() && v >= 0.0) {
                    return Err(spec_err(
                        &format!("{field}.linear_viscous.damping_kg_s"),
                        format!("must be a finite number >= 0, got {v}"),
                    ));
                }
            }
            DissipationSpec::KuwabaraKono {
                relaxation_time_s: v,
            } => {
                if !(v.is_finite() && v >= 0.0) {
                    return Err(spec_err(
                        &format!("{field}.kuwabara_kono.relaxation_time_s"),
                        format!("must be a finite number >= 0, got {v}"),
                    ));
                }
            }
            DissipationSpec::HuntCrossley {
                restitution,
                impact_velocity_m_s,
            } => {
                if !(restitution.is_finite() && restitution > 0.0 && restitution <= 1.0) {
                    return Err(spec_err(
                        &format!("{field}.hunt_crossley.restitution"),
                        format!("must lie in (0, 1], got {restitution}"),
                    ));
                }
                if !(impact_velocity_m_s.is_finite() && impact_velocity_m_s > 0.0) {
                    return Err(spec_err(
                        &format!("{field}.hunt_crossley.impact_velocity_m_s"),
                        format!("must be a finite number > 0, got {impact_velocity_m_s}"),
                    ));
                }
            }
            DissipationSpec::Tsuji { restitution } => {
                if !(restitution.is_finite() && restitution > 0.0 && restitution <= 1.0) {
                    return Err(spec_err(
                        &format!("{field}.tsuji.restitution"),
                        format!("must lie in (0, 1], got {restitution}"),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Coefficients `(μ, γ, λ, β)` of this model on a contact with law `A δ^n` between bodies of
    /// reduced mass `reduced_mass` (kg), whose net force is clipped at zero when `clip`.
    pub fn coefficients(&self, a: f64, n: f64, reduced_mass: f64, clip: bool) -> Damping {
        match *self {
            DissipationSpec::LinearViscous { damping_kg_s } => Damping {
                linear: damping_kg_s,
                ..Damping::NONE
            },
            DissipationSpec::KuwabaraKono { relaxation_time_s } => Damping {
                viscoelastic: relaxation_time_s * n * a,
                ..Damping::NONE
            },
            DissipationSpec::HuntCrossley {
                restitution,
                impact_velocity_m_s,
            } => Damping {
                hunt_crossley: hunt_crossley_alpha(restitution, impact_velocity_m_s) * a,
                ..Damping::NONE
            },
            DissipationSpec::Tsuji { restitution } => {
                let beta = tsuji_alpha(restitution, n, clip) * (reduced_mass * a).sqrt();
                if n == 1.0 {
                    // δ^0 = 1: a constant damper, the linear viscous term.
                    Damping {
                        linear: beta,
                        ..Damping::NONE
                    }
                } else {
                    Damping {
                        tsuji: beta,
                        ..Damping::NONE
                    }
                }
            }
        }
    }
}

/// The dissipative coefficients of one contact: `F_d = (linear + viscoelastic δ^{n−1} +
/// hunt_crossley δ^n + tsuji δ^{(n−1)/2}) δ̇` while compressed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Damping {
    /// μ, kg/s.
    pub linear: f64,
    /// γ, coefficient of `δ^{n−1} δ̇`, N·s/m^n.
    pub viscoelastic: f64,
    /// λ, coefficient of `δ^n δ̇`, N·s/m^{n+1}.
    pub hunt_crossley: f64,
    /// β, coefficient of `δ^{(n−1)/2} δ̇`, N·s/m^{(n+1)/2} (zero where `n = 1`: there it is `μ`).
    pub tsuji: f64,
}

impl Damping {
    /// No dissipation.
    pub const NONE: Damping = Damping {
        linear: 0.0,
        viscoelastic: 0.0,
        hunt_crossley: 0.0,
        tsuji: 0.0,
    };
}

/// `g(z, e)/z²` with `g = ln(1 + z) − ln(1 − e z) − (1 + e) z`, whose root in `z = α v` is the
/// Hunt–Crossley relation below. Near `z = 0` the terms cancel to `O(z²)`, so there it is summed
/// as its series `Σ_{k≥2} z^{k−2} ((−1)^{k+1} + e^k)/k`, which keeps full relative precision up
/// to `e → 1`.
fn hunt_crossley_residual(z: f64, e: f64) -> f64 {
    if z < 0.1 {
        let mut sum = -0.5 * (1.0 - e) * (1.0 + e);
        let (mut zk, mut ek, mut sign) = (z, e * e * e, 1.0);
        for k in 3..60 {
            sum += zk * (sign + ek) / k as f64;
            zk *= z;
            ek *= e;
            sign = -sign;
            if zk < 1e-20 {
                break;
            }
        }
        sum
    } else {
        (z.ln_1p() - (-e * z).ln_1p() - (1.0 + e) * z) / (z * z)
    }
}

/// Bisection for the sign change of `f` on `(lo, hi)` where `f(lo) < 0 < f(hi)`.
fn bisect(f: impl Fn(f64) -> f64, mut lo: f64, mut hi: f64) -> f64 {
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if f(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Hunt–Crossley's `α` (s/m) for restitution `e` at impact velocity `v`: the root of the exact
/// two-body relation `α v (1 + e) = ln[(1 + α v)/(1 − e α v)]`, which follows from integrating
/// `m δ̈ = −A δ^n (1 + α δ̇)` once (`m v dv/(1 + α v) = −A δ^n dδ`) from `δ̇ = v` to `δ̇ = −e v`
/// (Carvalho & Martins, *Mech. Mach. Theory* 139, 2019). It holds for every exponent `n`, mass and
/// coefficient `A`, and for all `0 < e ≤ 1` (the force stays compressive during the impact). For
/// `e → 1` it reduces to Hunt & Crossley's own `α ≈ 3(1 − e)/(2v)`.
pub fn hunt_crossley_alpha(e: f64, v: f64) -> f64 {
    if e >= 1.0 {
        return 0.0;
    }
    // The residual is (e² − 1)/2 < 0 at z = 0 and → +∞ at z = 1/e: one root between.
    bisect(|z| hunt_crossley_residual(z, e), 0.0, 1.0 / e) / v
}

/// Coefficient of restitution of a two-body Hunt–Crossley impact with damping factor `alpha`
/// (s/m) at impact velocity `v`: the root `e` of the same exact relation.
pub fn hunt_crossley_restitution(alpha: f64, v: f64) -> f64 {
    let z = alpha * v;
    if z <= 0.0 {
        return 1.0;
    }
    // The residual grows with e: ln(1 + z)/z² − 1/z < 0 at e = 0, +∞ at e = 1/z, > 0 at e = 1.
    bisect(|e| hunt_crossley_residual(z, e), 0.0, (1.0 / z).min(1.0))
}

/// Step of the nondimensional two-body integration behind [`tsuji_restitution`], in units of the
/// impact's time scale (an impact lasts about 3 of them).
const TSUJI_STEP: f64 = 1e-3;
/// Longest nondimensional time a Tsuji impact is followed: an unclipped impact whose overlap has
/// not closed by then (damping so strong that the bodies creep apart) counts as `e = 0`.
const TSUJI_MAX_TIME: f64 = 200.0;
/// Tolerance of the inversion [`tsuji_alpha`]: `|e(α) − e|` below it, in the nondimensional
/// problem (whose own integration error is below 1e-11: halving the step moves `e` by less).
pub const TSUJI_INVERSION_TOLERANCE: f64 = 1e-12;

/// Acceleration of the nondimensional two-body Tsuji problem `x'' = −x^n − α x^{(n−1)/2} x'`.
#[inline]
fn tsuji_acceleration(x: f64, u: f64, alpha: f64, n: f64) -> f64 {
    let x = x.max(0.0);
    let (xn, xh) = if n == 1.5 {
        let r = x.sqrt();
        (x * r, r.sqrt())
    } else {
        (x.powf(n), x.powf(0.5 * (n - 1.0)))
    };
    -xn - alpha * xh * u
}

/// One classical Runge–Kutta step of length `h` of the nondimensional problem.
#[inline]
fn tsuji_step(x: f64, u: f64, h: f64, alpha: f64, n: f64) -> (f64, f64) {
    let a1 = tsuji_acceleration(x, u, alpha, n);
    let (x2, u2) = (x + 0.5 * h * u, u + 0.5 * h * a1);
    let a2 = tsuji_acceleration(x2, u2, alpha, n);
    let (x3, u3) = (x + 0.5 * h * u2, u + 0.5 * h * a2);
    let a3 = tsuji_acceleration(x3, u3, alpha, n);
    let (x4, u4) = (x + h * u3, u + h * a3);
    let a4 = tsuji_acceleration(x4, u4, alpha, n);
    (
        x + h / 6.0 * (u + 2.0 * u2 + 2.0 * u3 + u4),
        u + h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4),
    )
}

/// Coefficient of restitution of a two-body impact under Tsuji's damping with nondimensional
/// factor `alpha`, for the law `F = A δ^n`: with `δ = L x`, `t = T s`, `T = √(m*/(A L^{n−1}))` and
/// `L^{(n+1)/2} = v √(m*/A)` the impact `m* δ̈ = −A δ^n − α √(m* A) δ^{(n−1)/2} δ̇` becomes
/// `x'' = −x^n − α x^{(n−1)/2} x'`, `x(0) = 0`, `x'(0) = 1`, in which neither the velocity `v`, nor
/// the mass, nor `A` is left: `e` depends on `α` and `n` alone. It is integrated (classical
/// Runge–Kutta, step 1e-3, graded near `x = 0`) until the contact ends, under the solver's convention: without
/// clipping the force may pull at the end of unloading and the contact ends when the overlap
/// closes (`x = 0`); with clipping (`clip`) it ends when the net force `x^n + α x^{(n−1)/2} x'`
/// reaches zero, after which the bodies fly apart at that velocity. `e` is the separation speed
/// `−x'` at that moment.
pub fn tsuji_restitution(alpha: f64, n: f64, clip: bool) -> f64 {
    tsuji_restitution_with_step(alpha, n, clip, TSUJI_STEP)
}

/// [`tsuji_restitution`] with a given step (before its scaling by `1/α` for `α > 1`).
fn tsuji_restitution_with_step(alpha: f64, n: f64, clip: bool, step: f64) -> f64 {
    if alpha <= 0.0 {
        return 1.0;
    }
    // Zero or negative once the contact has ended.
    let end = |x: f64, u: f64| {
        if clip {
            x.max(0.0).powf(0.5 * (n + 1.0)) + alpha * u
        } else {
            x
        }
    };
    let h_max = step / alpha.max(1.0);
    let (mut x, mut u, mut t): (f64, f64, f64) = (0.0, 1.0, 0.0);
    let mut unloading = false;
    while t < TSUJI_MAX_TIME {
        // `x^{(n−1)/2}` is not smooth at x = 0, where the impact starts and (unclipped) ends:
        // there the steps are graded, 2 % of the time the overlap takes to open or close.
        let h = (0.02 * x / u.abs()).clamp(1e-10 * h_max, h_max);
        let (x1, u1) = tsuji_step(x, u, h, alpha, n);
        unloading |= u1 < 0.0;
        if unloading && end(x1, u1) <= 0.0 {
            // Locate the end inside the step: bisection on the length of a partial step.
            let (mut lo, mut hi) = (0.0, h);
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                let (xm, um) = tsuji_step(x, u, mid, alpha, n);
                if end(xm, um) > 0.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            return -tsuji_step(x, u, hi, alpha, n).1;
        }
        if unloading && u1 >= 0.0 {
            // Overdamped: the bodies stop before the overlap closes and creep apart.
            return 0.0;
        }
        (x, u, t) = (x1, u1, t + h);
    }
    0.0
}

/// Tsuji's nondimensional damping factor `α` for the coefficient of restitution `e` in (0, 1] on
/// a contact with law `F = A δ^n` (clipped at zero when `clip`): the root of
/// [`tsuji_restitution`]`(α, n, clip) = e`, bracketed (e falls monotonically from 1 at α = 0) and
/// found by regula falsi (Illinois) to [`TSUJI_INVERSION_TOLERANCE`]. The damping coefficient is
/// then `α √(m* A) δ^{(n−1)/2}`. Results are cached per `(e, n, clip)`: a chain of a million
/// contacts, or a grid over `e`, integrates each distinct problem once.
pub fn tsuji_alpha(e: f64, n: f64, clip: bool) -> f64 {
    use std::sync::Mutex;
    /// `(e, n)` as bits and `clip`: the key of one nondimensional problem.
    type Key = (u64, u64, bool);
    static CACHE: Mutex<Vec<(Key, f64)>> = Mutex::new(Vec::new());
    if e >= 1.0 {
        return 0.0;
    }
    let key = (e.to_bits(), n.to_bits(), clip);
    if let Some(&(_, alpha)) = CACHE
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .iter()
        .find(|(k, _)| *k == key)
    {
        return alpha;
    }
    let f = |alpha: f64| tsuji_restitution(alpha, n, clip) - e;
    let (mut lo, mut f_lo) = (0.0, 1.0 - e);
    let (mut hi, mut f_hi) = (1.0, f(1.0));
    while f_hi > 0.0 && hi < 1e12 {
        (lo, f_lo) = (hi, f_hi);
        hi *= 4.0;
        f_hi = f(hi);
    }
    let mut alpha = hi;
    let mut side = 0;
    for _ in 0..200 {
        let mut mid = (lo * f_hi - hi * f_lo) / (f_hi - f_lo);
        if !(mid > lo && mid < hi) {
            mid = 0.5 * (lo + hi);
        }
        let f_mid = f(mid);
        alpha = mid;
        if f_mid.abs() <= TSUJI_INVERSION_TOLERANCE || hi - lo <= 1e-15 * hi {
            break;
        }
        if f_mid > 0.0 {
            (lo, f_lo) = (mid, f_mid);
            if side == 1 {
                f_hi *= 0.5;
            }
            side = 1;
        } else {
            (hi, f_hi) = (mid, f_mid);
            if side == -1 {
                f_lo *= 0.5;
            }
            side = -1;
        }
    }
    let mut cache = CACHE.lock().unwrap_or_else(|p| p.into_inner());
    if cache.len() < 4096 {
        cache.push((key, alpha));
    }
    alpha
}

// ---------------------------------------------------------------------------------------------
// Thornton's elastic–perfectly-plastic contact (J. Appl. Mech. 64, 383, 1997).
// ---------------------------------------------------------------------------------------------

/// Thornton's elastic–perfectly-plastic law of one contact, its constants computed once from the
/// pair's effective modulus `E*`, effective radius `R*` and yield pressure `p_y`:
///
/// ```text
/// δ ≤ δ_y (never yielded):  F = (4/3) E* √R* δ^{3/2}          δ_y = (π p_y/(2E*))² R*
/// loading past yield:       F = F_y + π p_y R* (δ − δ_y)       F_y = (4/3) E* √R* δ_y^{3/2}
/// below the largest s:      F = F* ((δ − δ_p)/(s − δ_p))^{3/2}  F* = F(s) on the loading line
/// ```
///
/// The unloading (and reloading) curve is Hertz's with radius `R_p = 4 E* a*³/(3 F*)`, where the
/// contact radius at `s` is `a*² = (2F* + F_y)/(2π p_y) = R* s`; it passes through `(s, F*)`, so
/// `s − δ_p = a*²/R_p = 3F*/(4E* a*)`, and reaches zero at the residual indentation `δ_p`. The law
/// is continuous in `δ` and in `s`, and C¹ at yield (Hertz's slope there is `π p_y R*`).
///
/// Its history is one number per contact, held in the state as the gap `g = s − δ` between the
/// largest overlap reached and the present one: `ġ = −δ̇` except while loading on the plastic
/// line (`g ≤ 0` and `δ̇ > 0`), where `ġ = 0` and `g` stays exactly zero; it starts at
/// `δ_y − δ(0)` (`s = δ_y`: below yield the law is Hertz's, reversible). A second state, the
/// opening distance `o = δ − δ_p(s)` ([`Thornton::opening_rate`]), only marks where the contact
/// opens at its residual indentation, a switching function linear in the state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Thornton {
    /// Effective modulus `E*`, Pa.
    pub e_star: f64,
    /// Effective radius `R*`, m.
    pub r_star: f64,
    /// Yield (limiting contact) pressure `p_y`, Pa.
    pub yield_pressure: f64,
    /// Hertz coefficient `(4/3) E* √R*`, N/m^{3/2}.
    pub hertz: f64,
    /// Overlap at yield `δ_y`, m.
    pub yield_overlap: f64,
    /// Force at yield `F_y`, N.
    pub yield_force: f64,
    /// Slope of the plastic loading line `π p_y R*`, N/m.
    pub plastic_stiffness: f64,
}

impl Thornton {
    /// The law of a pair with effective modulus `e_star` (Pa) and radius `r_star` (m) that yields
    /// at contact pressure `yield_pressure` (Pa).
    pub fn new(e_star: f64, r_star: f64, yield_pressure: f64) -> Thornton {
        let pi = std::f64::consts::PI;
        let hertz = 4.0 / 3.0 * e_star * r_star.sqrt();
        let ratio = pi * yield_pressure / (2.0 * e_star);
        let yield_overlap = ratio * ratio * r_star;
        Thornton {
            e_star,
            r_star,
            yield_pressure,
            hertz,
            yield_overlap,
            yield_force: hertz * yield_overlap * yield_overlap.sqrt(),
            plastic_stiffness: pi * yield_pressure * r_star,
        }
    }

    /// The law whose two-body impact (reduced mass `reduced_mass`, kg) just reaches yield at the
    /// relative velocity `yield_velocity` (m/s): `½ m* V_y² = (2/5) F_y δ_y = (8/15) E* √R*
    /// δ_y^{5/2}`, so `δ_y = (15 m* V_y²/(16 E* √R*))^{2/5}` and `p_y = (2E*/π) √(δ_y/R*)`. (For a
    /// sphere on a rigid flat this is Thornton's `V_y = 1.56 (p_y⁵/(E*⁴ ρ))^{1/2}`; for two equal
    /// spheres the relative velocity is half of it.)
    pub fn from_yield_velocity(
        e_star: f64,
        r_star: f64,
        reduced_mass: f64,
        yield_velocity: f64,
    ) -> Thornton {
        let yield_overlap = (15.0 * reduced_mass * yield_velocity * yield_velocity
            / (16.0 * e_star * r_star.sqrt()))
        .powf(0.4);
        let p_y = 2.0 * e_star / std::f64::consts::PI * (yield_overlap / r_star).sqrt();
        Thornton::new(e_star, r_star, p_y)
    }

    /// Relative impact velocity at which a two-body impact of bodies of reduced mass
    /// `reduced_mass` just reaches yield, m/s.
    pub fn yield_velocity(&self, reduced_mass: f64) -> f64 {
        (0.8 * self.yield_force * self.yield_overlap / reduced_mass).sqrt()
    }

    /// Force on the plastic loading line at overlap `s ≥ δ_y`, N.
    #[inline(always)]
    fn loading_force(&self, s: f64) -> f64 {
        self.yield_force + self.plastic_stiffness * (s - self.yield_overlap)
    }

    /// Work done loading a contact from zero to its largest overlap `s ≥ δ_y`: `∫₀^s F dδ`, J.
    fn loading_work(&self, s: f64) -> f64 {
        let u = s - self.yield_overlap;
        0.4 * self.yield_force * self.yield_overlap
            + u * (self.yield_force + 0.5 * self.plastic_stiffness * u)
    }

    /// `(F*, s − δ_p)` of the unloading curve from the largest overlap `s > δ_y`.
    #[inline(always)]
    fn unloading(&self, s: f64) -> (f64, f64) {
        let f_max = self.loading_force(s);
        (
            f_max,
            0.75 * f_max / (self.e_star * (self.r_star * s).sqrt()),
        )
    }

    /// Residual indentation `δ_p` after unloading from the largest overlap `s`, m (zero below
    /// yield).
    pub fn residual_overlap(&self, s: f64) -> f64 {
        if s <= self.yield_overlap {
            0.0
        } else {
            s - self.unloading(s).1
        }
    }

    /// Force at overlap `overlap` with history gap `gap` (`s = δ + max(g, 0)`), N: never negative.
    #[inline(always)]
    pub fn force(&self, overlap: f64, gap: f64) -> f64 {
        let s = overlap + gap.max(0.0);
        if s <= self.yield_overlap {
            let d = overlap.max(0.0);
            return self.hertz * (d * d.sqrt());
        }
        if gap <= 0.0 {
            return self.loading_force(overlap);
        }
        let (f_max, w) = self.unloading(s);
        let x = overlap - (s - w);
        if x <= 0.0 {
            return 0.0;
        }
        let r = x / w;
        f_max * (r * r.sqrt())
    }

    /// `∂F/∂δ` at fixed largest overlap on the piece containing the state, N/m.
    pub fn stiffness(&self, overlap: f64, gap: f64) -> f64 {
        let s = overlap + gap.max(0.0);
        if s <= self.yield_overlap {
            return if overlap > 0.0 {
                1.5 * self.hertz * overlap.sqrt()
            } else {
                0.0
            };
        }
        if gap <= 0.0 {
            return self.plastic_stiffness;
        }
        let (f_max, w) = self.unloading(s);
        let x = overlap - (s - w);
        if x <= 0.0 {
            0.0
        } else {
            1.5 * f_max * (x / w).sqrt() / w
        }
    }

    /// Rate of the history gap `ġ`: zero while loading on the plastic line, `−δ̇` otherwise.
    #[inline(always)]
    pub fn gap_rate(overlap_rate: f64, gap: f64) -> f64 {
        if gap <= 0.0 && overlap_rate > 0.0 {
            0.0
        } else {
            -overlap_rate
        }
    }

    /// Rate of the opening distance `o = δ − δ_p(s)` (how far the contact is from opening at its
    /// residual indentation), a second history that only locates that opening for the adaptive
    /// integrators (the force reads `g`): `ȯ = δ̇ − δ_p'(s) ṡ`, with `ṡ = δ̇` while loading on the
    /// plastic line and zero otherwise. `δ_p = s − w`, `w = 3F*/(4E* a*)`, so
    /// `δ_p'(s) = 1 − w (π p_y R*/F* − 1/(2s))`.
    #[inline(always)]
    pub fn opening_rate(&self, overlap: f64, overlap_rate: f64, gap: f64) -> f64 {
        if gap <= 0.0 && overlap_rate > 0.0 && overlap > self.yield_overlap {
            let (f_max, w) = self.unloading(overlap);
            w * (self.plastic_stiffness / f_max - 0.5 / overlap) * overlap_rate
        } else {
            overlap_rate
        }
    }

    /// `(recoverable elastic energy, plastic work)` of the contact, J: the energy the unloading
    /// curve gives back from the present overlap, `(2/5) F (δ − δ_p)`, and the work the loading
    /// took that no unloading gives back, `∫₀^s F dδ − (2/5) F* (s − δ_p)`. Their rates sum to
    /// `F δ̇` on every piece, so the ledger closes with the plastic work as its own term.
    pub fn energies(&self, overlap: f64, gap: f64) -> (f64, f64) {
        let s = overlap + gap.max(0.0);
        if s <= self.yield_overlap {
            let d = overlap.max(0.0);
            return (0.4 * self.hertz * d * d * d.sqrt(), 0.0);
        }
        let (f_max, w) = self.unloading(s);
        let plastic = self.loading_work(s) - 0.4 * f_max * w;
        let x = (overlap - (s - w)).max(0.0);
        (0.4 * self.force(overlap, gap) * x, plastic)
    }

    /// Gap `g = s − δ` of a contact at overlap `overlap` that has never been loaded beyond it nor
    /// beyond yield (`s = δ_y`): the initial history.
    pub fn initial_gap(&self, overlap: f64) -> f64 {
        self.yield_overlap - overlap
    }
}

/// Thornton's closed-form coefficient of restitution of a two-body impact at relative velocity
/// `V_i` for `r = V_y/V_i`: `√(6√3/5) √(1 − r²/6) [r/(r + 2√(6/5 − r²/5))]^{1/4}` above yield
/// (`r < 1`), 1 below it. It is exact for the law of [`Thornton`] (the rebound energy
/// `(2/5) F* (s − δ_p)` over the impact's `½ m* V_i²`).
pub fn thornton_restitution(r: f64) -> f64 {
    if r >= 1.0 {
        return 1.0;
    }
    let r2 = r * r;
    (6.0 * 3f64.sqrt() / 5.0).sqrt()
        * (1.0 - r2 / 6.0).sqrt()
        * (r / (r + 2.0 * (1.2 - 0.2 * r2).sqrt())).powf(0.25)
}

/// Which elastic law a kernel is specialised on.
pub(crate) const HERTZ: u8 = 0;
/// Every contact linear (`n = 1`).
pub(crate) const LINEAR: u8 = 1;
/// Any exponent per contact.
pub(crate) const POWER: u8 = 2;

/// `(δ^n, δ^{n−1})` for an overlap `d ≥ 0` (zero where `d = 0`, but `δ^0 = 1` for the linear
/// law). `LAW` fixes `n` at 3/2 or 1; `POWER` reads it, taking the same arithmetic as the
/// specialised laws for those exponents so that every path gives the same bits.
#[inline(always)]
pub(crate) fn powers<const LAW: u8>(d: f64, n: f64) -> (f64, f64) {
    match LAW {
        HERTZ => {
            let r = d.sqrt();
            (d * r, r)
        }
        LINEAR => (d, 1.0),
        _ => {
            if n == 1.5 {
                let r = d.sqrt();
                (d * r, r)
            } else if n == 1.0 {
                (d, 1.0)
            } else if d > 0.0 {
                let p = d.powf(n);
                (p, p / d)
            } else {
                (0.0, 0.0)
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The paper's contact: Hertz with the linear viscous term (Eqs. 1–12), as its specialised
// kernels, its energy and its Jacobian compute it. Its arithmetic, `(A δ) √δ`, differs in the last
// bit from the general kernels' `A (δ √δ)` ([`powers`]); each is pinned bit for bit, so both are
// kept, here side by side.
// ---------------------------------------------------------------------------------------------

/// Hertz's law `F = A δ^{3/2}` for an overlap `d ≥ 0`, as the paper's kernels compute it.
#[inline(always)]
pub(crate) fn hertz_force(a: f64, d: f64) -> f64 {
    a * d * d.sqrt()
}

/// `A δ^{5/2}` for an overlap `d ≥ 0`: the Hertz potential `(2/5) A δ^{5/2}` without its factor
/// 2/5, which the energy applies once to the sum over contacts.
#[inline(always)]
pub(crate) fn hertz_potential_unscaled(a: f64, d: f64) -> f64 {
    a * d * d * d.sqrt()
}

/// Net force of one contact of the paper's chain and the power it dissipates: Hertz, with the
/// viscous term `μ Δv` while the contact is compressed (when `D`), clipped at zero so that the
/// contact cannot pull (when `C`).
#[inline(always)]
pub(crate) fn paper_contact_force<const D: bool, const C: bool>(
    a: f64,
    mu: f64,
    overlap: f64,
    rel_velocity: f64,
) -> (f64, f64) {
    // The viscous term acts only while the contact is compressed (paper, after Eq. 12).
    paper_contact_force_on_side::<D, C>(a, mu, overlap, rel_velocity, overlap > 0.0)
}

/// [`paper_contact_force`] on the compressed side of the contact (`compressed`: with the viscous
/// term) or the open side (without it), whichever side `overlap` is on: the elastic term is
/// continuous where the contact opens or closes, the viscous term jumps there. A step that lands
/// on that switch ends a hair past it, and holds the contact on its side before the crossing
/// there.
#[inline(always)]
pub(crate) fn paper_contact_force_on_side<const D: bool, const C: bool>(
    a: f64,
    mu: f64,
    overlap: f64,
    rel_velocity: f64,
    compressed: bool,
) -> (f64, f64) {
    let d = overlap.max(0.0);
    let elastic = hertz_force(a, d);
    if !D {
        let f = if C { elastic.max(0.0) } else { elastic };
        return (f, 0.0);
    }
    let c = if compressed { mu } else { 0.0 };
    let mut f = elastic + c * rel_velocity;
    if C {
        f = f.max(0.0);
    }
    (f, (f - elastic) * rel_velocity)
}

/// Derivatives `(∂F/∂δ, ∂F/∂Δv)` of [`paper_contact_force`] on the smooth piece containing the
/// state: `(3/2) A √δ` and `μ` while compressed (and, when clipped, while the force is positive),
/// zero otherwise.
#[inline(always)]
pub(crate) fn paper_contact_derivatives<const D: bool, const C: bool>(
    a: f64,
    mu: f64,
    overlap: f64,
    rel_velocity: f64,
) -> (f64, f64) {
    if overlap <= 0.0 {
        return (0.0, 0.0);
    }
    if C {
        let force = hertz_force(a, overlap) + if D { mu * rel_velocity } else { 0.0 };
        if force <= 0.0 {
            return (0.0, 0.0);
        }
    }
    (1.5 * a * overlap.sqrt(), if D { mu } else { 0.0 })
}

/// Parameters of one contact for the general kernels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ContactParams {
    pub a: f64,
    pub n: f64,
    pub damping: Damping,
}

/// Net force of one contact under the general law and the power its dissipative terms take out.
/// `T`: whether any contact of the chain carries Tsuji's term, the one whose power
/// `δ^{(n−1)/2} = √(δ^{n−1})` costs a square root the other terms do not need.
#[inline(always)]
pub(crate) fn general_force<const LAW: u8, const D: bool, const T: bool>(
    p: &ContactParams,
    overlap: f64,
    rel_velocity: f64,
    clip: bool,
) -> (f64, f64) {
    // Every dissipative term acts only while the contact is compressed.
    general_force_on_side::<LAW, D, T>(p, overlap, rel_velocity, clip, overlap > 0.0)
}

/// [`general_force`] on the compressed side of the contact (`compressed`: with its dissipative
/// terms) or the open side (without them), whichever side `overlap` is on; see
/// [`paper_contact_force_on_side`].
#[inline(always)]
pub(crate) fn general_force_on_side<const LAW: u8, const D: bool, const T: bool>(
    p: &ContactParams,
    overlap: f64,
    rel_velocity: f64,
    clip: bool,
    compressed: bool,
) -> (f64, f64) {
    let d = overlap.max(0.0);
    let (dn, dn1) = powers::<LAW>(d, p.n);
    let elastic = p.a * dn;
    if !D {
        return (if clip { elastic.max(0.0) } else { elastic }, 0.0);
    }
    let Damping {
        linear: mu,
        viscoelastic: gamma,
        hunt_crossley: lambda,
        tsuji: beta,
    } = p.damping;
    let c = if compressed {
        let c = mu + gamma * dn1 + lambda * dn;
        if T {
            c + beta * dn1.sqrt()
        } else {
            c
        }
    } else {
        0.0
    };
    let mut f = elastic + c * rel_velocity;
    if clip {
        f = f.max(0.0);
    }
    (f, (f - elastic) * rel_velocity)
}

/// Derivatives `(∂F/∂δ, ∂F/∂δ̇)` of [`general_force`] on the smooth piece containing the state:
/// zero for an open contact and for a clipped one.
#[inline(always)]
pub(crate) fn general_derivatives<const LAW: u8, const D: bool, const T: bool>(
    p: &ContactParams,
    overlap: f64,
    rel_velocity: f64,
    clip: bool,
) -> (f64, f64) {
    if overlap <= 0.0 {
        return (0.0, 0.0);
    }
    let (dn, dn1) = powers::<LAW>(overlap, p.n);
    let Damping {
        linear: mu,
        viscoelastic: gamma,
        hunt_crossley: lambda,
        tsuji: beta,
    } = p.damping;
    let dh = if D && T { dn1.sqrt() } else { 0.0 };
    let c = if D {
        let c = mu + gamma * dn1 + lambda * dn;
        if T {
            c + beta * dh
        } else {
            c
        }
    } else {
        0.0
    };
    if clip && p.a * dn + c * rel_velocity <= 0.0 {
        return (0.0, 0.0);
    }
    // d(δ^n)/dδ = n δ^{n−1}; d(δ^{n−1})/dδ = (n − 1) δ^{n−2} = (n − 1) δ^{n−1}/δ;
    // d(δ^{(n−1)/2})/dδ = ((n − 1)/2) δ^{(n−1)/2}/δ.
    let mut k = p.a * p.n * dn1;
    if D {
        let ddn1 = if LAW == LINEAR || p.n == 1.0 {
            0.0
        } else {
            (p.n - 1.0) * dn1 / overlap
        };
        k += (gamma * ddn1 + lambda * p.n * dn1) * rel_velocity;
        if T {
            k += beta * 0.5 * (p.n - 1.0) * dh / overlap * rel_velocity;
        }
    }
    (k, c)
}

/// Elastic potential `A δ^{n+1}/(n+1)` of a contact with overlap `d ≥ 0`.
#[inline(always)]
pub(crate) fn potential(a: f64, n: f64, d: f64) -> f64 {
    if n == 1.5 {
        0.4 * a * d * d * d.sqrt()
    } else if n == 1.0 {
        0.5 * a * d * d
    } else {
        a * d.powf(n + 1.0) / (n + 1.0)
    }
}

/// Elastic force `A δ^n` at overlap `d ≥ 0`.
pub(crate) fn elastic_force(a: f64, n: f64, d: f64) -> f64 {
    a * powers::<POWER>(d, n).0
}

/// Overlap at which the elastic force is `f ≥ 0`: `(f/A)^{1/n}`.
pub(crate) fn overlap_at_force(a: f64, n: f64, f: f64) -> f64 {
    if n == 1.5 {
        (f / a).powf(2.0 / 3.0)
    } else {
        (f / a).powf(1.0 / n)
    }
}

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
    fn hunt_crossley_relation_round_trips() {
        for e in [0.05, 0.3, 0.6, 0.9, 0.99, 0.9999] {
            for v in [0.1, 1.0, 7.0] {
                let a = hunt_crossley_alpha(e, v);
                let z = a * v;
                // z is the sign change of ln[(1 + z)/(1 − e z)] − z(1 + e), to 1e-10.
                let g = |z: f64| hunt_crossley_residual(z, e);
                assert!(
                    g(z * (1.0 - 1e-10)) < 0.0 && g(z * (1.0 + 1e-10)) > 0.0,
                    "e {e}"
                );
                // The series and the closed form of the residual agree where both are accurate.
                let closed = |z: f64| (z.ln_1p() - (-e * z).ln_1p() - (1.0 + e) * z) / (z * z);
                assert!((g(0.0999) - closed(0.0999)).abs() < 1e-9, "e {e}");
                assert!((hunt_crossley_restitution(a, v) - e).abs() < 1e-12, "e {e}");
            }
        }
        // Near e = 1 it is Hunt & Crossley's linearised relation.
        let e = 0.9999;
        assert!((hunt_crossley_alpha(e, 2.0) / (1.5 * (1.0 - e) / 2.0) - 1.0).abs() < 1e-3);
        assert_eq!(hunt_crossley_alpha(1.0, 2.0), 0.0);
    }

    #[test]
    fn tsuji_restitution_is_converged_and_inverted() {
        for n in [1.5, 1.25, 2.5] {
            for clip in [false, true] {
                for e in [0.05, 0.3, 0.7, 0.95, 0.999] {
                    let alpha = tsuji_alpha(e, n, clip);
                    let got = tsuji_restitution(alpha, n, clip);
                    assert!(
                        (got - e).abs() <= TSUJI_INVERSION_TOLERANCE,
                        "n {n} clip {clip} e {e}: {got}"
                    );
                    // Halving the step moves e by less than 1e-11.
                    let fine = tsuji_restitution_with_step(alpha, n, clip, 0.5 * TSUJI_STEP);
                    assert!(
                        (fine - got).abs() < 1e-11,
                        "n {n} clip {clip} e {e}: {fine} vs {got}"
                    );
                    eprintln!(
                        "n {n} clip {clip} e {e}: alpha {alpha}, halving {:e}",
                        fine - got
                    );
                }
            }
        }
        assert_eq!(tsuji_alpha(1.0, 1.5, false), 0.0);
        // Clipping ends the contact earlier, so the same α restitutes more.
        assert!(tsuji_restitution(1.0, 1.5, true) > tsuji_restitution(1.0, 1.5, false));
    }

    #[test]
    fn power_paths_agree_bitwise_with_the_specialised_laws() {
        for d in [0.0, 1e-9, 3.7e-6, 2e-3] {
            assert_eq!(powers::<POWER>(d, 1.5), powers::<HERTZ>(d, 1.5));
            assert_eq!(powers::<POWER>(d, 1.0), powers::<LINEAR>(d, 1.0));
            let (p, q) = powers::<POWER>(d, 2.25);
            assert_eq!(p, if d > 0.0 { d.powf(2.25) } else { 0.0 });
            if d > 0.0 {
                assert!((q / d.powf(1.25) - 1.0).abs() < 1e-14);
            }
        }
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
