//! `periodic`: at every point of the axes, the branch of periodic orbits of the driven scene,
//! continued in one scene field from the point's own value to `to`, with its stability and
//! bifurcations ([`chainsweep_solver::periodic`]).

use serde::Deserialize;
use serde_json::Value;

use chainsweep_solver::periodic::{
    doubled_orbits, BranchOptions, Monodromy, PeriodMap, PeriodicOptions,
};
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
    /// scene's value of it (at each point of the axes).
    field: String,
    /// Its name in the output (default: the field's last part).
    #[serde(default)]
    name: Option<String>,
    /// The value the branch ends at.
    to: f64,
    /// First step of the field (default a fiftieth of the range).
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
}

impl PeriodicSpec {
    /// The block in a sentence.
    pub fn describe(&self) -> String {
        use crate::error::number_text as num;
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
}

/// Checks `periodic` against the base scene and the axes; errors name `periodic.…`.
pub(super) fn parse(
    file: Option<PeriodicFile>,
    base: &Value,
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
    check_settable(base, &f.field).map_err(|m| Error::input("periodic.field", m))?;
    if let Some(axis) = dims
        .iter()
        .flat_map(|d| &d.axes)
        .find(|a| a.field == f.field)
    {
        return Err(Error::input(
            "periodic.field",
            format!(
                "{:?} is set by the axis {:?}: a branch continues the field itself, so it cannot also be an axis",
                f.field, axis.name
            ),
        ));
    }
    let name = f.name.unwrap_or_else(|| field_name(&f.field));
    if dims.iter().any(|d| d.axes.iter().any(|a| a.name == name)) {
        return Err(Error::input(
            "periodic.name",
            format!("{name:?} is already the name of an axis"),
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
        units: units_of(&f.field),
        field: f.field,
        name,
        orbit,
        branch,
        switch: f.switch,
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
    Ok(Some(spec))
}
