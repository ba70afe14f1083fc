//! Chains as sequences of named particle types: spheres and flat-ended cylinders of any size,
//! material and mass, in repeated blocks and explicit lists, with an optional striker, a taper
//! (geometric progression of size and mass along the chain) and seeded disorder; contact laws
//! derived from the geometry (Hertz for sphere–sphere and sphere–flat pairs) and overridable per
//! pair of types, like the dissipation model.
//!
//! ```json
//! "chain": {
//!   "particles": {
//!     "ball": {"sphere": {"diameter_m": 0.008, "mass_kg": 0.002085,
//!                         "material": {"youngs_modulus_pa": 2e11, "poisson_ratio": 0.28}}},
//!     "tall": {"cylinder": {"diameter_m": 0.008, "height_m": 0.0096, "density_kg_m3": 7813,
//!                           "material": {"youngs_modulus_pa": 1.93e11, "poisson_ratio": 0.29}}}
//!   },
//!   "sequence": [{"repeat": 50, "of": ["ball", "tall"]}, "ball"],
//!   "striker": "ball",
//!   "taper": {"ratio": 0.98},
//!   "disorder": {"level": 0.05, "seed": 7, "of": "mass"},
//!   "contacts": [{"between": ["tall", "wall"],
//!                 "law": {"power_law": {"coefficient": 1e10, "exponent": 1.0}}}]
//! }
//! ```

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

use crate::chain::mount::WallMount;
use crate::chain::parts::{
    check_factor_count, check_material, effective_modulus, effective_radius, hertz_coefficient,
    Layout, Material, Particle, ParticleKind, Shape, MAX_PARTICLES,
};
use crate::contact::{DissipationSpec, LawSpec, SplitMix64, Thornton};
use crate::spec::{check_positive, spec_err, SpecError};

/// Name a contact rule uses for the wall.
pub const WALL: &str = "wall";
/// Name a contact rule uses for the wall at the top of the chain (`top_wall_material`).
pub const TOP_WALL: &str = "top_wall";
/// Name a contact rule uses for the striker, whatever its type.
pub const STRIKER: &str = "striker";

/// Largest factor by which taper and disorder may scale a particle's size, either way: beyond a
/// thousandfold a particle is a few µm across, the size of the overlaps, and its contact laws mean
/// nothing (such a taper "makes a particle vanish").
pub const MAX_SIZE_FACTOR: f64 = 1e3;

/// A chain described as a sequence of named particle types.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize))]
// The schema of the form read (by `ChainSpec`'s deserializer): `striker`, `wall_material`,
// `taper`, `disorder` and `contacts` may be left out.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "schema", schemars(deny_unknown_fields))]
pub struct SequenceSpec {
    /// The particle types, by name.
    pub particles: BTreeMap<String, ParticleType>,
    /// The chain from the top (struck end) to the wall: type names and repeated blocks.
    pub sequence: Vec<SequenceItem>,
    /// Type of the striker, particle 1, above the sequence. Absent: no striker; the chain is
    /// excited by the scene's `excitation`.
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Option::is_none"))]
    pub striker: Option<String>,
    /// Material of the flat wall (default SS304 steel, as the paper's).
    #[cfg_attr(feature = "schema", schemars(default = "default_wall_material"))]
    pub wall_material: Material,
    /// Geometric progression of size and mass along the chain.
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Option::is_none"))]
    pub taper: Option<TaperSpec>,
    /// Seeded random perturbation of masses or sizes.
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Option::is_none"))]
    pub disorder: Option<DisorderSpec>,
    /// Contact laws and dissipation models per pair of types, overriding the defaults.
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Vec::is_empty"))]
    #[cfg_attr(feature = "schema", schemars(default))]
    pub contacts: Vec<ContactRule>,
    /// Material of a flat wall at the top of the chain, touching its first particle (a chain
    /// between two walls, with `physics.wall`). Absent: no wall at the top. Contact rules name it
    /// `"top_wall"`.
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Option::is_none"))]
    pub top_wall_material: Option<Material>,
    /// Close the chain into a ring: the last particle touches the first (no walls, no gravity,
    /// no striker).
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "std::ops::Not::not"))]
    #[cfg_attr(feature = "schema", schemars(default))]
    pub ring: bool,
    /// The wall under the chain on a spring and a dashpot (a load cell, a soft support) rather
    /// than rigid. Absent: a rigid wall.
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Option::is_none"))]
    pub wall_mount: Option<WallMount>,
    /// Factors on each particle's mass, from particle 1 to the last (empty: none), applied after
    /// taper and disorder.
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Vec::is_empty"))]
    #[cfg_attr(feature = "schema", schemars(default))]
    pub mass_factors: Vec<f64>,
    /// Factors on each particle's size, from particle 1 to the last (empty: none), applied after
    /// taper and disorder: every length scaled, the mass following at constant density and the
    /// Hertz laws at the new radii.
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Vec::is_empty"))]
    #[cfg_attr(feature = "schema", schemars(default))]
    pub size_factors: Vec<f64>,
}

