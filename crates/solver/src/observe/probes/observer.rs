//! The run observer ([`RunObserver`]): fed every accepted step, it samples the probes' summaries
//! and histories, the fields, the steady state and the energy flow, keeps the energy ledger, and
//! stops the run at its deadline, its stop flag or its last leading pulse. Where the probes'
//! peaks are looked for, and which samples a settled probe may skip, is its submodule `locate`:
//! the observer's cost is won there, and proved there to change nothing.

mod locate;

use std::time::Instant;

use crate::chain::model::{Chain, ContactMap};
use crate::integrate::{Control, DenseStep, StepObserver};
use crate::motion::balance::StaticBalance;
use crate::motion::system::{EnergyTerms, Ledger};
use crate::observe::flow::{EnergyFlow, FlowRecorder};
use crate::observe::peaks::{PeakTracker, PulsePhase};
use crate::observe::steady::{SteadyRecorder, SteadyState, SteadyStateSpec};

use super::compiled::ProbeSet;
use super::field_recorder::FieldRecorder;
use super::sampling::{sample_grid, SAMPLE_BATCH};
use super::{
    max_history_samples, FieldSpec, Fields, History, Preload, ProbeSummary, DEADLINE_CHECK_STEPS,
};

/// Options of the run observer.
#[derive(Debug, Clone)]
pub(crate) struct ObserverOptions {
    pub history: bool,
    pub history_interval: f64,
    pub summary_interval: f64,
    pub min_overlap: bool,
    pub arrival_fraction: f64,
    pub release_fraction: f64,
    pub stop_after_leading_pulses: bool,
    pub impact_energy: f64,
    pub impact_momentum: f64,
    /// Whether a drive feeds the chain for the whole run: its energy drift is then measured
    /// against the larger of `impact_energy` and the work the drive has done so far (a driven
    /// chain's energy grows far beyond the scale of one period).
    pub driven: bool,
    /// Space–time fields to record, with the preload setting of the force probes.
    pub fields: Option<(FieldSpec, Preload)>,
    /// The steady-state window to analyse, at its frequency (Hz).
    pub steady_state: Option<(SteadyStateSpec, f64)>,
    /// Whether to integrate the energy flow ([`crate::observe::flow`]).
    pub energy_flow: bool,
}

/// Most steps a probe whose bound failed waits before its bound is tried again
/// ([`RunObserver::settle`]): whether a probe settles changes no result, only what its samples
/// cost.
const MAX_SETTLE_WAIT: u8 = 15;

