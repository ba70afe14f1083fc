//! A scene — chain, physics, impact, integrator and record block — and running it.

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

use crate::integrate::{
    AdaptiveOptions, Dop853, IntegrateError, IntegrationStats, Integrator, Rk4, Ros34pw2,
    VelocityVerlet,
};
use crate::model::{spec_err, Chain, ChainSpec, PhysicsSpec, SpecError};
use crate::probes::{History, ObserverOptions, ProbeSet, ProbeSummary, RecordSpec, RunObserver};
use crate::system::EnergyTerms;

/// Integrator and its accuracy settings.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(
    feature = "serde",
    serde(tag = "method", rename_all = "snake_case", deny_unknown_fields)
)]
pub enum IntegratorSpec {
    /// Velocity Verlet, fixed step (second order).
    Verlet {
        /// Step, s.
        dt_s: f64,
    },
    /// Classic Runge–Kutta, fixed step (fourth order).
    Rk4 {
        /// Step, s.
        dt_s: f64,
    },
    /// Dormand–Prince 8(5,3), adaptive, 7th-order dense output. `atol` is relative to each
    /// component's natural scale (the two-body peak overlap for positions, the striker velocity for
    /// velocities, the impact energy and momentum for the ledger's quadratures).
    Dop853(AdaptiveOptions),
    /// ROS34PW2, a linearly implicit (Rosenbrock-W) method of order 3, L-stable, with the chain's
    /// tridiagonal Jacobian: for damping-dominated chains (μ ≳ 1000 kg/s with light particles),
    /// where explicit methods are held to steps of order m/μ. Options as for DOP853.
    Ros34pw2(AdaptiveOptions),
}

impl Default for IntegratorSpec {
    fn default() -> Self {
        IntegratorSpec::Dop853(AdaptiveOptions::new(1e-9))
    }
}

impl IntegratorSpec {
    /// Stable name of the method.
    pub fn method_name(&self) -> &'static str {
        match self {
            IntegratorSpec::Verlet { .. } => "verlet",
            IntegratorSpec::Rk4 { .. } => "rk4",
            IntegratorSpec::Dop853(_) => "dop853",
            IntegratorSpec::Ros34pw2(_) => "ros34pw2",
        }
    }

    /// The options of an adaptive method (`None` for the fixed-step ones).
    pub fn adaptive_options(&self) -> Option<&AdaptiveOptions> {
        match self {
            IntegratorSpec::Dop853(o) | IntegratorSpec::Ros34pw2(o) => Some(o),
            IntegratorSpec::Verlet { .. } | IntegratorSpec::Rk4 { .. } => None,
        }
    }

    /// Checks the settings; errors name the field (relative to `integrator`).
    pub fn validate(&self) -> Result<(), SpecError> {
        let pos = |name: &str, v: f64| -> Result<(), SpecError> {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(spec_err(
                    name,
                    format!("must be a finite number > 0, got {v}"),
                ))
            }
        };
        match *self {
            IntegratorSpec::Verlet { dt_s } | IntegratorSpec::Rk4 { dt_s } => {
                pos("integrator.dt_s", dt_s)
            }
            IntegratorSpec::Dop853(AdaptiveOptions {
                rtol,
                atol,
                max_step_s,
                ..
            })
            | IntegratorSpec::Ros34pw2(AdaptiveOptions {
                rtol,
                atol,
                max_step_s,
                ..
            }) => {
                if !(rtol.is_finite() && (1e-15..=1e-1).contains(&rtol)) {
                    return Err(spec_err(
                        "integrator.rtol",
                        format!("must lie in [1e-15, 0.1], got {rtol}"),
                    ));
                }
                if let Some(a) = atol {
                    if !(a.is_finite() && (1e-18..=1e-1).contains(&a)) {
                        return Err(spec_err(
                            "integrator.atol",
                            format!("must lie in [1e-18, 0.1], got {a}"),
                        ));
                    }
                }
                if let Some(h) = max_step_s {
                    pos("integrator.max_step_s", h)?;
                }
                Ok(())
            }
        }
    }
}

