//! Reference problems with known answers, shared by the tests, the benchmarks and the examples:
//! small chains built from the general description ([`SequenceSpec`]) and the closed forms they
//! are checked against (two-body impacts under power laws, coefficients of restitution of the
//! dissipation models, Nesterenko's solitary-wave speed, the sound speed of a precompressed chain).

use std::collections::BTreeMap;

use crate::chain::model::Material;
use crate::chain::sequence::{ContactRule, ParticleType, SequenceItem, SequenceSpec, SphereType};
use crate::contact::{impact_duration_factor, ln_gamma, DissipationSpec, LawSpec};
use crate::integrate::{
    Control, DenseStep, IntegrateError, IntegrationStats, Integrator, OdeSystem, OdeSystemDyn,
    StepObserver, Switch,
};

/// 440C steel (the paper's spheres).
pub const STEEL: Material = Material::STEEL_440C;

/// A sphere type of `diameter` m and `mass` kg.
pub fn sphere(material: Material, diameter_m: f64, mass_kg: f64) -> ParticleType {
    ParticleType::Sphere(SphereType {
        material,
        diameter_m,
        mass_kg: Some(mass_kg),
        density_kg_m3: None,
    })
}

/// `F = A δ^n`.
pub fn power_law(coefficient: f64, exponent: f64) -> LawSpec {
    LawSpec::PowerLaw {
        coefficient,
        exponent,
    }
}

/// A chain of the given types in `sequence`, an optional striker type, contact rules.
pub fn chain(
    types: &[(&str, ParticleType)],
    sequence: Vec<SequenceItem>,
    striker: Option<&str>,
    contacts: Vec<ContactRule>,
) -> SequenceSpec {
    SequenceSpec {
        particles: types
            .iter()
            .map(|(n, t)| (n.to_string(), *t))
            .collect::<BTreeMap<_, _>>(),
        sequence,
        striker: striker.map(str::to_string),
        wall_material: Material::STEEL_SS304,
        taper: None,
        disorder: None,
        contacts,
        top_wall_material: None,
        ring: false,
        wall_mount: None,
        mass_factors: Vec::new(),
        size_factors: Vec::new(),
    }
}

/// A rule giving every contact between types `a` and `b` the law and dissipation model.
pub fn rule(
    a: &str,
    b: &str,
    law: Option<LawSpec>,
    dissipation: Option<DissipationSpec>,
) -> ContactRule {
    ContactRule {
        between: [a.to_string(), b.to_string()],
        law,
        dissipation,
    }
}

/// `n` particles of type `name`.
pub fn repeat(n: usize, name: &str) -> SequenceItem {
    SequenceItem::Repeat(crate::chain::sequence::RepeatBlock {
        repeat: n,
        of: vec![SequenceItem::Type(name.to_string())],
    })
}

/// `n` identical spheres ("ball": 8 mm, 2.085 g, 440C) in contact under `law` (Hertz when
/// `None`), struck by one more of them when `striker`.
pub fn monodisperse(n: usize, law: Option<LawSpec>, striker: bool) -> SequenceSpec {
    let contacts = law
        .map(|l| {
            vec![
                rule("ball", "ball", Some(l), None),
                rule("ball", "wall", Some(l), None),
            ]
        })
        .unwrap_or_default();
    chain(
        &[("ball", sphere(STEEL, 8e-3, 2.085e-3))],
        vec![repeat(n, "ball")],
        striker.then_some("ball"),
        contacts,
    )
}

/// A step observer for the integrators' tests: the state at the last accepted step and every
/// step's interval, asserting that the steps are contiguous.
#[derive(Debug, Default)]
pub struct StepRecord {
    /// End of the last accepted step (the start before the first).
    pub t: f64,
    /// State at `t`.
    pub y: Vec<f64>,
    /// `(t_start, t_end)` of every accepted step.
    pub steps: Vec<(f64, f64)>,
}

impl StepObserver for StepRecord {
    fn on_start(&mut self, t0: f64, y0: &[f64]) {
        self.t = t0;
        self.y = y0.to_vec();
    }
    fn on_step(&mut self, step: &dyn DenseStep) -> Control {
        assert_eq!(step.t_start(), self.t, "steps must be contiguous");
        self.t = step.t_end();
        self.y.clear();
        self.y.extend_from_slice(step.y_end());
        self.steps.push((step.t_start(), step.t_end()));
        Control::Continue
    }
}

