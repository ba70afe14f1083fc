//! Running a scene: the chain built from it, integrated (whole, or only its moving part,
//! [`crate::scene::active`]) with the probes and the ledger watching, into a [`RunOutput`] or a
//! [`RunError`]. The scene itself, what it says, is [`crate::scene`].

use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Instant;

#[cfg(feature = "serde")]
use serde::Serialize;

use crate::chain::model::{spec_err, Chain, SpecError};
use crate::integrate::{
    Adaptive, AdaptiveMethod, AdaptiveOptions, IntegrateError, IntegrationStats, Integrator,
    OdeSystemDyn,
};
use crate::motion::system::EnergyTerms;
use crate::observe::probes::{
    Fields, History, ObserverOptions, ProbeSet, ProbeSummary, RunObserver,
};
use crate::observe::steady::SteadyState;
use crate::scene::integrator::MethodVisitor;
use crate::scene::{
    Excitation, ImpactScales, Scene, MAX_HERTZ_OVERLAP_RATIO, MIN_PULSE_TO_TRANSIT_RATIO,
};
use crate::spectrum::SpectrumSummary;

/// Why a run failed.
#[derive(Debug, Clone, PartialEq)]
pub enum RunError {
    /// The scene is invalid.
    Spec(SpecError),
    /// The integrator gave up.
    Integrate(IntegrateError),
    /// The deadline given to [`run_until`] passed before the run ended.
    Deadline {
        /// Simulated time reached, s.
        t_s: f64,
        /// Accepted steps taken.
        steps: u64,
        /// Rejected step attempts.
        rejected: u64,
    },
    /// The stop flag given to [`run_stoppable`] was set (an interrupt) before the run ended.
    Stopped {
        /// Simulated time reached, s.
        t_s: f64,
    },
}

impl std::fmt::Display for RunError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RunError::Spec(e) => write!(f, "invalid scene: {e}"),
            RunError::Integrate(e) => write!(f, "integration failed: {e}"),
            RunError::Deadline { t_s, steps, rejected } => write!(
                f,
                "deadline reached at t = {t_s:.6e} s after {steps} steps ({rejected} rejected attempts)"
            ),
            RunError::Stopped { t_s } => write!(f, "stopped at t = {t_s:.6e} s (interrupted)"),
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
    /// Space–time fields, when recorded (`record.fields`).
    pub fields: Option<Fields>,
    /// Largest |E(t) − E(0)| over accepted steps, relative to the impact energy (the excitation's
    /// energy scale, [`ImpactScales::energy_j`]; for a driven chain, the larger of it and the work
    /// the drive has done so far).
    pub energy_drift_max: f64,
    /// |E(t_end) − E(0)| relative to the impact energy.
    pub energy_drift_final: f64,
    /// Largest momentum-balance residual over accepted steps, relative to the striker's momentum
    /// (the excitation's momentum scale).
    pub momentum_residual_max: f64,
    /// Energy terms at the end, J.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub final_energy: EnergyTerms,
    /// Energy terms at the start, J.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub initial_energy: EnergyTerms,
    /// Energy scale of the excitation, J: the striker's (or the impulse's) kinetic energy, or for
    /// a force pulse the estimate of [`ImpactScales::force_pulse`].
    pub impact_energy_j: f64,
    /// Largest contact overlap over the run (located on the dense output), m.
    pub max_overlap_m: f64,
    /// Particles integrated at the end when the run integrated only the moving part of its chain
    /// ([`crate::scene::active`]): the rest stayed at rest in static equilibrium throughout. `None` when
    /// the whole chain was integrated.
    pub active_particles: Option<usize>,
    /// Where the run leaves the model's own assumptions (not fatal): overlaps too large for
    /// Hertz's small-strain law, or an impact pulse not much longer than the time sound takes to
    /// cross a particle (the paper's condition for using the static Hertz law, Sec. III).
    pub warnings: Vec<String>,
    /// The linear spectrum at the static state, when `record.spectrum` asks for it.
    pub spectrum: Option<SpectrumSummary>,
    /// The state `[x, v, q, …]` at the end, when the run is on a continuation axis
    /// ([`crate::scene::Continuation`]): what the next point on the axis starts from.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub final_state: Option<Vec<f64>>,
    /// The energy through every contact and each particle's largest kinetic energy, when
    /// `record.energy_flow` asks for them.
    pub energy_flow: Option<crate::observe::flow::EnergyFlow>,
    /// Steady-state observables of every probe, when `record.steady_state` asks for them (absent
    /// from the serialised output otherwise).
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Option::is_none"))]
    pub steady_state: Option<SteadyState>,
}

