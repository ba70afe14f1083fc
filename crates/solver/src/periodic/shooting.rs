//! The period map of a harmonically driven chain and its periodic orbits by shooting: Newton's
//! method on `P(x) − x = 0`, with the monodromy matrix `∂P/∂x` from the variational equations
//! integrated alongside the orbit or, where those do not hold, by central differences.

use crate::chain::drive::Waveform;
use crate::chain::model::{spec_err, Chain, SpecError};
use crate::integrate::{
    Adaptive, AdaptiveMethod, AdaptiveOptions, Control, DenseStep, IntegrationStats, Integrator,
    OdeSystem, OdeSystemDyn, StepObserver, Switch, Tridiagonal,
};
use crate::observe::probes::RecordSpec;
use crate::observe::steady::SteadyStateSpec;
use crate::periodic::dense::{self, Multiplier};
use crate::periodic::{Monodromy, PeriodicOptions};
use crate::scene::solve::{run, state_scales, RunError, RunOutput};
use crate::scene::MethodVisitor;
use crate::scene::{Continuation, Excitation, Scene};

/// Most particles of a chain whose periodic orbits are computed: its monodromy matrix (dense,
/// `(2N)²`, 10 MB at this size) and the variational equations' `(2N)²` components bound it.
pub const MAX_PARTICLES: usize = 400;

/// The field named by errors about the drive a periodic orbit needs.
const DRIVE_FIELD: &str = "excitation.drive";

/// The map that takes a chain's state at `t = 0` to its state one orbit period `T` later under its
/// harmonic drive (ramp removed), on the components that make up the orbit: every particle's
/// position and velocity, and a mounted wall's displacement and velocity. The quadratures (the
/// dissipated work, the walls' impulse, the drive's work) start from zero; a moving wall's
/// displacement and velocity, which its waveform prescribes, from the waveform's.
#[derive(Debug, Clone)]
pub struct PeriodMap {
    scene: Scene,
    chain: Chain,
    /// The orbit period, s.
    period_s: f64,
    /// The drive's frequency, Hz.
    drive_hz: f64,
    /// Periods of the drive in one orbit period.
    periods: u32,
    /// The whole state at `t = 0`, into which the orbit's components are written.
    start: Vec<f64>,
    /// The orbit's components in the whole state.
    indices: Vec<usize>,
    /// Each orbit component's natural scale (the integrator's absolute-tolerance scale).
    scales: Vec<f64>,
    /// The adaptive method's relative tolerance (`None`: a fixed-step method).
    rtol: Option<f64>,
    monodromy: Monodromy,
}

/// One application of the period map.
#[derive(Debug, Clone)]
pub struct MapOutput {
    /// The orbit's components after one period.
    pub end: Vec<f64>,
    /// `∂end/∂start`, row-major, when asked for.
    pub monodromy: Option<Vec<f64>>,
    /// How the monodromy was computed.
    pub method: Monodromy,
    /// Steps and evaluations, the finite differences' included.
    pub stats: IntegrationStats,
    /// Period maps integrated (one, or `1 + 2·dim` with finite differences).
    pub maps: u32,
}

/// A periodic orbit found by shooting.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Orbit {
    /// The orbit's components at `t = 0` (and `t = T`).
    pub state: Vec<f64>,
    /// The monodromy matrix at the orbit, row-major (left out of its serialisation: what is
    /// kept of an orbit is its multipliers).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub monodromy: Vec<f64>,
    /// Its eigenvalues, the Floquet multipliers, largest modulus first.
    pub multipliers: Vec<Multiplier>,
    /// How the monodromy was computed.
    pub method: Monodromy,
    /// Newton iterations taken.
    pub iterations: u32,
    /// `max_i |P(x)_i − x_i| / scale_i` at the orbit.
    pub residual: f64,
    /// Period maps integrated.
    pub maps: u32,
    /// Steps and evaluations of all of them.
    pub stats: IntegrationStats,
}

impl Orbit {
    /// Largest modulus of the multipliers.
    pub fn largest_multiplier(&self) -> f64 {
        self.multipliers.first().map_or(0.0, |m| m.0.hypot(m.1))
    }