/// Integrates `sys` from `(0, y0)` to `t_end` with a budget of a million steps, recording the
/// steps ([`StepRecord`]).
pub fn run_recorded(
    solver: &dyn Integrator,
    sys: &mut dyn OdeSystemDyn,
    y0: &[f64],
    t_end: f64,
) -> (Result<IntegrationStats, IntegrateError>, StepRecord) {
    let mut rec = StepRecord::default();
    let r = solver.integrate(sys, 0.0, y0, t_end, 1_000_000, &mut rec);
    (r, rec)
}

/// The harmonic oscillator `x'' = −x` (state `[x, v]`, exact solution `x = cos t` from
/// `[1, 0]`), optionally with the quadrature `q' = x²` (`q = t/2 + sin(2t)/4`): a smooth problem
/// for the integrators' convergence and dense-output orders.
#[derive(Debug, Clone, Copy)]
pub struct HarmonicOscillator {
    /// Whether the state carries the quadrature `q' = x²`.
    pub quadrature: bool,
}

impl OdeSystem for HarmonicOscillator {
    fn n_pos(&self) -> usize {
        1
    }
    fn n_quad(&self) -> usize {
        usize::from(self.quadrature)
    }
    fn rhs(&mut self, _t: f64, y: &[f64], dy: &mut [f64]) {
        dy[0] = y[1];
        dy[1] = -y[0];
        if self.quadrature {
            dy[2] = y[0] * y[0];
        }
    }
}

/// The forced decay `y' = −y + sin t` (a lone quadrature component), whose solution from
/// `y(0) = 1` is [`ForcedDecay::exact`]: a smooth, non-autonomous problem for the integrators'
/// convergence and dense-output orders.
#[derive(Debug, Clone, Copy)]
pub struct ForcedDecay;

impl ForcedDecay {
    /// The solution from `y(0) = 1`: `1.5 e^{−t} + (sin t − cos t)/2`.
    pub fn exact(t: f64) -> f64 {
        1.5 * (-t).exp() + 0.5 * (t.sin() - t.cos())
    }
}

impl OdeSystem for ForcedDecay {
    fn n_pos(&self) -> usize {
        0
    }
    fn n_quad(&self) -> usize {
        1
    }
    fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]) {
        dy[0] = -y[0] + t.sin();
    }
}

/// `y' = y²` (a lone quadrature component), whose solution from `y(0) = y0 > 0` is
/// [`QuadraticGrowth::exact`], growing without bound towards `t = 1/y0`: a smooth nonlinear
/// problem whose derivatives all grow along the solution, for orders that linear problems
/// overstate (their error involves only some of a method's order conditions).
#[derive(Debug, Clone, Copy)]
pub struct QuadraticGrowth;

impl QuadraticGrowth {
    /// The solution from `y(0) = y0`: `1 / (1/y0 − t)`.
    pub fn exact(y0: f64, t: f64) -> f64 {
        1.0 / (1.0 / y0 - t)
    }
}

impl OdeSystem for QuadraticGrowth {
    fn n_pos(&self) -> usize {
        0
    }
    fn n_quad(&self) -> usize {
        1
    }
    fn rhs(&mut self, _t: f64, y: &[f64], dy: &mut [f64]) {
        dy[0] = y[0] * y[0];
    }
}

/// `x'' = c0 + c1 t`, a constant jerk, with the quadrature `q' = x` (state `[x, v, q]`): its
/// Taylor series ends at `t³` (`t⁴` for `q`), so a Taylor step's error is known exactly.
#[derive(Debug, Clone, Copy)]
pub struct ConstantJerk {
    /// Acceleration at `t = 0`.
    pub c0: f64,
    /// The jerk.
    pub c1: f64,
}

impl OdeSystem for ConstantJerk {
    fn n_pos(&self) -> usize {
        1
    }
    fn n_quad(&self) -> usize {
        1
    }
    fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]) {
        dy[0] = y[1];
        dy[1] = self.c0 + self.c1 * t;
        dy[2] = y[0];
    }
}

/// A sphere falling onto a Hertzian floor at `x = 0` while a force growing in time pushes it
/// up, `x'' = c t + k (−x)₊^{3/2}` (state `[x, v]`, one switch: `x`): the jerk `c` is what a
/// quadratic prediction of the floor's crossing misses, so that some steps aimed at it end a hair
/// before it. It counts its evaluations in a counter an observer can read while it runs.
#[derive(Debug, Clone)]
pub struct PushedFall {
    /// Growth rate of the push, m/s³.
    pub push_rate: f64,
    /// The floor's stiffness, m^{-1/2} s^{-2}.
    pub stiffness: f64,
    /// Evaluations of the right-hand side so far.
    pub evals: std::rc::Rc<std::cell::Cell<u64>>,
    switch: [Switch; 1],
}