/// Physical-validity warnings for a scene and its largest overlap.
fn validity_warnings(
    scene: &Scene,
    chain: &Chain,
    scales: &ImpactScales,
    max_overlap: f64,
) -> Vec<String> {
    let mut warnings = Vec::new();
    // Hertz's law is judged on the smallest sphere; chains of flat faces only have explicit laws.
    if let Some(radius) = chain.smallest_sphere_radius_m() {
        let ratio = max_overlap / radius;
        if ratio > MAX_HERTZ_OVERLAP_RATIO {
            warnings.push(format!(
                "largest overlap {max_overlap:.3e} m is {ratio:.3} of the sphere radius (> {MAX_HERTZ_OVERLAP_RATIO}): Hertz's small-strain contact law is stretched"
            ));
        }
    }
    // The excitation's pulse (the two-body impact, or the force pulse) against the slowest
    // crossing of a particle.
    let duration = scales.contact_duration_s();
    let transit = chain.sound_transit_s();
    if duration < MIN_PULSE_TO_TRANSIT_RATIO * transit {
        let what = match scene.excitation {
            Some(Excitation::HalfSineForce { .. }) => "force pulse",
            Some(Excitation::Drive(_)) => "drive's half period at its highest frequency",
            _ => "impact pulse",
        };
        warnings.push(format!(
            "{what} of {duration:.3e} s is only {:.1} times the sound transit time through a particle ({transit:.3e} s; want > {MIN_PULSE_TO_TRANSIT_RATIO}): the static Hertz law assumes a much longer pulse",
            duration / transit
        ));
    }
    warnings
}

/// The integrator a scene's spec names ([`crate::scene::IntegratorSpec::visit`]) for `chain`
/// (whose scales the adaptive methods' tolerances are relative to), starting with step `h0` when
/// given.
struct Build<'a> {
    chain: &'a Chain,
    scales: &'a ImpactScales,
    h0: Option<f64>,
}

impl MethodVisitor for Build<'_> {
    type Output = Box<dyn Integrator>;
    fn fixed<S: Integrator + 'static>(self, scheme: S) -> Box<dyn Integrator> {
        Box::new(scheme)
    }
    fn adaptive<M: AdaptiveMethod + 'static>(
        self,
        options: AdaptiveOptions,
    ) -> Box<dyn Integrator> {
        adaptive::<M>(options, self.chain, self.scales, self.h0)
    }
}

/// Adaptive method `M` with `options` for `chain`, its absolute tolerances scaled by
/// [`state_scales`], starting with step `h0` when given (else choosing its first step).
fn adaptive<M: AdaptiveMethod + 'static>(
    options: AdaptiveOptions,
    chain: &Chain,
    scales: &ImpactScales,
    h0: Option<f64>,
) -> Box<dyn Integrator> {
    Box::new(
        Adaptive::<M>::with_options(options)
            .with_atol_scale(state_scales(chain, scales))
            .with_initial_step_if(h0),
    )
}

