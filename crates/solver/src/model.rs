//! The chain of the paper (Sec. III): configuration with the paper's defaults, and the built
//! [`Chain`] with masses, Hertz coefficients, damping coefficients and the static-equilibrium state.
//!
//! Numbering follows `docs/MODEL.md`: particle 1 is the striker, particle 2 the first chain sphere,
//! cylinders have odd indices (cylinder `k` is particle `2k+1`), the last particle `N = 2n+2` is a
//! sphere on the wall. Contact `j` joins particles `j` and `j+1`; contact `N` joins particle `N` and
//! the wall. Displacement is positive downwards, towards the wall. Internally arrays are 0-based:
//! particle `i` is index `i-1`, contact `j` is index `j-1`.

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

/// Standard gravity used by default, m/s².
pub const STANDARD_GRAVITY_M_S2: f64 = 9.81;

/// Elastic constants of a material.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct Material {
    /// Young's modulus, Pa.
    pub youngs_modulus_pa: f64,
    /// Poisson's ratio, dimensionless.
    pub poisson_ratio: f64,
}

impl Material {
    /// 440C stainless steel (spheres and striker): E = 200 GPa, ν = 0.28.
    pub const STEEL_440C: Material = Material {
        youngs_modulus_pa: 200e9,
        poisson_ratio: 0.28,
    };
    /// SS304 stainless steel (cylinders, wall): E = 193 GPa, ν = 0.29.
    pub const STEEL_SS304: Material = Material {
        youngs_modulus_pa: 193e9,
        poisson_ratio: 0.29,
    };
}

/// A sphere (chain sphere or striker).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct SphereSpec {
    /// Material of the sphere.
    pub material: Material,
    /// Diameter, m.
    pub diameter_m: f64,
    /// Mass, kg.
    pub mass_kg: f64,
}

impl SphereSpec {
    /// The paper's 440C sphere: 8 mm, 2.085 g.
    pub const PAPER: SphereSpec = SphereSpec {
        material: Material::STEEL_440C,
        diameter_m: 8e-3,
        mass_kg: 2.085e-3,
    };
}

/// How the cylinder mass is given.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(
    feature = "serde",
    serde(rename_all = "snake_case", deny_unknown_fields)
)]
pub enum CylinderMass {
    /// An explicit mass, kg.
    Explicit {
        /// Cylinder mass, kg.
        mass_kg: f64,
    },
    /// Heavy cylinders: `m_c = m_s / ε` (Figs. 8, 15, 17).
    HeavyCylinders {
        /// Mass ratio ε = m_s / m_c, in (0, 1].
        mass_ratio: f64,
    },
    /// Light cylinders: `m_c = ε m_s` (Figs. 18, 19).
    LightCylinders {
        /// Mass ratio ε = m_c / m_s, in (0, 1].
        mass_ratio: f64,
    },
}

/// A flat-ended cylinder.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct CylinderSpec {
    /// Material of the cylinder.
    pub material: Material,
    /// Diameter, m (enters only the height derived from the mass).
    pub diameter_m: f64,
    /// Mass, directly or through a mass ratio.
    pub mass: CylinderMass,
    /// Height, m. When absent it follows from the mass at `density_kg_m3`.
    #[cfg_attr(feature = "serde", serde(default))]
    pub height_m: Option<f64>,
    /// Density used to derive the height from the mass, kg/m³. The default 7813 kg/m³ is the
    /// density of the paper's tall cylinder (3.77 g, 9.6 mm, 8 mm diameter).
    #[cfg_attr(feature = "serde", serde(default = "default_cylinder_density"))]
    pub density_kg_m3: f64,
}

/// Density of the paper's tall SS304 cylinder, kg/m³ (3.77 g in a 9.6 mm × ⌀8 mm cylinder).
pub const PAPER_CYLINDER_DENSITY_KG_M3: f64 = 7813.0;

#[cfg(feature = "serde")]
fn default_cylinder_density() -> f64 {
    PAPER_CYLINDER_DENSITY_KG_M3
}