impl PushedFall {
    /// The fall with push rate `c` onto a floor of stiffness `k`, its counter at zero.
    pub fn new(push_rate: f64, stiffness: f64) -> Self {
        PushedFall {
            push_rate,
            stiffness,
            evals: Default::default(),
            switch: [Switch::between(0, None)],
        }
    }
}

impl OdeSystem for PushedFall {
    fn n_pos(&self) -> usize {
        1
    }
    fn n_quad(&self) -> usize {
        0
    }
    fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]) {
        self.evals.set(self.evals.get() + 1);
        dy[0] = y[1];
        dy[1] = self.push_rate * t + self.stiffness * (-y[0]).max(0.0).powf(1.5);
    }
    fn switches(&self) -> &[Switch] {
        &self.switch
    }
}

/// Two-body impact of particle 1 (mass `m1`) at `v` on a free particle 2 (`m2`) under
/// `F = A δ^n`: the closed forms of its peak overlap, peak force and duration.
#[derive(Debug, Clone, Copy)]
pub struct PowerLawImpact {
    /// Peak overlap, m: `((n+1) μ v² / 2A)^{1/(n+1)}`, `μ` the reduced mass.
    pub peak_overlap_m: f64,
    /// Peak force `A δm^n`, N.
    pub peak_force_n: f64,
    /// Contact duration `2 δm/v · ∫₀¹ (1 − x^{n+1})^{−1/2} dx`, s.
    pub duration_s: f64,
}

impl PowerLawImpact {
    /// The closed form for masses `m1`, `m2`, law `(a, n)` and approach velocity `v`.
    pub fn new(m1: f64, m2: f64, a: f64, n: f64, v: f64) -> Self {
        let reduced = m1 * m2 / (m1 + m2);
        let peak = (0.5 * (n + 1.0) * reduced * v * v / a).powf(1.0 / (n + 1.0));
        PowerLawImpact {
            peak_overlap_m: peak,
            peak_force_n: a * peak.powf(n),
            duration_s: impact_duration_factor(n) * peak / v,
        }
    }
}

/// Kuwabara–Kono restitution of a two-body Hertz impact (law `A δ^{3/2}`, reduced mass `m`,
/// approach velocity `v`, relaxation time `τ`) to second order in `β = (3/2) τ (A/m)^{2/5} v^{1/5}`:
/// `ε = 1 − C₁β + C₂β² + O(β³)` (Schwager & Pöschel 1998; Ramírez, Pöschel, Brilliantov &
/// Schwager 1999), with `C₁ = √π Γ(3/5) / (2^{1/5} 5^{2/5} Γ(21/10)) = 1.153447`, the energy the
/// damper takes along the elastic trajectory, and `C₂ = (3/5) C₁² = 0.798258`. The remainder is
/// about `0.52 β³` (measured with this solver); valid for `β ≪ 1`.
pub fn kuwabara_kono_restitution(tau: f64, a: f64, m: f64, v: f64) -> f64 {
    let beta = 1.5 * tau * (a / m).powf(0.4) * v.powf(0.2);
    let c1 = (0.5 * std::f64::consts::PI.ln() + ln_gamma(0.6) - ln_gamma(2.1)).exp()
        / (2f64.powf(0.2) * 5f64.powf(0.4));
    1.0 - c1 * beta + 0.6 * c1 * c1 * beta * beta
}

/// Nesterenko's long-wave solitary-wave speed in a monodisperse chain of particles of mass `m`
/// and size `a` under `F = A δ^n`, for maximum particle velocity `v_m`:
/// `V = (2c²/(n+1))^{1/(n+1)} v_m^{(n−1)/(n+1)}` with `c² = A a^{n+1}/m`, which follows from
/// `V² = 2c² ξ_m^{n−1}/(n+1)` (the speed–amplitude relation of the long-wave solution) and
/// `v_m = V ξ_m`; for `n = 3/2` it is the paper's Eq. (13).
pub fn nesterenko_speed(a_coefficient: f64, n: f64, size_m: f64, mass_kg: f64, v_m: f64) -> f64 {
    let c2 = a_coefficient * size_m.powf(n + 1.0) / mass_kg;
    (2.0 * c2 / (n + 1.0)).powf(1.0 / (n + 1.0)) * v_m.powf((n - 1.0) / (n + 1.0))
}

