//! The paper's equations of motion (Eqs. 2–12) as an [`OdeSystem`], specialised at compile time
//! on the physics a scene switches on, the energy and momentum ledgers of every chain, and the
//! dispatch from a built chain to its specialised right-hand side (the paper's, or one of
//! [`crate::motion::general::GeneralChainSystem`]'s for other laws, dissipation models and loads).

use chainsweep_cpu::{dispatch, Kernel, MulAdd};

use crate::chain::model::{Chain, ContactMap};
use crate::contact::{hertz_potential_unscaled, paper_contact_force, paper_contact_force_on_side};
use crate::integrate::{OdeSystem, Switch, Tridiagonal};

/// Right-hand side of the chain, specialised on gravity, damping, wall and tensile clipping so that
/// what a scene switches off is compiled out of the hot loop.
///
/// State: `[x (N), v (N), q]` where `q` holds, in order, the dissipated work (J) when `DAMPING`
/// and the wall impulse (N·s) when `WALL`.
#[derive(Debug, Clone)]
pub struct ChainSystem<const GRAVITY: bool, const DAMPING: bool, const WALL: bool, const CLIP: bool>
{
    inv_mass: Vec<f64>,
    stiffness: Vec<f64>,
    damping: Vec<f64>,
    gravity: f64,
    /// Net force of each interior contact, scratch for the accelerations.
    force: Vec<f64>,
    /// Power dissipated at each interior contact, scratch for the dissipated-work rate.
    power: Vec<f64>,
    /// Overlap of every contact as a switching function: the force is not smooth where it vanishes.
    switches: Vec<Switch>,
}

impl<const G: bool, const D: bool, const W: bool, const C: bool> ChainSystem<G, D, W, C> {
    /// Builds the system; panics if the chain's switches differ from the type's (a programming error:
    /// use [`crate::dispatch_chain_system`] to pick the type from a chain).
    pub fn new(chain: &Chain) -> Self {
        assert!(
            chain.is_paper_physics(),
            "ChainSystem is the paper's physics (Hertz laws, linear damping, no external force)"
        );
        assert_eq!(chain.wall, W, "wall switch mismatch");
        assert_eq!(chain.clip_tensile, C, "clip switch mismatch");
        assert_eq!(chain.gravity_m_s2 != 0.0, G, "gravity switch mismatch");
        let n = chain.n_particles();
        ChainSystem {
            inv_mass: chain.mass.iter().map(|m| 1.0 / m).collect(),
            stiffness: chain.stiffness.clone(),
            damping: chain.damping.clone(),
            gravity: chain.gravity_m_s2,
            force: vec![0.0; n],
            power: vec![0.0; n],
            switches: (0..chain.n_contacts())
                .map(|c| Switch::between(c, (c + 1 < n).then_some(c + 1)))
                .collect(),
        }
    }

    /// Stiffness of contact `c` (Hertz plus damper), N/m^{3/2} and kg/s, for the Jacobian.
    pub(crate) fn contact_parameters(&self, c: usize) -> (f64, f64) {
        (self.stiffness[c], self.damping[c])
    }

    /// Inverse masses, 1/kg.
    pub(crate) fn inverse_masses(&self) -> &[f64] {
        &self.inv_mass
    }
}