impl CylinderSpec {
    /// Short cylinder of the 0.98 chain: 2.043 g, h = 5.3 mm.
    pub const SHORT: CylinderSpec = CylinderSpec {
        material: Material::STEEL_SS304,
        diameter_m: 8e-3,
        mass: CylinderMass::Explicit { mass_kg: 2.043e-3 },
        height_m: Some(5.3e-3),
        density_kg_m3: PAPER_CYLINDER_DENSITY_KG_M3,
    };
    /// Tall cylinder of the 0.55 chain: 3.77 g, h = 9.6 mm.
    pub const TALL: CylinderSpec = CylinderSpec {
        material: Material::STEEL_SS304,
        diameter_m: 8e-3,
        mass: CylinderMass::Explicit { mass_kg: 3.77e-3 },
        height_m: Some(9.6e-3),
        density_kg_m3: PAPER_CYLINDER_DENSITY_KG_M3,
    };

    /// Cylinder mass for a given sphere mass, kg.
    pub fn mass_kg(&self, sphere_mass_kg: f64) -> f64 {
        match self.mass {
            CylinderMass::Explicit { mass_kg } => mass_kg,
            CylinderMass::HeavyCylinders { mass_ratio } => sphere_mass_kg / mass_ratio,
            CylinderMass::LightCylinders { mass_ratio } => sphere_mass_kg * mass_ratio,
        }
    }

    /// Cylinder height, m: the given one, or the one its mass has at `density_kg_m3`.
    pub fn height(&self, sphere_mass_kg: f64) -> f64 {
        self.height_m.unwrap_or_else(|| {
            let area = std::f64::consts::PI * 0.25 * self.diameter_m * self.diameter_m;
            self.mass_kg(sphere_mass_kg) / (self.density_kg_m3 * area)
        })
    }
}

/// Geometry and materials of the chain.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct ChainSpec {
    /// Number of cylinders `n`; the chain has `n+1` spheres and `N = 2n+2` particles with the striker.
    pub cylinders: usize,
    /// Chain spheres.
    pub sphere: SphereSpec,
    /// Cylinders.
    pub cylinder: CylinderSpec,
    /// Striker (particle 1), a sphere.
    pub striker: SphereSpec,
    /// Material of the rigid flat wall under the last sphere (Eq. 7 uses the sphere–flat law).
    pub wall_material: Material,
}

impl ChainSpec {
    /// The 0.98 chain (short cylinders) with `cylinders` cylinders.
    pub fn chain_098(cylinders: usize) -> Self {
        ChainSpec {
            cylinders,
            sphere: SphereSpec::PAPER,
            cylinder: CylinderSpec::SHORT,
            striker: SphereSpec::PAPER,
            wall_material: Material::STEEL_SS304,
        }
    }

    /// The 0.55 chain (tall 3.77 g cylinders) with `cylinders` cylinders.
    pub fn chain_055(cylinders: usize) -> Self {
        ChainSpec {
            cylinder: CylinderSpec::TALL,
            ..Self::chain_098(cylinders)
        }
    }

    /// Number of particles including the striker, `N = 2n + 2`.
    pub fn particles(&self) -> usize {
        2 * self.cylinders + 2
    }
}

/// Which physics a scene switches on.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct PhysicsSpec {
    /// Gravity along +x on every particle, striker included, with the static-equilibrium initial state.
    pub gravity: bool,
    /// Gravitational acceleration, m/s².
    #[cfg_attr(feature = "serde", serde(default = "default_gravity"))]
    pub gravity_m_s2: f64,
    /// Viscous damping coefficient μ on every contact but the striker's, kg/s (Eqs. 9–12).
    pub damping_kg_s: f64,
    /// Damping μ₁ on the striker contact, kg/s (Eqs. 8–9). Absent: equal to `damping_kg_s`.
    #[cfg_attr(feature = "serde", serde(default))]
    pub striker_damping_kg_s: Option<f64>,
    /// The rigid wall under the last sphere (Eq. 7). Without it the last sphere is free.
    pub wall: bool,
    /// Clip the net (elastic + viscous) contact force at zero so a contact never pulls. The paper's
    /// equations allow a slightly tensile force at the end of unloading; that is the default.
    #[cfg_attr(feature = "serde", serde(default))]
    pub clip_tensile: bool,
}

#[cfg(feature = "serde")]
fn default_gravity() -> f64 {
    STANDARD_GRAVITY_M_S2
}