/// Per-component absolute-tolerance scales for the state `[x, v, q]`: the two-body peak overlap
/// for positions, the striker velocity for velocities, the impact energy and momentum for the
/// dissipated work, the wall impulse and the work of a force pulse or a drive. The adaptive integrators
/// multiply them by `atol`.
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
    if let Some(k) = chain.external_work_index() {
        s[k] = scales.energy_j;
    }
    if let (Some(d), Some(k)) = (&chain.drive, chain.drive_state_index()) {
        // A force drive's impulse; a moving wall's displacement (the overlap's scale) and velocity.
        if d.point.moves_a_wall() {
            s[k + 1] = scales.velocity_m_s;
        } else {
            s[k] = scales.momentum;
        }
    }
    if let Some(k) = chain.mount_state_index() {
        // A mounted wall's displacement, on the overlaps' scale, and its velocity.
        s[k + 1] = scales.velocity_m_s;
    }
    s
}

/// Integrates `sys` from `(t0, y0)` over consecutive legs ending at each of `leg_ends` (the last
/// is the run's end), each leg a fresh call of the integrator, so that no step straddles a time
/// where the right-hand side is not smooth. The observer sees one continuous record (it takes the
/// second and later `on_start` as continuations); the step budget and the statistics are the
/// run's, summed over the legs. Stops after the leg in which the observer stopped the run.
fn integrate_legs(
    integrator: &dyn Integrator,
    sys: &mut dyn OdeSystemDyn,
    t0: f64,
    y0: &[f64],
    leg_ends: &[f64],
    max_steps: u64,
    observer: &mut RunObserver,
) -> Result<IntegrationStats, IntegrateError> {
    if let [t_end] = leg_ends {
        return integrator.integrate(sys, t0, y0, *t_end, max_steps, observer);
    }
    observer.state = Some(y0.to_vec());
    let mut total = IntegrationStats::default();
    let mut t = t0;
    let mut y = y0.to_vec();
    for &t_leg in leg_ends {
        let budget = max_steps.saturating_sub(total.attempts());
        let stats = integrator
            .integrate(sys, t, &y, t_leg, budget, observer)
            .map_err(|e| match e {
                IntegrateError::StepBudget { t, .. } => IntegrateError::StepBudget { max_steps, t },
                other => other,
            })?;
        total.add(&stats);
        if observer.stopped || total.attempts() >= max_steps {
            break;
        }
        t = t_leg;
        y.copy_from_slice(observer.state.as_ref().expect("kept for legs"));
    }
    Ok(total)
}

/// Runs a scene.
pub fn run(scene: &Scene) -> Result<RunOutput, RunError> {
    run_until(scene, None)
}

/// Runs a scene, giving up with [`RunError::Deadline`] once `deadline` has passed (`None`: no
/// deadline). The clock is read every [`DEADLINE_CHECK_STEPS`] accepted steps, so the run ends
/// within that many steps of the deadline; a run that only rejects attempts ends on its step
/// budget ([`Scene::max_steps`]) instead.
pub fn run_until(scene: &Scene, deadline: Option<Instant>) -> Result<RunOutput, RunError> {
    run_stoppable(scene, deadline, None)
}

