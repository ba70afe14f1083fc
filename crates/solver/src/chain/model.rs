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

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

use crate::chain::drive::{Drive, DrivePoint};
pub use crate::chain::mount::WallMount;
pub(crate) use crate::chain::parts::{check_material, Layout, Particle};
pub use crate::chain::parts::{hertz_coefficient, Material, ParticleKind, Shape, MAX_PARTICLES};
use crate::chain::sequence::{SequenceSpec, MAX_SIZE_FACTOR};
use crate::contact::{overlap_at_force, ContactParams, Damping, DissipationSpec, Thornton};
pub(crate) use crate::spec::check_positive;
pub use crate::spec::{spec_err, SpecError};

/// Standard gravity used by default, m/s².
pub const STANDARD_GRAVITY_M_S2: f64 = 9.81;

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

/// Geometry and materials of a chain: the paper's dimer ([`DimerSpec`], in which every existing
/// scene is written) or a sequence of named particle types ([`SequenceSpec`]). In a scene file the
/// two are told apart by their fields: `particles`/`sequence` (and the optional `taper`,
/// `disorder`, `contacts`, a `striker` naming a particle type) make a sequence; `cylinders`,
/// `sphere`, `cylinder`, `striker` (a sphere) make the dimer. Both take `wall_material`.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize))]
#[cfg_attr(feature = "serde", serde(untagged))]
pub enum ChainSpec {
    /// The paper's sphere–cylinder chain with a striker.
    Dimer(DimerSpec),
    /// Any sequence of particle types.
    Sequence(SequenceSpec),
}

impl From<DimerSpec> for ChainSpec {
    fn from(d: DimerSpec) -> Self {
        ChainSpec::Dimer(d)
    }
}

impl From<SequenceSpec> for ChainSpec {
    fn from(s: SequenceSpec) -> Self {
        ChainSpec::Sequence(s)
    }
}

impl ChainSpec {
    /// The 0.98 chain (short cylinders) with `cylinders` cylinders.
    pub fn chain_098(cylinders: usize) -> Self {
        ChainSpec::Dimer(DimerSpec::chain_098(cylinders))
    }

    /// The 0.55 chain (tall 3.77 g cylinders) with `cylinders` cylinders.
    pub fn chain_055(cylinders: usize) -> Self {
        ChainSpec::Dimer(DimerSpec::chain_055(cylinders))
    }

    /// The dimer description, if this is one.
    pub fn dimer(&self) -> Option<&DimerSpec> {
        match self {
            ChainSpec::Dimer(d) => Some(d),
            ChainSpec::Sequence(_) => None,
        }
    }

    /// The dimer description, mutably, if this is one.
    pub fn dimer_mut(&mut self) -> Option<&mut DimerSpec> {
        match self {
            ChainSpec::Dimer(d) => Some(d),
            ChainSpec::Sequence(_) => None,
        }
    }

    /// Whether particle 1 is a striker.
    pub fn has_striker(&self) -> bool {
        match self {
            ChainSpec::Dimer(_) => true,
            ChainSpec::Sequence(s) => s.striker.is_some(),
        }
    }

    /// Factors on each particle's mass (empty: none), particle 1 first: applied last, after the
    /// mass a type, taper and disorder give, so that a tolerance on every particle is one list.
    pub fn mass_factors(&self) -> &[f64] {
        match self {
            ChainSpec::Dimer(d) => &d.mass_factors,
            ChainSpec::Sequence(s) => &s.mass_factors,
        }
    }

    /// Checks every field for physical sense; the error names the field (relative to `chain`).
    pub fn validate(&self) -> Result<(), SpecError> {
        for (i, &f) in self.mass_factors().iter().enumerate() {
            if !((1.0 / MAX_SIZE_FACTOR..=MAX_SIZE_FACTOR).contains(&f)) {
                return Err(spec_err(
                    &format!("chain.mass_factors[{i}]"),
                    format!(
                        "must be a number in [1e-3, 1e3] (a factor on particle {}'s mass), got {f}",
                        i + 1
                    ),
                ));
            }
        }
        match self {
            ChainSpec::Dimer(d) => d.validate(),
            ChainSpec::Sequence(s) => s.validate(),
        }
    }
}