impl<const G: bool, const D: bool, const W: bool, const C: bool> OdeSystem
    for ChainSystem<G, D, W, C>
{
    fn n_pos(&self) -> usize {
        self.inv_mass.len()
    }

    fn n_quad(&self) -> usize {
        D as usize + W as usize
    }

    fn switches(&self) -> &[Switch] {
        &self.switches
    }

    /// Every switch is a contact's overlap (the wall's for the last), and an open contact carries
    /// no force, elastic or viscous.
    fn vanishes_below(&self, _switch: usize) -> bool {
        true
    }

    fn acceleration_jacobian(
        &self,
        t: f64,
        y: &[f64],
        kx: &mut Tridiagonal,
        kv: &mut Tridiagonal,
    ) -> bool {
        self.jacobian(t, y, kx, kv);
        true
    }

    #[inline]
    fn rhs(&mut self, _t: f64, y: &[f64], dy: &mut [f64]) {
        dispatch(RhsKernel { sys: self, y, dy });
    }

    /// Only the viscous term jumps where a contact opens or closes (the elastic force `A δ^{3/2}`
    /// is continuous there): held on one side, the contact acts as it does on that side.
    fn hold_switch(&self, switch: usize, positive: bool, y: &[f64], dy: &mut [f64]) {
        if !D {
            return;
        }
        let n = self.inv_mass.len();
        // Switch `c` is contact `c`'s overlap (the wall's for the last), positive when compressed.
        let c = switch;
        let (overlap, rel_velocity) = if c + 1 < n {
            (y[c] - y[c + 1], y[n + c] - y[n + c + 1])
        } else {
            (y[n - 1], y[2 * n - 1])
        };
        let (a, mu) = (self.stiffness[c], self.damping[c]);
        let (force, power) = paper_contact_force::<D, C>(a, mu, overlap, rel_velocity);
        let (held, held_power) =
            paper_contact_force_on_side::<D, C>(a, mu, overlap, rel_velocity, positive);
        let change = held - force;
        dy[n + c] -= change * self.inv_mass[c];
        if c + 1 < n {
            dy[n + c + 1] += change * self.inv_mass[c + 1];
        }
        // The quadratures: the dissipated work, then the wall impulse.
        dy[2 * n] += held_power - power;
        if W && c + 1 == n {
            dy[2 * n + 1] += change;
        }
    }
}

/// The right-hand side as a kernel compiled for the CPU's vector instructions at run time.
struct RhsKernel<'a, const G: bool, const D: bool, const W: bool, const C: bool> {
    sys: &'a mut ChainSystem<G, D, W, C>,
    y: &'a [f64],
    dy: &'a mut [f64],
}

impl<const G: bool, const D: bool, const W: bool, const C: bool> Kernel
    for RhsKernel<'_, G, D, W, C>
{
    type Output = ();
    #[inline(always)]
    fn run<M: MulAdd>(self) {
        self.sys.rhs_body(self.y, self.dy);
    }
}

impl<const G: bool, const D: bool, const W: bool, const C: bool> ChainSystem<G, D, W, C> {
    /// Eqs. (2)–(12): accelerations from the contact forces, and the quadratures.
    #[inline(always)]
    fn rhs_body(&mut self, y: &[f64], dy: &mut [f64]) {
        let n = self.inv_mass.len();
        let (x, rest) = y.split_at(n);
        let v = &rest[..n];
        let (dx, rest) = dy.split_at_mut(n);
        let (dv, dq) = rest.split_at_mut(n);

        // Interior contacts 0..n-1, contact c between particles c and c+1. Forces and the power
        // each contact dissipates come out of one vectorised pass; the power is summed in a second
        // pass over eight partial sums, since one running sum would serialise the first loop
        // (measured: 103 ns against 175 ns per evaluation of a 102-contact chain).
        const LANES: usize = 8;
        let m = n - 1;
        let force = &mut self.force[..m];
        let contact_power = &mut self.power[..m];
        let a = &self.stiffness[..m];
        let mu = &self.damping[..m];
        // `x' = v` is copied in the pass that reads `v` anyway (a separate copy was a memcpy
        // call per evaluation, 3.6 % of the reference run's instructions).
        let dx = &mut dx[..n];
        for c in 0..m {
            dx[c] = v[c];
            let (fc, p) =
                paper_contact_force::<D, C>(a[c], mu[c], x[c] - x[c + 1], v[c] - v[c + 1]);
            force[c] = fc;
            if D {
                contact_power[c] = p;
            }
        }
        let mut power = [0.0f64; LANES];
        if D {
            let chunks = contact_power.chunks_exact(LANES);
            power[0] = chunks.remainder().iter().sum();
            for chunk in chunks {
                for k in 0..LANES {
                    power[k] += chunk[k];
                }
            }
        }
        dx[m] = v[m];
        let (wall_force, wall_power) = if W {
            paper_contact_force::<D, C>(
                self.stiffness[n - 1],
                self.damping[n - 1],
                x[n - 1],
                v[n - 1],
            )
        } else {
            (0.0, 0.0)
        };

        let g = if G { self.gravity } else { 0.0 };
        let im = &self.inv_mass[..n];
        dv[0] = g - force[0] * im[0];
        for i in 1..n - 1 {
            dv[i] = g + (force[i - 1] - force[i]) * im[i];
        }
        dv[n - 1] = g + (force[n - 2] - wall_force) * im[n - 1];

        let mut k = 0;
        if D {
            dq[k] = power.iter().sum::<f64>() + wall_power;
            k += 1;
        }
        if W {
            dq[k] = wall_force;
        }
    }
}