    /// Whether no multiplier lies outside the unit circle (beyond the accuracy of the monodromy,
    /// [`dense::UNIT_CIRCLE_TOLERANCE`]): small perturbations do not grow (they decay where there
    /// is dissipation; an undamped orbit's multipliers lie on the circle, neutrally stable).
    pub fn stable(&self) -> bool {
        !self.multipliers.iter().any(|&m| dense::outside(m))
    }
}

impl PeriodMap {
    /// The period map of `scene`, which must drive its chain harmonically (any point: a force, an
    /// actuator, a moving base), with `options.periods` drive periods per orbit. Errors name the
    /// field: no harmonic drive, plastic contacts (their history grows without a periodic state).
    pub fn new(scene: &Scene, options: &PeriodicOptions) -> Result<PeriodMap, SpecError> {
        options.validate()?;
        let mut scene = scene.clone();
        let Some(Excitation::Drive(drive)) = &mut scene.excitation else {
            return Err(spec_err(
                DRIVE_FIELD,
                "a periodic orbit needs a harmonic drive (excitation.drive with a harmonic waveform)",
            ));
        };
        let field = drive.field();
        let drive_hz = match drive.waveform_mut() {
            Waveform::Harmonic(h) => {
                // The orbit is that of the full drive: no ramp.
                h.ramp_periods = 0.0;
                h.frequency_hz
            }
            _ => {
                return Err(spec_err(
                    &field,
                    "a periodic orbit needs a harmonic drive (one frequency); a chirp, a sum or a recording has no single period",
                ))
            }
        };
        let period_s = f64::from(options.periods) / drive_hz;
        scene.duration_s = period_s;
        scene.continuation = None;
        scene.record = Default::default();
        let chain = scene.validate()?;
        if chain.has_plasticity() {
            return Err(spec_err(
                "chain",
                "plastic contacts keep a history of their largest overlap, which a periodic orbit cannot repeat: periodic orbits need elastic contacts",
            ));
        }
        let n = chain.n_particles();
        if n > MAX_PARTICLES {
            return Err(spec_err(
                "chain",
                format!(
                    "periodic orbits are computed for chains of at most {MAX_PARTICLES} particles (the monodromy matrix is dense, (2N)² numbers, and its variational equations as many components); the chain has {n}"
                ),
            ));
        }
        let mut indices: Vec<usize> = (0..2 * n).collect();
        if let Some(k) = chain.mount_state_index() {
            indices.extend([k, k + 1]);
        }
        let impact = scene.impact_scales(&chain);
        let all_scales = state_scales(&chain, &impact);
        let scales = indices.iter().map(|&i| all_scales[i]).collect();
        let start = scene.initial_state(&chain);
        let rtol = scene.integrator.visit(Tolerance);
        Ok(PeriodMap {
            scene,
            chain,
            period_s,
            drive_hz,
            periods: options.periods,
            start,
            indices,
            scales,
            rtol,
            monodromy: options.monodromy,
        })
    }

    /// The orbit period, s.
    pub fn period_s(&self) -> f64 {
        self.period_s
    }

    /// The drive's frequency, Hz.
    pub fn drive_hz(&self) -> f64 {
        self.drive_hz
    }

    /// Drive periods in one orbit period.
    pub fn periods(&self) -> u32 {
        self.periods
    }

    /// Number of orbit components.
    pub fn dim(&self) -> usize {
        self.indices.len()
    }

    /// Each orbit component's natural scale.
    pub fn scales(&self) -> &[f64] {
        &self.scales
    }

    /// Particles in the chain.
    pub fn n_particles(&self) -> usize {
        self.chain.n_particles()
    }