/// The schema of a chain as read: the dimer's fields or the sequence's, never a mix (each form
/// refuses the other's fields).
#[cfg(feature = "schema")]
impl schemars::JsonSchema for ChainSpec {
    fn schema_name() -> std::borrow::Cow<'static, str> {
        "ChainSpec".into()
    }

    fn json_schema(generator: &mut schemars::SchemaGenerator) -> schemars::Schema {
        let dimer = generator.subschema_for::<DimerSpec>();
        let sequence = generator.subschema_for::<SequenceSpec>();
        schemars::json_schema!({
            "description": "Geometry and materials: the paper's dimer {cylinders, sphere, cylinder, striker, wall_material} or a sequence of particle types {particles, sequence, …}.",
            "oneOf": [dimer, sequence]
        })
    }
}

#[cfg(feature = "serde")]
mod chain_spec_serde {
    //! `ChainSpec` is read in one pass over its fields: each field has one type whichever form
    //! the chain takes (a `striker` is a sphere in the dimer and a type name in a sequence), so
    //! every value is read straight into its type and errors keep their full path.
    use super::*;
    use crate::chain::sequence::{
        ContactRule, DisorderSpec, ParticleType, SequenceItem, TaperSpec,
    };
    use serde::de::{self, Deserializer, MapAccess, Visitor};
    use std::collections::BTreeMap;

    const SEQUENCE_FIELDS: &[&str] = &[
        "particles",
        "sequence",
        "striker",
        "wall_material",
        "taper",
        "disorder",
        "contacts",
        "top_wall_material",
        "ring",
        "wall_mount",
        "mass_factors",
    ];
    const ALL_FIELDS: &[&str] = &[
        "cylinders",
        "sphere",
        "cylinder",
        "particles",
        "sequence",
        "striker",
        "wall_material",
        "taper",
        "disorder",
        "contacts",
        "top_wall_material",
        "ring",
        "wall_mount",
        "mass_factors",
    ];

    /// A striker: a sphere (dimer) or the name of a particle type (sequence).
    enum Striker {
        Sphere(SphereSpec),
        Name(String),
    }