/// Energy and momentum bookkeeping for a chain state, independent of the integrator.
#[derive(Debug, Clone)]
pub struct Ledger {
    mass: Vec<f64>,
    /// `Σ m`, summed once: the momentum residual needs it after every step.
    total_mass: f64,
    stiffness: Vec<f64>,
    /// Exponents of the contact laws, when any is not Hertz's 3/2.
    exponent: Option<Vec<f64>>,
    gravity: f64,
    wall: bool,
    /// What each contact joins.
    contacts: ContactMap,
    work_index: Option<usize>,
    wall_impulse_index: Option<usize>,
    /// Particle the external forces act on, the precompression force, and the force pulse
    /// `(amplitude, duration)` with the index of its work quadrature.
    top: usize,
    precompression: f64,
    pulse: Option<(f64, f64, usize)>,
    /// The index of a drive's work in the state, and of a force drive's impulse.
    drive_work: Option<usize>,
    drive_impulse: Option<usize>,
    /// The contacts with Thornton's law: `(contact, law, index of its history in the state)`.
    plastic: Vec<(usize, crate::contact::Thornton, usize)>,
    /// A mounted wall: the index of its displacement in the state, its mass, its spring's
    /// stiffness and the static force of the wall's contact.
    mount: Option<(usize, f64, f64, f64)>,
}

/// Energy terms of a state, J.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnergyTerms {
    /// Kinetic energy.
    pub kinetic: f64,
    /// Elastic potential `Σ A δ^{n+1}/(n+1)` over compressed contacts (`(2/5) A δ^{5/2}` for Hertz).
    pub elastic: f64,
    /// Gravitational potential `-g Σ m x` (x positive downwards).
    pub gravitational: f64,
    /// Work dissipated by the contacts' dissipative terms so far.
    pub dissipated: f64,
    /// Plastic work of the contacts with Thornton's law so far: the work their loading took that
    /// no unloading gives back (their `elastic` term is the recoverable part). Zero without them.
    pub plastic: f64,
    /// Minus the work of the external forces so far: `−F_p x_top` for the precompression (its
    /// potential) minus the work the force pulse or the drive has done. Zero without them.
    pub external: f64,
    /// A mounted wall's kinetic energy and its spring's energy over its loaded state (see
    /// [`crate::chain::mount`]). Zero without a mount.
    pub mount: f64,
    /// Largest contact overlap in the state, m (not an energy; computed in the same pass).
    pub max_overlap: f64,
}

impl EnergyTerms {
    /// The conserved total.
    pub fn total(&self) -> f64 {
        self.kinetic
            + self.elastic
            + self.gravitational
            + self.dissipated
            + self.external
            + self.plastic
            + self.mount
    }
}