    /// The scene as the map integrates it (ramp removed, one orbit period long).
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The chain's static state (or its excitation's start) as an orbit state: the first guess
    /// of a chain driven from rest.
    pub fn rest_state(&self) -> Vec<f64> {
        self.indices.iter().map(|&i| self.start[i]).collect()
    }

    /// The whole state at `t = 0` with the orbit's components `x`.
    pub fn whole_state(&self, x: &[f64]) -> Vec<f64> {
        let mut y = self.start.clone();
        for (&i, &v) in self.indices.iter().zip(x) {
            y[i] = v;
        }
        y
    }

    /// `max_i |a_i − b_i| / scale_i`.
    pub fn scaled_distance(&self, a: &[f64], b: &[f64]) -> f64 {
        a.iter()
            .zip(b)
            .zip(&self.scales)
            .fold(0.0, |m: f64, ((x, y), s)| m.max((x - y).abs() / s))
    }

    /// The state of `scene` (the original, ramp included) after `periods` periods of its drive
    /// from its own start: the first guess of shooting. Errors name the integrator's failure.
    pub fn settle(scene: &Scene, drive_hz: f64, periods: u32) -> Result<Vec<f64>, RunError> {
        let mut s = scene.clone();
        s.duration_s = f64::from(periods) / drive_hz;
        s.record = Default::default();
        s.continuation = Some(Continuation::default());
        let chain = s.validate()?;
        let mut legs = s.breakpoints_s(&chain);
        legs.push(s.duration_s);
        let y0 = s.initial_state(&chain);
        let (integrator, _) = build(&s, &chain, None);
        let mut t = 0.0;
        let mut y = y0;
        for &t_end in &legs {
            let mut obs = EndObserver::new(&[]);
            crate::dispatch_chain_system!(&chain, |sys| integrator.integrate(
                &mut sys,
                t,
                &y,
                t_end,
                s.max_steps,
                &mut obs
            ))?;
            y = obs.y;
            t = t_end;
        }
        let n = chain.n_particles();
        let mut x: Vec<f64> = y[..2 * n].to_vec();
        if let Some(k) = chain.mount_state_index() {
            x.extend([y[k], y[k + 1]]);
        }
        Ok(x)
    }

    /// Integrates one period from the orbit state `x`; with `monodromy`, also `∂P/∂x`, by the
    /// method the options ask for (`auto`: the variational equations when the chain gives its
    /// Jacobian and no force jumps during the period — a viscous contact that opens with its
    /// ends still moving apart — else central differences).
    pub fn map(&self, x: &[f64], monodromy: bool) -> Result<MapOutput, RunError> {
        let y0 = self.whole_state(x);
        let variational = monodromy
            && self.monodromy != Monodromy::FiniteDifference
            && self.chain.mount_state_index().is_none()
            && self.has_jacobian(&y0);
        if variational {
            let (y, phi, crossed, stats) = self.integrate_variational(&y0)?;
            let jumps = crossed && self.chain.has_damping();
            if !jumps || self.monodromy == Monodromy::Variational {
                return Ok(MapOutput {
                    end: self.indices.iter().map(|&i| y[i]).collect(),
                    monodromy: Some(phi),
                    method: Monodromy::Variational,
                    stats,
                    maps: 1,
                });
            }
        }
        let (y, _, mut stats) = self.integrate(&y0)?;
        let end: Vec<f64> = self.indices.iter().map(|&i| y[i]).collect();
        let mut maps = 1;
        let phi = if monodromy {
            let m = self.dim();
            let h_rel = self.rtol.map_or(1e-4, |r| r.cbrt());
            let mut phi = vec![0.0; m * m];
            for j in 0..m {
                let h = h_rel * self.scales[j];
                let mut column = [Vec::new(), Vec::new()];
                for (side, sign) in [(0, 1.0), (1, -1.0)] {
                    let mut xp = x.to_vec();
                    xp[j] += sign * h;
                    let (y, _, s) = self.integrate(&self.whole_state(&xp))?;
                    stats.add(&s);
                    column[side] = self.indices.iter().map(|&i| y[i]).collect();
                }
                for i in 0..m {
                    phi[i * m + j] = (column[0][i] - column[1][i]) / (2.0 * h);
                }
                maps += 2;
            }
            Some(phi)
        } else {
            None
        };
        Ok(MapOutput {
            end,
            monodromy: phi,
            method: if monodromy {
                Monodromy::FiniteDifference
            } else {
                self.monodromy
            },
            stats,
            maps,
        })
    }

    /// Newton's method on `P(x) − x = 0` from `x0`, to `tolerance` (the scaled residual), in at
    /// most `max_iterations` iterations, each step halved (up to 5 times) while it does not
    /// reduce the residual. The error says why it stopped.
    pub fn shoot(
        &self,
        x0: &[f64],
        tolerance: f64,
        max_iterations: u32,
    ) -> Result<Orbit, ShootingError> {
        let m = self.dim();
        let mut x = x0.to_vec();
        let mut out = self.map(&x, true)?;
        let mut maps = out.maps;
        let mut stats = out.stats;
        let mut residual = self.scaled_distance(&out.end, &x);
        for iteration in 0.. {
            if residual <= tolerance {
                let monodromy = out.monodromy.expect("asked for");
                let multipliers =
                    dense::multipliers(&monodromy, m).ok_or(ShootingError::Multipliers)?;
                return Ok(Orbit {
                    state: x,
                    monodromy,
                    multipliers,
                    method: out.method,
                    iterations: iteration,
                    residual,
                    maps,
                    stats,
                });
            }
            if iteration >= max_iterations {
                return Err(ShootingError::NotConverged {
                    iterations: max_iterations,
                    residual,
                    tolerance,
                });
            }
            let mut a = out.monodromy.clone().expect("asked for");
            let mut dx: Vec<f64> = x.iter().zip(&out.end).map(|(x, p)| x - p).collect();
            for i in 0..m {
                a[i * m + i] -= 1.0;
            }
            dense::solve(&mut a, m, &mut dx).ok_or(ShootingError::Singular)?;
            let mut lambda = 1.0;
            loop {
                let trial: Vec<f64> = x.iter().zip(&dx).map(|(x, d)| x + lambda * d).collect();
                let next = self.map(&trial, true)?;
                maps += next.maps;
                stats.add(&next.stats);
                let r = self.scaled_distance(&next.end, &trial);
                if r < residual || lambda < 0.05 {
                    x = trial;
                    out = next;
                    residual = r;
                    break;
                }
                lambda *= 0.5;
            }
        }
        unreachable!("the loop returns")
    }

    /// One run of the orbit, two orbit periods long from `x`, with the scene's record (`scene`'s
    /// probes and summaries) and its steady state over both periods at the orbit's frequency
    /// (the drive's over `periods`): the orbit's amplitudes and harmonics per probe, by the same
    /// definitions as every run's. The steady state's `settledness` compares the two periods, a
    /// check of periodicity.
    pub fn orbit_run(&self, scene: &Scene, x: &[f64]) -> Result<RunOutput, RunError> {
        two_period_run(
            &self.scene,
            scene.record.clone(),
            self.drive_hz / f64::from(self.periods),
            self.whole_state(x),
        )
    }

    fn has_jacobian(&self, y0: &[f64]) -> bool {
        has_jacobian(&self.chain, y0)
    }

    /// One period from the whole state `y0`: the whole state at its end, whether a switch
    /// crossed, the statistics.
    fn integrate(&self, y0: &[f64]) -> Result<(Vec<f64>, bool, IntegrationStats), RunError> {
        let (integrator, _) = build(&self.scene, &self.chain, None);
        let switches = self.switches();
        let mut obs = EndObserver::new(&switches);
        let stats = crate::dispatch_chain_system!(&self.chain, |sys| integrator.integrate(
            &mut sys,
            0.0,
            y0,
            self.period_s,
            self.scene.max_steps,
            &mut obs
        ))?;
        Ok((obs.y, obs.crossed, stats))
    }

    /// One period of the state and its variational equations from `y0`: the whole state at the
    /// end, `Φ = ∂x(T)/∂x(0)` (row-major over positions and velocities), whether a switch
    /// crossed, the statistics.
    #[allow(clippy::type_complexity)]
    fn integrate_variational(
        &self,
        y0: &[f64],
    ) -> Result<(Vec<f64>, Vec<f64>, bool, IntegrationStats), RunError> {
        let m = 2 * self.chain.n_particles();
        integrate_variational(
            &self.scene,
            &self.chain,
            y0,
            &self.scales[..m],
            self.period_s,
        )
    }

    fn switches(&self) -> Vec<Switch> {
        crate::dispatch_chain_system!(&self.chain, |sys| switches_of(&mut sys))
    }
}