/// Long-wave sound speed of a chain of particles of mass `m` and spacing `a` whose contacts are
/// preloaded to overlap `δ0` under `F = A δ^n`: `a √(n A δ0^{n−1} / m)`.
pub fn sound_speed(a_coefficient: f64, n: f64, overlap_m: f64, size_m: f64, mass_kg: f64) -> f64 {
    size_m * (n * a_coefficient * overlap_m.powf(n - 1.0) / mass_kg).sqrt()
}

/// Observes the contact between particles 1 and 2 of a two-body impact: its peak overlap (where
/// the relative velocity changes sign) and when it opens, both located on the dense output by
/// bisection, and the velocities at the end.
#[derive(Debug, Clone)]
pub struct ContactTimer {
    /// Number of particles (the velocities start at index `n`).
    pub n: usize,
    last_overlap: f64,
    /// When the contact opened, s.
    pub opened_at: Option<f64>,
    /// Peak overlap, m.
    pub peak_overlap: f64,
    /// Velocities of particles 1 and 2 when the contact opened.
    pub velocities_at_opening: (f64, f64),
}

impl ContactTimer {
    /// A timer for a chain of `n` particles.
    pub fn new(n: usize) -> Self {
        ContactTimer {
            n,
            last_overlap: 0.0,
            opened_at: None,
            peak_overlap: 0.0,
            velocities_at_opening: (f64::NAN, f64::NAN),
        }
    }
}

fn bisect_on(step: &dyn DenseStep, f: impl Fn(f64) -> f64) -> f64 {
    let (mut a, mut b) = (step.t_start(), step.t_end());
    for _ in 0..200 {
        let m = 0.5 * (a + b);
        if f(m) > 0.0 {
            a = m
        } else {
            b = m
        }
    }
    0.5 * (a + b)
}

impl StepObserver for ContactTimer {
    fn on_start(&mut self, _t0: f64, y0: &[f64]) {
        self.last_overlap = y0[0] - y0[1];
    }

    fn on_step(&mut self, step: &dyn DenseStep) -> Control {
        let n = self.n;
        let overlap = |t: f64| step.eval_component(t, 0) - step.eval_component(t, 1);
        let rel = |t: f64| step.eval_component(t, n) - step.eval_component(t, n + 1);
        let (t0, t1) = (step.t_start(), step.t_end());
        if rel(t0) > 0.0 && rel(t1) <= 0.0 {
            self.peak_overlap = overlap(bisect_on(step, rel));
        }
        let now = overlap(t1);
        if self.last_overlap > 0.0 && now <= 0.0 && self.opened_at.is_none() {
            let t = bisect_on(step, overlap);
            self.opened_at = Some(t);
            self.velocities_at_opening = (step.eval_component(t, n), step.eval_component(t, n + 1));
        }
        self.last_overlap = now;
        Control::Continue
    }
}

/// Complex arithmetic for the closed-form steady responses of driven linear chains,
/// `(K − ω²M + iωC) X = F`: a number as `(re, im)`, and the small dense solve the tests need.
pub mod complex {
    /// A complex number `(re, im)`.
    pub type C = (f64, f64);

    /// `a b`.
    pub fn mul(a: C, b: C) -> C {
        (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0)
    }

    /// `a / b`.
    pub fn div(a: C, b: C) -> C {
        let d = b.0 * b.0 + b.1 * b.1;
        ((a.0 * b.0 + a.1 * b.1) / d, (a.1 * b.0 - a.0 * b.1) / d)
    }

    /// `a − b`.
    pub fn sub(a: C, b: C) -> C {
        (a.0 - b.0, a.1 - b.1)
    }

    /// `|a|`.
    pub fn abs(a: C) -> f64 {
        a.0.hypot(a.1)
    }

    /// Solves `A x = b` by Gaussian elimination without pivoting: for the small, diagonally
    /// dominant enough systems of a chain driven below or between its resonances.
    #[allow(clippy::needless_range_loop)] // rows and columns of a dense matrix
    pub fn solve(mut a: Vec<Vec<C>>, mut b: Vec<C>) -> Vec<C> {
        let n = b.len();
        for k in 0..n {
            for i in k + 1..n {
                let f = div(a[i][k], a[k][k]);
                for j in k..n {
                    a[i][j] = sub(a[i][j], mul(f, a[k][j]));
                }
                b[i] = sub(b[i], mul(f, b[k]));
            }
        }
        let mut x = vec![(0.0, 0.0); n];
        for i in (0..n).rev() {
            let mut s = b[i];
            for j in i + 1..n {
                s = sub(s, mul(a[i][j], x[j]));
            }
            x[i] = div(s, a[i][i]);
        }
        x
    }
}