impl Ledger {
    /// Ledger for a chain.
    pub fn new(chain: &Chain) -> Self {
        Ledger {
            mass: chain.mass.clone(),
            total_mass: chain.mass.iter().sum(),
            stiffness: chain.stiffness.clone(),
            exponent: (chain.exponent.iter().any(|&n| n != 1.5) || chain.has_plasticity())
                .then(|| chain.exponent.clone()),
            gravity: chain.gravity_m_s2,
            wall: chain.has_walls(),
            contacts: ContactMap::of(chain),
            work_index: chain.work_index(),
            wall_impulse_index: chain.wall_impulse_index(),
            top: chain.first_chain_particle(),
            precompression: chain.top_force_n(),
            pulse: chain
                .force_pulse
                .map(|(a, d)| (a, d, chain.external_work_index().expect("pulse quadrature"))),
            drive_work: chain.drive.as_ref().and(chain.external_work_index()),
            drive_impulse: chain
                .drive
                .as_ref()
                .filter(|d| d.point == crate::chain::drive::DrivePoint::Force)
                .and(chain.drive_state_index()),
            plastic: chain.plastic_contacts(),
            mount: chain.wall_mount.map(|m| {
                (
                    chain.mount_state_index().expect("a mount"),
                    m.mass_kg,
                    m.stiffness_n_m,
                    chain.static_force(chain.n_particles() - 1),
                )
            }),
        }
    }

    /// Energy terms of state `y`.
    pub fn energy(&self, y: &[f64]) -> EnergyTerms {
        self.energy_prefix(y, self.mass.len())
    }

    /// Energy terms of the first `k` particles of state `y` and of the contacts they touch (contact
    /// `k-1` included, read with particle `k`'s position in `y`; the wall's only when `k` is every
    /// particle): with `k = N`, [`Ledger::energy`]. The quadratures and external terms are the
    /// whole state's.
    pub fn energy_prefix(&self, y: &[f64], k: usize) -> EnergyTerms {
        dispatch(EnergyKernel { ledger: self, y, k })
    }

    #[inline(always)]
    fn energy_body(&self, y: &[f64], k: usize) -> EnergyTerms {
        // Evaluated after every accepted step: sums run over eight partial sums so they vectorise.
        const L: usize = 8;
        let n = self.mass.len();
        // Positions first; the overlap of a wall a drive moves reads its displacement further on.
        let x = y;
        let (v, m) = (&y[n..n + k], &self.mass[..k]);
        let (mut twice_kinetic, mut weight_moment) = ([0.0f64; L], [0.0f64; L]);
        let full = k - k % L;
        for i in (0..full).step_by(L) {
            for lane in 0..L {
                let j = i + lane;
                twice_kinetic[lane] += m[j] * v[j] * v[j];
                weight_moment[lane] += m[j] * x[j];
            }
        }
        for j in full..k {
            twice_kinetic[0] += m[j] * v[j] * v[j];
            weight_moment[0] += m[j] * x[j];
        }
        let sum = |lanes: [f64; L]| lanes.iter().sum::<f64>();
        let (mut elastic, max_overlap) = match &self.exponent {
            None => self.hertz_potential(x, k),
            Some(exponent) => self.general_potential(x, exponent, k),
        };
        let mut plastic = 0.0;
        if !self.plastic.is_empty() {
            (elastic, plastic) = self.plastic_potential(y, k);
        }
        let kinetic = 0.5 * sum(twice_kinetic);
        let mut mount = 0.0;
        if let Some((i, mass, stiffness, static_force)) = self.mount {
            // The mounted wall: its kinetic energy, and its spring's energy over its loaded state
            // (the work against the static force included), `F_s u + k u²/2`.
            let (u, w) = (y[i], y[i + 1]);
            mount = 0.5 * mass * w * w + u * (static_force + 0.5 * stiffness * u);
        }
        let gravitational = -self.gravity * sum(weight_moment);
        let dissipated = self.work_index.map_or(0.0, |w| y[w]);
        let mut external = 0.0;
        if self.precompression != 0.0 {
            external -= self.precompression * x[self.top];
        }
        if let Some((_, _, w)) = self.pulse {
            external -= y[w];
        }
        if let Some(w) = self.drive_work {
            external -= y[w];
        }
        EnergyTerms {
            kinetic,
            elastic,
            gravitational,
            dissipated,
            plastic,
            external,
            mount,
            max_overlap,
        }
    }

