//! What a chain is made of: its description ([`ChainSpec`]: the paper's sphere–cylinder dimer
//! with a striker, or any sequence of named particle types, see [`crate::chain::sequence`]), the physics
//! switches ([`PhysicsSpec`]), and the built [`Chain`] with per-particle masses, per-contact laws
//! and dissipation, and the static-equilibrium state.
//!
//! Numbering follows `docs/MODEL.md`: particle 1 is the striker when the chain has one (the paper's
//! chain always does: particle 2 is then the first chain sphere, cylinder `k` is particle `2k+1` and
//! the last particle `N = 2n+2` is a sphere on the wall); without a striker particle 1 is the first
//! particle of the sequence. Contact `j` joins particles `j` and `j+1`; contact `N` joins particle
//! `N` and the wall. Displacement is positive downwards, towards the wall. Internally arrays are
//! 0-based: particle `i` is index `i-1`, contact `j` is index `j-1`.
//!
//! The specification is split by what it describes, a file each: `chain_spec` (the [`ChainSpec`]
//! either form of a chain is read into), `dimer` (the paper's dimer, its parts and its presets)
//! and `physics` (the physics switches); `contact_map` holds what each contact of a built chain
//! joins, which the ledger, the probes and the observers read. The built [`Chain`] is here.

mod chain_spec;
mod contact_map;
mod dimer;
mod physics;

use crate::chain::drive::{Drive, DrivePoint};
pub use crate::chain::mount::WallMount;
use crate::chain::parts::check_factor_count;
pub(crate) use crate::chain::parts::Layout;
pub use crate::chain::parts::{hertz_coefficient, Material, ParticleKind, Shape, MAX_PARTICLES};
use crate::contact::{overlap_at_force, ContactParams, Damping, Thornton};
pub use crate::spec::{spec_err, SpecError};

pub use chain_spec::ChainSpec;
use contact_map::contact_ends;
pub use contact_map::{ContactEnds, ContactMap};
pub use dimer::{CylinderMass, CylinderSpec, DimerSpec, SphereSpec, PAPER_CYLINDER_DENSITY_KG_M3};
pub use physics::{PhysicsSpec, STANDARD_GRAVITY_M_S2};

/// The built chain: per-particle and per-contact arrays (0-based) and the initial state.
///
/// Contact `c` exerts `F = A δ^n + (μ + γ δ^{n−1} + λ δ^n + β δ^{(n−1)/2}) δ̇` while compressed (see
/// [`crate::contact`]); for the paper's chain every `n` is 3/2 and only `μ` is used.
#[derive(Debug, Clone)]
pub struct Chain {
    /// Particle masses, kg (index 0 is the striker when there is one).
    pub mass: Vec<f64>,
    /// Particle kinds.
    pub kind: Vec<ParticleKind>,
    /// Particle shapes.
    pub shape: Vec<Shape>,
    /// Coefficient `A` of each contact's law, N/m^n; the last one is the wall contact when there
    /// is a wall.
    pub stiffness: Vec<f64>,
    /// Exponent `n` of each contact's law (3/2 for Hertz).
    pub exponent: Vec<f64>,
    /// Linear viscous coefficient μ of each contact, kg/s (zero without damping).
    pub damping: Vec<f64>,
    /// Viscoelastic (Kuwabara–Kono) coefficient γ of each contact, the factor of `δ^{n−1} δ̇`.
    pub viscoelastic_damping: Vec<f64>,
    /// Hunt–Crossley coefficient λ of each contact, the factor of `δ^n δ̇`.
    pub hunt_crossley_damping: Vec<f64>,
    /// Tsuji coefficient β of each contact, the factor of `δ^{(n−1)/2} δ̇` (zero where `n = 1`:
    /// there Tsuji's damper is constant and held in `damping`).
    pub tsuji_damping: Vec<f64>,
    /// Gravitational acceleration applied, m/s² (zero when gravity is off).
    pub gravity_m_s2: f64,
    /// Whether the last particle rests on a wall.
    pub wall: bool,
    /// Whether the last particle touches the first (a ring; its closing contact is contact `N`).
    pub ring: bool,
    /// Position of the wall at the top of the chain, m, when there is one: its contact with
    /// particle 1, the last contact, has overlap `x_top − x₁`.
    pub top_wall_m: Option<f64>,
    /// Clip tensile net contact forces at zero.
    pub clip_tensile: bool,
    /// Whether particle 1 is a striker.
    pub striker: bool,
    /// Static precompression force on the first chain particle, N.
    pub precompression_force_n: f64,
    /// A half-sine force pulse on the first chain particle: `(amplitude N, duration s)`.
    pub force_pulse: Option<(f64, f64)>,
    /// A boundary drive ([`Drive`]): a force on the first chain particle, an actuator at the top
    /// (the top wall, moving) or a moving base (the wall under the chain).
    pub drive: Option<Drive>,
    /// Static overlap of each contact in the loaded chain, m (zero for the striker contact).
    pub static_overlap: Vec<f64>,
    /// Equilibrium displacement of each particle from the undeformed, just-touching chain, m.
    pub equilibrium_position: Vec<f64>,
    /// Cell length `h + d` of the paper's dimer chain, m (`None` for a sequence chain: use
    /// [`Chain::center_distance_m`]).
    pub cell_length_m: Option<f64>,
    /// Particle materials.
    pub materials: Vec<Material>,
    /// Thornton's elastic–plastic law of each contact that has it (see [`crate::contact::Thornton`]),
    /// empty when none has;
    /// its `stiffness` and `exponent` entries are then its Hertz law below yield. Each such
    /// contact keeps its history (the gap between its largest overlap and the present one) in the
    /// state, after the quadratures ([`Chain::history_index`]).
    pub plasticity: Vec<Option<Thornton>>,
    /// The wall under the chain on a spring and a dashpot ([`WallMount`]), when it is: its
    /// displacement and velocity are in the state ([`Chain::mount_state_index`]).
    pub wall_mount: Option<WallMount>,
}