/// One simulation: everything needed to reproduce a run.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct Scene {
    /// Geometry and materials.
    pub chain: ChainSpec,
    /// Physics switches.
    pub physics: PhysicsSpec,
    /// Striker velocity towards the wall at impact, m/s.
    pub striker_velocity_m_s: f64,
    /// Simulated time after impact, s.
    pub duration_s: f64,
    /// Integrator.
    #[cfg_attr(feature = "serde", serde(default))]
    pub integrator: IntegratorSpec,
    /// Largest number of accepted steps before the run is abandoned.
    #[cfg_attr(feature = "serde", serde(default = "default_max_steps"))]
    pub max_steps: u64,
    /// What to record.
    #[cfg_attr(feature = "serde", serde(default))]
    pub record: RecordSpec,
}

/// Default step budget: ample for any scene in the paper (a 1 ms run needs ~10⁴ adaptive steps).
pub const DEFAULT_MAX_STEPS: u64 = 100_000_000;

#[cfg(feature = "serde")]
fn default_max_steps() -> u64 {
    DEFAULT_MAX_STEPS
}

impl Scene {
    /// A scene with the paper's defaults: `chain`, gravity and wall on, no damping, DOP853 at
    /// rtol 1e-9, nothing recorded.
    pub fn new(chain: ChainSpec, striker_velocity_m_s: f64, duration_s: f64) -> Self {
        Scene {
            chain,
            physics: PhysicsSpec::default(),
            striker_velocity_m_s,
            duration_s,
            integrator: IntegratorSpec::default(),
            max_steps: DEFAULT_MAX_STEPS,
            record: RecordSpec::default(),
        }
    }

    /// Checks the whole scene before anything runs; the error names the field.
    pub fn validate(&self) -> Result<Chain, SpecError> {
        let chain = Chain::build(&self.chain, &self.physics)?;
        let v0 = self.striker_velocity_m_s;
        if !(v0.is_finite() && v0 > 0.0) {
            return Err(spec_err(
                "striker_velocity_m_s",
                format!("must be a finite number > 0, got {v0}"),
            ));
        }
        let d = self.duration_s;
        if !(d.is_finite() && d > 0.0) {
            return Err(spec_err(
                "duration_s",
                format!("must be a finite number > 0, got {d}"),
            ));
        }
        if self.max_steps == 0 {
            return Err(spec_err("max_steps", "must be at least 1"));
        }
        self.integrator.validate()?;
        self.record.validate(&chain)?;
        Ok(chain)
    }
}

/// Natural scales of an impact: the two-body collision of the striker with the first sphere.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImpactScales {
    /// Peak overlap of the two-body collision, m.
    pub overlap_m: f64,
    /// Peak force of the two-body collision, N.
    pub force_n: f64,
    /// Striker velocity, m/s.
    pub velocity_m_s: f64,
    /// Striker kinetic energy, J.
    pub energy_j: f64,
    /// Striker momentum, kg·m/s.
    pub momentum: f64,
}

impl ImpactScales {
    /// Duration of the two-body striker impact, s: `2 δm / v0 · ∫₀¹ (1 − x^{5/2})^{-1/2} dx`
    /// = 2.943 δm / v0 (the closed form checked in `tests/dynamics.rs`).
    pub fn contact_duration_s(&self) -> f64 {
        2.943 * self.overlap_m / self.velocity_m_s
    }

    /// Scales for a chain struck at `v0`.
    pub fn new(chain: &Chain, v0: f64) -> Self {
        let m1 = chain.mass[0];
        let m2 = chain.mass[1];
        let reduced = m1 * m2 / (m1 + m2);
        let a1 = chain.stiffness[0];
        let overlap = (1.25 * reduced * v0 * v0 / a1).powf(0.4);
        ImpactScales {
            overlap_m: overlap,
            force_n: a1 * overlap * overlap.sqrt(),
            velocity_m_s: v0,
            energy_j: 0.5 * m1 * v0 * v0,
            momentum: m1 * v0,
        }
    }
}

/// Why a run failed.
#[derive(Debug, Clone, PartialEq)]
pub enum RunError {
    /// The scene is invalid.
    Spec(SpecError),
    /// The integrator gave up.
    Integrate(IntegrateError),
}

