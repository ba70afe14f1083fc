//! `periodic`: at every point of the axes, the branch of periodic orbits of the driven scene,
//! continued in one scene field from the point's own value to `to`, with its stability and
//! bifurcations ([`chainsweep_solver::periodic`]); or, with `autonomous`, the family of free
//! orbits of the conservative scene (breathers, backbone curves) continued in their frequency.

use std::f64::consts::TAU;

use serde::Deserialize;
use serde_json::Value;

use chainsweep_solver::periodic::{
    doubled_orbits, AutonomousMap, BranchOptions, Monodromy, PeriodMap, PeriodicOptions,
};
use chainsweep_solver::spectrum::LinearChain;
use chainsweep_solver::Scene;

use super::paths::{check_settable, field_name, from_value_at, lookup, set_path, units_of};
use super::Dim;
use crate::error::{Error, Result};

/// `periodic` as written.
#[derive(Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub(super) struct PeriodicFile {
    /// The scene field continued, as a dotted path
    /// (`excitation.drive.actuator_m.harmonic.frequency_hz`): each branch starts at the base
    /// scene's value of it (at each point of the axes). Left out with `autonomous`.
    #[serde(default)]
    field: Option<String>,
    /// `true`: not a driven branch but the free orbits of the conservative chain (no drive, no
    /// damping, elastic contacts), set in motion by `excitation.initial_state`, whose
    /// displacements are the first orbit's guess of its turning point: breathers, backbone
    /// curves. They are continued in their own frequency from `from` to `to` by `step` Hz, each
    /// shot on time-reversal symmetry from the two before it.
    #[serde(default)]
    autonomous: bool,
    /// With `autonomous`: the first orbit's frequency, Hz.
    #[serde(default)]
    from: Option<f64>,
    /// Its name in the output (default: the field's last part; `frequency_hz` with
    /// `autonomous`).
    #[serde(default)]
    name: Option<String>,
    /// The value the branch ends at.
    to: f64,
    /// First step of the field (default a fiftieth of the range); with `autonomous`, the step
    /// between orbits' frequencies, Hz.
    #[serde(default)]
    step: Option<f64>,
    /// Smallest step before a branch gives up (default a ten-thousandth of the first step).
    #[serde(default)]
    min_step: Option<f64>,
    /// Largest change of the field in one step (default a twentieth of the range).
    #[serde(default)]
    max_step: Option<f64>,
    /// Most points of a branch, special points included (default 400).
    #[serde(default)]
    max_points: Option<u32>,
    /// Special points are located to this fraction of the range in arclength (default 1e-6).
    #[serde(default)]
    locate_tolerance: Option<f64>,
    /// Drive periods in one orbit period (default 1; 2 for a period-doubled response).
    #[serde(default)]
    periods: Option<u32>,
    /// Drive periods integrated from rest, the scene's ramp included, for the first orbit's
    /// guess (default 50).
    #[serde(default)]
    settle_periods: Option<u32>,
    /// Largest scaled residual of a converged orbit (default 1e-7).
    #[serde(default)]
    tolerance: Option<f64>,
    /// Most Newton iterations per orbit (default 12).
    #[serde(default)]
    max_iterations: Option<u32>,
    /// How the monodromy matrix is computed: `auto` (default), `variational` or
    /// `finite_difference`.
    #[serde(default)]
    monodromy: Option<Monodromy>,
    /// `period_doubling`: the branch stored is not the one from the point's value but the branch
    /// of orbits of twice the period that starts at its first period doubling (met on the way to
    /// `to`), continued while the field stays within `|to − p_PD|` of the doubling's value `p_PD`,
    /// on either side (absent: the branch from the point's value).
    #[serde(default)]
    switch: Option<Switch>,
}

/// Which branch a `periodic` block stores instead of the one from the point's value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Switch {
    /// The branch of twice the period from the first period doubling.
    PeriodDoubling,
}

/// A sweep's `periodic` block, checked.
#[derive(Debug, Clone, PartialEq)]
pub struct PeriodicSpec {
    /// The continued field's dotted path.
    pub field: String,
    /// Its name in the output.
    pub name: String,
    /// Its unit.
    pub units: String,
    /// How orbits are found.
    pub orbit: PeriodicOptions,
    /// How branches are continued.
    pub branch: BranchOptions,
    /// The branch switched to at a bifurcation of the point's branch, when one is.
    pub switch: Option<Switch>,
    /// The frequencies of the free orbits, in order, when the block continues autonomous orbits
    /// (`branch.to` is then the last frequency's target and `orbit` holds the shooting's
    /// tolerance and iterations).
    pub autonomous: Option<Vec<f64>>,
}

