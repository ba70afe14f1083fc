//! Where the run observer looks for peaks, and which of its samples it may skip: a probe whose
//! every value in a step provably stays below what could change its record is settled and not
//! sampled ([`RunObserver::settle`]), and peaks are located on the dense output only where they
//! may lie. Apart from the observer's bookkeeping because this is where its cost is won, and where
//! a test proves that skipping samples changes nothing, bitwise.

use crate::integrate::DenseStep;
use crate::observe::grid_instant;
use crate::observe::peaks::{hermite_max, maximise, maximise_batched};

use super::{RunObserver, MAX_SETTLE_WAIT};
// Named only by the docs.
#[cfg(doc)]
use crate::observe::{peaks::PeakTracker, probes::ProbeSet};

impl RunObserver {
    /// Marks the probes whose summary samples in this step (those up to `until`) provably change
    /// nothing but the last two samples their trackers keep: the step's enclosure of the
    /// components each reads ([`DenseStep::component_range`]) bounds its values
    /// ([`ProbeSet::upper_bound`]) below what could change its tracker
    /// ([`PeakTracker::settled_below`]). Collects the components of the others in
    /// `live_components`; returns whether any probe is settled. Only a step of at least three
    /// samples is looked at (below that nothing is saved).
    pub(super) fn settle(&mut self, step: &dyn DenseStep, until: f64) -> bool {
        self.settled.fill(false);
        #[cfg(test)]
        if tests::NO_SETTLING.with(|c| c.get()) {
            return false;
        }
        // (The third instant from the next, as the sampling loop places it.)
        if grid_instant(self.t0, self.next_summary + 2, self.opts.summary_interval) > until {
            return false;
        }
        let mut any = false;
        for (k, tracker) in self.trackers.iter().enumerate() {
            if !tracker.may_settle() {
                continue;
            }
            let (wait, waited) = &mut self.settle_wait[k];
            if *wait > 0 {
                *wait -= 1;
                continue;
            }
            self.settled[k] = self
                .probes
                .upper_bound(k, &|i| step.component_range(i))
                .is_some_and(|u| tracker.settled_below(u));
            // A bound that fails is tried again after a wait that doubles while it keeps failing:
            // a probe whose signal keeps rising by round-off (a particle at rest, integrated)
            // costs the bound once in a while, not at every step.
            (*wait, *waited) = if self.settled[k] {
                (0, 0)
            } else {
                let next = (2 * *waited + 1).min(MAX_SETTLE_WAIT);
                (next, next)
            };
            any |= self.settled[k];
        }
        if any {
            self.live_components.clear();
            for (k, c) in self.components_of.iter().enumerate() {
                if !self.settled[k] {
                    self.live_components.extend_from_slice(c);
                }
            }
            self.live_components.sort_unstable();
            self.live_components.dedup();
        }
        any
    }

    /// Under test, the settled probes' trackers ([`RunObserver::settle`]) against copies that
    /// took every summary instant of the step from index `first` up to `until`: skipping them
    /// must change nothing, bitwise.
    #[cfg(test)]
    pub(super) fn sample_settled(&mut self, step: &dyn DenseStep, first: u64, until: f64) {
        let interval = self.opts.summary_interval;
        let at = |j: u64| grid_instant(self.t0, j, interval);
        for k in 0..self.trackers.len() {
            if !self.settled[k] {
                continue;
            }
            let mut copy = self.trackers[k];
            let components = &self.components_of[k];
            let mut row = vec![0.0; components.len()];
            let mut j = first;
            while at(j) <= until {
                step.eval_components_at(&[at(j)], components, &mut row);
                for (&i, &v) in components.iter().zip(&row) {
                    self.probe_state[i] = v;
                }
                let state = &self.probe_state;
                copy.sample(at(j), self.probes.value(k, &|i: usize| state[i]));
                tests::SKIPPED.with(|c| c.set(c.get() + 1));
                j += 1;
            }
            tests::assert_same_tracker(&self.trackers[k], &copy);
        }
    }