impl Chain {
    /// Builds the chain for a specification and physics switches.
    pub fn build(spec: &ChainSpec, physics: &PhysicsSpec) -> Result<Chain, SpecError> {
        spec.validate()?;
        physics.validate()?;
        let sizes = spec.size_factors();
        let mut layout = match spec {
            ChainSpec::Dimer(d) => d.layout(physics.wall, sizes)?,
            ChainSpec::Sequence(s) => s.layout(physics.wall, sizes)?,
        };
        let factors = spec.mass_factors();
        check_factor_count("chain.mass_factors", factors, layout.particles.len())?;
        for (p, f) in layout.particles.iter_mut().zip(factors) {
            p.mass_kg *= f;
        }
        if layout.plasticity.iter().any(Option::is_some) {
            if physics.dissipation.is_some() {
                return Err(spec_err(
                    "physics.dissipation",
                    "must be absent when a contact has Thornton's law (it dissipates through plastic work; give other contacts their dissipation in their contact rules)",
                ));
            }
            if physics.has_damping() {
                return Err(spec_err(
                    "physics.damping_kg_s",
                    "must be 0 when a contact has Thornton's law (it dissipates through plastic work; give other contacts their dissipation in their contact rules)",
                ));
            }
        }
        if !layout.striker && physics.striker_damping_kg_s.is_some() {
            return Err(spec_err(
                "physics.striker_damping_kg_s",
                "the chain has no striker (a sequence chain names one in chain.striker)",
            ));
        }
        if layout.ring {
            if physics.gravity {
                return Err(spec_err(
                    "physics.gravity",
                    "must be false for a ring (chain.ring = true): gravity has no direction along a ring",
                ));
            }
            if physics.precompression_force_n != 0.0 {
                return Err(spec_err(
                    "physics.precompression_force_n",
                    "must be 0 for a ring (chain.ring = true): nothing holds a ring's load",
                ));
            }
        }
        if layout.particles.len() == 1 && !physics.wall && !layout.top_wall {
            return Err(spec_err(
                "chain.sequence",
                "a single particle touches nothing: give it a wall to rest on (physics.wall) or one at the top (chain.top_wall_material), or add particles",
            ));
        }
        if layout.wall_mount.is_some() && !physics.wall {
            return Err(spec_err(
                "chain.wall_mount",
                "mounts the wall under the chain: turn physics.wall on, or remove it",
            ));
        }
        let chain = Self::from_layout(layout, physics);
        for (c, law) in chain.plasticity.iter().enumerate() {
            if let Some(t) = law {
                if chain.static_overlap[c] >= t.yield_overlap {
                    let field = if physics.precompression_force_n > 0.0 {
                        "physics.precompression_force_n"
                    } else {
                        "physics.gravity"
                    };
                    return Err(spec_err(
                        field,
                        format!(
                            "loads contact {} with Thornton's law beyond yield at rest ({:e} N, yield at {:e} N): the static state must be elastic",
                            c + 1,
                            chain.static_force(c),
                            t.yield_force
                        ),
                    ));
                }
            }
        }
        Ok(chain)
    }