/// The continued field's name and text where a block continues free orbits in their frequency.
pub const AUTONOMOUS_FIELD: &str = "the free orbit's frequency";

impl PeriodicSpec {
    /// The block in a sentence.
    pub fn describe(&self) -> String {
        use crate::error::number_text as num;
        if let Some(f) = &self.autonomous {
            return format!(
                "free (autonomous) orbits of the conservative chain continued in their frequency ({}) from {} to {} Hz, {} orbits each, tolerance {}",
                self.name,
                num(f[0]),
                num(f[f.len() - 1]),
                f.len(),
                num(self.orbit.tolerance)
            );
        }
        format!(
            "branches of periodic orbits continued in {} ({}) from its base value to {} {}{}, at most {} points each, {} drive period{} per orbit, tolerance {}",
            self.name,
            self.field,
            num(self.branch.to),
            self.units,
            match self.switch {
                None => "",
                Some(Switch::PeriodDoubling) =>
                    ", each switched at its first period doubling to the branch of twice the period",
            },
            self.branch.max_points,
            self.stored_orbit().periods,
            if self.stored_orbit().periods == 1 {
                ""
            } else {
                "s"
            },
            num(self.orbit.tolerance)
        )
    }

    /// How the stored branch's orbits are found: [`PeriodicSpec::orbit`], of twice the drive
    /// periods on a branch switched to at a period doubling.
    pub fn stored_orbit(&self) -> PeriodicOptions {
        match self.switch {
            None => self.orbit,
            Some(Switch::PeriodDoubling) => doubled_orbits(&self.orbit),
        }
    }

    /// The continued field's value in the grid point's scene `point` (the branch's start).
    pub fn start(&self, point: &Value) -> Result<f64> {
        lookup(point, &self.field)
            .ok()
            .and_then(Value::as_f64)
            .ok_or_else(|| {
                Error::input(
                    "periodic.field",
                    format!("must name a number of the base scene, got {:?}", self.field),
                )
            })
    }

    /// The scene of grid point `point` (its JSON) with the continued field at `value`.
    pub fn scene_at(&self, point: &Value, value: f64) -> Result<Scene> {
        let mut v = point.clone();
        set_path(&mut v, &self.field, Value::from(value));
        from_value_at::<Scene>(v, "base")
    }

    /// The scene of grid point `point` (its JSON) as it is: an `autonomous` block's.
    pub fn scene_of(&self, point: &Value) -> Result<Scene> {
        from_value_at::<Scene>(point.clone(), "base")
    }
}