/// The wall a sequence chain stands on when it names none (as the paper's).
#[cfg(feature = "schema")]
fn default_wall_material() -> Material {
    Material::STEEL_SS304
}

/// A particle type.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(
    feature = "serde",
    serde(rename_all = "snake_case", deny_unknown_fields)
)]
pub enum ParticleType {
    /// A sphere.
    Sphere(SphereType),
    /// A cylinder with flat ends along the chain.
    Cylinder(CylinderType),
}

/// A sphere type; give exactly one of `mass_kg` and `density_kg_m3`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct SphereType {
    /// Material.
    pub material: Material,
    /// Diameter, m.
    pub diameter_m: f64,
    /// Mass, kg.
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Option::is_none")
    )]
    pub mass_kg: Option<f64>,
    /// Density, kg/m³.
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Option::is_none")
    )]
    pub density_kg_m3: Option<f64>,
}

/// A flat-ended cylinder type; give exactly one of `mass_kg` and `density_kg_m3`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct CylinderType {
    /// Material.
    pub material: Material,
    /// Diameter, m.
    pub diameter_m: f64,
    /// Height (length along the chain), m.
    pub height_m: f64,
    /// Mass, kg.
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Option::is_none")
    )]
    pub mass_kg: Option<f64>,
    /// Density, kg/m³.
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Option::is_none")
    )]
    pub density_kg_m3: Option<f64>,
}

impl ParticleType {
    fn material(&self) -> Material {
        match self {
            ParticleType::Sphere(s) => s.material,
            ParticleType::Cylinder(c) => c.material,
        }
    }

    fn shape(&self) -> Shape {
        match *self {
            ParticleType::Sphere(s) => Shape::Sphere {
                diameter_m: s.diameter_m,
            },
            ParticleType::Cylinder(c) => Shape::Cylinder {
                diameter_m: c.diameter_m,
                height_m: c.height_m,
            },
        }
    }

    fn mass_or_density(&self) -> (Option<f64>, Option<f64>) {
        match *self {
            ParticleType::Sphere(s) => (s.mass_kg, s.density_kg_m3),
            ParticleType::Cylinder(c) => (c.mass_kg, c.density_kg_m3),
        }
    }

    /// Mass of one particle of this type, kg.
    pub fn mass_kg(&self) -> f64 {
        match self.mass_or_density() {
            (Some(m), _) => m,
            (None, Some(rho)) => rho * self.shape().volume_m3(),
            (None, None) => f64::NAN,
        }
    }

    fn kind(&self) -> ParticleKind {
        match self {
            ParticleType::Sphere(_) => ParticleKind::Sphere,
            ParticleType::Cylinder(_) => ParticleKind::Cylinder,
        }
    }

    fn validate(&self, field: &str) -> Result<(), SpecError> {
        let (variant, diameter, height) = match *self {
            ParticleType::Sphere(s) => ("sphere", s.diameter_m, None),
            ParticleType::Cylinder(c) => ("cylinder", c.diameter_m, Some(c.height_m)),
        };
        let field = format!("{field}.{variant}");
        check_material(&format!("{field}.material"), &self.material())?;
        check_positive(&format!("{field}.diameter_m"), diameter)?;
        if let Some(h) = height {
            check_positive(&format!("{field}.height_m"), h)?;
        }
        match self.mass_or_density() {
            (Some(m), None) => check_positive(&format!("{field}.mass_kg"), m),
            (None, Some(rho)) => check_positive(&format!("{field}.density_kg_m3"), rho),
            _ => Err(spec_err(
                &field,
                "give exactly one of `mass_kg` and `density_kg_m3`",
            )),
        }
    }
}