    fn from_layout(layout: Layout, physics: &PhysicsSpec) -> Chain {
        let n_particles = layout.particles.len();
        let mass: Vec<f64> = layout.particles.iter().map(|p| p.mass_kg).collect();
        let n_contacts = layout.laws.len();
        let stiffness: Vec<f64> = layout.laws.iter().map(|l| l.0).collect();
        let exponent: Vec<f64> = layout.laws.iter().map(|l| l.1).collect();

        let mu = physics.damping_kg_s;
        let mu1 = physics.striker_damping_kg_s.unwrap_or(mu);
        let mut damping = Vec::with_capacity(n_contacts);
        let mut viscoelastic_damping = Vec::with_capacity(n_contacts);
        let mut hunt_crossley_damping = Vec::with_capacity(n_contacts);
        let mut tsuji_damping = Vec::with_capacity(n_contacts);
        let ends = |c: usize| {
            contact_ends(
                n_particles,
                physics.wall,
                layout.ring,
                layout.top_wall.then_some(0.0),
                None,
                None,
                c,
            )
        };
        for c in 0..n_contacts {
            let model = layout.dissipation[c].or(physics.dissipation);
            // Contact c joins two particles, or a particle and a wall.
            let reduced_mass = match ends(c) {
                ContactEnds {
                    above: Some(a),
                    below: Some(b),
                    ..
                } => mass[a] * mass[b] / (mass[a] + mass[b]),
                ContactEnds { above, below, .. } => mass[above.or(below).expect("a particle")],
            };
            let d = match model {
                Some(m) => m.coefficients(
                    stiffness[c],
                    exponent[c],
                    reduced_mass,
                    physics.clip_tensile,
                ),
                None => Damping {
                    linear: if c == 0 && layout.striker { mu1 } else { mu },
                    ..Damping::NONE
                },
            };
            damping.push(d.linear);
            viscoelastic_damping.push(d.viscoelastic);
            hunt_crossley_damping.push(d.hunt_crossley);
            tsuji_damping.push(d.tsuji);
        }

        let g = if physics.gravity {
            physics.gravity_m_s2
        } else {
            0.0
        };
        let first = layout.striker as usize;
        let top = physics.precompression_force_n;
        // Static equilibrium (docs/MODEL.md, docs/CHAINS.md): contact j carries the precompression
        // and the weight of the chain particles above it. Without a wall nothing supports the
        // chain, it falls freely and no contact is preloaded.
        // A wall at the top carries the precompression itself (it is pressed in until it does)
        // and touches a chain under gravity alone without load.
        let mut static_overlap = vec![0.0; n_contacts];
        if physics.wall && (g > 0.0 || top > 0.0) {
            let mut load = top;
            for j in first..n_particles {
                load += g * mass[j];
                static_overlap[j] = overlap_at_force(stiffness[j], exponent[j], load);
            }
            if layout.top_wall {
                let t = n_contacts - 1;
                static_overlap[t] = overlap_at_force(stiffness[t], exponent[t], top);
            }
        }
        // Positions measured from the undeformed chain touching the wall (or, without a wall, from
        // the undeformed chain): x_N = δ_N, x_j = x_{j+1} + δ_j.
        // (The wall's contact is contact N; with a wall at the top too, the last contact is the top
        // wall's, which may carry another overlap.)
        let mut equilibrium_position = vec![0.0; n_particles];
        if physics.wall {
            equilibrium_position[n_particles - 1] = static_overlap[n_particles - 1];
        }
        for i in (0..n_particles - 1).rev() {
            equilibrium_position[i] = equilibrium_position[i + 1] + static_overlap[i];
        }
        let top_wall_m = layout
            .top_wall
            .then(|| equilibrium_position[0] + static_overlap[n_contacts - 1]);

        Chain {
            mass,
            kind: layout.particles.iter().map(|p| p.kind).collect(),
            shape: layout.particles.iter().map(|p| p.shape).collect(),
            stiffness,
            exponent,
            damping,
            viscoelastic_damping,
            hunt_crossley_damping,
            tsuji_damping,
            gravity_m_s2: g,
            wall: physics.wall,
            ring: layout.ring,
            top_wall_m,
            clip_tensile: physics.clip_tensile,
            striker: layout.striker,
            precompression_force_n: top,
            force_pulse: None,
            drive: None,
            static_overlap,
            equilibrium_position,
            cell_length_m: layout.cell_length_m,
            materials: layout.particles.iter().map(|p| p.material).collect(),
            plasticity: layout.plasticity,
            wall_mount: layout.wall_mount,
        }
    }

