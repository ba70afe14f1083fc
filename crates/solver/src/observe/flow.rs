//! Where the energy went, contact by contact and particle by particle (`record.energy_flow`): the
//! work that has flowed into each contact from the side of the struck end, its largest value over
//! the run and its value at the end, and each particle's largest kinetic energy.
//!
//! **Energy through a contact.** Contact `c` joins the particle above it (towards the struck end,
//! the top of the chain) to the particle or the wall below it. Its force `F_c` (elastic and
//! dissipative, exactly as the equations of motion use it) does work on the body above at the rate
//! `−F_c v_above`, so energy flows from that body into the contact at the rate `P_c = F_c v_above`:
//! `W_c(t) = ∫₀ᵗ F_c v_above dt` is the energy that has passed into contact `c` from above. For a
//! striker's contact it is what the striker has given away; for the wall under the chain it is
//! the **energy that has reached the wall** (what the wall's contact stores and dissipates and, on
//! a mounted wall, what the mount takes); for a wall at the top, with nothing above it, it is the
//! energy that has reached that wall from particle 1, `∫ F (−v₁) dt`. A pulse that crosses the
//! contact and comes back after a reflection takes its energy back with it, so `W_c` rises, then
//! falls: its largest value is the energy the incident pulse carried past the contact, its value
//! at the end the net energy left below it (dissipated or still there).
//!
//! **Exactly to the integrator's tolerance.** `W_c` is integrated over every accepted step by
//! three-point Gauss–Legendre quadrature of the dense output (exact for polynomials of degree 5;
//! the integrand is smooth within a step, whose ends the integrators put at contacts' openings and
//! closings). Where the quadratic through the three nodes' powers falls through zero inside the
//! step, the running value peaks there: its largest value is searched by golden section on the
//! dense output, each value integrated by five-point Gauss–Legendre quadrature over the part of
//! the step before it. A particle's largest kinetic energy `m v²/2` is found among the step's ends
//! and nodes and, where the parabola through the largest and its neighbours peaks between them,
//! refined by a golden-section search of the dense output: not only where steps happen to end.

use crate::chain::model::Chain;
use crate::integrate::DenseStep;

use super::probes::{Preload, Probe, ProbeSet};

/// Gauss–Legendre nodes on [0, 1], three of them.
const NODES: [f64; 3] = [
    0.5 - 0.387_298_334_620_741_7, // 0.5 − √15/10
    0.5,
    0.5 + 0.387_298_334_620_741_7,
];
/// Their weights on [0, 1].
const WEIGHTS: [f64; 3] = [5.0 / 18.0, 8.0 / 18.0, 5.0 / 18.0];

/// Golden-section iterations of a peak's refinement: the bracket shrinks by 0.618⁴⁰ ≈ 4e-9 of a
/// step, far below what the dense output resolves.
const GOLDEN_ITERATIONS: usize = 40;

/// A step is searched for a new largest value (a contact's energy, a particle's kinetic energy)
/// when its estimate comes within this fraction of the largest so far: the estimates (the samples,
/// the interpolant's integral) are far closer than that to the values they estimate.
const PEAK_MARGIN: f64 = 1e-3;

/// Energies below this fraction of the excitation's energy scale are taken as the samples give
/// them, without a search: a chain's particles at rest, whose velocities are rounding noise, would
/// otherwise be searched at every step.
const NEGLIGIBLE: f64 = 1e-12;

/// What `record.energy_flow` gives a run.
#[derive(Debug, Clone, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct EnergyFlow {
    /// Largest energy that had passed into each contact from above at any time, J (contact
    /// order: neighbours, the wall under the chain or a ring's closing contact, the top wall).
    pub energy_passed_max_j: Vec<f64>,
    /// Energy that had passed into each contact from above by the end of the run, J.
    pub energy_passed_final_j: Vec<f64>,
    /// Largest kinetic energy of each particle over the run, J.
    pub max_kinetic_energy_j: Vec<f64>,
}