/// The observer that feeds probes, summaries and the ledger from every accepted step. A run
/// integrated in legs ([`crate::scene::solve::run`]) calls `on_start` once per leg: the first call
/// starts the record, the later ones continue it from the state the previous leg ended in.
pub(crate) struct RunObserver {
    /// Whether the record has started (later `on_start` calls are continuations).
    started: bool,
    /// Whether the observer asked the integrator to stop.
    pub stopped: bool,
    /// The run stops once this instant has passed (checked every [`DEADLINE_CHECK_STEPS`]).
    pub deadline: Option<Instant>,
    /// Whether the run was stopped by its deadline.
    pub deadline_reached: bool,
    /// The run stops once this flag is set (read after every accepted step).
    pub stop_flag: Option<std::sync::Arc<std::sync::atomic::AtomicBool>>,
    /// Whether the run was stopped by its stop flag.
    pub interrupted: bool,
    /// Accepted steps since the clock was last read.
    steps_since_clock: u32,
    /// The state at the end of the last accepted step, kept when the run has several legs.
    pub state: Option<Vec<f64>>,
    /// The ledger's terms at the start.
    pub first_energy: Option<EnergyTerms>,
    probes: ProbeSet,
    ledger: Ledger,
    opts: ObserverOptions,
    t0: f64,
    t_end: f64,
    e0: f64,
    p0: f64,
    /// The external term of the ledger at the start, and the largest work done since (driven
    /// chains).
    external0: f64,
    work_max: f64,
    trackers: Vec<PeakTracker>,
    next_summary: u64,
    next_history: u64,
    pub history: Option<History>,
    pub min_overlap: Option<Vec<f64>>,
    /// The space–time fields, when recorded.
    fields: Option<FieldRecorder>,
    /// The steady-state sums, when recorded.
    steady: Option<SteadyRecorder>,
    /// The energy flow, when recorded.
    flow: Option<FlowRecorder>,
    pub energy_drift_max: f64,
    pub energy_drift_final: f64,
    pub momentum_residual_max: f64,
    pub max_overlap: f64,
    pub last_energy: Option<EnergyTerms>,
    pub t_reached: f64,
    n: usize,
    n_contacts: usize,
    /// What each contact joins.
    contacts: ContactMap,
    /// The components the probes read ([`ProbeSet::components`]).
    probe_components: Vec<usize>,
    /// The components each probe reads ([`ProbeSet::components_of`]).
    components_of: Vec<Vec<usize>>,
    /// The probes whose samples in the current step provably change nothing they record
    /// ([`PeakTracker::settled_below`]), and the components the others read.
    settled: Vec<bool>,
    live_components: Vec<usize>,
    /// Per probe, the steps to pass before its bound is tried again, and how many it waited last
    /// ([`MAX_SETTLE_WAIT`]).
    settle_wait: Vec<(u8, u8)>,
    /// Those components at one sample time, at their indices in the state.
    probe_state: Vec<f64>,
    /// Particles integrated (the rest rest at their static equilibrium, [`crate::scene::active`]): the
    /// ledger sums over them and adds the constant energy of the rest, [`RunObserver::set_active`].
    active: usize,
    /// Elastic and gravitational energy of the particles at rest and their contacts, J.
    frozen_energy: (f64, f64),
    /// Largest overlap of the contacts between particles at rest, m.
    frozen_max_overlap: f64,
    /// Those components at up to [`SAMPLE_BATCH`] sample times, one row per time.
    batch_values: Vec<f64>,
    /// Each probe's value at the end of the last step (at the start, before the first).
    last_value: Vec<f64>,
    /// Each probe's smallest and largest sample in the current step.
    step_range: Vec<(f64, f64)>,
    /// The largest contact overlap at the end of the last step.
    last_max_overlap: f64,
    /// The energy balance above the static state, for chains whose static state holds energy
    /// ([`RunObserver::uses_static_balance`]): its total at the start, and the largest energy of
    /// the motion and work exchanged so far.
    balance: Option<(StaticBalance, f64)>,
    motion_max: f64,
}

impl RunObserver {
    pub fn new(
        chain: &Chain,
        probes: ProbeSet,
        opts: ObserverOptions,
        t0: f64,
        t_end: f64,
    ) -> Self {
        let n_probes = probes.len();
        let history = opts.history.then(|| {
            // Bounded whatever the caller validated: a history longer than this grows as it goes.
            let cap = ((t_end - t0) / opts.history_interval)
                .floor()
                .min(max_history_samples(n_probes) as f64) as usize
                + 1;
            History {
                time_s: Vec::with_capacity(cap),
                values: (0..n_probes).map(|_| Vec::with_capacity(cap)).collect(),
            }
        });
        let probe_components = probes.components();
        let probe_state = vec![0.0; probe_components.last().map_or(0, |i| i + 1)];
        let components_of = (0..n_probes).map(|k| probes.components_of(k)).collect();
        RunObserver {
            components_of,
            settled: vec![false; n_probes],
            settle_wait: vec![(0, 0); n_probes],
            live_components: Vec::with_capacity(probe_components.len()),
            batch_values: vec![0.0; SAMPLE_BATCH * probe_components.len()],
            probe_components,
            probe_state,
            started: false,
            stopped: false,
            first_energy: None,
            deadline: None,
            deadline_reached: false,
            stop_flag: None,
            interrupted: false,
            steps_since_clock: 0,
            state: None,
            ledger: Ledger::new(chain),
            probes,
            t0,
            t_end,
            e0: 0.0,
            p0: 0.0,
            external0: 0.0,
            work_max: 0.0,
            trackers: Vec::new(),
            next_summary: 0,
            next_history: 0,
            history,
            min_overlap: opts
                .min_overlap
                .then(|| vec![f64::INFINITY; chain.n_contacts()]),
            fields: opts
                .fields
                .as_ref()
                .map(|(spec, preload)| FieldRecorder::new(chain, spec, *preload, t0, t_end)),
            steady: opts
                .steady_state
                .as_ref()
                .map(|(spec, f)| SteadyRecorder::new(spec, *f, n_probes)),
            flow: opts
                .energy_flow
                .then(|| FlowRecorder::new(chain, opts.impact_energy)),
            energy_drift_max: 0.0,
            energy_drift_final: 0.0,
            momentum_residual_max: 0.0,
            max_overlap: 0.0,
            last_energy: None,
            t_reached: t0,
            n: chain.n_particles(),
            n_contacts: chain.n_contacts(),
            contacts: ContactMap::of(chain),
            opts,
            active: chain.n_particles(),
            frozen_energy: (0.0, 0.0),
            frozen_max_overlap: 0.0,
            last_value: vec![f64::NAN; n_probes],
            step_range: vec![(f64::INFINITY, f64::NEG_INFINITY); n_probes],
            last_max_overlap: 0.0,
            balance: Self::uses_static_balance(chain).then(|| (StaticBalance::new(chain), 0.0)),
            motion_max: 0.0,
        }
    }