/// The run of `scene` (an orbit's, its drive if any unchanged) from the whole state `start`
/// over two periods of `frequency_hz`, recording `record` (no histories) with its steady state
/// over both periods at that frequency (its harmonics and sampling as `record` gives them): an
/// orbit's amplitudes and harmonics per probe, by the same definitions as every run's, and in
/// their settledness a check of its periodicity.
pub(crate) fn two_period_run(
    scene: &Scene,
    record: RecordSpec,
    frequency_hz: f64,
    start: Vec<f64>,
) -> Result<RunOutput, RunError> {
    let mut s = scene.clone();
    s.record = record;
    s.record.history = false;
    let mut spec = s
        .record
        .steady_state
        .clone()
        .unwrap_or_else(|| SteadyStateSpec::new(None, 0, 2));
    spec.frequency_hz = Some(frequency_hz);
    spec.settle_periods = 0;
    spec.window_periods = 2;
    s.record.steady_state = Some(spec);
    s.duration_s = 2.0 / frequency_hz;
    s.continuation = Some(Continuation {
        start_state: Some(start),
    });
    run(&s)
}

/// Whether `chain` gives its acceleration Jacobian (at `y0`, `t = 0`).
pub(super) fn has_jacobian(chain: &Chain, y0: &[f64]) -> bool {
    let (mut kx, mut kv) = (Tridiagonal::default(), Tridiagonal::default());
    crate::dispatch_chain_system!(chain, |sys| jacobian_at(&mut sys, y0, &mut kx, &mut kv))
}