/// Checks `periodic` against the base scene and the axes; errors name `periodic.…`.
pub(super) fn parse(
    file: Option<PeriodicFile>,
    base: &mut Value,
    dims: &[Dim],
    other_goal: Option<&str>,
) -> Result<Option<PeriodicSpec>> {
    let Some(f) = file else {
        return Ok(None);
    };
    if let Some(goal) = other_goal {
        return Err(Error::input(
            "periodic",
            format!(
                "a sweep with a `periodic` block continues branches of orbits; it cannot also have `{goal}`: remove one"
            ),
        ));
    }
    let field = match (&f.field, f.autonomous) {
        (Some(_), true) => {
            return Err(Error::input(
                "periodic.field",
                "free (`autonomous`) orbits are continued in their own frequency, not in a scene field: leave out `field`",
            ))
        }
        (None, true) => AUTONOMOUS_FIELD.to_string(),
        (Some(field), false) => field.clone(),
        (None, false) => {
            return Err(Error::input(
                "periodic.field",
                "is required: the scene field a driven branch continues (a dotted path), or `\"autonomous\": true` for the free orbits of a conservative chain",
            ))
        }
    };
    if !f.autonomous {
        check_settable(base, &field).map_err(|m| Error::input("periodic.field", m))?;
        if let Some(axis) = dims.iter().flat_map(|d| &d.axes).find(|a| a.field == field) {
            return Err(Error::input(
                "periodic.field",
                format!(
                    "{:?} is set by the axis {:?}: a branch continues the field itself, so it cannot also be an axis",
                    field, axis.name
                ),
            ));
        }
    }
    let name = f.name.clone().unwrap_or_else(|| {
        if f.autonomous {
            "frequency_hz".to_string()
        } else {
            field_name(&field)
        }
    });
    if dims.iter().any(|d| d.axes.iter().any(|a| a.name == name)) {
        return Err(Error::input(
            "periodic.name",
            format!("{name:?} is already the name of an axis"),
        ));
    }
    if f.autonomous {
        return parse_autonomous(f, base, field, name).map(Some);
    }
    if f.from.is_some() {
        return Err(Error::input(
            "periodic.from",
            "a driven branch starts at the base scene's value of `field`; `from` is the first frequency of `autonomous` orbits",
        ));
    }
    let defaults = PeriodicOptions::default();
    let orbit = PeriodicOptions {
        periods: f.periods.unwrap_or(defaults.periods),
        settle_periods: f.settle_periods.unwrap_or(defaults.settle_periods),
        tolerance: f.tolerance.unwrap_or(defaults.tolerance),
        max_iterations: f.max_iterations.unwrap_or(defaults.max_iterations),
        monodromy: f.monodromy.unwrap_or(defaults.monodromy),
    };
    let mut branch = BranchOptions::new(f.to);
    branch.step = f.step;
    branch.min_step = f.min_step;
    branch.max_step = f.max_step;
    branch.max_points = f.max_points.unwrap_or(branch.max_points);
    branch.locate_tolerance = f.locate_tolerance.unwrap_or(branch.locate_tolerance);
    let spec = PeriodicSpec {
        units: units_of(&field),
        field,
        name,
        orbit,
        branch,
        switch: f.switch,
        autonomous: None,
    };
    let from = spec.start(base)?;
    orbit
        .validate()
        .map_err(|e| Error::input(e.field, e.message))?;
    spec.stored_orbit().validate().map_err(|e| {
        Error::input(
            "periodic.periods",
            format!(
                "{} (the doubled branch's orbits span twice `periods`)",
                e.message
            ),
        )
    })?;
    spec.branch
        .validate(from)
        .map_err(|e| Error::input(e.field, e.message))?;
    // The drive a periodic orbit needs (harmonic), elastic contacts: refused before anything
    // runs, naming the field.
    let scene = spec.scene_at(base, from)?;
    PeriodMap::new(&scene, &orbit).map_err(|e| {
        let field = if e.field.starts_with("periodic") {
            e.field
        } else {
            format!("base.{}", e.field)
        };
        Error::input(field, e.message)
    })?;
    // The branch's far end is a scene too (a drive frequency of −100 Hz is none): refused now,
    // not after the continuation walked to it.
    let refused = |message: String| {
        Error::input(
            "periodic.to",
            format!(
                "{} = {} is refused by the scene: {message}",
                spec.field, spec.branch.to
            ),
        )
    };
    let far = spec
        .scene_at(base, spec.branch.to)
        .map_err(|e| refused(e.to_string()))?;
    // As the continuation builds it (its record and duration its own), not the raw scene.
    PeriodMap::new(&far, &orbit).map_err(|e| refused(format!("`{}` {}", e.field, e.message)))?;
    Ok(Some(spec))
}

/// Most orbits of a family a block may ask for (`max_points`), as for a driven branch.
const MAX_AUTONOMOUS_ORBITS: u32 = 20_000;

/// The lowest frequency of a free orbit, relative to the chain's lowest linear frequency: an
/// orbit slower than this is one of a chain flung far from its static state, and each of its
/// periods would take millions of the chain's own steps.
const MIN_FREE_FREQUENCY_RATIO: f64 = 1e-3;