impl std::fmt::Display for RunError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RunError::Spec(e) => write!(f, "invalid scene: {e}"),
            RunError::Integrate(e) => write!(f, "integration failed: {e}"),
        }
    }
}

impl std::error::Error for RunError {}

impl From<SpecError> for RunError {
    fn from(e: SpecError) -> Self {
        RunError::Spec(e)
    }
}

impl From<IntegrateError> for RunError {
    fn from(e: IntegrateError) -> Self {
        RunError::Integrate(e)
    }
}

/// Everything a run reports.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize))]
pub struct RunOutput {
    /// Integrator name.
    pub method: &'static str,
    /// Steps and right-hand-side evaluations.
    pub stats: IntegrationStats,
    /// Time the run reached, s (the scene's duration unless it stopped after the leading pulses).
    pub t_end_s: f64,
    /// One summary per probe, in the record block's order.
    pub probes: Vec<ProbeSummary>,
    /// Histories, when recorded.
    pub history: Option<History>,
    /// Minimum overlap of every contact over the run, m, when recorded.
    pub min_overlap_m: Option<Vec<f64>>,
    /// Largest |E(t) − E(0)| over accepted steps, relative to the impact energy.
    pub energy_drift_max: f64,
    /// |E(t_end) − E(0)| relative to the impact energy.
    pub energy_drift_final: f64,
    /// Largest momentum-balance residual over accepted steps, relative to the striker's momentum.
    pub momentum_residual_max: f64,
    /// Energy terms at the end, J.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub final_energy: EnergyTerms,
    /// Striker kinetic energy, J.
    pub impact_energy_j: f64,
    /// Largest contact overlap over the run (at step ends), m.
    pub max_overlap_m: f64,
    /// Where the run leaves the model's own assumptions (not fatal): overlaps too large for
    /// Hertz's small-strain law, or an impact pulse not much longer than the time sound takes to
    /// cross a particle (the paper's condition for using the static Hertz law, Sec. III).
    pub warnings: Vec<String>,
}

/// Largest overlap-to-radius ratio for which Hertz's law is taken as valid: the contact radius
/// `√(Rδ)` is then at most a tenth of the sphere's radius.
pub const MAX_HERTZ_OVERLAP_RATIO: f64 = 0.01;

/// Smallest ratio of the impact pulse duration to the longest sound transit time through a
/// particle for which the static Hertz law is taken as valid ("much longer", Sec. III).
pub const MIN_PULSE_TO_TRANSIT_RATIO: f64 = 10.0;

/// Longitudinal wave speed of a material of density `rho`, m/s.
fn longitudinal_speed(m: &crate::model::Material, rho: f64) -> f64 {
    let (e, nu) = (m.youngs_modulus_pa, m.poisson_ratio);
    (e * (1.0 - nu) / (rho * (1.0 + nu) * (1.0 - 2.0 * nu))).sqrt()
}

/// Physical-validity warnings for a scene and its largest overlap.
fn validity_warnings(
    scene: &Scene,
    chain: &Chain,
    scales: &ImpactScales,
    max_overlap: f64,
) -> Vec<String> {
    let mut warnings = Vec::new();
    let radius = 0.5
        * scene
            .chain
            .sphere
            .diameter_m
            .min(scene.chain.striker.diameter_m);
    let ratio = max_overlap / radius;
    if ratio > MAX_HERTZ_OVERLAP_RATIO {
        warnings.push(format!(
            "largest overlap {max_overlap:.3e} m is {ratio:.3} of the sphere radius (> {MAX_HERTZ_OVERLAP_RATIO}): Hertz's small-strain contact law is stretched"
        ));
    }
    // Two-body striker impact duration against the slowest crossing of a particle.
    let duration = scales.contact_duration_s();
    let sphere = &scene.chain.sphere;
    let sphere_rho = sphere.mass_kg / (std::f64::consts::PI / 6.0 * sphere.diameter_m.powi(3));
    let cyl = &scene.chain.cylinder;
    let cyl_rho = chain.cylinder_mass_kg
        / (0.25 * std::f64::consts::PI * cyl.diameter_m * cyl.diameter_m * chain.cylinder_height_m);
    let transit = (sphere.diameter_m / longitudinal_speed(&sphere.material, sphere_rho))
        .max(chain.cylinder_height_m / longitudinal_speed(&cyl.material, cyl_rho));
    if duration < MIN_PULSE_TO_TRANSIT_RATIO * transit {
        warnings.push(format!(
            "impact pulse of {duration:.3e} s is only {:.1} times the sound transit time through a particle ({transit:.3e} s; want > {MIN_PULSE_TO_TRANSIT_RATIO}): the static Hertz law assumes a much longer pulse",
            duration / transit
        ));
    }
    warnings
}