    /// Hertz potential `(2/5) Σ A δ^{5/2}` and the largest overlap, interior contacts then the
    /// wall's, of the contacts of the first `k` particles. Inlined into [`EnergyKernel`] so that its
    /// square roots run in the dispatched kernel's vector width (a square root is exact whatever
    /// the width: the same bits).
    #[inline(always)]
    fn hertz_potential(&self, x: &[f64], k: usize) -> (f64, f64) {
        const L: usize = 8;
        let n = self.mass.len();
        let interior = (n - 1).min(k);
        let a = &self.stiffness[..interior];
        let (mut potential, mut largest) = ([0.0f64; L], [0.0f64; L]);
        let full = interior - interior % L;
        for c0 in (0..full).step_by(L) {
            // Fixed-size windows (c0 + 8 <= interior <= n − 1, so nine positions are there): no
            // bounds check per element, so the lanes and their square roots vectorise (indexed
            // `x[c + 1]`, this loop ran scalar, 5 % of the reference run).
            let xs: [f64; L + 1] = x[c0..c0 + L + 1].try_into().expect("nine positions");
            let aw: [f64; L] = a[c0..c0 + L].try_into().expect("eight stiffnesses");
            for lane in 0..L {
                let d = (xs[lane] - xs[lane + 1]).max(0.0);
                potential[lane] += hertz_potential_unscaled(aw[lane], d);
                largest[lane] = largest[lane].max(d);
            }
        }
        for c in full..interior {
            let d = (x[c] - x[c + 1]).max(0.0);
            potential[0] += hertz_potential_unscaled(a[c], d);
            largest[0] = largest[0].max(d);
        }
        if k == n {
            for (c, &a) in self.stiffness.iter().enumerate().skip(interior) {
                let d = self.contacts.overlap(c, x).max(0.0);
                potential[0] += hertz_potential_unscaled(a, d);
                largest[0] = largest[0].max(d);
            }
        }
        let elastic = 0.4 * potential.iter().sum::<f64>();
        (elastic, largest.iter().fold(0.0f64, |a, &b| a.max(b)))
    }

    /// `Σ A δ^{n+1}/(n+1)` for any exponents, and the largest overlap, of the contacts of the
    /// first `k` particles.
    fn general_potential(&self, x: &[f64], exponent: &[f64], k: usize) -> (f64, f64) {
        let n = self.mass.len();
        let (mut elastic, mut largest) = (0.0f64, 0.0f64);
        let contacts = if k == n {
            self.stiffness.len()
        } else {
            k.min(n - 1)
        };
        for (c, (&a, &e)) in self.stiffness[..contacts].iter().zip(exponent).enumerate() {
            let d = self.contacts.overlap(c, x).max(0.0);
            elastic += crate::contact::potential(a, e, d);
            largest = largest.max(d);
        }
        (elastic, largest)
    }

    /// The elastic energy of a chain with Thornton's contacts, whose recoverable energy and
    /// plastic work come from their histories in the state `y`, and their plastic work: kept out
    /// of line, so that the ledger of every other chain compiles as it did.
    #[inline(never)]
    fn plastic_potential(&self, y: &[f64], k: usize) -> (f64, f64) {
        let n = self.mass.len();
        let exponent = self
            .exponent
            .as_deref()
            .expect("plastic chains keep their exponents");
        let (mut elastic, mut plastic) = (0.0f64, 0.0f64);
        let contacts = if k == n {
            self.stiffness.len()
        } else {
            k.min(n - 1)
        };
        let mut laws = self.plastic.iter().peekable();
        for (c, (&a, &e)) in self.stiffness[..contacts].iter().zip(exponent).enumerate() {
            let overlap = self.contacts.overlap(c, y);
            let d = overlap.max(0.0);
            match laws.next_if(|(pc, _, _)| *pc == c) {
                Some((_, law, h)) => {
                    let (recoverable, work) = law.energies(overlap, y[*h]);
                    elastic += recoverable;
                    plastic += work;
                }
                None => elastic += crate::contact::potential(a, e, d),
            }
        }
        (elastic, plastic)
    }

    /// Impulse of the external forces from `t0` to `t`, N·s.
    fn external_impulse(&self, t: f64, t0: f64) -> f64 {
        let mut j = self.precompression * (t - t0);
        if let Some((amplitude, duration, _)) = self.pulse {
            // The pulse starts at t = 0: ∫ F₀ sin(πs/T) ds = F₀ T/π (1 − cos(πs/T)).
            let phase = |s: f64| std::f64::consts::PI * s.clamp(0.0, duration) / duration;
            j += amplitude * duration / std::f64::consts::PI * (phase(t0).cos() - phase(t).cos());
        }
        j
    }

