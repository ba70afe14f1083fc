//! How a name says its unit (`damping_kg_s`, `frequency_hz`, `leading_peak_time_s`): the one
//! table of unit suffixes, the unit a name gives, and the short name a plot labels it by. Scene
//! fields, axes and stored columns are all named this way.

/// Unit suffixes of names and their units, the longer suffix of two that share an ending first.
const UNIT_SUFFIXES: &[(&str, &str)] = &[
    ("_kg_m3", "kg/m^3"),
    ("_m_s2", "m/s^2"),
    ("_kg_s", "kg/s"),
    ("_m_s", "m/s"),
    ("_pa", "Pa"),
    ("_hz", "Hz"),
    ("_rad", "rad"),
    ("_kg", "kg"),
    ("_s", "s"),
    ("_m", "m"),
    ("_n", "N"),
    ("_j", "J"),
];

/// Unit of a field from its name's suffix (`damping_kg_s` → `kg/s`, `frequency_hz` → `Hz`).
pub fn units_of(field: &str) -> String {
    let last = field.rsplit('.').next().unwrap_or(field);
    UNIT_SUFFIXES
        .iter()
        .find(|(suffix, _)| last.ends_with(suffix))
        .map_or("1", |(_, unit)| unit)
        .to_string()
}

/// A name as a plot labels it: its unit suffix left out (the unit is its own attribute) and
/// words apart (`damping_kg_s` → `damping`, `mass_ratio` → `mass ratio`, `leading_peak_time_s` →
/// `leading peak time`).
pub fn human_name(name: &str) -> String {
    let stem = UNIT_SUFFIXES
        .iter()
        .find_map(|(suffix, _)| name.strip_suffix(suffix).filter(|s| !s.is_empty()))
        .unwrap_or(name);
    stem.replace('_', " ")
}