impl Default for PhysicsSpec {
    fn default() -> Self {
        PhysicsSpec {
            gravity: true,
            gravity_m_s2: STANDARD_GRAVITY_M_S2,
            damping_kg_s: 0.0,
            striker_damping_kg_s: None,
            wall: true,
            clip_tensile: false,
        }
    }
}

impl PhysicsSpec {
    /// Whether any contact carries viscous damping.
    pub fn has_damping(&self) -> bool {
        self.damping_kg_s != 0.0 || self.striker_damping_kg_s.is_some_and(|m| m != 0.0)
    }
}

/// Hertz coefficient `A` of Eq. (1): `F = A δ^{3/2}` for two bodies with radii of curvature
/// `r1`, `r2` at the contact; `None` stands for a flat surface (infinite radius), which gives
/// Eq. (4) for a sphere on a flat.
pub fn hertz_coefficient(m1: Material, r1: Option<f64>, m2: Material, r2: Option<f64>) -> f64 {
    let (e1, n1) = (m1.youngs_modulus_pa, m1.poisson_ratio);
    let (e2, n2) = (m2.youngs_modulus_pa, m2.poisson_ratio);
    let effective_radius = match (r1, r2) {
        (Some(a), Some(b)) => a * b / (a + b),
        (Some(a), None) | (None, Some(a)) => a,
        (None, None) => f64::INFINITY,
    };
    4.0 * e1 * e2 / (3.0 * (e1 * (1.0 - n2 * n2) + e2 * (1.0 - n1 * n1))) * effective_radius.sqrt()
}

/// Kind of a particle in the chain.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParticleKind {
    /// Particle 1.
    Striker,
    /// Even particles.
    Sphere,
    /// Odd particles from 3 on.
    Cylinder,
}

/// Error in a chain or physics specification, naming the field.
#[derive(Debug, Clone, PartialEq)]
pub struct SpecError {
    /// Dotted path of the offending field.
    pub field: String,
    /// What is allowed.
    pub message: String,
}

impl std::fmt::Display for SpecError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.field, self.message)
    }
}

impl std::error::Error for SpecError {}

pub(crate) fn spec_err(field: &str, message: impl Into<String>) -> SpecError {
    SpecError {
        field: field.to_string(),
        message: message.into(),
    }
}

fn check_positive(field: &str, v: f64) -> Result<(), SpecError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(spec_err(
            field,
            format!("must be a finite number > 0, got {v}"),
        ))
    }
}

fn check_material(field: &str, m: &Material) -> Result<(), SpecError> {
    check_positive(&format!("{field}.youngs_modulus_pa"), m.youngs_modulus_pa)?;
    if !(m.poisson_ratio.is_finite() && m.poisson_ratio > -1.0 && m.poisson_ratio < 0.5) {
        return Err(spec_err(
            &format!("{field}.poisson_ratio"),
            format!("must lie in (-1, 0.5), got {}", m.poisson_ratio),
        ));
    }
    Ok(())
}

fn check_sphere(field: &str, s: &SphereSpec) -> Result<(), SpecError> {
    check_material(&format!("{field}.material"), &s.material)?;
    check_positive(&format!("{field}.diameter_m"), s.diameter_m)?;
    check_positive(&format!("{field}.mass_kg"), s.mass_kg)
}