/// Integrates [`EnergyFlow`] along a run from its dense output.
pub(crate) struct FlowRecorder {
    /// Every contact's force, then every particle's velocity.
    probes: ProbeSet,
    n_contacts: usize,
    n_particles: usize,
    mass: Vec<f64>,
    /// The state component whose velocity each contact's power reads, and its sign (−1 for a wall
    /// at the top, where the flow is upwards).
    side: Vec<(usize, f64)>,
    components: Vec<usize>,
    state: Vec<f64>,
    /// The components at the three nodes, one row per node.
    batch: Vec<f64>,
    /// Each contact's power at the three nodes, contact-major.
    power: Vec<f64>,
    /// Each particle's velocity at the three nodes, particle-major.
    velocity: Vec<f64>,
    /// Each particle's largest squared velocity so far.
    max_v2: Vec<f64>,
    /// Each particle's velocity at the end of the last step.
    last_v: Vec<f64>,
    /// Energies below this are not searched for a peak ([`NEGLIGIBLE`] of the scale), J.
    negligible_j: f64,
    out: EnergyFlow,
}

impl FlowRecorder {
    /// The recorder of a run of `chain` whose excitation's energy scale is `energy_scale_j`.
    pub fn new(chain: &Chain, energy_scale_j: f64) -> Self {
        let (n_p, n_c) = (chain.n_particles(), chain.n_contacts());
        let list: Vec<Probe> = (1..=n_c)
            .map(|contact| Probe::ContactForce { contact })
            .chain((1..=n_p).map(|particle| Probe::Velocity { particle }))
            .collect();
        let probes = ProbeSet::new(chain, &list, Preload::Include, 1.0, 1.0, 1.0);
        let components = probes.components();
        let side = (0..n_c)
            .map(|c| {
                let e = chain.contact_ends(c);
                match (e.above, e.below) {
                    (Some(a), _) => (n_p + a, 1.0),
                    (None, Some(b)) => (n_p + b, -1.0),
                    (None, None) => unreachable!("a contact touches a particle"),
                }
            })
            .collect();
        FlowRecorder {
            state: vec![0.0; components.last().map_or(0, |i| i + 1)],
            batch: vec![0.0; NODES.len() * components.len()],
            components,
            probes,
            n_contacts: n_c,
            n_particles: n_p,
            mass: chain.mass.clone(),
            side,
            power: vec![0.0; NODES.len() * n_c],
            velocity: vec![0.0; NODES.len() * n_p],
            max_v2: vec![0.0; n_p],
            last_v: vec![0.0; n_p],
            negligible_j: NEGLIGIBLE * energy_scale_j,
            out: EnergyFlow {
                energy_passed_max_j: vec![0.0; n_c],
                energy_passed_final_j: vec![0.0; n_c],
                max_kinetic_energy_j: vec![0.0; n_p],
            },
        }
    }

    /// The initial state's kinetic energies (nothing has passed any contact yet).
    pub fn start(&mut self, y0: &[f64]) {
        let n = self.n_particles;
        for (m, &v) in self.max_v2.iter_mut().zip(&y0[n..2 * n]) {
            *m = m.max(v * v);
        }
        self.last_v.copy_from_slice(&y0[n..2 * n]);
    }