    /// Locates each probe's peaks on the dense output over the step `[a, b]` (`b` the record's
    /// last instant in it) where they may lie (see [`crate::observe::peaks`]): a probe whose samples or
    /// ends in the step come within the step's own swing (and a thousandth of the excursion so
    /// far) of its largest value is maximised over the step, for its record maximum, and over the
    /// part of the step its leading pulse spans, for its leading peak. Settled probes are not:
    /// their every value in the step is below their record.
    pub(super) fn locate_peaks(&mut self, step: &dyn DenseStep, a: f64, b: f64) {
        let exact_end = b == step.t_end();
        for k in 0..self.trackers.len() {
            let end_value = if exact_end {
                let y = step.y_end();
                self.probes.value(k, &|i: usize| y[i])
            } else {
                let components = &self.components_of[k];
                for &i in components {
                    self.probe_state[i] = step.eval_component(b, i);
                }
                let state = &self.probe_state;
                self.probes.value(k, &|i: usize| state[i])
            };
            let start_value = std::mem::replace(&mut self.last_value[k], end_value);
            let (lo, hi) =
                std::mem::replace(&mut self.step_range[k], (f64::INFINITY, f64::NEG_INFINITY));
            if self.settled[k] {
                continue;
            }
            let top = hi.max(start_value).max(end_value);
            let swing = top - lo.min(start_value).min(end_value);
            let tracker = &mut self.trackers[k];
            let near = |peak: f64| {
                let excursion = (peak - tracker.baseline).abs();
                top + swing + 1e-3 * excursion >= peak
            };
            let record = near(tracker.record.peak);
            let leading = tracker
                .leading_span(a, b, self.opts.summary_interval)
                .filter(|_| near(tracker.leading.peak));
            if !record && leading.is_none() {
                continue;
            }
            let components = &self.components_of[k];
            let probes = &self.probes;
            let state = &mut self.probe_state;
            let batch = &mut self.batch_values;
            // One instant: each component's interpolant; a scan: the method's batched
            // interpolant, in rows of the sample batch (the same values either way).
            let m = components.len();
            let mut eval = |times: &[f64], values: &mut [f64]| {
                if times.len() == 1 || m == 0 {
                    for (v, &t) in values.iter_mut().zip(times) {
                        for &i in components {
                            state[i] = step.eval_component(t, i);
                        }
                        let state = &*state;
                        *v = probes.value(k, &|i: usize| state[i]);
                    }
                    return;
                }
                let rows = (batch.len() / m).max(1);
                for (times, values) in times.chunks(rows).zip(values.chunks_mut(rows)) {
                    let batch = &mut batch[..times.len() * m];
                    step.eval_components_at(times, components, batch);
                    for (v, row) in values.iter_mut().zip(batch.chunks_exact(m)) {
                        for (&i, &x) in components.iter().zip(row) {
                            state[i] = x;
                        }
                        let state = &*state;
                        *v = probes.value(k, &|i: usize| state[i]);
                    }
                }
            };
            let spacing = 0.5 * self.opts.summary_interval;
            let whole = record.then(|| maximise_batched(a, b, spacing, &mut eval));
            if let Some((v, t)) = whole {
                tracker.record.consider(t, v);
            }
            if let Some((lo, hi)) = leading {
                let (v, t) = match whole {
                    Some(found) if (lo, hi) == (a, b) => found,
                    _ => maximise_batched(lo, hi, spacing, &mut eval),
                };
                tracker.leading.consider(t, v);
            }
        }
    }

    /// Locates the largest contact overlap on the dense output over the step, where the largest
    /// overlap at either end of the step (`end_max` at its end) comes within a tenth of the
    /// largest so far: each contact of the moving part that is opening at the step's end from a
    /// peak that could lie above the largest so far (its overlap plus its rate over the step), and
    /// was closing at the step's start with the cubic through its ends' overlaps and rates
    /// reaching within a thousandth of it, is maximised over the step.
    pub(super) fn locate_max_overlap(&mut self, step: &dyn DenseStep, end_max: f64) {
        let start_max = std::mem::replace(&mut self.last_max_overlap, end_max);
        let mut found = self.max_overlap;
        if found <= 0.0 || start_max.max(end_max) < 0.9 * found {
            return;
        }
        let (a, b) = (step.t_start(), step.t_end());
        let h = b - a;
        let y1 = step.y_end();
        let at_start = |i: usize| step.eval_component(a, i);
        for c in 0..self.n_contacts.min(self.active) {
            let (d1, r1) = self.contacts.kinematics(c, |i| y1[i]);
            if r1 >= 0.0 || d1 - r1 * h < 0.999 * found {
                continue;
            }
            let (d0, r0) = self.contacts.kinematics(c, at_start);
            if r0 <= 0.0 || hermite_max(h, (d0, r0), (d1, r1)) < 0.999 * found {
                continue;
            }
            let contacts = &self.contacts;
            let (d, _) = maximise(a, b, h, |t| {
                contacts.overlap_read(c, |i| step.eval_component(t, i))
            });
            found = found.max(d);
        }
        self.max_overlap = found;
    }
}

#[cfg(test)]
mod tests {
    use crate::observe::peaks::PeakTracker;
    use crate::observe::probes::Probe;

    /// Two trackers in the same state, to the bit.
    pub(super) fn assert_same_tracker(a: &PeakTracker, b: &PeakTracker) {
        let window = |w: &crate::observe::peaks::PeakWindow| {
            vec![
                w.best.to_bits(),
                w.time.to_bits(),
                w.after as u64,
                w.peak.to_bits(),
                w.peak_time.to_bits(),
            ]
        };
        let bits = |t: &PeakTracker| {
            let mut v = window(&t.leading);
            v.extend(window(&t.record));
            v.extend([t.arrived_at.to_bits(), t.passed_at.to_bits()]);
            v
        };
        assert_eq!(a.phase, b.phase, "a settled tracker's phase changed");
        assert_eq!(
            bits(a),
            bits(b),
            "skipping a settled tracker's samples changed it"
        );
    }