impl ChainSpec {
    /// Checks every field for physical sense; the error names the field (relative to `chain`).
    pub fn validate(&self) -> Result<(), SpecError> {
        check_sphere("chain.sphere", &self.sphere)?;
        check_sphere("chain.striker", &self.striker)?;
        check_material("chain.wall_material", &self.wall_material)?;
        let c = &self.cylinder;
        check_material("chain.cylinder.material", &c.material)?;
        check_positive("chain.cylinder.diameter_m", c.diameter_m)?;
        check_positive("chain.cylinder.density_kg_m3", c.density_kg_m3)?;
        match c.mass {
            CylinderMass::Explicit { mass_kg } => {
                check_positive("chain.cylinder.mass.explicit.mass_kg", mass_kg)?
            }
            CylinderMass::HeavyCylinders { mass_ratio }
            | CylinderMass::LightCylinders { mass_ratio } => {
                if !(mass_ratio.is_finite() && mass_ratio > 0.0 && mass_ratio <= 1.0) {
                    let which = if matches!(c.mass, CylinderMass::HeavyCylinders { .. }) {
                        "heavy_cylinders"
                    } else {
                        "light_cylinders"
                    };
                    return Err(spec_err(
                        &format!("chain.cylinder.mass.{which}.mass_ratio"),
                        format!("must lie in (0, 1], got {mass_ratio}"),
                    ));
                }
            }
        }
        if let Some(h) = c.height_m {
            check_positive("chain.cylinder.height_m", h)?;
        }
        if self.cylinders > 1_000_000 {
            return Err(spec_err(
                "chain.cylinders",
                format!("must be at most 1000000, got {}", self.cylinders),
            ));
        }
        Ok(())
    }
}

impl PhysicsSpec {
    /// Checks every field for physical sense; the error names the field (relative to `physics`).
    pub fn validate(&self) -> Result<(), SpecError> {
        if !(self.gravity_m_s2.is_finite() && self.gravity_m_s2 >= 0.0) {
            return Err(spec_err(
                "physics.gravity_m_s2",
                format!("must be a finite number >= 0, got {}", self.gravity_m_s2),
            ));
        }
        if !(self.damping_kg_s.is_finite() && self.damping_kg_s >= 0.0) {
            return Err(spec_err(
                "physics.damping_kg_s",
                format!("must be a finite number >= 0, got {}", self.damping_kg_s),
            ));
        }
        if let Some(m) = self.striker_damping_kg_s {
            if !(m.is_finite() && m >= 0.0) {
                return Err(spec_err(
                    "physics.striker_damping_kg_s",
                    format!("must be a finite number >= 0, got {m}"),
                ));
            }
        }
        Ok(())
    }
}

/// The built chain: per-particle and per-contact arrays (0-based) and the initial state.
#[derive(Debug, Clone)]
pub struct Chain {
    /// Particle masses, kg (index 0 is the striker).
    pub mass: Vec<f64>,
    /// Particle kinds.
    pub kind: Vec<ParticleKind>,
    /// Hertz coefficient of each contact, N/m^{3/2}; the last one is the wall contact when there is a wall.
    pub stiffness: Vec<f64>,
    /// Damping coefficient of each contact, kg/s (zero without damping).
    pub damping: Vec<f64>,
    /// Gravitational acceleration applied, m/s² (zero when gravity is off).
    pub gravity_m_s2: f64,
    /// Whether the last sphere rests on a wall.
    pub wall: bool,
    /// Clip tensile net contact forces at zero.
    pub clip_tensile: bool,
    /// Static overlap of each contact in the gravity-loaded chain, m (zero for the striker contact).
    pub static_overlap: Vec<f64>,
    /// Equilibrium displacement of each particle from the undeformed, just-touching chain, m.
    pub equilibrium_position: Vec<f64>,
    /// Cell length `h + d`, m.
    pub cell_length_m: f64,
    /// Cylinder height used, m.
    pub cylinder_height_m: f64,
    /// Cylinder mass used, kg.
    pub cylinder_mass_kg: f64,
}