    /// One accepted step.
    pub fn step(&mut self, step: &dyn DenseStep) {
        let (t0, t1) = (step.t_start(), step.t_end());
        let h = t1 - t0;
        if h <= 0.0 {
            return;
        }
        let times = NODES.map(|tau| t0 + tau * h);
        let m = self.components.len();
        step.eval_components_at(&times, &self.components, &mut self.batch);
        let (n_c, n_p) = (self.n_contacts, self.n_particles);
        for (r, row) in self.batch.chunks_exact(m.max(1)).enumerate() {
            for (&i, &v) in self.components.iter().zip(row) {
                self.state[i] = v;
            }
            let state = &self.state;
            let get = |i: usize| state[i];
            for c in 0..n_c {
                let (index, sign) = self.side[c];
                self.power[3 * c + r] = sign * self.probes.value(c, &get) * state[index];
            }
            for i in 0..n_p {
                self.velocity[3 * i + r] = state[n_p + i];
            }
        }
        for c in 0..n_c {
            let p = &self.power[3 * c..3 * c + 3];
            let w0 = self.out.energy_passed_final_j[c];
            let w1 = w0 + h * (WEIGHTS[0] * p[0] + WEIGHTS[1] * p[1] + WEIGHTS[2] * p[2]);
            let mut best = w1;
            let peak = self.out.energy_passed_max_j[c];
            for tau in falling_roots(p) {
                let estimate = w0 + h * quadratic_integral(p, tau);
                if estimate < peak - PEAK_MARGIN * peak.abs() || estimate.abs() < self.negligible_j
                {
                    // No new largest value here, or none worth a search.
                    best = best.max(estimate);
                    continue;
                }
                // The power falls through zero inside the step: the running energy's largest
                // value, searched on the dense output around the interpolant's root and
                // integrated there by Gauss–Legendre quadrature over the part of the step before it.
                let (side, sign) = self.side[c];
                let probes = &self.probes;
                let power = |t: f64| {
                    let get = |i: usize| step.eval_component(t, i);
                    sign * probes.value(c, &get) * get(side)
                };
                let energy = |tau: f64| w0 + partial_integral(&power, t0, tau * h);
                let (lo, hi) = ((tau - 0.25).max(0.0), (tau + 0.25).min(1.0));
                best = best.max(golden_max(energy, lo, hi));
            }
            self.out.energy_passed_final_j[c] = w1;
            let peak = &mut self.out.energy_passed_max_j[c];
            *peak = peak.max(best);
        }
        let y1 = step.y_end();
        for i in 0..n_p {
            let v = &self.velocity[3 * i..3 * i + 3];
            let end = y1[n_p + i];
            let at = [t0, times[0], times[1], times[2], t1];
            let s = [
                self.last_v[i] * self.last_v[i],
                v[0] * v[0],
                v[1] * v[1],
                v[2] * v[2],
                end * end,
            ];
            self.last_v[i] = end;
            let k = (0..5).fold(0, |k, j| if s[j] > s[k] { j } else { k });
            // Nothing near the largest so far: no new peak here (the samples are a fifth of a
            // step apart, far closer than a peak's width at the integrator's tolerance).
            if s[k] < (1.0 - PEAK_MARGIN) * self.max_v2[i] {
                continue;
            }
            let mut top = s[k];
            if 0.5 * self.mass[i] * top < self.negligible_j {
                self.max_v2[i] = self.max_v2[i].max(top);
                continue;
            }
            // The parabola through the largest sample and its neighbours: a peak lies inside the
            // samples' span only if its vertex does (at the step's ends it may lie in the
            // neighbouring step, which looks at it itself).
            let (a, b) = match k {
                0 => (0, 2),
                4 => (2, 4),
                _ => (k - 1, k + 1),
            };
            if let Some(vertex) = vertex(&at[a..=b], &s[a..=b]) {
                let (lo, hi) = (at[k.saturating_sub(1)], at[(k + 1).min(4)]);
                if vertex > lo && vertex < hi {
                    let index = n_p + i;
                    let speed2 = |t: f64| {
                        let v = step.eval_component(t, index);
                        v * v
                    };
                    top = top.max(golden_max(speed2, lo, hi));
                }
            }
            self.max_v2[i] = self.max_v2[i].max(top);
        }
    }

    /// The result.
    pub fn finish(mut self) -> EnergyFlow {
        self.out.max_kinetic_energy_j = self
            .mass
            .iter()
            .zip(&self.max_v2)
            .map(|(m, v2)| 0.5 * m * v2)
            .collect();
        self.out
    }
}

/// The quadratic through the powers `p` at the three [`NODES`], as `a + b τ + c τ²` on [0, 1].
fn quadratic(p: &[f64]) -> (f64, f64, f64) {
    let [x0, x1, x2] = NODES;
    // Newton's divided differences, then expanded.
    let d01 = (p[1] - p[0]) / (x1 - x0);
    let d12 = (p[2] - p[1]) / (x2 - x1);
    let c = (d12 - d01) / (x2 - x0);
    let b = d01 - c * (x0 + x1);
    let a = p[0] - b * x0 - c * x0 * x0;
    (a, b, c)
}

/// `∫₀^τ` of the quadratic through `p`.
fn quadratic_integral(p: &[f64], tau: f64) -> f64 {
    let (a, b, c) = quadratic(p);
    tau * (a + tau * (b / 2.0 + tau * c / 3.0))
}

