//! Thornton's elastic–perfectly-plastic contact (J. Appl. Mech. 64, 383, 1997): the law of one
//! contact with its history, its energies and its closed-form coefficient of restitution. Apart
//! because it is the one law with a memory (its history is part of the state), read by the
//! plastic right-hand side alone.

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