    thread_local! {
        /// Set: no probe settles ([`RunObserver::settle`]), every sample is taken.
        pub(super) static NO_SETTLING: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
        /// Samples settled probes skipped on this thread ([`RunObserver::sample_settled`]).
        pub(super) static SKIPPED: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
    }

    /// Samples skipped where a probe is settled change nothing: the Fig. 8 sweep's chain (the
    /// paper's 0.55 chain of 50 cylinders, gauges in cylinders 4 and 21, stopped after the leading
    /// pulses, DOP853 rtol 1e-8 with switch prediction), without and with damping and at a heavy
    /// and a light mass ratio, run as it is and with every sample taken gives every summary, the
    /// run's end, its counts and its ledger to the bit; and the first run did skip most of the
    /// gauge in cylinder 4's samples after its pulse passed, and cylinder 21's before the pulse
    /// came near.
    #[test]
    fn settled_probes_skip_samples_and_change_nothing() {
        use crate::chain::model::{ChainSpec, CylinderMass, DimerSpec};
        use crate::scene::solve::run;
        use crate::scene::{IntegratorSpec, Scene};
        use crate::AdaptiveOptions;
        /// Every summary, the run's end, its counts and its ledger, as bits.
        fn bits(o: &crate::scene::solve::RunOutput) -> Vec<u64> {
            let mut v: Vec<u64> = o
                .probes
                .iter()
                .flat_map(|p| {
                    [
                        p.leading_peak,
                        p.leading_peak_time_s,
                        p.record_max,
                        p.record_max_time_s,
                    ]
                })
                .map(f64::to_bits)
                .collect();
            v.extend(
                [
                    o.t_end_s,
                    o.energy_drift_max,
                    o.energy_drift_final,
                    o.momentum_residual_max,
                ]
                .map(f64::to_bits),
            );
            v.extend([o.stats.steps, o.stats.rejected, o.stats.rhs_evals]);
            v
        }
        /// The scene run as it is and with every sample taken, which must agree to the bit:
        /// the first run's output and how many samples it skipped.
        fn both_ways(s: &Scene, case: &str) -> (crate::scene::solve::RunOutput, u64) {
            SKIPPED.with(|c| c.set(0));
            let skipping = run(s).unwrap();
            let skipped = SKIPPED.with(|c| c.get());
            NO_SETTLING.with(|c| c.set(true));
            let every = run(s).unwrap();
            NO_SETTLING.with(|c| c.set(false));
            assert_eq!(
                SKIPPED.with(|c| c.get()),
                skipped,
                "{case}: skipped without settling"
            );
            assert_eq!(bits(&skipping), bits(&every), "{case}");
            (skipping, skipped)
        }
        let dop853 = IntegratorSpec::Dop853(AdaptiveOptions {
            predict_switches: true,
            ..AdaptiveOptions::new(1e-8)
        });
        for (mass_ratio, mu) in [(0.2, 0.0), (0.2, 6.0), (0.9, 0.0), (0.9, 6.0)] {
            let mut spec = DimerSpec::chain_055(50);
            spec.cylinder.mass = CylinderMass::HeavyCylinders { mass_ratio };
            spec.cylinder.height_m = None;
            let mut s = Scene::new(ChainSpec::Dimer(spec), 1.3, 3e-3);
            s.physics.damping_kg_s = mu;
            s.integrator = dop853;
            s.record.probes = vec![
                Probe::GaugeForce { cylinder: 4 },
                Probe::GaugeForce { cylinder: 21 },
            ];
            s.record.stop_after_leading_pulses = true;
            let case = format!("mass ratio {mass_ratio}, μ = {mu} kg/s");
            let (skipping, skipped) = both_ways(&s, &case);
            let samples = (skipping.t_end_s / s.record.summary_interval_s) as u64;
            assert!(
                skipped > samples / 2,
                "{case}: {skipped} of the two probes' {samples} samples each skipped"
            );
            assert!(
                skipping.probes.iter().all(|p| p.leading_peak.is_finite()),
                "{case}"
            );
        }
        // A short chain on its wall, integrated whole, a gauge next to the wall and run past the
        // leading pulse: the wave reflected there brings a record maximum above the leading peak
        // after samples were skipped, which the bound must let through.
        for mu in [0.0, 6.0] {
            let mut s = Scene::new(ChainSpec::chain_055(10), 1.3, 4e-4);
            s.physics.damping_kg_s = mu;
            s.integrator = dop853;
            s.record.probes = vec![
                Probe::GaugeForce { cylinder: 2 },
                Probe::GaugeForce { cylinder: 9 },
            ];
            // Sampled finely, so that the steps while the reflected wave rises hold samples
            // enough to be looked at.
            s.record.summary_interval_s = 2e-8;
            let case = format!("10 cylinders, μ = {mu} kg/s");
            let (skipping, skipped) = both_ways(&s, &case);
            assert!(skipped > 100, "{case}: {skipped} samples skipped");
            let near_wall = &skipping.probes[1];
            assert!(
                near_wall.record_max > 1.1 * near_wall.leading_peak
                    && near_wall.record_max_time_s > near_wall.leading_peak_time_s,
                "{case}: {near_wall:?}"
            );
        }
    }
}