    impl<'de> Deserialize<'de> for Striker {
        fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
            struct V;
            impl<'de> Visitor<'de> for V {
                type Value = Striker;
                fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                    f.write_str("a sphere {\"material\", \"diameter_m\", \"mass_kg\"} (the dimer chain) or the name of a particle type (a sequence chain)")
                }
                fn visit_str<E: de::Error>(self, v: &str) -> Result<Striker, E> {
                    Ok(Striker::Name(v.to_string()))
                }
                fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<Striker, A::Error> {
                    SphereSpec::deserialize(de::value::MapAccessDeserializer::new(map))
                        .map(Striker::Sphere)
                }
            }
            d.deserialize_any(V)
        }
    }

    #[derive(Default)]
    struct Fields {
        cylinders: Option<usize>,
        sphere: Option<SphereSpec>,
        cylinder: Option<CylinderSpec>,
        particles: Option<BTreeMap<String, ParticleType>>,
        sequence: Option<Vec<SequenceItem>>,
        striker: Option<Striker>,
        wall_material: Option<Material>,
        taper: Option<Option<TaperSpec>>,
        disorder: Option<Option<DisorderSpec>>,
        contacts: Option<Vec<ContactRule>>,
        top_wall_material: Option<Option<Material>>,
        ring: Option<bool>,
        wall_mount: Option<Option<crate::chain::mount::WallMount>>,
        mass_factors: Option<Vec<f64>>,
    }

    fn once<T, E: de::Error>(slot: &mut Option<T>, value: T, key: &'static str) -> Result<(), E> {
        if slot.is_some() {
            return Err(E::duplicate_field(key));
        }
        *slot = Some(value);
        Ok(())
    }

    impl<'de> Deserialize<'de> for ChainSpec {
        fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
            struct V;
            impl<'de> Visitor<'de> for V {
                type Value = ChainSpec;
                fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                    f.write_str("a chain: the paper's dimer {cylinders, sphere, cylinder, striker, wall_material} or a sequence {particles, sequence, …}")
                }
                fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<ChainSpec, A::Error> {
                    let mut f = Fields::default();
                    while let Some(key) = map.next_key::<String>()? {
                        match key.as_str() {
                            "cylinders" => once(&mut f.cylinders, map.next_value()?, "cylinders")?,
                            "sphere" => once(&mut f.sphere, map.next_value()?, "sphere")?,
                            "cylinder" => once(&mut f.cylinder, map.next_value()?, "cylinder")?,
                            "particles" => once(&mut f.particles, map.next_value()?, "particles")?,
                            "sequence" => once(&mut f.sequence, map.next_value()?, "sequence")?,
                            "striker" => once(&mut f.striker, map.next_value()?, "striker")?,
                            "wall_material" => {
                                once(&mut f.wall_material, map.next_value()?, "wall_material")?
                            }
                            "taper" => once(&mut f.taper, map.next_value()?, "taper")?,
                            "disorder" => once(&mut f.disorder, map.next_value()?, "disorder")?,
                            "contacts" => once(&mut f.contacts, map.next_value()?, "contacts")?,
                            "top_wall_material" => once(
                                &mut f.top_wall_material,
                                map.next_value()?,
                                "top_wall_material",
                            )?,
                            "ring" => once(&mut f.ring, map.next_value()?, "ring")?,
                            "wall_mount" => {
                                once(&mut f.wall_mount, map.next_value()?, "wall_mount")?
                            }
                            "mass_factors" => {
                                once(&mut f.mass_factors, map.next_value()?, "mass_factors")?
                            }
                            other => return Err(de::Error::unknown_field(other, ALL_FIELDS)),
                        }
                    }
                    let sequence = f.particles.is_some()
                        || f.sequence.is_some()
                        || f.taper.is_some()
                        || f.disorder.is_some()
                        || f.contacts.is_some()
                        || f.top_wall_material.is_some()
                        || f.ring.is_some()
                        || f.wall_mount.is_some()
                        || matches!(f.striker, Some(Striker::Name(_)));
                    if sequence {
                        let stray = [
                            ("cylinders", f.cylinders.is_some()),
                            ("sphere", f.sphere.is_some()),
                            ("cylinder", f.cylinder.is_some()),
                        ];
                        if let Some((name, _)) = stray.iter().find(|(_, given)| *given) {
                            return Err(de::Error::custom(format!(
                                "`{name}` is a field of the paper's dimer chain, not of a sequence chain (given `particles`/`sequence`); a sequence chain has: {}",
                                SEQUENCE_FIELDS.join(", ")
                            )));
                        }
                        let striker = match f.striker {
                            None => None,
                            Some(Striker::Name(n)) => Some(n),
                            Some(Striker::Sphere(_)) => {
                                return Err(de::Error::custom(
                                    "in a sequence chain `striker` names one of the particle types (e.g. \"striker\": \"ball\")",
                                ))
                            }
                        };
                        Ok(ChainSpec::Sequence(SequenceSpec {
                            particles: f
                                .particles
                                .ok_or_else(|| de::Error::missing_field("particles"))?,
                            sequence: f
                                .sequence
                                .ok_or_else(|| de::Error::missing_field("sequence"))?,
                            striker,
                            wall_material: f.wall_material.unwrap_or(Material::STEEL_SS304),
                            taper: f.taper.flatten(),
                            disorder: f.disorder.flatten(),
                            contacts: f.contacts.unwrap_or_default(),
                            top_wall_material: f.top_wall_material.flatten(),
                            ring: f.ring.unwrap_or(false),
                            wall_mount: f.wall_mount.flatten(),
                            mass_factors: f.mass_factors.unwrap_or_default(),
                        }))
                    } else {
                        let striker = match f.striker {
                            Some(Striker::Sphere(s)) => s,
                            _ => return Err(de::Error::missing_field("striker")),
                        };
                        Ok(ChainSpec::Dimer(DimerSpec {
                            cylinders: f
                                .cylinders
                                .ok_or_else(|| de::Error::missing_field("cylinders"))?,
                            sphere: f.sphere.ok_or_else(|| de::Error::missing_field("sphere"))?,
                            cylinder: f
                                .cylinder
                                .ok_or_else(|| de::Error::missing_field("cylinder"))?,
                            striker,
                            wall_material: f
                                .wall_material
                                .ok_or_else(|| de::Error::missing_field("wall_material"))?,
                            mass_factors: f.mass_factors.unwrap_or_default(),
                        }))
                    }
                }
            }
            d.deserialize_map(V)
        }
    }
}

