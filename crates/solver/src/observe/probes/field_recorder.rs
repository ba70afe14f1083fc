//! Space–time fields as a run records them ([`FieldRecorder`]): one probe per contact or particle
//! of each quantity, sampled on the histories' grid. Apart from the run observer, which only
//! starts and feeds it, so that what a field costs and how it is laid out read in one place.

use crate::chain::model::Chain;
use crate::integrate::DenseStep;

use super::compiled::ProbeSet;
use super::sampling::{sample_grid, samples_in, SAMPLE_BATCH};
use super::{FieldSeries, FieldSpec, Fields, Preload, MAX_HISTORY_VALUES_PER_RUN};

/// Most values in the fields' batch of samples (8 MiB): a chain of millions of particles
/// interpolates one instant at a time rather than holding [`SAMPLE_BATCH`] whole states.
const FIELD_BATCH_VALUES: usize = 1 << 20;

/// Samples a run's space–time fields: one probe per contact or particle of each quantity, on the
/// grid `t0 + i · interval`, with the probes' own sampling ([`sample_grid`]) and arithmetic
/// ([`ProbeSet::value`]).
pub(super) struct FieldRecorder {
    probes: ProbeSet,
    interval: f64,
    /// The next instant's index on the grid.
    next: u64,
    components: Vec<usize>,
    state: Vec<f64>,
    batch: Vec<f64>,
    pub(super) out: Fields,
}

impl FieldRecorder {
    pub(super) fn new(
        chain: &Chain,
        spec: &FieldSpec,
        preload: Preload,
        t0: f64,
        t_end: f64,
    ) -> Self {
        let (n_p, n_c) = (chain.n_particles(), chain.n_contacts());
        let mut list = Vec::new();
        let mut series = Vec::new();
        for &q in &spec.quantities {
            let width = if q.per_contact() { n_c } else { n_p };
            list.extend((1..=width).map(|k| q.probe(k)));
            series.push(FieldSeries {
                quantity: q,
                width,
                values: Vec::new(),
            });
        }
        // (The reference scales only serve leading pulses, which fields do not track.)
        let probes = ProbeSet::new(chain, &list, preload, 1.0, 1.0, 1.0);
        let components = probes.components();
        let state = vec![0.0; components.last().map_or(0, |i| i + 1)];
        // Bounded whatever the caller validated: a longer record grows as it goes.
        let per_sample = list.len().max(1) as u64;
        let cap = samples_in(t0, spec.interval_s, t_end)
            .min((MAX_HISTORY_VALUES_PER_RUN / per_sample).max(1)) as usize;
        for s in &mut series {
            s.values.reserve_exact(cap * s.width);
        }
        // A batch of up to FIELD_BATCH_VALUES values (a long chain's batch holds fewer instants).
        let rows = (FIELD_BATCH_VALUES / components.len().max(1)).clamp(1, SAMPLE_BATCH);
        FieldRecorder {
            batch: vec![0.0; rows * components.len()],
            probes,
            interval: spec.interval_s,
            next: 0,
            components,
            state,
            out: Fields {
                time_s: Vec::with_capacity(cap),
                series,
            },
        }
    }

    /// Appends one sample at `t` from the state components `get` gives.
    #[inline]
    fn push(probes: &ProbeSet, out: &mut Fields, t: f64, get: &impl Fn(usize) -> f64) {
        out.time_s.push(t);
        let mut k = 0;
        for s in &mut out.series {
            for _ in 0..s.width {
                s.values.push(probes.value(k, get));
                k += 1;
            }
        }
    }

    pub(super) fn start(&mut self, t0: f64, y0: &[f64]) {
        let get = |i: usize| y0[i];
        FieldRecorder::push(&self.probes, &mut self.out, t0, &get);
        self.next = 1;
    }

    pub(super) fn step(&mut self, step: &dyn DenseStep, t0: f64, until: f64) {
        let (probes, out) = (&self.probes, &mut self.out);
        sample_grid(
            step,
            (t0, self.interval),
            &mut self.next,
            until,
            &self.components,
            &mut self.batch[..],
            &mut self.state,
            |t, state| {
                let g = |i: usize| state[i];
                FieldRecorder::push(probes, out, t, &g);
            },
        );
    }
}