    /// Whether the energy drift is measured from the static state ([`StaticBalance`]): where a
    /// precompression, a drive or a load cell loads the chain, whose static energy would otherwise
    /// bury a small motion's balance in its rounding. (The paper's chains, loaded by their weight
    /// alone, keep the ledger's total.)
    fn uses_static_balance(chain: &Chain) -> bool {
        chain.static_overlap.iter().any(|&d| d > 0.0)
            && (chain.precompression_force_n > 0.0
                || chain.drive.is_some()
                || chain.wall_mount.is_some())
    }

    /// Only the first `k` particles move from now on; the rest stay at rest at their positions
    /// in the full state `y` (and so does the wall impulse's rate): the ledger then sums over the
    /// moving part only and adds the constant terms of the rest, computed here once.
    pub fn set_active(&mut self, k: usize, y: &[f64]) {
        self.active = k;
        if k == self.n {
            return;
        }
        let whole = self.ledger.energy(y);
        let part = self.ledger.energy_prefix(y, k);
        self.frozen_energy = (
            whole.elastic - part.elastic,
            whole.gravitational - part.gravitational,
        );
        self.frozen_max_overlap = (k..self.n_contacts)
            .map(|c| self.contacts.overlap(c, y))
            .fold(0.0, f64::max);
    }

    pub fn summaries(&self) -> Vec<ProbeSummary> {
        self.trackers
            .iter()
            .map(|tr| {
                // A leading peak counts only once the signal has fallen after it: a run that ends
                // while the pulse is still rising has no leading peak yet.
                let (lv, lt) = if tr.leading.after >= 1 {
                    tr.leading.located()
                } else {
                    (f64::NAN, f64::NAN)
                };
                let (rv, rt) = tr.record.located();
                ProbeSummary {
                    leading_peak: lv,
                    leading_peak_time_s: lt,
                    record_max: rv,
                    record_max_time_s: rt,
                }
            })
            .collect()
    }