    /// Momentum balance residual `P(t) - P(0) - M g t - J_ext(t) + J_wall(t)`, N·s, which is zero
    /// for the exact solution (`J_wall` is the impulse the wall has taken, `J_ext` that of the
    /// precompression and the force pulse).
    pub fn momentum_residual(&self, y: &[f64], t: f64, t0: f64, p0: f64) -> f64 {
        self.momentum_residual_prefix(y, self.mass.len(), t, t0, p0)
    }

    /// [`Ledger::momentum_residual`] for a state whose particles from `k` on are at rest.
    pub fn momentum_residual_prefix(&self, y: &[f64], k: usize, t: f64, t0: f64, p0: f64) -> f64 {
        let n = self.mass.len();
        let p: f64 = self.mass[..k]
            .iter()
            .zip(&y[n..n + k])
            .map(|(m, v)| m * v)
            .sum();
        let m_total = self.total_mass;
        let j = self.wall_impulse_index.map_or(0.0, |k| y[k]);
        debug_assert!(self.wall || j == 0.0);
        let mut external = if self.precompression != 0.0 || self.pulse.is_some() {
            self.external_impulse(t, t0)
        } else {
            0.0
        };
        if let Some(i) = self.drive_impulse {
            // A force drive's impulse since the start, where its quadrature is zero.
            external += y[i];
        }
        p - p0 - m_total * self.gravity * (t - t0) - external + j
    }

    /// Total momentum of state `y`, kg·m/s.
    pub fn momentum(&self, y: &[f64]) -> f64 {
        let n = self.mass.len();
        (0..n).map(|i| self.mass[i] * y[n + i]).sum()
    }
}

/// [`Ledger::energy`] as a kernel compiled for the CPU's vector instructions at run time.
struct EnergyKernel<'a> {
    ledger: &'a Ledger,
    y: &'a [f64],
    k: usize,
}

impl Kernel for EnergyKernel<'_> {
    type Output = EnergyTerms;
    #[inline(always)]
    fn run<M: MulAdd>(self) -> EnergyTerms {
        self.ledger.energy_body(self.y, self.k)
    }
}

/// Calls `$body` with `$sys` bound to the right-hand side specialised for `$chain`: the paper's
/// [`ChainSystem`] (16 variants: gravity × damping × wall × clipping) when the chain is the
/// paper's physics, [`crate::motion::plastic::PlasticChainSystem`] when a contact has Thornton's
/// elastic–plastic law, else a [`crate::motion::general::GeneralChainSystem`] (8 variants: Hertz,
/// linear or per-contact power laws × damping on or off, and Hertz or power laws with Tsuji's
/// term). This is the one place where run-time switches become compile-time ones: 25 compiled
/// right-hand sides in all.
#[macro_export]
macro_rules! dispatch_chain_system {
    ($chain:expr, |$sys:ident| $body:expr) => {{
        let chain: &$crate::chain::model::Chain = $chain;
        if chain.is_paper_physics() {
            $crate::dispatch_paper_system!(chain, |$sys| $body)
        } else if chain.has_plasticity() {
            let mut $sys = $crate::motion::plastic::PlasticChainSystem::new(chain);
            $body
        } else {
            $crate::dispatch_general_system!(chain, |$sys| $body)
        }
    }};
}

