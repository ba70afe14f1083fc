//! The paper's dimer ([`DimerSpec`]): a striker, then spheres alternating with flat-ended
//! cylinders, the form every existing scene is written in, with its parts ([`SphereSpec`],
//! [`CylinderSpec`]), the mass-ratio conventions and the presets `chain_055` and `chain_098`.
//! Apart from the general chain because it is the paper's own description, resolved into
//! particles and Hertz laws here and nowhere else.

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

use crate::chain::parts::{
    check_factor_count, check_material, hertz_coefficient, Layout, Material, Particle,
    ParticleKind, Shape,
};
use crate::spec::{check_positive, spec_err, SpecError};

// Named only by a field's docs, which the JSON Schema repeats word for word.
#[cfg(doc)]
use super::ChainSpec;

/// A sphere (chain sphere or striker).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
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
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
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
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
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

/// The paper's chain: a striker sphere, then `n + 1` spheres alternating with `n` flat-ended
/// cylinders, the last sphere on the wall. The presets `chain_055` and `chain_098` and the
/// heavy/light mass-ratio conventions are written in this form.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct DimerSpec {
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
    /// Factors on each particle's mass, from particle 1 (the striker) to the last (empty: none):
    /// a toleranced chain, every particle's mass its own ([`ChainSpec::mass_factors`]).
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Vec::is_empty")
    )]
    pub mass_factors: Vec<f64>,
    /// Factors on each particle's size, from particle 1 (the striker) to the last (empty: none):
    /// every length scaled, the mass following at constant density and the Hertz laws at the
    /// new radii ([`ChainSpec::size_factors`]).
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Vec::is_empty")
    )]
    pub size_factors: Vec<f64>,
}

impl DimerSpec {
    /// The 0.98 chain (short cylinders) with `cylinders` cylinders.
    pub fn chain_098(cylinders: usize) -> Self {
        DimerSpec {
            cylinders,
            sphere: SphereSpec::PAPER,
            cylinder: CylinderSpec::SHORT,
            striker: SphereSpec::PAPER,
            wall_material: Material::STEEL_SS304,
            mass_factors: Vec::new(),
            size_factors: Vec::new(),
        }
    }

    /// The 0.55 chain (tall 3.77 g cylinders) with `cylinders` cylinders.
    pub fn chain_055(cylinders: usize) -> Self {
        DimerSpec {
            cylinder: CylinderSpec::TALL,
            ..Self::chain_098(cylinders)
        }
    }

    /// Number of particles including the striker, `N = 2n + 2`.
    pub fn particles(&self) -> usize {
        2 * self.cylinders + 2
    }
}

fn check_sphere(field: &str, s: &SphereSpec) -> Result<(), SpecError> {
    // The common case, checked without building a field name (a grid checks millions of them).
    let m = &s.material;
    let positive = |v: f64| v.is_finite() && v > 0.0;
    if positive(m.youngs_modulus_pa)
        && m.poisson_ratio.is_finite()
        && m.poisson_ratio > -1.0
        && m.poisson_ratio < 0.5
        && positive(s.diameter_m)
        && positive(s.mass_kg)
    {
        return Ok(());
    }
    check_material(&format!("{field}.material"), &s.material)?;
    check_positive(&format!("{field}.diameter_m"), s.diameter_m)?;
    check_positive(&format!("{field}.mass_kg"), s.mass_kg)
}

impl DimerSpec {
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

    /// The particles (each scaled by its size factor, when given) and their Hertz contact laws.
    pub(super) fn layout(&self, wall: bool, size_factors: &[f64]) -> Result<Layout, SpecError> {
        check_factor_count("chain.size_factors", size_factors, self.particles())?;
        let n_particles = self.particles();
        let m_s = self.sphere.mass_kg;
        let m_c = self.cylinder.mass_kg(m_s);
        let h = self.cylinder.height(m_s);
        let sphere = Particle {
            kind: ParticleKind::Sphere,
            shape: Shape::Sphere {
                diameter_m: self.sphere.diameter_m,
            },
            material: self.sphere.material,
            mass_kg: m_s,
        };
        let cylinder = Particle {
            kind: ParticleKind::Cylinder,
            shape: Shape::Cylinder {
                diameter_m: self.cylinder.diameter_m,
                height_m: h,
            },
            material: self.cylinder.material,
            mass_kg: m_c,
        };
        let mut particles = Vec::with_capacity(n_particles);
        particles.push(Particle {
            kind: ParticleKind::Striker,
            shape: Shape::Sphere {
                diameter_m: self.striker.diameter_m,
            },
            material: self.striker.material,
            mass_kg: self.striker.mass_kg,
        });
        for p in 2..=n_particles {
            particles.push(if p % 2 == 0 { sphere } else { cylinder });
        }
        for (p, &f) in particles.iter_mut().zip(size_factors) {
            p.scale_size(f);
        }
        let laws = hertz_laws(&particles, wall.then_some(self.wall_material));
        let n_contacts = laws.len();
        Ok(Layout {
            particles,
            striker: true,
            ring: false,
            top_wall: false,
            wall_mount: None,
            laws,
            dissipation: vec![None; n_contacts],
            plasticity: Vec::new(),
            // Scaled particles make the cells unequal.
            cell_length_m: size_factors
                .is_empty()
                .then_some(h + self.sphere.diameter_m),
        })
    }
}

/// Hertz laws (`n = 3/2`) of consecutive particles, and of the last one with a flat wall of
/// `wall` when there is one. Only for particle pairs of which at least one is a sphere.
fn hertz_laws(particles: &[Particle], wall: Option<Material>) -> Vec<(f64, f64)> {
    let mut laws: Vec<(f64, f64)> = particles
        .windows(2)
        .map(|w| {
            let (a, b) = (&w[0], &w[1]);
            // The paper's argument order (flat body first) is kept; the formula is symmetric.
            let coefficient = match (a.shape.contact_radius(), b.shape.contact_radius()) {
                (None, rb) => hertz_coefficient(a.material, None, b.material, rb),
                (ra, None) => hertz_coefficient(b.material, None, a.material, ra),
                (ra, rb) => hertz_coefficient(a.material, ra, b.material, rb),
            };
            (coefficient, 1.5)
        })
        .collect();
    if let (Some(wall_material), Some(last)) = (wall, particles.last()) {
        laws.push((
            hertz_coefficient(
                wall_material,
                None,
                last.material,
                last.shape.contact_radius(),
            ),
            1.5,
        ));
    }
    laws
}