/// The state of `chain` (in `scene`) and its variational equations from the whole state `y0` at
/// `t = 0` to `t_end`: the whole state at the end, `Φ = ∂x(t_end)/∂x(0)` over positions and
/// velocities (row-major, `2N × 2N`), whether a switch crossed, the statistics. `scales` are the
/// natural scales of positions and velocities (`2N`), which set the error tolerance of `Φ`'s
/// entries (entry `(i, j)` on `scales_i / scales_j`).
#[allow(clippy::type_complexity)]
pub(super) fn integrate_variational(
    scene: &Scene,
    chain: &Chain,
    y0: &[f64],
    scales: &[f64],
    t_end: f64,
) -> Result<(Vec<f64>, Vec<f64>, bool, IntegrationStats), RunError> {
    let m = 2 * chain.n_particles();
    let base = y0.len();
    let mut y = y0.to_vec();
    y.resize(base + m * m, 0.0);
    for j in 0..m {
        y[base + j * m + j] = 1.0;
    }
    // Entry i of column j is ∂x_i/∂x_j: its scale is scale_i / scale_j.
    let mut all = state_scales(chain, &scene.impact_scales(chain));
    for j in 0..m {
        for i in 0..m {
            all.push(scales[i] / scales[j]);
        }
    }
    let (integrator, _) = build(scene, chain, Some(all));
    let switches = crate::dispatch_chain_system!(chain, |sys| switches_of(&mut sys));
    let mut obs = EndObserver::new(&switches);
    let stats = crate::dispatch_chain_system!(chain, |sys| {
        let mut v = Variational::new(&mut sys, m / 2, base);
        integrator.integrate(&mut v, 0.0, &y, t_end, scene.max_steps, &mut obs)
    })?;
    let mut phi = vec![0.0; m * m];
    for j in 0..m {
        for i in 0..m {
            phi[i * m + j] = obs.y[base + j * m + i];
        }
    }
    obs.y.truncate(base);
    Ok((obs.y, phi, obs.crossed, stats))
}

/// Whether `sys` gives its acceleration Jacobian (at `y0`, `t = 0`).
fn jacobian_at(
    sys: &mut dyn OdeSystemDyn,
    y0: &[f64],
    kx: &mut Tridiagonal,
    kv: &mut Tridiagonal,
) -> bool {
    sys.acceleration_jacobian(0.0, y0, kx, kv)
}

