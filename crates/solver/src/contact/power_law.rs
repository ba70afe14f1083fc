//! The elastic power law `F = A δ^n` (Hertz's `n = 3/2` among them) and the force kernels built
//! on it: the paper's contact (Hertz with the linear viscous term, Eqs. 1–12) and the general
//! one (any exponent, every dissipation model), each with its derivatives, and the potential.
//! Apart because these are the kernels the right-hand sides, the Jacobian, the energy ledger and
//! the probes call at every step, whose arithmetic is pinned bit for bit.

use super::Damping;

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

#[cfg(test)]
mod tests {
    use super::*;

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
}