/// Which physics a scene switches on.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
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
    /// The rigid wall under the last particle (Eq. 7). Without it the last particle is free.
    pub wall: bool,
    /// Clip the net (elastic + viscous) contact force at zero so a contact never pulls. The paper's
    /// equations allow a slightly tensile force at the end of unloading; that is the default.
    #[cfg_attr(feature = "serde", serde(default))]
    pub clip_tensile: bool,
    /// Static precompression force pressing the first chain particle towards the wall, N (needs
    /// the wall). The initial state is the exact static equilibrium under it and gravity.
    #[cfg_attr(feature = "serde", serde(default, skip_serializing_if = "is_zero"))]
    pub precompression_force_n: f64,
    /// Dissipation model of every contact (a sequence chain's contact rules may override it per
    /// pair). Absent: the paper's linear viscous term with `damping_kg_s` and
    /// `striker_damping_kg_s`, which must then be zero.
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Option::is_none")
    )]
    pub dissipation: Option<DissipationSpec>,
}

#[cfg(feature = "serde")]
fn is_zero(x: &f64) -> bool {
    *x == 0.0
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
            precompression_force_n: 0.0,
            dissipation: None,
        }
    }
}

impl PhysicsSpec {
    /// Whether any contact carries the paper's linear viscous damping.
    pub fn has_damping(&self) -> bool {
        self.damping_kg_s != 0.0 || self.striker_damping_kg_s.is_some_and(|m| m != 0.0)
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

    /// The particles and their Hertz contact laws.
    fn layout(&self, wall: bool) -> Layout {
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
        let laws = hertz_laws(&particles, wall.then_some(self.wall_material));
        let n_contacts = laws.len();
        Layout {
            particles,
            striker: true,
            ring: false,
            top_wall: false,
            wall_mount: None,
            laws,
            dissipation: vec![None; n_contacts],
            plasticity: Vec::new(),
            cell_length_m: Some(h + self.sphere.diameter_m),
        }
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
        let f = self.precompression_force_n;
        if !(f.is_finite() && f >= 0.0) {
            return Err(spec_err(
                "physics.precompression_force_n",
                format!("must be a finite number >= 0, got {f}"),
            ));
        }
        if f > 0.0 && !self.wall {
            return Err(spec_err(
                "physics.precompression_force_n",
                "a static force needs a wall to push the chain against (physics.wall = true)",
            ));
        }
        if let Some(d) = &self.dissipation {
            d.validate("physics.dissipation")?;
            if self.damping_kg_s != 0.0 {
                return Err(spec_err(
                    "physics.damping_kg_s",
                    format!("must be 0 when physics.dissipation is given (the model replaces the linear viscous term; for both, give a contact rule {{\"linear_viscous\": …}}), got {}", self.damping_kg_s),
                ));
            }
            if self.striker_damping_kg_s.is_some() {
                return Err(spec_err(
                    "physics.striker_damping_kg_s",
                    "must be absent when physics.dissipation is given (give the striker contact its own model with a contact rule between \"striker\" and its neighbour)",
                ));
            }
        }
        Ok(())
    }
}

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
        let mut layout = match spec {
            ChainSpec::Dimer(d) => d.layout(physics.wall),
            ChainSpec::Sequence(s) => s.layout(physics.wall)?,
        };
        let factors = spec.mass_factors();
        if !factors.is_empty() {
            if factors.len() != layout.particles.len() {
                return Err(spec_err(
                    "chain.mass_factors",
                    format!(
                        "must give one factor per particle, the striker first: the chain has {} particles, got {} factors",
                        layout.particles.len(),
                        factors.len()
                    ),
                ));
            }
            for (p, f) in layout.particles.iter_mut().zip(factors) {
                p.mass_kg *= f;
            }
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

    /// Contact `c`'s elastic law and dissipation, as the general laws of `contact.rs` take them.
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

/// What a contact joins: its overlap is `x[above] − x[below] + offset`, a missing side being a
/// fixed wall at position 0 (the wall under the chain: `below` is `None`) or at `offset` (the
/// wall at the top: `above` is `None`). The force pushes `above` up (towards −x) and `below`
/// down. A wall that a drive moves is displaced by the state's component `wall_state` (its
/// velocity the next), positive downwards for the base, into the chain for the actuator: the
/// overlap is then `x[n−1] − u` under the chain, `offset + u − x[0]` at the top. A mounted wall
/// under the chain ([`WallMount`]) is displaced the same way, by its own state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactEnds {
    /// The particle above the contact, if any.
    pub above: Option<usize>,
    /// The particle below the contact, if any.
    pub below: Option<usize>,
    /// Position of the wall at the top, m (zero for every other contact).
    pub offset: f64,
    /// Index in the state of the displacement of the wall a drive moves (its velocity at the
    /// next index), when this contact's wall moves.
    pub wall_state: Option<usize>,
}

impl ContactEnds {
    /// Overlap and its rate in state `(x, v)`, read through `x(i)` and `v(i)`; a moving wall's
    /// displacement and velocity through `wall(k)` (`k` its index in the state).
    #[inline(always)]
    pub fn kinematics(
        &self,
        x: impl Fn(usize) -> f64,
        v: impl Fn(usize) -> f64,
        wall: impl Fn(usize) -> f64,
    ) -> (f64, f64) {
        let read = |f: &dyn Fn(usize) -> f64, i: Option<usize>| i.map_or(0.0, f);
        let mut rate = read(&v, self.above) - read(&v, self.below);
        if let Some(w) = self.wall_state {
            rate += self.wall_sign() * wall(w + 1);
        }
        (self.overlap(x, wall), rate)
    }