    fn update_ledger(&mut self, t: f64, y: &[f64]) {
        let k = self.active;
        let e = if k == self.n {
            self.ledger.energy(y)
        } else {
            let mut e = self.ledger.energy_prefix(y, k);
            e.elastic += self.frozen_energy.0;
            e.gravitational += self.frozen_energy.1;
            e.max_overlap = e.max_overlap.max(self.frozen_max_overlap);
            e
        };
        let drift = if let Some((balance, start)) = &self.balance {
            let b = balance.terms(y, k);
            self.motion_max = self.motion_max.max(b.motion);
            self.work_max = self.work_max.max(b.work.abs());
            let scale = if self.opts.driven {
                self.opts
                    .impact_energy
                    .max(self.work_max)
                    .max(self.motion_max)
            } else {
                self.opts.impact_energy
            };
            (b.total - start).abs() / scale
        } else {
            let scale = if self.opts.driven {
                self.work_max = self.work_max.max((e.external - self.external0).abs());
                self.opts.impact_energy.max(self.work_max)
            } else {
                self.opts.impact_energy
            };
            (e.total() - self.e0).abs() / scale
        };
        self.energy_drift_max = self.energy_drift_max.max(drift);
        self.energy_drift_final = drift;
        let r = self
            .ledger
            .momentum_residual_prefix(y, k, t, self.t0, self.p0)
            .abs()
            / self.opts.impact_momentum;
        self.momentum_residual_max = self.momentum_residual_max.max(r);
        self.last_energy = Some(e);
        self.max_overlap = self.max_overlap.max(e.max_overlap);
        if let Some(mins) = &mut self.min_overlap {
            // Contacts between particles at rest keep their overlap.
            for (c, m) in mins.iter_mut().enumerate().take(self.n_contacts.min(k)) {
                *m = m.min(self.contacts.overlap(c, y));
            }
        }
    }

    /// The space–time fields recorded, when asked for (taken: a second call gives `None`).
    pub fn take_fields(&mut self) -> Option<Fields> {
        self.fields.take().map(|f| f.out)
    }

    /// The energy flow, when asked for (taken: a second call gives `None`).
    pub fn take_energy_flow(&mut self) -> Option<EnergyFlow> {
        self.flow.take().map(FlowRecorder::finish)
    }

    /// The steady state analysed, when asked for (taken: a second call gives `None`).
    pub fn take_steady_state(&mut self) -> Option<SteadyState> {
        self.steady.take().map(|s| s.finish())
    }
}

impl StepObserver for RunObserver {
    fn on_start(&mut self, t0: f64, y0: &[f64]) {
        if self.started {
            // A new leg: it starts where the last accepted step ended, already recorded.
            debug_assert_eq!(t0, self.t_reached);
            return;
        }
        self.started = true;
        if let Some(s) = &mut self.state {
            s.copy_from_slice(y0);
        }
        let e0 = self.ledger.energy(y0);
        self.e0 = e0.total();
        self.first_energy = Some(e0);
        if let Some((balance, start)) = &mut self.balance {
            *start = balance.terms(y0, self.n).total;
        }
        self.external0 = e0.external;
        self.p0 = self.ledger.momentum(y0);
        let get = |i: usize| y0[i];
        self.trackers = (0..self.probes.len())
            .map(|k| {
                let base = self.probes.value(k, &get);
                PeakTracker::new(
                    base,
                    self.opts.arrival_fraction * self.probes.scale[k],
                    self.opts.release_fraction,
                )
            })
            .collect();
        // The initial state is whole: every contact's overlap enters the minima once.
        let active = std::mem::replace(&mut self.active, self.n);
        self.update_ledger(t0, y0);
        self.active = active;
        for (k, tr) in self.trackers.iter_mut().enumerate() {
            let v = self.probes.value(k, &get);
            tr.sample(t0, v);
            self.last_value[k] = v;
        }
        self.last_max_overlap = self.max_overlap;
        self.next_summary = 1;
        if let Some(h) = &mut self.history {
            h.time_s.push(t0);
            for (k, series) in h.values.iter_mut().enumerate() {
                series.push(self.probes.value(k, &get));
            }
        }
        self.next_history = 1;
        if let Some(f) = &mut self.fields {
            f.start(t0, y0);
        }
        if let Some(f) = &mut self.flow {
            f.start(y0);
        }
        self.t_reached = t0;
    }