/// An element of a sequence: a type name, or a block of elements repeated `repeat` times.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(untagged))]
pub enum SequenceItem {
    /// One particle of the named type.
    Type(String),
    /// `repeat × [of…]`.
    Repeat(RepeatBlock),
}

/// `repeat` copies of a block.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct RepeatBlock {
    /// Number of copies, at least 1.
    pub repeat: usize,
    /// The block.
    pub of: Vec<SequenceItem>,
}

#[cfg(feature = "serde")]
impl<'de> Deserialize<'de> for SequenceItem {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = SequenceItem;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a particle type name or a block {\"repeat\": n, \"of\": [...]}")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<SequenceItem, E> {
                Ok(SequenceItem::Type(v.to_string()))
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                map: A,
            ) -> Result<SequenceItem, A::Error> {
                RepeatBlock::deserialize(serde::de::value::MapAccessDeserializer::new(map))
                    .map(SequenceItem::Repeat)
            }
        }
        d.deserialize_any(V)
    }
}

/// Geometric progression along the chain: chain particle `k` (0 for the first below the striker)
/// has every length multiplied by `ratio^k` and its mass by `ratio^{3k}` (same density).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct TaperSpec {
    /// Size ratio of consecutive particles, > 0 (< 1: decreasing towards the wall).
    pub ratio: f64,
}

/// What disorder perturbs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum DisorderOf {
    /// Masses only (geometry and contact laws unchanged).
    #[default]
    Mass,
    /// Sizes (every length; the mass follows at constant density, and so do Hertz laws).
    Size,
}

/// Seeded random perturbation: chain particle `k` is scaled by `1 + level · u_k`, `u_k` uniform in
/// [−1, 1) drawn in order from SplitMix64 seeded with `seed`. One seed per axis value makes an
/// ensemble of chains.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct DisorderSpec {
    /// Relative amplitude, in [0, 1).
    pub level: f64,
    /// Seed of the generator.
    pub seed: u64,
    /// What is perturbed (default: mass).
    #[cfg_attr(feature = "serde", serde(default))]
    pub of: DisorderOf,
}

/// A contact law and/or dissipation model for every contact between two named types (`"wall"`
/// for the wall, `"striker"` for the striker whatever its type; a rule naming the striker wins
/// over one naming its type).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct ContactRule {
    /// The two types, in either order.
    pub between: [String; 2],
    /// The elastic law (absent: Hertz from the geometry).
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Option::is_none")
    )]
    pub law: Option<LawSpec>,
    /// The dissipation model (absent: the physics block's).
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Option::is_none")
    )]
    pub dissipation: Option<DissipationSpec>,
}

/// Number of particles a sequence expands to, or the item whose repeat count is not allowed.
fn count(items: &[SequenceItem], field: &str) -> Result<usize, SpecError> {
    let mut total = 0usize;
    for (i, item) in items.iter().enumerate() {
        let n = match item {
            SequenceItem::Type(_) => 1,
            SequenceItem::Repeat(b) => {
                let f = format!("{field}[{i}]");
                if b.repeat == 0 {
                    return Err(spec_err(&format!("{f}.repeat"), "must be at least 1"));
                }
                if b.of.is_empty() {
                    return Err(spec_err(&format!("{f}.of"), "must hold at least one item"));
                }
                count(&b.of, &format!("{f}.of"))?
                    .checked_mul(b.repeat)
                    .filter(|&n| n <= MAX_PARTICLES)
                    .ok_or_else(|| {
                        spec_err(
                            &format!("{f}.repeat"),
                            format!("makes the chain longer than {MAX_PARTICLES} particles"),
                        )
                    })?
            }
        };
        total = total
            .checked_add(n)
            .filter(|&n| n <= MAX_PARTICLES)
            .ok_or_else(|| {
                spec_err(
                    field,
                    format!("the chain is longer than {MAX_PARTICLES} particles"),
                )
            })?;
    }
    Ok(total)
}