    /// The overlap alone (what [`ContactEnds::kinematics`] gives first), reading no velocity.
    #[inline(always)]
    pub fn overlap(&self, x: impl Fn(usize) -> f64, wall: impl Fn(usize) -> f64) -> f64 {
        let read = |i: Option<usize>| i.map_or(0.0, &x);
        let overlap = read(self.above) - read(self.below) + self.offset;
        match self.wall_state {
            Some(w) => overlap + self.wall_sign() * wall(w),
            None => overlap,
        }
    }

    /// How a moving wall's displacement enters the overlap: the wall is the missing side, above
    /// the chain it adds, below it takes away.
    #[inline(always)]
    fn wall_sign(&self) -> f64 {
        if self.above.is_none() {
            1.0
        } else {
            -1.0
        }
    }
}

/// What every contact of a chain joins, to read overlaps from a state `[x, v, …]` (the ledger,
/// the probes, the observers): neighbours inline, the few contacts beyond them from a table.
#[derive(Debug, Clone)]
pub struct ContactMap {
    n: usize,
    /// Contacts `N − 1` on: the wall under the chain, a ring's closing contact, the top wall.
    ends: Vec<ContactEnds>,
}

impl ContactMap {
    /// The state components an interior contact `c` reads: the positions of the particles it
    /// joins, `c` above and `c + 1` below, and their velocities (`None` for the contacts from
    /// `N − 1` on: a wall's, a ring's closing contact, the top wall's).
    #[inline(always)]
    pub fn between(&self, c: usize) -> Option<([usize; 2], [usize; 2])> {
        let n = self.n;
        (c + 1 < n).then_some(([c, c + 1], [n + c, n + c + 1]))
    }