    fn on_step(&mut self, step: &dyn DenseStep) -> Control {
        let t1 = step.t_end();
        let n_probes = self.probes.len();
        // The record's last instant in this step: the step's end, or, for a run that stops after
        // its leading pulses, the summary instant at which the last of them is seen to pass. The
        // step goes on past that instant by however far the integrator's step size took it, and
        // a record reaching beyond it would depend on the step sizes (a probe still rising there
        // would put its record maximum wherever the last step happened to end).
        let mut until = t1.min(self.t_end);
        let mut passed_at: Option<f64> = None;
        if n_probes > 0 {
            #[cfg(test)]
            let first_summary = self.next_summary;
            let any_settled = self.settle(step, until);
            let probes = &self.probes;
            let trackers = &mut self.trackers;
            let step_range = &mut self.step_range;
            let settled = &self.settled;
            let stop_when_passed = self.opts.stop_after_leading_pulses;
            let components = if any_settled {
                &self.live_components
            } else {
                &self.probe_components
            };
            sample_grid(
                step,
                (self.t0, self.opts.summary_interval),
                &mut self.next_summary,
                until,
                components,
                &mut self.batch_values[..],
                &mut self.probe_state,
                |ts, state| {
                    if passed_at.is_some() {
                        return;
                    }
                    let g = |i: usize| state[i];
                    for (k, tracker) in trackers.iter_mut().enumerate() {
                        if !settled[k] {
                            let v = probes.value(k, &g);
                            tracker.sample(ts, v);
                            let r = &mut step_range[k];
                            *r = (r.0.min(v), r.1.max(v));
                        }
                    }
                    // A settled tracker's phase stays as it is over the step.
                    if stop_when_passed && trackers.iter().all(|t| t.phase == PulsePhase::Passed) {
                        passed_at = Some(ts);
                    }
                },
            );
            if let Some(t) = passed_at {
                until = t;
            }
            #[cfg(test)]
            if any_settled {
                self.sample_settled(step, first_summary, until);
            }
            self.locate_peaks(step, step.t_start(), until);
            let probes = &self.probes;
            if let Some(h) = &mut self.history {
                sample_grid(
                    step,
                    (self.t0, self.opts.history_interval),
                    &mut self.next_history,
                    until,
                    &self.probe_components,
                    &mut self.batch_values[..],
                    &mut self.probe_state,
                    |th, state| {
                        let g = |i: usize| state[i];
                        h.time_s.push(th);
                        for (k, series) in h.values.iter_mut().enumerate() {
                            series.push(probes.value(k, &g));
                        }
                    },
                );
            }
            if let Some(s) = self.steady.as_mut().filter(|s| !s.complete()) {
                // Up to the window's last instant, so that nothing is sampled after it.
                let last = s.last_instant_s();
                let mut next = s.next;
                let mut j = next;
                sample_grid(
                    step,
                    (s.start_s, s.interval_s),
                    &mut next,
                    until.min(last),
                    &self.probe_components,
                    &mut self.batch_values[..],
                    &mut self.probe_state,
                    |t, state| {
                        let g = |i: usize| state[i];
                        s.sample(j, t, |k| probes.value(k, &g));
                        j += 1;
                    },
                );
                s.next = next;
            }
        }
        if let Some(f) = &mut self.fields {
            f.step(step, self.t0, until);
        }
        if let Some(f) = &mut self.flow {
            f.step(step);
        }
        self.update_ledger(t1, step.y_end());
        if let Some(e) = self.last_energy {
            self.locate_max_overlap(step, e.max_overlap);
        }
        self.t_reached = t1;
        if let Some(s) = &mut self.state {
            s.copy_from_slice(step.y_end());
        }
        if passed_at.is_some() {
            self.stopped = true;
            return Control::Stop;
        }
        if let Some(flag) = &self.stop_flag {
            if flag.load(std::sync::atomic::Ordering::Relaxed) {
                self.interrupted = true;
                self.stopped = true;
                return Control::Stop;
            }
        }
        if let Some(deadline) = self.deadline {
            self.steps_since_clock += 1;
            if self.steps_since_clock >= DEADLINE_CHECK_STEPS {
                self.steps_since_clock = 0;
                if Instant::now() >= deadline {
                    self.deadline_reached = true;
                    self.stopped = true;
                    return Control::Stop;
                }
            }
        }
        Control::Continue
    }
}