/// `sys`'s switching functions.
fn switches_of(sys: &mut dyn OdeSystemDyn) -> Vec<Switch> {
    sys.switches().to_vec()
}

/// Why shooting stopped without an orbit.
#[derive(Debug, Clone, PartialEq)]
pub enum ShootingError {
    /// A period could not be integrated.
    Run(RunError),
    /// Newton's method did not reach the tolerance.
    NotConverged {
        /// Iterations taken.
        iterations: u32,
        /// Scaled residual reached.
        residual: f64,
        /// Tolerance asked for.
        tolerance: f64,
    },
    /// `M − I` was singular (a multiplier exactly 1).
    Singular,
    /// The QR iteration for the multipliers did not converge.
    Multipliers,
    /// A free orbit's shooting converged to the static state, which is an orbit of every period.
    StaticState {
        /// The turning point's largest distance from the static state, `max_i |x_i(0) − x̄_i| / s_i`.
        motion: f64,
    },
    /// A free orbit's shooting converged to an orbit of a fraction `T/k` of the period asked
    /// for, which turns at `T/2` too.
    MultipleCover {
        /// The share of its motion at the fundamental `1/T`.
        share: f64,
    },
}

impl std::fmt::Display for ShootingError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ShootingError::Run(e) => write!(f, "{e}"),
            ShootingError::NotConverged {
                iterations,
                residual,
                tolerance,
            } => write!(
                f,
                "Newton's method did not converge in {iterations} iterations: residual {residual:.3e} above the tolerance {tolerance:.1e}"
            ),
            ShootingError::Singular => write!(
                f,
                "the Newton matrix M − I is singular (a Floquet multiplier equal to 1)"
            ),
            ShootingError::Multipliers => write!(
                f,
                "the QR iteration for the Floquet multipliers did not converge"
            ),
            ShootingError::StaticState { motion } => write!(
                f,
                "shooting converged to the static state, an orbit of every period (largest motion {motion:.1e} of the position scales): start from a guess nearer the orbit sought, a larger displacement or a frequency nearer the one of its amplitude"
            ),
            ShootingError::MultipleCover { share } => write!(
                f,
                "shooting converged to an orbit of a fraction of the period asked for, repeated within it (its fundamental {share:.1e} of its motion): no free orbit of this frequency was found near the guess; the family's frequencies have left the range its orbits reach"
            ),
        }
    }
}

impl std::error::Error for ShootingError {}

impl From<RunError> for ShootingError {
    fn from(e: RunError) -> Self {
        ShootingError::Run(e)
    }
}

/// The integrator the scene asks for on `chain`, with the scene's absolute-tolerance scales or
/// `scales` (a longer state), and its relative tolerance.
fn build(
    scene: &Scene,
    chain: &Chain,
    scales: Option<Vec<f64>>,
) -> (Box<dyn Integrator>, Option<f64>) {
    let scales = scales.unwrap_or_else(|| state_scales(chain, &scene.impact_scales(chain)));
    scene.integrator.visit(Build { scales })
}

struct Build {
    scales: Vec<f64>,
}

impl MethodVisitor for Build {
    type Output = (Box<dyn Integrator>, Option<f64>);
    fn fixed<S: Integrator + 'static>(self, scheme: S) -> (Box<dyn Integrator>, Option<f64>) {
        (Box::new(scheme), None)
    }
    fn adaptive<M: AdaptiveMethod + 'static>(
        self,
        options: AdaptiveOptions,
    ) -> (Box<dyn Integrator>, Option<f64>) {
        (
            Box::new(Adaptive::<M>::with_options(options).with_atol_scale(self.scales)),
            Some(options.rtol),
        )
    }
}

/// The relative tolerance of the scene's adaptive method.
struct Tolerance;

impl MethodVisitor for Tolerance {
    type Output = Option<f64>;
    fn fixed<S: Integrator + 'static>(self, _: S) -> Option<f64> {
        None
    }
    fn adaptive<M: AdaptiveMethod + 'static>(self, options: AdaptiveOptions) -> Option<f64> {
        Some(options.rtol)
    }
}