    /// The chain with a half-sine force pulse on its first chain particle.
    pub fn with_force_pulse(mut self, amplitude_n: f64, duration_s: f64) -> Chain {
        self.force_pulse = Some((amplitude_n, duration_s));
        self
    }

    /// The chain driven by `drive`; the error names the field when the chain lacks the wall the
    /// drive moves.
    pub fn with_drive(mut self, drive: Drive) -> Result<Chain, SpecError> {
        let field = format!("excitation.drive.{}", drive.point.key());
        match drive.point {
            DrivePoint::Actuator if self.top_wall_m.is_none() => {
                return Err(spec_err(
                    &field,
                    "an actuator is a wall at the top that moves: give the chain one (chain.top_wall_material, the actuator's face), or drive with force_n",
                ))
            }
            DrivePoint::Base if !self.wall => {
                return Err(spec_err(
                    &field,
                    "a moving base is the wall under the chain: turn physics.wall on, or drive with force_n or actuator_m",
                ))
            }
            DrivePoint::Base if self.wall_mount.is_some() => {
                return Err(spec_err(
                    &field,
                    "the wall under the chain is on a spring (chain.wall_mount), which a moving base is not: remove one of the two, or drive with force_n or actuator_m",
                ))
            }
            _ => {}
        }
        if self.ring {
            return Err(spec_err(
                &field,
                "a ring has no boundary to drive (chain.ring); excite it with an initial state",
            ));
        }
        self.drive = Some(drive);
        Ok(self)
    }

    /// Number of particles `N`, striker included.
    pub fn n_particles(&self) -> usize {
        self.mass.len()
    }

    /// Number of contacts (`N` with a wall, `N-1` without).
    pub fn n_contacts(&self) -> usize {
        self.stiffness.len()
    }

    /// Index of the first chain particle (1 after a striker, else 0): where precompression and
    /// force pulses act.
    pub fn first_chain_particle(&self) -> usize {
        self.striker as usize
    }

    /// Whether any contact dissipates energy.
    pub fn has_damping(&self) -> bool {
        self.damping
            .iter()
            .chain(&self.viscoelastic_damping)
            .chain(&self.hunt_crossley_damping)
            .chain(&self.tsuji_damping)
            .any(|&m| m != 0.0)
            || self.wall_mount.is_some_and(|m| m.damping_kg_s != 0.0)
    }

    /// Whether any contact carries Tsuji's term `β δ^{(n−1)/2} δ̇` (its kernels are apart).
    pub fn has_tsuji_damping(&self) -> bool {
        self.tsuji_damping.iter().any(|&b| b != 0.0)
    }

    /// Whether the chain is the paper's physics: every law Hertz's, only linear viscous damping,
    /// no precompression and no force pulse. Such chains run on the paper's specialised
    /// right-hand side ([`crate::motion::system::ChainSystem`]), all others on the general one.
    pub fn is_paper_physics(&self) -> bool {
        self.n_particles() > 1
            && self.exponent.iter().all(|&n| n == 1.5)
            && self.viscoelastic_damping.iter().all(|&g| g == 0.0)
            && self.hunt_crossley_damping.iter().all(|&l| l == 0.0)
            && !self.has_tsuji_damping()
            && self.precompression_force_n == 0.0
            && self.force_pulse.is_none()
            && self.drive.is_none()
            && !self.has_plasticity()
            && !self.ring
            && self.top_wall_m.is_none()
            && self.wall_mount.is_none()
    }