/// [`run_until`], also giving up with [`RunError::Stopped`] once `stop` is set (read after every
/// accepted step: an interrupt from another thread ends the run within one step).
pub fn run_stoppable(
    scene: &Scene,
    deadline: Option<Instant>,
    stop: Option<Arc<AtomicBool>>,
) -> Result<RunOutput, RunError> {
    let chain = scene.validate()?;
    let scales = scene.impact_scales(&chain);
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
        driven: chain.drive.is_some(),
        fields: scene
            .record
            .fields
            .clone()
            .map(|f| (f, scene.record.preload)),
        steady_state: scene
            .steady_state_frequency_hz()?
            .zip(scene.record.steady_state.clone())
            .map(|(f, spec)| (spec, f)),
        energy_flow: scene.record.energy_flow,
    };
    let spectrum = match &scene.record.spectrum {
        Some(spec) => Some(spec.summarise(&chain)?),
        None => None,
    };
    if !scene.record.needs_integration() {
        // Only the spectrum: the static state, not integrated.
        return Ok(RunOutput {
            method: "none",
            stats: Default::default(),
            t_end_s: 0.0,
            probes: Vec::new(),
            history: None,
            min_overlap_m: None,
            fields: None,
            energy_drift_max: 0.0,
            energy_drift_final: 0.0,
            momentum_residual_max: 0.0,
            // The state the run starts from (the striker or impulse moving), as at t = 0.
            final_energy: crate::motion::system::Ledger::new(&chain)
                .energy(&scene.initial_state(&chain)),
            initial_energy: crate::motion::system::Ledger::new(&chain)
                .energy(&scene.initial_state(&chain)),
            impact_energy_j: scales.energy_j,
            max_overlap_m: chain.static_overlap.iter().fold(0.0, |m: f64, &d| m.max(d)),
            active_particles: None,
            warnings: Vec::new(),
            spectrum,
            final_state: None,
            steady_state: None,
            energy_flow: None,
        });
    }
    let t0 = 0.0;
    let t_end = scene.duration_s;
    let mut observer = RunObserver::new(&chain, probes, opts, t0, t_end);
    observer.deadline = deadline;
    observer.stop_flag = stop;

    let y0 = scene.initial_state(&chain);
    if y0.len() != chain.state_len() {
        return Err(RunError::Spec(spec_err(
            "continuation",
            format!(
                "the start state has {} components, the chain's state {}",
                y0.len(),
                chain.state_len()
            ),
        )));
    }
    if scene.continuation.is_some() {
        // Kept at every accepted step: the next point on the axis starts from it.
        observer.state = Some(y0.clone());
    }
    let mut leg_ends = scene.breakpoints_s(&chain);
    leg_ends.push(t_end);

    // The integrator for `c` (the chain, or the moving part of it), starting with step `h0` when
    // given (a grown moving part goes on at the step size it had reached) or choosing its own.
    let build = |c: &Chain, h0: Option<f64>| -> Box<dyn Integrator> {
        scene.integrator.visit(Build {
            chain: c,
            scales: &scales,
            h0,
        })
    };
    let integrator = build(&chain, None);
    let (stats, active_particles) = match crate::scene::active::plan(scene, &chain, &scales, &y0) {
        Some(plan) => {
            let (stats, k) = crate::scene::active::integrate(
                &plan,
                &build,
                &chain,
                t0,
                &y0,
                &leg_ends,
                scene.max_steps,
                &mut observer,
            )?;
            (stats, Some(k))
        }
        None => (
            crate::dispatch_chain_system!(&chain, |sys| integrate_legs(
                integrator.as_ref(),
                &mut sys,
                t0,
                &y0,
                &leg_ends,
                scene.max_steps,
                &mut observer
            ))?,
            None,
        ),
    };
    if observer.interrupted {
        return Err(RunError::Stopped {
            t_s: observer.t_reached,
        });
    }
    if observer.deadline_reached {
        return Err(RunError::Deadline {
            t_s: observer.t_reached,
            steps: stats.steps,
            rejected: stats.rejected,
        });
    }

    let mut warnings = validity_warnings(scene, &chain, &scales, observer.max_overlap);
    if stats.stiffness_detections > 0 {
        warnings.push(format!(
            "{}: steps were held by stability, not accuracy ({} stiff stretches): the chain is stiff here (damping against light masses); ros34pw2 needs far fewer steps",
            integrator.name(),
            stats.stiffness_detections
        ));
    }
    let steady_state = observer.take_steady_state();
    if let (Some(s), Some(spec)) = (&steady_state, &scene.record.steady_state) {
        let names: Vec<String> = scene.record.probes.iter().map(|p| p.name()).collect();
        warnings.extend(s.warning(&names, spec.settled_tolerance));
    }
    Ok(RunOutput {
        method: integrator.name(),
        active_particles,
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
        initial_energy: observer
            .first_energy
            .expect("observer saw the initial state"),
        impact_energy_j: scales.energy_j,
        min_overlap_m: observer.min_overlap.take(),
        history: observer.history.take(),
        fields: observer.take_fields(),
        spectrum,
        final_state: observer
            .state
            .take()
            .filter(|_| scene.continuation.is_some()),
        steady_state,
        energy_flow: observer.take_energy_flow(),
    })
}