/// Keeps the last accepted state and whether any switch changed sign.
struct EndObserver {
    switches: Vec<Switch>,
    signs: Vec<bool>,
    crossed: bool,
    y: Vec<f64>,
}

impl EndObserver {
    fn new(switches: &[Switch]) -> Self {
        EndObserver {
            switches: switches.to_vec(),
            signs: Vec::new(),
            crossed: false,
            y: Vec::new(),
        }
    }

    fn signs_of(&self, y: &[f64]) -> impl Iterator<Item = bool> + '_ {
        let y = y.to_vec();
        self.switches.iter().map(move |s| s.value(|i| y[i]) > 0.0)
    }
}

impl StepObserver for EndObserver {
    fn on_start(&mut self, _t0: f64, y0: &[f64]) {
        self.y = y0.to_vec();
        self.signs = self.signs_of(y0).collect();
    }

    fn on_step(&mut self, step: &dyn DenseStep) -> Control {
        let y = step.y_end();
        self.y.copy_from_slice(y);
        if !self.crossed {
            let now: Vec<bool> = self.signs_of(y).collect();
            self.crossed = now != self.signs;
        }
        Control::Continue
    }
}

/// A chain's equations with their variational equations: the state `[y, Φ]`, `Φ` the `2N × 2N`
/// sensitivity of positions and velocities to their start (column-major, after the chain's
/// quadratures), `Φ' = [[0, I], [∂a/∂x, ∂a/∂v]] Φ` with the chain's tridiagonal acceleration
/// Jacobian. Where the right-hand side is continuous across a switch (an elastic contact opening
/// or closing) `Φ` needs no jump there; a force that jumps (a viscous contact opening while its
/// ends move apart) would need a saltation matrix, which [`PeriodMap::map`] avoids by finite
/// differences.
struct Variational<'a> {
    base: &'a mut dyn OdeSystemDyn,
    n: usize,
    base_dim: usize,
    kx: Tridiagonal,
    kv: Tridiagonal,
}

impl<'a> Variational<'a> {
    fn new(base: &'a mut dyn OdeSystemDyn, n: usize, base_dim: usize) -> Self {
        Variational {
            base,
            n,
            base_dim,
            kx: Tridiagonal::default(),
            kv: Tridiagonal::default(),
        }
    }
}

/// `out = m x` for a tridiagonal `m`, added (`add`) or written.
fn tridiagonal_product(m: &Tridiagonal, x: &[f64], out: &mut [f64], add: bool) {
    let n = x.len();
    for i in 0..n {
        let mut s = m.diag[i] * x[i];
        if i > 0 {
            s += m.lower[i - 1] * x[i - 1];
        }
        if i + 1 < n {
            s += m.upper[i] * x[i + 1];
        }
        if add {
            out[i] += s;
        } else {
            out[i] = s;
        }
    }
}

impl OdeSystem for Variational<'_> {
    fn n_pos(&self) -> usize {
        self.base.n_pos()
    }
    fn n_quad(&self) -> usize {
        self.base.n_quad() + 4 * self.n * self.n
    }
    fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]) {
        let (b, n) = (self.base_dim, self.n);
        self.base.rhs(t, &y[..b], &mut dy[..b]);
        self.base
            .acceleration_jacobian(t, &y[..b], &mut self.kx, &mut self.kv);
        let m = 2 * n;
        for (col, dcol) in y[b..].chunks_exact(m).zip(dy[b..].chunks_exact_mut(m)) {
            let (px, pv) = col.split_at(n);
            let (dx, dv) = dcol.split_at_mut(n);
            dx.copy_from_slice(pv);
            tridiagonal_product(&self.kx, px, dv, false);
            tridiagonal_product(&self.kv, pv, dv, true);
        }
    }
    fn switches(&self) -> &[Switch] {
        self.base.switches()
    }
    fn hold_switch(&self, switch: usize, positive: bool, y: &[f64], dy: &mut [f64]) {
        let b = self.base_dim;
        self.base
            .hold_switch(switch, positive, &y[..b], &mut dy[..b]);
    }
    fn vanishes_below(&self, switch: usize) -> bool {
        self.base.vanishes_below(switch)
    }
}