/// The points of (0, 1) where the quadratic through `p` falls through zero (the running integral's
/// interior maxima).
fn falling_roots(p: &[f64]) -> impl Iterator<Item = f64> {
    let (a, b, c) = quadratic(p);
    let roots: [Option<f64>; 2] = if c.abs() <= 1e-14 * (a.abs() + b.abs()) {
        [(b != 0.0).then(|| -a / b), None]
    } else {
        let disc = b * b - 4.0 * a * c;
        if disc < 0.0 {
            [None, None]
        } else {
            // The stable pair of roots.
            let q = -0.5 * (b + b.signum() * disc.sqrt());
            [(q != 0.0).then(|| q / c), (q != 0.0).then(|| a / q)]
        }
    };
    roots
        .into_iter()
        .flatten()
        .filter(move |&tau| tau > 0.0 && tau < 1.0 && b + 2.0 * c * tau < 0.0)
}

/// Largest value of `f` over `[lo, hi]` (where it has one peak), by golden-section search.
fn golden_max(f: impl Fn(f64) -> f64, lo: f64, hi: f64) -> f64 {
    const INV_PHI: f64 = 0.618_033_988_749_894_9;
    let (mut a, mut b) = (lo, hi);
    let mut x1 = b - INV_PHI * (b - a);
    let mut x2 = a + INV_PHI * (b - a);
    let (mut f1, mut f2) = (f(x1), f(x2));
    let mut best = f1.max(f2);
    for _ in 0..GOLDEN_ITERATIONS {
        if f1 > f2 {
            b = x2;
            x2 = x1;
            f2 = f1;
            x1 = b - INV_PHI * (b - a);
            f1 = f(x1);
            best = best.max(f1);
        } else {
            a = x1;
            x1 = x2;
            f1 = f2;
            x2 = a + INV_PHI * (b - a);
            f2 = f(x2);
            best = best.max(f2);
        }
    }
    best
}

/// `∫_{t0}^{t0 + len} power dt` by five-point Gauss–Legendre quadrature (exact for polynomials of
/// degree 9: to the dense output's accuracy on part of a step).
fn partial_integral(power: &impl Fn(f64) -> f64, t0: f64, len: f64) -> f64 {
    const X: [f64; 5] = [
        0.046_910_077_030_668,
        0.230_765_344_947_158_45,
        0.5,
        0.769_234_655_052_841_5,
        0.953_089_922_969_332,
    ];
    const W: [f64; 5] = [
        0.118_463_442_528_094_54,
        0.239_314_335_249_683_23,
        0.284_444_444_444_444_45,
        0.239_314_335_249_683_23,
        0.118_463_442_528_094_54,
    ];
    len * X
        .iter()
        .zip(&W)
        .map(|(&x, &w)| w * power(t0 + x * len))
        .sum::<f64>()
}

/// The abscissa of the vertex of the parabola through three points, when it opens downwards.
fn vertex(t: &[f64], s: &[f64]) -> Option<f64> {
    let d01 = (s[1] - s[0]) / (t[1] - t[0]);
    let d12 = (s[2] - s[1]) / (t[2] - t[1]);
    let c = (d12 - d01) / (t[2] - t[0]);
    // s ≈ s0 + d01 (t − t0) + c (t − t0)(t − t1): its derivative vanishes at the vertex.
    (c < 0.0).then(|| 0.5 * (t[0] + t[1]) - d01 / (2.0 * c))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The quadratic through the nodes integrates to the Gauss sum, and its roots are found.
    #[test]
    fn the_nodes_quadratic_is_the_gauss_rule() {
        let f = |t: f64| 3.0 - 10.0 * t + 4.0 * t * t;
        let p = NODES.map(f);
        let gauss: f64 = WEIGHTS.iter().zip(&p).map(|(w, v)| w * v).sum();
        assert!((quadratic_integral(&p, 1.0) - gauss).abs() < 1e-14);
        assert!((quadratic_integral(&p, 1.0) - (3.0 - 5.0 + 4.0 / 3.0)).abs() < 1e-14);
        // 4τ² − 10τ + 3 = 0: τ = (10 ± √52)/8; only the smaller lies in (0, 1), where it falls.
        let roots: Vec<f64> = falling_roots(&p).collect();
        assert_eq!(roots.len(), 1);
        assert!((roots[0] - (10.0 - 52f64.sqrt()) / 8.0).abs() < 1e-14);
        // A rising root is not a maximum.
        let q = NODES.map(|t| -f(t));
        assert_eq!(falling_roots(&q).count(), 0);
    }
}
