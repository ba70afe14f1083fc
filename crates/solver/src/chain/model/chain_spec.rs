//! A chain as written ([`ChainSpec`]): the paper's dimer or a sequence of particle types, told
//! apart by their fields, with the reader that takes either in one pass and its JSON Schema.
//! Apart from both forms because it only tells them apart and checks what they share.

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

use crate::chain::sequence::{SequenceSpec, MAX_SIZE_FACTOR};
use crate::spec::{spec_err, SpecError};

use super::dimer::DimerSpec;

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

    /// Factors on each particle's size (empty: none), particle 1 first: every length scaled, the
    /// mass following at constant density and the Hertz laws at the new radii; applied after
    /// type, taper and disorder, before the mass factors, so that a tolerance on every diameter
    /// is one list.
    pub fn size_factors(&self) -> &[f64] {
        match self {
            ChainSpec::Dimer(d) => &d.size_factors,
            ChainSpec::Sequence(s) => &s.size_factors,
        }
    }

    /// Checks every field for physical sense; the error names the field (relative to `chain`).
    pub fn validate(&self) -> Result<(), SpecError> {
        for (list, factors, of) in [
            ("mass_factors", self.mass_factors(), "mass"),
            ("size_factors", self.size_factors(), "size"),
        ] {
            for (i, &f) in factors.iter().enumerate() {
                if !((1.0 / MAX_SIZE_FACTOR..=MAX_SIZE_FACTOR).contains(&f)) {
                    return Err(spec_err(
                        &format!("chain.{list}[{i}]"),
                        format!(
                            "must be a number in [1e-3, 1e3] (a factor on particle {}'s {of}), got {f}",
                            i + 1
                        ),
                    ));
                }
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
    use crate::chain::model::{CylinderSpec, SphereSpec};
    use crate::chain::parts::Material;
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
        "size_factors",
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
        "size_factors",
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
        size_factors: Option<Vec<f64>>,
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
                            "size_factors" => {
                                once(&mut f.size_factors, map.next_value()?, "size_factors")?
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
                            size_factors: f.size_factors.unwrap_or_default(),
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
                            size_factors: f.size_factors.unwrap_or_default(),
                        }))
                    }
                }
            }
            d.deserialize_map(V)
        }
    }
}