/// Checks that every name in the sequence is a type.
fn check_names(
    items: &[SequenceItem],
    field: &str,
    types: &BTreeMap<String, ParticleType>,
) -> Result<(), SpecError> {
    for (i, item) in items.iter().enumerate() {
        match item {
            SequenceItem::Type(name) if !types.contains_key(name) => {
                return Err(spec_err(
                    &format!("{field}[{i}]"),
                    format!(
                        "unknown particle type `{name}`; the types are: {}",
                        type_list(types)
                    ),
                ))
            }
            SequenceItem::Type(_) => {}
            SequenceItem::Repeat(b) => check_names(&b.of, &format!("{field}[{i}].of"), types)?,
        }
    }
    Ok(())
}

fn type_list(types: &BTreeMap<String, ParticleType>) -> String {
    types.keys().cloned().collect::<Vec<_>>().join(", ")
}

/// Appends the type names of `items`, expanded, to `out`.
fn expand<'a>(items: &'a [SequenceItem], out: &mut Vec<&'a str>) {
    for item in items {
        match item {
            SequenceItem::Type(name) => out.push(name),
            SequenceItem::Repeat(b) => {
                for _ in 0..b.repeat {
                    expand(&b.of, out);
                }
            }
        }
    }
}

impl SequenceSpec {
    /// Checks every field that does not depend on the expanded chain; the error names the field
    /// (relative to `chain`).
    pub fn validate(&self) -> Result<(), SpecError> {
        if self.particles.is_empty() {
            return Err(spec_err(
                "chain.particles",
                "must name at least one particle type",
            ));
        }
        for (name, t) in &self.particles {
            if name.is_empty() || name == WALL || name == TOP_WALL || name == STRIKER {
                return Err(spec_err(
                    "chain.particles",
                    format!(
                        "`{name}` cannot name a particle type (reserved: \"\", {WALL}, {TOP_WALL}, {STRIKER})"
                    ),
                ));
            }
            t.validate(&format!("chain.particles.{name}"))?;
        }
        if self.sequence.is_empty() {
            return Err(spec_err(
                "chain.sequence",
                "must hold at least one particle",
            ));
        }
        check_names(&self.sequence, "chain.sequence", &self.particles)?;
        let n = count(&self.sequence, "chain.sequence")? + self.striker.is_some() as usize;
        if n > MAX_PARTICLES {
            return Err(spec_err(
                "chain.sequence",
                format!("the chain has {n} particles, at most {MAX_PARTICLES} allowed"),
            ));
        }
        if let Some(s) = &self.striker {
            if !self.particles.contains_key(s) {
                return Err(spec_err(
                    "chain.striker",
                    format!(
                        "unknown particle type `{s}`; the types are: {}",
                        type_list(&self.particles)
                    ),
                ));
            }
        }
        check_material("chain.wall_material", &self.wall_material)?;
        if let Some(m) = &self.top_wall_material {
            check_material("chain.top_wall_material", m)?;
            if self.striker.is_some() {
                return Err(spec_err(
                    "chain.top_wall_material",
                    "a chain with a wall at the top has no striker: set particles in motion with excitation.initial_state",
                ));
            }
        }
        if self.ring {
            if n < 3 {
                return Err(spec_err(
                    "chain.ring",
                    format!("a ring needs at least 3 particles, got {n}"),
                ));
            }
            if self.striker.is_some() {
                return Err(spec_err(
                    "chain.ring",
                    "a ring has no striker: set particles in motion with excitation.initial_state or excitation.impulse",
                ));
            }
            if self.top_wall_material.is_some() {
                return Err(spec_err(
                    "chain.ring",
                    "a ring has no walls: remove chain.top_wall_material",
                ));
            }
            if self.wall_mount.is_some() {
                return Err(spec_err(
                    "chain.ring",
                    "a ring has no walls: remove chain.wall_mount",
                ));
            }
        }
        if let Some(m) = &self.wall_mount {
            m.validate()?;
        }
        if let Some(t) = &self.taper {
            check_positive("chain.taper.ratio", t.ratio)?;
        }
        if let Some(d) = &self.disorder {
            if !(d.level.is_finite() && (0.0..1.0).contains(&d.level)) {
                return Err(spec_err(
                    "chain.disorder.level",
                    format!("must lie in [0, 1), got {}", d.level),
                ));
            }
        }
        let mut pairs: Vec<(&str, &str, usize)> = Vec::new();
        for (i, rule) in self.contacts.iter().enumerate() {
            let field = format!("chain.contacts[{i}]");
            for (k, name) in rule.between.iter().enumerate() {
                let known = self.particles.contains_key(name)
                    || name == WALL
                    || (name == TOP_WALL && self.top_wall_material.is_some())
                    || (name == STRIKER && self.striker.is_some());
                if !known {
                    return Err(spec_err(
                        &format!("{field}.between[{k}]"),
                        format!(
                            "unknown name `{name}`; allowed: the particle types ({}), \"{WALL}\"{}{}",
                            type_list(&self.particles),
                            if self.top_wall_material.is_some() {
                                format!(", \"{TOP_WALL}\"")
                            } else {
                                String::new()
                            },
                            if self.striker.is_some() {
                                format!(", \"{STRIKER}\"")
                            } else {
                                String::new()
                            }
                        ),
                    ));
                }
            }
            let (a, b) = (rule.between[0].as_str(), rule.between[1].as_str());
            let is_wall = |x: &str| x == WALL || x == TOP_WALL;
            if is_wall(a) && is_wall(b) {
                return Err(spec_err(
                    &format!("{field}.between"),
                    "a wall touches only a particle (the wall the last one, the top wall the first)",
                ));
            }
            let key = if a <= b { (a, b) } else { (b, a) };
            if let Some((_, _, j)) = pairs.iter().find(|p| (p.0, p.1) == key) {
                return Err(spec_err(
                    &format!("{field}.between"),
                    format!("the pair ({a}, {b}) already has a rule, chain.contacts[{j}]"),
                ));
            }
            pairs.push((key.0, key.1, i));
            if rule.law.is_none() && rule.dissipation.is_none() {
                return Err(spec_err(
                    &field,
                    "a contact rule needs a `law`, a `dissipation`, or both",
                ));
            }
            if let Some(law) = &rule.law {
                law.validate(&format!("{field}.law"))?;
                if matches!(law, LawSpec::Thornton { .. }) && rule.dissipation.is_some() {
                    return Err(spec_err(
                        &format!("{field}.dissipation"),
                        "must be absent on a contact with Thornton's law (it dissipates through plastic work; a dissipation model beside it is not supported)",
                    ));
                }
            }
            if let Some(d) = &rule.dissipation {
                d.validate(&format!("{field}.dissipation"))?;
            }
        }
        Ok(())
    }