/// Per-component absolute-tolerance scales for the state `[x, v, q]`: the two-body peak overlap
/// for positions, the striker velocity for velocities, the impact energy and momentum for the
/// dissipated work and the wall impulse. The adaptive integrators multiply them by `atol`.
pub fn state_scales(chain: &Chain, scales: &ImpactScales) -> Vec<f64> {
    let n = chain.n_particles();
    let mut s = vec![scales.overlap_m; chain.state_len()];
    s[n..2 * n].fill(scales.velocity_m_s);
    if let Some(k) = chain.work_index() {
        s[k] = scales.energy_j;
    }
    if let Some(k) = chain.wall_impulse_index() {
        s[k] = scales.momentum;
    }
    s
}

/// Runs a scene.
pub fn run(scene: &Scene) -> Result<RunOutput, RunError> {
    let chain = scene.validate()?;
    let v0 = scene.striker_velocity_m_s;
    let scales = ImpactScales::new(&chain, v0);
    let probes = ProbeSet::new(
        &chain,
        &scene.record.probes,
        scene.record.preload,
        scales.force_n,
        scales.velocity_m_s,
        scales.overlap_m,
    );
    let opts = ObserverOptions {
        history: scene.record.history,
        history_interval: scene.record.history_interval_s,
        summary_interval: scene.record.summary_interval_s,
        min_overlap: scene.record.min_overlap,
        arrival_fraction: scene.record.leading_pulse.arrival_fraction,
        release_fraction: scene.record.leading_pulse.release_fraction,
        stop_after_leading_pulses: scene.record.stop_after_leading_pulses,
        impact_energy: scales.energy_j,
        impact_momentum: scales.momentum,
    };
    let t0 = 0.0;
    let t_end = scene.duration_s;
    let mut observer = RunObserver::new(&chain, probes, opts, t0, t_end);

    let y0 = chain.initial_state(v0);

    let integrator: Box<dyn Integrator> = match scene.integrator {
        IntegratorSpec::Verlet { dt_s } => Box::new(VelocityVerlet { dt: dt_s }),
        IntegratorSpec::Rk4 { dt_s } => Box::new(Rk4 { dt: dt_s }),
        IntegratorSpec::Dop853(options) => {
            Box::new(Dop853::with_options(options).with_atol_scale(state_scales(&chain, &scales)))
        }
        IntegratorSpec::Ros34pw2(options) => {
            Box::new(Ros34pw2::with_options(options).with_atol_scale(state_scales(&chain, &scales)))
        }
    };
    let stats = crate::dispatch_chain_system!(&chain, |sys| integrator.integrate(
        &mut sys,
        t0,
        &y0,
        t_end,
        scene.max_steps,
        &mut observer
    ))?;

    let mut warnings = validity_warnings(scene, &chain, &scales, observer.max_overlap);
    if stats.stiffness_detections > 0 {
        warnings.push(format!(
            "{}: steps were held by stability, not accuracy ({} stiff stretches): the chain is stiff here (damping against light masses); ros34pw2 needs far fewer steps",
            integrator.name(),
            stats.stiffness_detections
        ));
    }
    Ok(RunOutput {
        method: integrator.name(),
        max_overlap_m: observer.max_overlap,
        warnings,
        stats,
        t_end_s: observer.t_reached,
        probes: observer.summaries(),
        energy_drift_max: observer.energy_drift_max,
        energy_drift_final: observer.energy_drift_final,
        momentum_residual_max: observer.momentum_residual_max,
        final_energy: observer
            .last_energy
            .expect("observer saw the initial state"),
        impact_energy_j: scales.energy_j,
        min_overlap_m: observer.min_overlap.take(),
        history: observer.history.take(),
    })
}