/// The general half of [`dispatch_chain_system`]: a [`crate::motion::general::GeneralChainSystem`] whose
/// law and damping parameters match `$chain` (whether or not it is the paper's physics).
#[doc(hidden)]
#[macro_export]
macro_rules! dispatch_general_system {
    ($chain:expr, |$sys:ident| $body:expr) => {{
        let chain: &$crate::chain::model::Chain = $chain;
        use $crate::motion::general::GeneralChainSystem as General;
        use $crate::motion::general::{HERTZ_LAW, LINEAR_LAW, POWER_LAW};
        match (
            $crate::motion::general::law(chain),
            chain.has_damping(),
            chain.has_tsuji_damping(),
        ) {
            (HERTZ_LAW, false, _) => {
                let mut $sys = General::<HERTZ_LAW, false>::new(chain);
                $body
            }
            (HERTZ_LAW, true, false) => {
                let mut $sys = General::<HERTZ_LAW, true>::new(chain);
                $body
            }
            (HERTZ_LAW, true, true) => {
                let mut $sys = General::<HERTZ_LAW, true, true>::new(chain);
                $body
            }
            (LINEAR_LAW, false, _) => {
                let mut $sys = General::<LINEAR_LAW, false>::new(chain);
                $body
            }
            // Tsuji's damper on a linear law is constant, held as the linear viscous term.
            (LINEAR_LAW, true, _) => {
                let mut $sys = General::<LINEAR_LAW, true>::new(chain);
                $body
            }
            (_, false, _) => {
                let mut $sys = General::<POWER_LAW, false>::new(chain);
                $body
            }
            (_, true, false) => {
                let mut $sys = General::<POWER_LAW, true>::new(chain);
                $body
            }
            (_, true, true) => {
                let mut $sys = General::<POWER_LAW, true, true>::new(chain);
                $body
            }
        }
    }};
}

/// The paper's half of [`dispatch_chain_system`]: a [`ChainSystem`] whose const parameters match
/// the chain's switches.
#[doc(hidden)]
#[macro_export]
macro_rules! dispatch_paper_system {
    ($chain:expr, |$sys:ident| $body:expr) => {{
        let chain: &$crate::chain::model::Chain = $chain;
        let g = chain.gravity_m_s2 != 0.0;
        let d = chain.has_damping();
        match (g, d, chain.wall, chain.clip_tensile) {
            (false, false, false, false) => {
                let mut $sys =
                    $crate::motion::system::ChainSystem::<false, false, false, false>::new(chain);
                $body
            }
            (false, false, false, true) => {
                let mut $sys =
                    $crate::motion::system::ChainSystem::<false, false, false, true>::new(chain);
                $body
            }
            (false, false, true, false) => {
                let mut $sys =
                    $crate::motion::system::ChainSystem::<false, false, true, false>::new(chain);
                $body
            }
            (false, false, true, true) => {
                let mut $sys =
                    $crate::motion::system::ChainSystem::<false, false, true, true>::new(chain);
                $body
            }
            (false, true, false, false) => {
                let mut $sys =
                    $crate::motion::system::ChainSystem::<false, true, false, false>::new(chain);
                $body
            }
            (false, true, false, true) => {
                let mut $sys =
                    $crate::motion::system::ChainSystem::<false, true, false, true>::new(chain);
                $body
            }
            (false, true, true, false) => {
                let mut $sys =
                    $crate::motion::system::ChainSystem::<false, true, true, false>::new(chain);
                $body
            }
            (false, true, true, true) => {
                let mut $sys =
                    $crate::motion::system::ChainSystem::<false, true, true, true>::new(chain);
                $body
            }
            (true, false, false, false) => {
                let mut $sys =
                    $crate::motion::system::ChainSystem::<true, false, false, false>::new(chain);
                $body
            }
            (true, false, false, true) => {
                let mut $sys =
                    $crate::motion::system::ChainSystem::<true, false, false, true>::new(chain);
                $body
            }
            (true, false, true, false) => {
                let mut $sys =
                    $crate::motion::system::ChainSystem::<true, false, true, false>::new(chain);
                $body
            }
            (true, false, true, true) => {
                let mut $sys =
                    $crate::motion::system::ChainSystem::<true, false, true, true>::new(chain);
                $body
            }
            (true, true, false, false) => {
                let mut $sys =
                    $crate::motion::system::ChainSystem::<true, true, false, false>::new(chain);
                $body
            }
            (true, true, false, true) => {
                let mut $sys =
                    $crate::motion::system::ChainSystem::<true, true, false, true>::new(chain);
                $body
            }
            (true, true, true, false) => {
                let mut $sys =
                    $crate::motion::system::ChainSystem::<true, true, true, false>::new(chain);
                $body
            }
            (true, true, true, true) => {
                let mut $sys =
                    $crate::motion::system::ChainSystem::<true, true, true, true>::new(chain);
                $body
            }
        }
    }};
}