    /// What contact `c` joins ([`ContactEnds`]).
    #[inline]
    pub fn contact_ends(&self, c: usize) -> ContactEnds {
        contact_ends(
            self.n_particles(),
            self.wall,
            self.ring,
            self.top_wall_m,
            self.moving_wall(),
            self.mount_state_index(),
            c,
        )
    }

    /// The wall a drive moves, and the index in the state of its displacement (its velocity
    /// follows it), when one does.
    pub fn moving_wall(&self) -> Option<(DrivePoint, usize)> {
        let d = self.drive.as_ref()?;
        d.point
            .moves_a_wall()
            .then(|| (d.point, self.drive_state_index().expect("a drive")))
    }

    /// Whether a wall holds either end of the chain (then the state carries the walls' impulse).
    pub fn has_walls(&self) -> bool {
        self.wall || self.top_wall_m.is_some()
    }

    /// The external force pressing the first chain particle towards the wall, N: the
    /// precompression, unless a wall at the top carries it.
    pub fn top_force_n(&self) -> f64 {
        if self.top_wall_m.is_some() {
            0.0
        } else {
            self.precompression_force_n
        }
    }

    /// Index of the dissipated-work quadrature in the state `[x, v, q]`, when damping is on.
    pub fn work_index(&self) -> Option<usize> {
        self.has_damping().then_some(2 * self.n_particles())
    }

    /// Index of the quadrature of the walls' impulse in the state `[x, v, q]` (the impulse the
    /// wall under the chain has taken, less the one the wall at the top has given), when there
    /// is a wall.
    pub fn wall_impulse_index(&self) -> Option<usize> {
        self.has_walls()
            .then_some(2 * self.n_particles() + self.has_damping() as usize)
    }

    /// Index of the quadrature of the work done by a force pulse or a drive, when there is one.
    pub fn external_work_index(&self) -> Option<usize> {
        (self.force_pulse.is_some() || self.drive.is_some()).then_some(
            2 * self.n_particles() + self.has_damping() as usize + self.has_walls() as usize,
        )
    }

    /// Index in the state of a drive's own quadratures, after its work: a force drive's impulse
    /// `∫F dt`; a moving wall's displacement, then its velocity.
    pub fn drive_state_index(&self) -> Option<usize> {
        self.drive.as_ref()?;
        self.external_work_index().map(|w| w + 1)
    }

    /// Index in the state of a mounted wall's displacement (its velocity follows it), after the
    /// drive's quadratures, when the wall under the chain is mounted ([`WallMount`]).
    pub fn mount_state_index(&self) -> Option<usize> {
        self.wall_mount?;
        Some(2 * self.n_particles() + self.quadratures() - 2)
    }

    /// Number of quadratures in the state: dissipated work, the walls' impulse, an external force's
    /// work, a drive's impulse or its wall's displacement and velocity, a mounted wall's
    /// displacement and velocity.
    fn quadratures(&self) -> usize {
        self.has_damping() as usize
            + self.has_walls() as usize
            + (self.force_pulse.is_some() || self.drive.is_some()) as usize
            + self
                .drive
                .as_ref()
                .map_or(0, |d| 1 + d.point.moves_a_wall() as usize)
            + 2 * self.wall_mount.is_some() as usize
    }

    /// Contact `c`'s elastic law and dissipation, as the general laws of `contact/` take them.
    pub(crate) fn contact_params(&self, c: usize) -> ContactParams {
        ContactParams {
            a: self.stiffness[c],
            n: self.exponent[c],
            damping: Damping {
                linear: self.damping[c],
                viscoelastic: self.viscoelastic_damping[c],
                hunt_crossley: self.hunt_crossley_damping[c],
                tsuji: self.tsuji_damping[c],
            },
        }
    }

    /// Whether any contact has Thornton's elastic–plastic law (its own right-hand side).
    pub fn has_plasticity(&self) -> bool {
        self.plasticity.iter().any(Option::is_some)
    }

    /// Index in the state of the history of the `k`-th contact with Thornton's law (in contact
    /// order), after the positions, the velocities and the quadratures: its gap `g = s − δ`, and
    /// at the next index its opening distance `o = δ − δ_p(s)` (see [`Thornton`]).
    pub fn history_index(&self, k: usize) -> usize {
        2 * self.n_particles() + self.quadratures() + 2 * k
    }

