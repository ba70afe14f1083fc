//! The dissipation models of a contact ([`DissipationSpec`]: linear viscous, Kuwabara–Kono,
//! Hunt–Crossley, Tsuji) as the coefficients of one contact ([`Damping`]), and the exact two-body
//! relations that calibrate Hunt–Crossley's and Tsuji's from a coefficient of restitution. Apart
//! from the elastic laws because these are calibrations, solved once per chain, not kernels
//! evaluated at every step.

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

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

#[cfg(test)]
mod tests {
    use super::*;

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
}