#[cfg(test)]
pub(crate) mod tests {
    use super::ChainSystem;
    use crate::chain::model::{Chain, ChainSpec, PhysicsSpec};
    use crate::integrate::OdeSystem;

    /// Contact `c` of a damped 0.55 chain just past closing (`overlap` > 0) or opening (< 0),
    /// its particles approaching or separating at `rel_velocity`; the system and the state.
    fn state_at(
        c: usize,
        overlap: f64,
        rel_velocity: f64,
    ) -> (ChainSystem<true, true, true, false>, Vec<f64>) {
        let physics = PhysicsSpec {
            damping_kg_s: 6.0,
            striker_damping_kg_s: Some(9.0),
            ..PhysicsSpec::default()
        };
        let chain = Chain::build(&ChainSpec::chain_055(4), &physics).unwrap();
        let sys = ChainSystem::<true, true, true, false>::new(&chain);
        let n = chain.n_particles();
        let mut y = chain.initial_state(1.3);
        if c + 1 < n {
            y[c + 1] = y[c] - overlap;
            y[n + c + 1] = y[n + c] - rel_velocity;
        } else {
            y[n - 1] = overlap;
            y[2 * n - 1] = rel_velocity;
        }
        (sys, y)
    }

    /// Equal to rounding, component by component.
    pub(crate) fn close(got: &[f64], expected: &[f64], what: &str) {
        for (i, (a, b)) in got.iter().zip(expected).enumerate() {
            assert!(
                (a - b).abs() <= 1e-12 * b.abs().max(1.0),
                "{what}, component {i}: {a} against {b}"
            );
        }
    }

    /// A contact held on one side acts as it does there, every other term unchanged: held open
    /// just past closing it carries no viscous force, as if its damping were zero; held compressed
    /// just past opening it carries `μ Δv` and dissipates `μ Δv²`, the wall's impulse taking the
    /// wall's force; held on the side it is on, nothing changes.
    #[test]
    fn a_held_contact_acts_as_on_its_side() {
        let n = state_at(0, 0.0, 0.0).0.n_pos();
        for c in [0, 3, n - 1] {
            let (mut sys, y) = state_at(c, 1e-12, 0.4);
            let mut dy = vec![0.0; y.len()];
            sys.rhs(0.0, &y, &mut dy);
            let mut same = dy.clone();
            sys.hold_switch(c, true, &y, &mut same);
            assert_eq!(same, dy, "contact {c} held compressed while compressed");
            let mut open = dy.clone();
            sys.hold_switch(c, false, &y, &mut open);
            let mut undamped = sys.clone();
            undamped.damping[c] = 0.0;
            let mut expected = vec![0.0; y.len()];
            undamped.rhs(0.0, &y, &mut expected);
            close(&open, &expected, &format!("contact {c} held open"));
            assert_ne!(open, dy, "contact {c}: the viscous term is a real change");

            let (mut sys, y) = state_at(c, -1e-12, -0.4);
            let mut dy = vec![0.0; y.len()];
            sys.rhs(0.0, &y, &mut dy);
            let mut same = dy.clone();
            sys.hold_switch(c, false, &y, &mut same);
            assert_eq!(same, dy, "contact {c} held open while open");
            let mut compressed = dy.clone();
            sys.hold_switch(c, true, &y, &mut compressed);
            let (mu, force) = (sys.damping[c], sys.damping[c] * -0.4);
            let mut expected = dy.clone();
            expected[n + c] -= force * sys.inv_mass[c];
            if c + 1 < n {
                expected[n + c + 1] += force * sys.inv_mass[c + 1];
            } else {
                expected[2 * n + 1] += force;
            }
            expected[2 * n] += mu * 0.4 * 0.4;
            close(
                &compressed,
                &expected,
                &format!("contact {c} held compressed"),
            );
        }
    }
}