    /// Each contact with Thornton's law, its law and the index of its history in the state.
    pub fn plastic_contacts(&self) -> Vec<(usize, Thornton, usize)> {
        self.plasticity
            .iter()
            .enumerate()
            .filter_map(|(c, t)| t.map(|t| (c, t)))
            .enumerate()
            .map(|(k, (c, t))| (c, t, self.history_index(k)))
            .collect()
    }

    /// Length of the state `[x, v, q]`: positions, velocities, the quadratures above, then the
    /// two histories of each contact with Thornton's law.
    pub fn state_len(&self) -> usize {
        2 * self.n_particles()
            + self.quadratures()
            + 2 * self.plasticity.iter().filter(|t| t.is_some()).count()
    }

    /// Initial state `[x, v, q]`: the chain at static equilibrium, the striker (when there is one)
    /// touching particle 2 with zero overlap and moving towards the wall at `v0`, nothing
    /// dissipated or transmitted yet. Without a striker particle 1 starts at `v0` (a δ-force
    /// impulse; zero for a force pulse).
    pub fn initial_state(&self, striker_velocity_m_s: f64) -> Vec<f64> {
        let n = self.n_particles();
        let mut y = vec![0.0; self.state_len()];
        y[..n].copy_from_slice(&self.equilibrium_position);
        y[n] = striker_velocity_m_s;
        for (c, t, h) in self.plastic_contacts() {
            y[h] = t.initial_gap(self.static_overlap[c]);
            y[h + 1] = self.static_overlap[c];
        }
        if let Some((_, w)) = self.moving_wall() {
            // The wall where its waveform puts it at t = 0, at its velocity.
            let drive = self.drive.as_ref().expect("a drive");
            let (u, du, _) = drive.waveform.eval(0.0);
            y[w] = u;
            y[w + 1] = du;
        }
        y
    }

    /// Static (preload) force at contact index `c`, N.
    pub fn static_force(&self, c: usize) -> f64 {
        let d = self.static_overlap[c];
        if self.exponent[c] == 1.5 {
            self.stiffness[c] * d * d.sqrt()
        } else {
            crate::contact::elastic_force(self.stiffness[c], self.exponent[c], d)
        }
    }

    /// Distance between the centres of particles `i` and `j` (0-based) in the undeformed chain, m.
    pub fn center_distance_m(&self, i: usize, j: usize) -> f64 {
        let (lo, hi) = if i <= j { (i, j) } else { (j, i) };
        let lengths: f64 = self.shape[lo..=hi].iter().map(|s| s.length_m()).sum();
        lengths - 0.5 * (self.shape[lo].length_m() + self.shape[hi].length_m())
    }

    /// Indices (0-based) of the cylinders, in order: cylinder `k` (1-based) is `cylinders()[k-1]`.
    pub fn cylinders(&self) -> Vec<usize> {
        (0..self.n_particles())
            .filter(|&i| self.kind[i] == ParticleKind::Cylinder)
            .collect()
    }

    /// Smallest sphere radius in the chain (striker included), m: the scale on which Hertz's
    /// small-strain law is judged. `None` without spheres.
    pub fn smallest_sphere_radius_m(&self) -> Option<f64> {
        self.shape
            .iter()
            .filter_map(|s| s.contact_radius())
            .reduce(f64::min)
    }

    /// Longest time sound takes to cross a chain particle (striker excluded), s: its length over
    /// the longitudinal wave speed of its material at its density.
    pub fn sound_transit_s(&self) -> f64 {
        let first = self.first_chain_particle();
        (first..self.n_particles())
            .map(|i| {
                let rho = self.mass[i] / self.shape[i].volume_m3();
                self.shape[i].length_m() / longitudinal_speed(&self.materials[i], rho)
            })
            .fold(0.0, f64::max)
    }
}

/// Longitudinal wave speed of a material of density `rho`, m/s.
pub(crate) fn longitudinal_speed(m: &Material, rho: f64) -> f64 {
    let (e, nu) = (m.youngs_modulus_pa, m.poisson_ratio);
    (e * (1.0 - nu) / (rho * (1.0 + nu) * (1.0 - 2.0 * nu))).sqrt()
}

#[cfg(test)]
mod tests;
