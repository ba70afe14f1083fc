//! What a chain is made of: materials, particle shapes and kinds, the Hertz coefficient of two
//! bodies, and a chain resolved into particles and per-contact laws (a `Layout`) before physics.
//! The specs as written ([`crate::chain::model`], [`crate::chain::sequence`]) resolve into these.

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

use crate::contact::{DissipationSpec, Thornton};
use crate::spec::{check_positive, spec_err, SpecError};

/// Elastic constants of a material.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
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

/// Effective modulus `E* = (( 1 − ν₁²)/E₁ + (1 − ν₂²)/E₂)⁻¹` of two bodies, Pa.
pub fn effective_modulus(m1: Material, m2: Material) -> f64 {
    let (e1, n1) = (m1.youngs_modulus_pa, m1.poisson_ratio);
    let (e2, n2) = (m2.youngs_modulus_pa, m2.poisson_ratio);
    e1 * e2 / (e1 * (1.0 - n2 * n2) + e2 * (1.0 - n1 * n1))
}

/// Effective radius `R* = r₁ r₂/(r₁ + r₂)` of two bodies' radii of curvature (`None`: a flat), m.
pub fn effective_radius(r1: Option<f64>, r2: Option<f64>) -> f64 {
    match (r1, r2) {
        (Some(a), Some(b)) => a * b / (a + b),
        (Some(a), None) | (None, Some(a)) => a,
        (None, None) => f64::INFINITY,
    }
}

/// Kind of a particle in the chain.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParticleKind {
    /// The striker (particle 1 of a chain that has one; a sphere in the paper's chain).
    Striker,
    /// A sphere.
    Sphere,
    /// A flat-ended cylinder.
    Cylinder,
}

/// Shape of a particle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// A sphere.
    Sphere {
        /// Diameter, m.
        diameter_m: f64,
    },
    /// A cylinder with flat ends along the chain.
    Cylinder {
        /// Diameter, m.
        diameter_m: f64,
        /// Height (length along the chain), m.
        height_m: f64,
    },
}

impl Shape {
    /// The shape with every length multiplied by `factor`.
    pub fn scaled(self, factor: f64) -> Shape {
        match self {
            Shape::Sphere { diameter_m } => Shape::Sphere {
                diameter_m: diameter_m * factor,
            },
            Shape::Cylinder {
                diameter_m,
                height_m,
            } => Shape::Cylinder {
                diameter_m: diameter_m * factor,
                height_m: height_m * factor,
            },
        }
    }

    /// Radius of curvature of the faces that touch the neighbours: `None` for a flat face.
    pub fn contact_radius(&self) -> Option<f64> {
        match *self {
            Shape::Sphere { diameter_m } => Some(0.5 * diameter_m),
            Shape::Cylinder { .. } => None,
        }
    }

    /// Length along the chain, m.
    pub fn length_m(&self) -> f64 {
        match *self {
            Shape::Sphere { diameter_m } => diameter_m,
            Shape::Cylinder { height_m, .. } => height_m,
        }
    }

    /// Volume, m³.
    pub fn volume_m3(&self) -> f64 {
        match *self {
            Shape::Sphere { diameter_m } => std::f64::consts::PI / 6.0 * diameter_m.powi(3),
            Shape::Cylinder {
                diameter_m,
                height_m,
            } => 0.25 * std::f64::consts::PI * diameter_m * diameter_m * height_m,
        }
    }
}

pub(crate) fn check_material(field: &str, m: &Material) -> Result<(), SpecError> {
    let e = m.youngs_modulus_pa;
    if !(e.is_finite() && e > 0.0) {
        check_positive(&format!("{field}.youngs_modulus_pa"), e)?;
    }
    if !(m.poisson_ratio.is_finite() && m.poisson_ratio > -1.0 && m.poisson_ratio < 0.5) {
        return Err(spec_err(
            &format!("{field}.poisson_ratio"),
            format!("must lie in (-1, 0.5), got {}", m.poisson_ratio),
        ));
    }
    Ok(())
}

/// Checks that a per-particle factor list (`chain.mass_factors`, `chain.size_factors`) is empty
/// or gives one factor for each of the chain's `n` particles.
pub(crate) fn check_factor_count(field: &str, factors: &[f64], n: usize) -> Result<(), SpecError> {
    if factors.is_empty() || factors.len() == n {
        return Ok(());
    }
    Err(spec_err(
        field,
        format!(
            "must give one factor per particle, the striker first: the chain has {n} particles, got {} factors",
            factors.len()
        ),
    ))
}

impl Particle {
    /// Scales every length by `factor`, the mass following at constant density (`factor³`); the
    /// Hertz laws built from the particle follow its new radius.
    pub(crate) fn scale_size(&mut self, factor: f64) {
        self.shape = self.shape.scaled(factor);
        self.mass_kg *= factor * factor * factor;
    }
}

/// Largest number of particles a chain may have.
pub const MAX_PARTICLES: usize = 2_000_002;

/// One particle of a resolved chain.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Particle {
    pub kind: ParticleKind,
    pub shape: Shape,
    pub material: Material,
    pub mass_kg: f64,
}

/// A chain description resolved into particles and per-contact laws, before physics.
#[derive(Debug, Clone)]
pub(crate) struct Layout {
    pub particles: Vec<Particle>,
    pub striker: bool,
    /// Whether the last particle touches the first (a ring).
    pub ring: bool,
    /// Whether a wall touches the first particle from above.
    pub top_wall: bool,
    /// The wall under the chain on a spring and a dashpot, when it is.
    pub wall_mount: Option<crate::chain::mount::WallMount>,
    /// `(A, n)` of each contact: neighbours, then the wall's or the ring's closing contact, then
    /// the top wall's (see `Chain::contact_ends`).
    pub laws: Vec<(f64, f64)>,
    /// A per-pair dissipation model replacing the physics block's.
    pub dissipation: Vec<Option<DissipationSpec>>,
    /// Thornton's elastic–plastic law of each contact that has it (its `laws` entry is then its
    /// Hertz law below yield); empty when no contact has it, so that other chains allocate
    /// nothing for it (even a short-lived allocation moves the heap addresses of the state and
    /// stage vectors allocated after it, which measurably changed the paper's reference run).
    pub plasticity: Vec<Option<Thornton>>,
    pub cell_length_m: Option<f64>,
}