impl Chain {
    /// Builds the chain for a specification and physics switches.
    pub fn build(spec: &ChainSpec, physics: &PhysicsSpec) -> Result<Chain, SpecError> {
        spec.validate()?;
        physics.validate()?;
        let n_particles = spec.particles();
        let m_s = spec.sphere.mass_kg;
        let m_c = spec.cylinder.mass_kg(m_s);
        let h = spec.cylinder.height(m_s);
        let r_s = 0.5 * spec.sphere.diameter_m;
        let r_imp = 0.5 * spec.striker.diameter_m;

        let mut mass = Vec::with_capacity(n_particles);
        let mut kind = Vec::with_capacity(n_particles);
        for p in 1..=n_particles {
            let (m, k) = if p == 1 {
                (spec.striker.mass_kg, ParticleKind::Striker)
            } else if p % 2 == 0 {
                (m_s, ParticleKind::Sphere)
            } else {
                (m_c, ParticleKind::Cylinder)
            };
            mass.push(m);
            kind.push(k);
        }

        let a_striker = hertz_coefficient(
            spec.striker.material,
            Some(r_imp),
            spec.sphere.material,
            Some(r_s),
        );
        let a_chain = hertz_coefficient(
            spec.cylinder.material,
            None,
            spec.sphere.material,
            Some(r_s),
        );
        let a_wall = hertz_coefficient(spec.wall_material, None, spec.sphere.material, Some(r_s));
        let n_contacts = if physics.wall {
            n_particles
        } else {
            n_particles - 1
        };
        let mut stiffness = vec![a_chain; n_contacts];
        stiffness[0] = a_striker;
        if physics.wall {
            stiffness[n_contacts - 1] = a_wall;
        }

        let mu = physics.damping_kg_s;
        let mu1 = physics.striker_damping_kg_s.unwrap_or(mu);
        let mut damping = vec![mu; n_contacts];
        damping[0] = mu1;

        let g = if physics.gravity {
            physics.gravity_m_s2
        } else {
            0.0
        };
        // Static equilibrium (docs/MODEL.md): contact j carries the weight of particles 2..j. Without a
        // wall nothing supports the chain, it falls freely and no contact is preloaded.
        let mut static_overlap = vec![0.0; n_contacts];
        if physics.wall && g > 0.0 {
            let mut weight = 0.0;
            for j in 1..n_contacts {
                weight += g * mass[j];
                static_overlap[j] = (weight / stiffness[j]).powf(2.0 / 3.0);
            }
        }
        // Positions measured from the undeformed chain touching the wall (or, without a wall, from
        // the undeformed chain): x_N = δ_N, x_j = x_{j+1} + δ_j.
        let mut equilibrium_position = vec![0.0; n_particles];
        if physics.wall {
            equilibrium_position[n_particles - 1] = static_overlap[n_contacts - 1];
        }
        for i in (0..n_particles - 1).rev() {
            equilibrium_position[i] = equilibrium_position[i + 1] + static_overlap[i];
        }

        Ok(Chain {
            mass,
            kind,
            stiffness,
            damping,
            gravity_m_s2: g,
            wall: physics.wall,
            clip_tensile: physics.clip_tensile,
            static_overlap,
            equilibrium_position,
            cell_length_m: h + spec.sphere.diameter_m,
            cylinder_height_m: h,
            cylinder_mass_kg: m_c,
        })
    }

    /// Number of particles `N`, striker included.
    pub fn n_particles(&self) -> usize {
        self.mass.len()
    }

    /// Number of contacts (`N` with a wall, `N-1` without).
    pub fn n_contacts(&self) -> usize {
        self.stiffness.len()
    }

    /// Whether any contact is damped.
    pub fn has_damping(&self) -> bool {
        self.damping.iter().any(|&m| m != 0.0)
    }

    /// Index of the dissipated-work quadrature in the state `[x, v, q]`, when damping is on.
    pub fn work_index(&self) -> Option<usize> {
        self.has_damping().then_some(2 * self.n_particles())
    }

    /// Index of the wall-impulse quadrature in the state `[x, v, q]`, when there is a wall.
    pub fn wall_impulse_index(&self) -> Option<usize> {
        self.wall
            .then_some(2 * self.n_particles() + self.has_damping() as usize)
    }

    /// Length of the state `[x, v, q]`: positions, velocities, then the quadratures above.
    pub fn state_len(&self) -> usize {
        2 * self.n_particles() + self.has_damping() as usize + self.wall as usize
    }

    /// Initial state `[x, v, q]`: the chain at static equilibrium, the striker touching particle 2
    /// with zero overlap and moving towards the wall at `v0`, nothing dissipated or transmitted yet.
    pub fn initial_state(&self, striker_velocity_m_s: f64) -> Vec<f64> {
        let n = self.n_particles();
        let mut y = vec![0.0; self.state_len()];
        y[..n].copy_from_slice(&self.equilibrium_position);
        y[n] = striker_velocity_m_s;
        y
    }

    /// Static (preload) force at contact index `c`, N.
    pub fn static_force(&self, c: usize) -> f64 {
        let d = self.static_overlap[c];
        self.stiffness[c] * d * d.sqrt()
    }
}