    /// The map of `chain`.
    pub fn of(chain: &Chain) -> Self {
        let n = chain.n_particles();
        ContactMap {
            n,
            ends: (n - 1..chain.n_contacts())
                .map(|c| chain.contact_ends(c))
                .collect(),
        }
    }

    /// The contacts beyond the neighbours' (`N − 1` on), in order.
    pub fn ends(&self) -> &[ContactEnds] {
        &self.ends
    }

    /// Overlap of contact `c` and its rate, the state read through `get` (positions at `0..N`,
    /// velocities at `N..2N`).
    #[inline(always)]
    pub fn kinematics(&self, c: usize, get: impl Fn(usize) -> f64) -> (f64, f64) {
        match self.between(c) {
            Some(([above, below], [v_above, v_below])) => {
                (get(above) - get(below), get(v_above) - get(v_below))
            }
            None => {
                let n = self.n;
                self.ends[c + 1 - n].kinematics(&get, |i| get(n + i), &get)
            }
        }
    }

    /// Overlap of contact `c` in state `y` (negative: open): positions first, then whatever a
    /// moving wall's displacement needs.
    #[inline(always)]
    pub fn overlap(&self, c: usize, y: &[f64]) -> f64 {
        self.overlap_read(c, |i| y[i])
    }

    /// [`ContactMap::overlap`] with the state read through `get`: the overlap that
    /// [`ContactMap::kinematics`] gives, reading no velocity.
    #[inline(always)]
    pub fn overlap_read(&self, c: usize, get: impl Fn(usize) -> f64) -> f64 {
        match self.between(c) {
            Some(([above, below], _)) => get(above) - get(below),
            None => self.ends[c + 1 - self.n].overlap(&get, &get),
        }
    }
}

/// [`Chain::contact_ends`] from the chain's shape: contacts `0..N−1` join neighbours, then come
/// the wall under the last particle or the ring's closing contact, then the wall at the top at
/// `top_wall_m`; `moving` is the wall a drive moves and its displacement's index in the state,
/// `mount` the index of a mounted wall's displacement (the wall under the chain).
fn contact_ends(
    n: usize,
    wall: bool,
    ring: bool,
    top_wall_m: Option<f64>,
    moving: Option<(DrivePoint, usize)>,
    mount: Option<usize>,
    c: usize,
) -> ContactEnds {
    let (above, below, offset) = if c + 1 < n {
        (Some(c), Some(c + 1), 0.0)
    } else if c + 1 == n && wall {
        (Some(n - 1), None, 0.0)
    } else if c + 1 == n && ring {
        (Some(n - 1), Some(0), 0.0)
    } else {
        (
            None,
            Some(0),
            top_wall_m.expect("the last contact is the top wall's"),
        )
    };
    let wall_state = match moving {
        Some((DrivePoint::Base, w)) if below.is_none() => Some(w),
        Some((DrivePoint::Actuator, w)) if above.is_none() => Some(w),
        _ if below.is_none() => mount,
        _ => None,
    };
    ContactEnds {
        above,
        below,
        offset,
        wall_state,
    }
}

/// Longitudinal wave speed of a material of density `rho`, m/s.
pub(crate) fn longitudinal_speed(m: &Material, rho: f64) -> f64 {
    let (e, nu) = (m.youngs_modulus_pa, m.poisson_ratio);
    (e * (1.0 - nu) / (rho * (1.0 + nu) * (1.0 - 2.0 * nu))).sqrt()
}