    /// The rule for a pair of particles with the given names (type, and `"striker"` for the
    /// striker), the most specific first.
    fn rule(&self, a: &[&str], b: &[&str]) -> Option<&ContactRule> {
        let mut best: Option<(usize, &ContactRule)> = None;
        for rule in &self.contacts {
            let (x, y) = (rule.between[0].as_str(), rule.between[1].as_str());
            for &na in a {
                for &nb in b {
                    if (x == na && y == nb) || (x == nb && y == na) {
                        let score = (na == STRIKER) as usize + (nb == STRIKER) as usize;
                        if best.map_or(true, |(s, _)| score > s) {
                            best = Some((score, rule));
                        }
                    }
                }
            }
        }
        best.map(|(_, r)| r)
    }

    /// Expands the sequence into particles (taper, disorder and size factors applied) and
    /// resolves every contact's law and dissipation override.
    pub(crate) fn layout(&self, wall: bool, size_factors: &[f64]) -> Result<Layout, SpecError> {
        if self.ring && wall {
            return Err(spec_err(
                "physics.wall",
                "must be false for a ring (chain.ring = true): a ring has no walls",
            ));
        }
        let mut names: Vec<&str> = Vec::new();
        if let Some(s) = &self.striker {
            names.push(s);
        }
        let first = names.len();
        expand(&self.sequence, &mut names);
        check_factor_count("chain.size_factors", size_factors, names.len())?;

        let mut rng = self.disorder.map(|d| (d, SplitMix64(d.seed)));
        let mut particles = Vec::with_capacity(names.len());
        for (i, &name) in names.iter().enumerate() {
            let t = &self.particles[name];
            let mut shape = t.shape();
            let mut mass = t.mass_kg();
            let kind = if i < first {
                ParticleKind::Striker
            } else {
                t.kind()
            };
            if i >= first {
                let k = (i - first) as i32;
                let mut size = 1.0;
                if let Some(taper) = self.taper {
                    size = taper.ratio.powi(k);
                    mass *= size * size * size;
                }
                if let Some((d, rng)) = &mut rng {
                    let f = 1.0 + d.level * rng.symmetric();
                    match d.of {
                        crate::chain::sequence::DisorderOf::Mass => mass *= f,
                        crate::chain::sequence::DisorderOf::Size => {
                            size *= f;
                            mass *= f * f * f;
                        }
                    }
                }
                shape = shape.scaled(size);
                let ok = |x: f64| x.is_normal() && x > 0.0;
                let in_range = (1.0 / MAX_SIZE_FACTOR..=MAX_SIZE_FACTOR).contains(&size);
                if !(in_range && ok(shape.length_m()) && ok(mass) && ok(shape.volume_m3())) {
                    let field = if self.taper.is_some() {
                        "chain.taper.ratio"
                    } else {
                        "chain.disorder.level"
                    };
                    return Err(spec_err(
                        field,
                        format!(
                            "makes particle {} (type `{name}`) vanish or blow up: {size:e} times its type's size (allowed: {:e} to {MAX_SIZE_FACTOR:e}), length {:e} m, mass {:e} kg",
                            i + 1,
                            1.0 / MAX_SIZE_FACTOR,
                            shape.length_m(),
                            mass
                        ),
                    ));
                }
            }
            let mut particle = Particle {
                kind,
                shape,
                material: t.material(),
                mass_kg: mass,
            };
            if let Some(&f) = size_factors.get(i) {
                particle.scale_size(f);
            }
            particles.push(particle);
        }

        let labels = |i: usize| -> Vec<&str> {
            if i < first {
                vec![STRIKER, names[i]]
            } else {
                vec![names[i]]
            }
        };
        let n = particles.len();
        // Each contact: the particle on one side, and on the other a particle or a wall (its
        // material and name), in the order `Chain::contact_ends` reads them: neighbours, the wall
        // under the last particle or the ring's closing contact, the wall at the top.
        let mut sides: Vec<(usize, Other)> =
            (0..n - 1).map(|c| (c, Other::Neighbour(c + 1))).collect();
        if wall {
            sides.push((n - 1, Other::Wall(self.wall_material, WALL)));
        }
        if self.ring {
            sides.push((n - 1, Other::Neighbour(0)));
        }
        if let Some(m) = self.top_wall_material {
            sides.push((0, Other::Wall(m, TOP_WALL)));
        }
        let n_contacts = sides.len();
        let mut laws = Vec::with_capacity(n_contacts);
        let mut dissipation = Vec::with_capacity(n_contacts);
        // Allocated at the first plastic contact (empty for chains without one).
        let mut plasticity: Vec<Option<Thornton>> = Vec::new();
        for (c, &(i, other)) in sides.iter().enumerate() {
            let p = &particles[i];
            let (la, lb) = match other {
                Other::Neighbour(j) => (labels(i), labels(j)),
                Other::Wall(_, name) => (labels(i), vec![name]),
            };
            let rule = self.rule(&la, &lb);
            let (mb, rb) = match other {
                Other::Neighbour(j) => (particles[j].material, particles[j].shape.contact_radius()),
                Other::Wall(material, _) => (material, None),
            };
            let spec = rule.and_then(|r| r.law);
            let law = match spec {
                Some(LawSpec::PowerLaw {
                    coefficient,
                    exponent,
                }) => (coefficient, exponent),
                Some(LawSpec::Hertz) | Some(LawSpec::Thornton { .. }) | None => {
                    let ra = p.shape.contact_radius();
                    if ra.is_none() && rb.is_none() {
                        let (ta, tb) = (la[la.len() - 1], lb[lb.len() - 1]);
                        let what = match other {
                            Other::Neighbour(j) => format!(
                                "particles {} and {} (types `{ta}` and `{tb}`) touch flat to flat",
                                i + 1,
                                j + 1
                            ),
                            Other::Wall(_, wall) => format!(
                                "particle {} (type `{ta}`) touches the {} flat to flat",
                                i + 1,
                                wall.replace('_', " ")
                            ),
                        };
                        return Err(spec_err(
                            "chain.contacts",
                            format!("{what}, which has no Hertz law: add a rule {{\"between\": [\"{ta}\", \"{tb}\"], \"law\": {{\"power_law\": {{\"coefficient\": …, \"exponent\": …}}}}}}"),
                        ));
                    }
                    let a = match (ra, rb) {
                        (None, rb) => hertz_coefficient(p.material, None, mb, rb),
                        (ra, None) => hertz_coefficient(mb, None, p.material, ra),
                        (ra, rb) => hertz_coefficient(p.material, ra, mb, rb),
                    };
                    (a, 1.5)
                }
            };
            if let Some(LawSpec::Thornton {
                yield_pressure_pa,
                yield_velocity_m_s,
            }) = spec
            {
                let e_star = effective_modulus(p.material, mb);
                let r_star = effective_radius(p.shape.contact_radius(), rb);
                let thornton = match (yield_pressure_pa, yield_velocity_m_s) {
                    (Some(p_y), _) => Thornton::new(e_star, r_star, p_y),
                    (None, Some(v_y)) => {
                        let reduced_mass = match other {
                            Other::Neighbour(j) => {
                                let (ma, mb) = (p.mass_kg, particles[j].mass_kg);
                                ma * mb / (ma + mb)
                            }
                            Other::Wall(..) => p.mass_kg,
                        };
                        Thornton::from_yield_velocity(e_star, r_star, reduced_mass, v_y)
                    }
                    (None, None) => unreachable!("validated: one of the two is given"),
                };
                // A yield that the arithmetic cannot represent (an overlap or force of zero or of
                // infinity) would make the run's state not finite: refused at its rule.
                let usable = |x: f64| x.is_finite() && x >= f64::MIN_POSITIVE;
                if !(usable(thornton.yield_overlap) && usable(thornton.yield_force)) {
                    let k = rule
                        .and_then(|r| self.contacts.iter().position(|q| std::ptr::eq(q, r)))
                        .unwrap_or(0);
                    let key = if yield_pressure_pa.is_some() {
                        "yield_pressure_pa"
                    } else {
                        "yield_velocity_m_s"
                    };
                    return Err(spec_err(
                        &format!("chain.contacts[{k}].law.thornton.{key}"),
                        format!(
                            "puts yield at an overlap of {:e} m and a force of {:e} N, which the arithmetic cannot hold: give a yield between those of soft metals and of the hardest steels (a yield pressure of 1e7 to 1e10 Pa)",
                            thornton.yield_overlap, thornton.yield_force
                        ),
                    ));
                }
                plasticity.resize(c, None);
                plasticity.push(Some(thornton));
                laws.push((thornton.hertz, 1.5));
            } else {
                if !plasticity.is_empty() {
                    plasticity.push(None);
                }
                laws.push(law);
            }
            dissipation.push(rule.and_then(|r| r.dissipation));
        }
        Ok(Layout {
            particles,
            striker: first > 0,
            ring: self.ring,
            top_wall: self.top_wall_material.is_some(),
            wall_mount: self.wall_mount,
            laws,
            dissipation,
            plasticity: if plasticity.is_empty() {
                plasticity
            } else {
                let mut all = plasticity;
                all.resize(n_contacts, None);
                all
            },
            cell_length_m: None,
        })
    }
}

/// What a contact joins to its particle: another particle, or a wall (its material and the name
/// contact rules give it).
#[derive(Debug, Clone, Copy)]
enum Other {
    Neighbour(usize),
    Wall(Material, &'static str),
}