/// A `periodic` block with `autonomous`: the frequencies `from`, `from ± step`, … up to `to`
/// (the last one `to` itself), the shooting's options; the base scene checked to have free
/// orbits (an initial state, no drive, no damping, elastic contacts). Errors name the field.
fn parse_autonomous(
    f: PeriodicFile,
    base: &mut Value,
    field: String,
    name: String,
) -> Result<PeriodicSpec> {
    // What continues a driven branch by pseudo-arclength and has no meaning here.
    for (given, key) in [
        (f.min_step.is_some(), "min_step"),
        (f.max_step.is_some(), "max_step"),
        (f.locate_tolerance.is_some(), "locate_tolerance"),
        (f.periods.is_some(), "periods"),
        (f.settle_periods.is_some(), "settle_periods"),
        (f.monodromy.is_some(), "monodromy"),
        (f.switch.is_some(), "switch"),
    ] {
        if given {
            return Err(Error::input(
                format!("periodic.{key}"),
                "applies to driven branches (pseudo-arclength continuation of a driven orbit); free (`autonomous`) orbits are shot at the frequencies from `from` to `to` by `step`, with `tolerance` and `max_iterations`: leave it out",
            ));
        }
    }
    let positive = |value: Option<f64>, key: &str| -> Result<f64> {
        match value {
            Some(v) if v.is_finite() && v > 0.0 => Ok(v),
            Some(v) => Err(Error::input(
                format!("periodic.{key}"),
                format!("must be a positive frequency in Hz, got {v}"),
            )),
            None => Err(Error::input(
                format!("periodic.{key}"),
                "is required with `autonomous`: the first orbit's frequency, Hz",
            )),
        }
    };
    let from = positive(f.from, "from")?;
    let to = positive(Some(f.to), "to")?;
    if to == from {
        return Err(Error::input(
            "periodic.to",
            format!("must differ from `from` ({from} Hz)"),
        ));
    }
    let range = (to - from).abs();
    let step = match f.step {
        None => range / 50.0,
        Some(s) if s.is_finite() && s > 0.0 && s <= range => s,
        Some(s) => {
            return Err(Error::input(
                "periodic.step",
                format!("must be a frequency step in (0, |to − from|] = (0, {range}] Hz, got {s}"),
            ))
        }
    };
    let max_points = f.max_points.unwrap_or(BranchOptions::new(to).max_points);
    // A family has at least its two ends.
    if !(2..=MAX_AUTONOMOUS_ORBITS).contains(&max_points) {
        return Err(Error::input(
            "periodic.max_points",
            format!("must lie in 2..={MAX_AUTONOMOUS_ORBITS}, got {max_points}"),
        ));
    }
    // `from + k·step` towards `to`, the last one `to` itself (in place of `from + k·step` where
    // that reaches it to a millionth of a step). Counted in floating point first: a tiny step
    // would overflow an integer count.
    let sign = (to - from).signum();
    let steps = (range / step * (1.0 + 1e-12)).floor();
    if steps + 1.0 > f64::from(max_points) {
        return Err(Error::input(
            "periodic.step",
            format!(
                "from {from} to {to} Hz by {step} Hz is more than max_points ({max_points}) orbits: take a larger step or raise max_points"
            ),
        ));
    }
    let whole = steps as u32;
    let mut frequencies: Vec<f64> = (0..=whole)
        .map(|k| from + sign * f64::from(k) * step)
        .collect();
    if range - f64::from(whole) * step > 1e-6 * step {
        frequencies.push(to);
    } else {
        *frequencies.last_mut().expect("at least `from`") = to;
    }
    if frequencies.len() > max_points as usize {
        return Err(Error::input(
            "periodic.step",
            format!(
                "from {from} to {to} Hz by {step} Hz is {} orbits, more than max_points ({max_points}): take a larger step or raise max_points",
                frequencies.len()
            ),
        ));
    }
    let defaults = PeriodicOptions::default();
    let orbit = PeriodicOptions {
        tolerance: f.tolerance.unwrap_or(defaults.tolerance),
        max_iterations: f.max_iterations.unwrap_or(defaults.max_iterations),
        ..defaults
    };
    orbit
        .validate()
        .map_err(|e| Error::input(e.field, e.message))?;
    // Each orbit's probes are analysed at its own frequency (over two of its periods): a
    // `record.steady_state` given for its harmonics needs no frequency of its own.
    if let Some(steady) = base
        .pointer_mut("/record/steady_state")
        .and_then(Value::as_object_mut)
    {
        steady
            .entry("frequency_hz")
            .or_insert_with(|| Value::from(from));
    }
    let scene = from_value_at::<Scene>(base.clone(), "base")?;
    let map = AutonomousMap::new(&scene)
        .map_err(|e| Error::input(format!("base.{}", e.field), e.message))?;
    // A chain held by a static load has a lowest linear frequency to measure the range by.
    if let Ok(linear) = LinearChain::of(map.chain()) {
        let lowest = linear.spectrum_range(0, 1, false).angular_frequency_rad_s[0] / TAU;
        let floor = MIN_FREE_FREQUENCY_RATIO * lowest;
        if let Some((key, f)) = [("from", from), ("to", to)]
            .into_iter()
            .find(|&(_, f)| f < floor)
        {
            return Err(Error::input(
                format!("periodic.{key}"),
                format!(
                    "{f} Hz is below {MIN_FREE_FREQUENCY_RATIO} of the chain's lowest linear frequency ({lowest:.6} Hz): a free orbit that slow flings the chain far from its static state, and its periods would take millions of steps"
                ),
            ));
        }
    }
    let mut branch = BranchOptions::new(to);
    branch.step = Some(step);
    branch.max_points = max_points;
    Ok(PeriodicSpec {
        units: "Hz".to_string(),
        field,
        name,
        orbit,
        branch,
        switch: None,
        autonomous: Some(frequencies),
    })
}
