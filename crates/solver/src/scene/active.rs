//! The moving part of a chain: particles ahead of the leading front that still rest in their
//! initial static equilibrium are not integrated until the front approaches them.
//!
//! A run that qualifies ([`plan`]) integrates the prefix `[0, k)` of its chain, a chain of its own
//! whose last contact, with particle `k` held at its equilibrium position, takes the place of a
//! wall (its positions are shifted by `x_eq[k]`, so that this "wall" sits at the origin as a real
//! wall does). After every accepted step the last [`WATCH`] integrated particles are compared with
//! their equilibrium; once one has left it by more than a threshold tied to the run's absolute
//! tolerance, the integrator stops at the end of that step, the prefix grows by [`BLOCK`] particles
//! (taken from their exact equilibrium), and the integrator starts afresh from that state at the
//! step size it had reached (a new first right-hand side: the methods see one consistent, smaller
//! system at a time). The probes and the ledger see the whole chain throughout: the particles at
//! rest read their equilibrium, their energy is a constant added to the ledger's, and the wall
//! impulse grows at the equilibrium wall force.
//!
//! Qualifying is proved on the scene's own numbers, never assumed: an adaptive integrator (the
//! thresholds come from its tolerance), a chain of at least [`MIN_PARTICLES`] particles (in a
//! shorter one too little rests to pay for the restarts), no static force on the chain (a
//! precompression sends a fast linear wave ahead of the pulse), every particle beyond the first at
//! rest with no quadrature started, and the right-hand side at the initial state giving the
//! particles that start at rest accelerations so small that over the whole run they would move less
//! than a hundredth of the tolerance (a chain in free fall, a free end, a misplaced particle all
//! fail this). Scenes that do not qualify run the whole chain, unchanged.

use crate::chain::model::Chain;
use crate::integrate::{
    eval_each, eval_each_at, Control, DenseStep, IntegrateError, IntegrationStats, Integrator,
    OdeSystem, StepObserver, BATCH_COMPONENTS,
};
use crate::observe::probes::RunObserver;
pub use crate::scene::ActiveRegion;
use crate::scene::{ImpactScales, Scene};

/// Particles integrated from the start (the striker and the particles nearest it).
pub const INITIAL_PARTICLES: usize = 16;

/// Shortest chain (particles, striker included) that integrates only its moving part: below twice
/// the initial part, the part left at rest is too short to pay for the restarts.
pub const MIN_PARTICLES: usize = 2 * INITIAL_PARTICLES;

/// Particles added to the integrated prefix at a time. A restart costs a right-hand side or two
/// (the step size goes on where it was), so small blocks keep the prefix close to the front.
pub const BLOCK: usize = 8;

/// The last integrated particles watched for departure from equilibrium: far enough ahead of the
/// held particle that a disturbance crossing the watch within one step is seen before it reaches
/// the held particle (a solitary wave of the δ^{3/2} law spans about five particles).
pub const WATCH: usize = 8;

/// A watched particle counts as moving once its displacement from equilibrium exceeds this
/// fraction of the absolute tolerance on positions (`atol` times the two-body peak overlap), or its
/// velocity this fraction of that on velocities.
pub const THRESHOLD_FRACTION: f64 = 1e-3;

/// A particle is in static equilibrium when the net force on it is at most this fraction of the
/// forces that balance on it (its contacts' and its weight): round-off of the balance, never a
/// real load, which leaves a fraction of order one (a chain in free fall, a particle out of place).
pub const REST_FRACTION: f64 = 1e-6;

/// How a qualifying run integrates its moving part.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ActivePlan {
    /// Initial number of integrated particles.
    k0: usize,
    /// Displacement from equilibrium (m) and velocity (m/s) at which a watched particle moves.
    threshold_x: f64,
    threshold_v: f64,
    /// Force of the wall at equilibrium, N (the rate of the wall impulse while the far end rests).
    wall_force: f64,
}

/// The plan of a run of `scene` on its built `chain` from `y0`, or `None` when it does not qualify.
pub(crate) fn plan(
    scene: &Scene,
    chain: &Chain,
    scales: &ImpactScales,
    y0: &[f64],
) -> Option<ActivePlan> {
    let options = scene.integrator.adaptive_options()?;
    let n = chain.n_particles();
    if scene.active_region == ActiveRegion::Off
        || n < MIN_PARTICLES
        || chain.precompression_force_n != 0.0
        || chain.has_plasticity()
        || chain.ring
        || chain.top_wall_m.is_some()
        || chain.drive.is_some()
        || chain.wall_mount.is_some()
    {
        return None;
    }
    let k0 = INITIAL_PARTICLES;
    if y0[..n] != chain.equilibrium_position[..] || y0[n + 1..].iter().any(|&v| v != 0.0) {
        return None;
    }
    let mut dy = vec![0.0; y0.len()];
    crate::dispatch_chain_system!(chain, |sys| OdeSystem::rhs(&mut sys, 0.0, y0, &mut dy));
    if !at_rest(chain, &dy, k0) {
        return None;
    }
    Some(ActivePlan {
        k0,
        threshold_x: THRESHOLD_FRACTION * options.atol() * scales.overlap_m,
        threshold_v: THRESHOLD_FRACTION * options.atol() * scales.velocity_m_s,
        wall_force: chain.wall_impulse_index().map_or(0.0, |w| dy[w]),
    })
}

/// Whether a run of `scene` integrates only the moving part of its chain (the test [`plan`] makes
/// when the run starts). Such a run agrees with the whole chain's within the run's tolerance but not
/// in its last digits, so the runner makes this part of the run's identity: results stored by
/// versions that integrated the whole chain are recomputed rather than mixed with new ones.
/// `false` for a scene that does not validate.
pub fn integrates_moving_part(scene: &Scene) -> bool {
    if scene.active_region == ActiveRegion::Off || scene.integrator.adaptive_options().is_none() {
        return false;
    }
    let Ok(chain) = scene.validate() else {
        return false;
    };
    integrates_moving_part_of(scene, &chain)
}

/// [`integrates_moving_part`] of a scene whose chain the caller has built already (`chain`:
/// `scene.validate()`'s), which spares building it again (expanding a grid of ten million points,
/// say).
pub fn integrates_moving_part_of(scene: &Scene, chain: &Chain) -> bool {
    if scene.active_region == ActiveRegion::Off
        || scene.integrator.adaptive_options().is_none()
        || chain.n_particles() < MIN_PARTICLES
    {
        return false;
    }
    let scales = scene.impact_scales(chain);
    let y0 = scene.initial_state(chain);
    plan(scene, chain, &scales, &y0).is_some()
}

/// Whether the particles from `k0` on, whose accelerations at the initial state are `dy[N..2N]`,
/// start in static equilibrium ([`REST_FRACTION`]); their velocities are checked by the caller.
fn at_rest(chain: &Chain, dy: &[f64], k0: usize) -> bool {
    let n = chain.n_particles();
    let contact = |c: usize| chain.static_force(c).abs();
    (k0..n).all(|i| {
        let mut balanced = chain.mass[i] * chain.gravity_m_s2.abs();
        if i > 0 {
            balanced += contact(i - 1);
        }
        if i < chain.n_contacts() {
            balanced += contact(i);
        }
        chain.mass[i] * dy[n + i].abs() <= REST_FRACTION * balanced
    })
}

/// The first `k` particles of `chain` as a chain of their own: contact `k-1`, against particle `k`
/// at rest, becomes its wall, and positions are measured from particle `k`'s equilibrium position.
/// The equilibrium positions are summed from the static overlaps as the whole chain's are from its
/// wall (not differences of the whole chain's, whose round-off grows with the chain's length and
/// would set the watched particles moving). With `k = N`, the chain itself.
fn prefix_chain(chain: &Chain, k: usize) -> Chain {
    let n = chain.n_particles();
    if k == n {
        return chain.clone();
    }
    debug_assert!(
        !chain.has_plasticity(),
        "plastic chains are integrated whole"
    );
    let mut equilibrium_position = vec![0.0; k];
    equilibrium_position[k - 1] = chain.static_overlap[k - 1];
    for i in (0..k - 1).rev() {
        equilibrium_position[i] = equilibrium_position[i + 1] + chain.static_overlap[i];
    }
    Chain {
        mass: chain.mass[..k].to_vec(),
        kind: chain.kind[..k].to_vec(),
        shape: chain.shape[..k].to_vec(),
        stiffness: chain.stiffness[..k].to_vec(),
        exponent: chain.exponent[..k].to_vec(),
        damping: chain.damping[..k].to_vec(),
        viscoelastic_damping: chain.viscoelastic_damping[..k].to_vec(),
        hunt_crossley_damping: chain.hunt_crossley_damping[..k].to_vec(),
        tsuji_damping: chain.tsuji_damping[..k].to_vec(),
        gravity_m_s2: chain.gravity_m_s2,
        wall: true,
        ring: false,
        top_wall_m: None,
        clip_tensile: chain.clip_tensile,
        striker: chain.striker,
        precompression_force_n: chain.precompression_force_n,
        force_pulse: chain.force_pulse,
        // Never driven: driven chains are integrated whole (see `plan`).
        drive: None,
        static_overlap: chain.static_overlap[..k].to_vec(),
        equilibrium_position,
        cell_length_m: chain.cell_length_m,
        materials: chain.materials[..k].to_vec(),
        // Never plastic: chains with Thornton's contacts are integrated whole (see `plan`).
        plasticity: Vec::new(),
        // Never mounted: chains on a mounted wall are integrated whole (see `plan`).
        wall_mount: None,
    }
}

/// Where each component of the whole chain's state comes from while the prefix `[0, k)` is
/// integrated.
#[derive(Debug, Clone, Copy)]
struct StateMap {
    n: usize,
    k: usize,
    /// Added to the prefix's positions.
    shift: f64,
    /// Dissipated work: (whole, prefix) indices; no prefix index: constant (nothing dissipates).
    work: Option<(usize, Option<usize>)>,
    /// Wall impulse: (whole, prefix) indices; no prefix index: it grows at the equilibrium wall
    /// force from its value at `wall_since`.
    wall: Option<(usize, Option<usize>)>,
    wall_since: (f64, f64),
    wall_force: f64,
    /// Work of the force pulse: (whole, prefix) indices.
    pulse: Option<(usize, usize)>,
}

/// Where a component of the whole chain's state comes from during a step of the prefix.
#[derive(Debug, Clone, Copy)]
enum Source {
    /// A position in the prefix: its component, shifted ([`StateMap::shift`]).
    Shifted(usize),
    /// The prefix's component as it is (a velocity, or a quadrature the prefix keeps).
    Prefix(usize),
    /// A value the step does not change (a particle at rest, or what nothing adds to).
    Fixed(f64),
    /// The wall impulse while the wall is not in the prefix: it grows at the equilibrium wall
    /// force.
    WallRamp,
}

impl StateMap {
    fn new(chain: &Chain, sub: &Chain, k: usize, t: f64, full: &[f64], wall_force: f64) -> Self {
        let n = chain.n_particles();
        let whole = k == n;
        let wall = chain.wall_impulse_index();
        StateMap {
            n,
            k,
            shift: if whole {
                0.0
            } else {
                chain.equilibrium_position[k]
            },
            work: chain.work_index().map(|w| (w, sub.work_index())),
            wall: wall.map(|w| (w, whole.then_some(w))),
            wall_since: (t, wall.map_or(0.0, |w| full[w])),
            wall_force,
            pulse: chain.external_work_index().map(|w| {
                (
                    w,
                    sub.external_work_index()
                        .expect("the prefix keeps the pulse"),
                )
            }),
        }
    }

    /// The prefix's state, taken from the whole chain's `full` (positions shifted; see
    /// [`integrate`] for the positions of a grown prefix).
    fn prefix_state(&self, sub: &Chain, full: &[f64]) -> Vec<f64> {
        let (n, k) = (self.n, self.k);
        let mut y = vec![0.0; sub.state_len()];
        for i in 0..k {
            y[i] = full[i] - self.shift;
        }
        y[k..2 * k].copy_from_slice(&full[n..n + k]);
        if let Some((w, Some(s))) = self.work {
            y[s] = full[w];
        }
        if let Some((w, Some(s))) = self.wall {
            y[s] = full[w];
        }
        if let Some((w, s)) = self.pulse {
            y[s] = full[w];
        }
        y
    }

    /// Where component `i` of the whole chain's state comes from during a step of the prefix
    /// (`full`: the whole state, which holds the resting particles).
    #[inline]
    fn source(&self, i: usize, full: &[f64]) -> Source {
        let (n, k) = (self.n, self.k);
        if i < n {
            return if i < k {
                Source::Shifted(i)
            } else {
                Source::Fixed(full[i])
            };
        }
        if i < 2 * n {
            return if i - n < k {
                Source::Prefix(k + i - n)
            } else {
                Source::Fixed(0.0)
            };
        }
        if let Some((w, s)) = self.work {
            if i == w {
                return s.map_or(Source::Fixed(full[i]), Source::Prefix);
            }
        }
        if let Some((w, s)) = self.wall {
            if i == w {
                return s.map_or(Source::WallRamp, Source::Prefix);
            }
        }
        match self.pulse {
            Some((w, s)) if i == w => Source::Prefix(s),
            _ => Source::Fixed(full[i]),
        }
    }

    /// The value at `t` of a component that comes from `source`, given the prefix's component
    /// it names (`sub`, asked only for the prefix's components).
    #[inline]
    fn at(&self, source: Source, t: f64, sub: impl FnOnce(usize) -> f64) -> f64 {
        match source {
            Source::Shifted(j) => sub(j) + self.shift,
            Source::Prefix(j) => sub(j),
            Source::Fixed(v) => v,
            Source::WallRamp => self.wall_since.1 + self.wall_force * (t - self.wall_since.0),
        }
    }

    /// Component `i` of the whole chain's state at `t`, from the prefix's components `sub` and the
    /// whole state `full` (which holds the resting particles).
    #[inline]
    fn value(&self, i: usize, t: f64, sub: impl FnOnce(usize) -> f64, full: &[f64]) -> f64 {
        self.at(self.source(i, full), t, sub)
    }

    /// Writes the prefix's state `y` at `t` into the whole chain's `full`.
    fn update(&self, t: f64, y: &[f64], full: &mut [f64]) {
        let (n, k) = (self.n, self.k);
        for i in 0..k {
            full[i] = y[i] + self.shift;
        }
        full[n..n + k].copy_from_slice(&y[k..2 * k]);
        for q in 2 * n..full.len() {
            let value = self.value(q, t, |j| y[j], full);
            full[q] = value;
        }
    }
}

/// The whole chain's view of a step of the prefix.
struct WholeStep<'a> {
    step: &'a dyn DenseStep,
    map: &'a StateMap,
    full: &'a [f64],
}

impl DenseStep for WholeStep<'_> {
    fn t_start(&self) -> f64 {
        self.step.t_start()
    }
    fn t_end(&self) -> f64 {
        self.step.t_end()
    }
    fn y_end(&self) -> &[f64] {
        self.full
    }
    fn eval_component(&self, t: f64, i: usize) -> f64 {
        self.map
            .value(i, t, |j| self.step.eval_component(t, j), self.full)
    }
    /// The prefix step's enclosure, shifted as its values are (a sum rounds monotonically, so
    /// the shifted bounds enclose the shifted values); a particle at rest is its one value.
    fn component_range(&self, i: usize) -> Option<(f64, f64)> {
        match self.map.source(i, self.full) {
            Source::Shifted(j) => self
                .step
                .component_range(j)
                .map(|(lo, hi)| (lo + self.map.shift, hi + self.map.shift)),
            Source::Prefix(j) => self.step.component_range(j),
            Source::Fixed(v) => Some((v, v)),
            Source::WallRamp => None,
        }
    }
    fn eval_components(&self, t: f64, indices: &[usize], out: &mut [f64]) {
        if indices.len() > BATCH_COMPONENTS {
            return eval_each(self, t, indices, out);
        }
        let mut row = [0.0f64; BATCH_COMPONENTS];
        let row = &mut row[..indices.len()];
        self.eval_components_at(&[t], indices, row);
        for (&i, &v) in indices.iter().zip(row.iter()) {
            out[i] = v;
        }
    }
    /// The prefix's components among `indices` interpolated by the prefix's step in one call
    /// for a batch of times (its batched interpolant: the probes' samples cost what they cost
    /// when the whole chain is integrated), the others from the whole state; each value is the
    /// one [`DenseStep::eval_component`] gives.
    fn eval_components_at(&self, times: &[f64], indices: &[usize], out: &mut [f64]) {
        let m = indices.len();
        if m == 0 || m > BATCH_COMPONENTS {
            return eval_each_at(self, times, indices, out);
        }
        let mut sources = [Source::Fixed(0.0); BATCH_COMPONENTS];
        let mut in_prefix = [0usize; BATCH_COMPONENTS];
        let mut p = 0;
        for (source, &i) in sources.iter_mut().zip(indices) {
            *source = self.map.source(i, self.full);
            if let Source::Shifted(j) | Source::Prefix(j) = *source {
                in_prefix[p] = j;
                p += 1;
            }
        }
        let (sources, in_prefix) = (&sources[..m], &in_prefix[..p]);
        let count = times.len().min(out.len() / m);
        if p > 0 {
            self.step
                .eval_components_at(&times[..count], in_prefix, &mut out[..count * p]);
        }
        if p == m {
            // Every component read is integrated (a force probe's once the prefix holds its
            // particles, say), so the rows are already in place: only the positions are shifted,
            // the same sum as `StateMap::at`.
            for (c, source) in sources.iter().enumerate() {
                if let Source::Shifted(_) = source {
                    for row in out[..count * m].chunks_exact_mut(m) {
                        row[c] += self.map.shift;
                    }
                }
            }
            return;
        }
        // Otherwise the prefix's values, `p` a row, are packed at the start of `out`; each row is
        // spread out to its `m` columns, the last row first: a value is read before its place is
        // written (row `r`'s prefix values start at `r·p ≤ r·m`).
        for r in (0..count).rev() {
            let t = times[r];
            let mut q = p;
            for c in (0..m).rev() {
                let source = sources[c];
                out[r * m + c] = self.map.at(source, t, |_| {
                    q -= 1;
                    out[r * p + q]
                });
            }
        }
    }
}

/// Feeds the run's observer with the whole chain's view and asks for a larger prefix once a watched
/// particle moves.
struct PrefixObserver<'a> {
    inner: &'a mut RunObserver,
    map: StateMap,
    full: &'a mut Vec<f64>,
    /// Equilibrium positions of the watched particles in the prefix's coordinates.
    watched_rest: Vec<f64>,
    threshold_x: f64,
    threshold_v: f64,
    grow: bool,
    /// The prefix's state at the end of the last accepted step.
    last: Vec<f64>,
    /// The size of the last accepted step, s.
    last_step_s: Option<f64>,
}

impl StepObserver for PrefixObserver<'_> {
    fn on_start(&mut self, t0: f64, _y0: &[f64]) {
        self.inner.on_start(t0, self.full);
    }

    fn on_step(&mut self, step: &dyn DenseStep) -> Control {
        let y = step.y_end();
        self.map.update(step.t_end(), y, self.full);
        self.last.copy_from_slice(y);
        self.last_step_s = Some(step.t_end() - step.t_start());
        let control = self.inner.on_step(&WholeStep {
            step,
            map: &self.map,
            full: self.full,
        });
        let k = self.map.k;
        if control == Control::Stop || k == self.map.n {
            return control;
        }
        let first = k - WATCH;
        let moving = (first..k).any(|i| {
            (y[i] - self.watched_rest[i - first]).abs() > self.threshold_x
                || y[k + i].abs() > self.threshold_v
        });
        if moving {
            self.grow = true;
            return Control::Stop;
        }
        Control::Continue
    }
}

/// Makes the run's integrator for a chain (the moving part), with the first step to take when given.
pub(crate) type BuildIntegrator<'a> = dyn Fn(&Chain, Option<f64>) -> Box<dyn Integrator> + 'a;

/// Integrates a qualifying run ([`plan`]) over its legs (as [`crate::scene::solve::run`] does for the
/// whole chain), growing the integrated prefix as the front approaches its end. Returns the
/// statistics summed over every start of the integrator and the number of particles integrated at
/// the end.
#[allow(clippy::too_many_arguments)]
pub(crate) fn integrate(
    plan: &ActivePlan,
    build: &BuildIntegrator,
    chain: &Chain,
    t0: f64,
    y0: &[f64],
    leg_ends: &[f64],
    max_steps: u64,
    observer: &mut RunObserver,
) -> Result<(IntegrationStats, usize), IntegrateError> {
    let n = chain.n_particles();
    let mut k = plan.k0.min(n);
    let mut full = y0.to_vec();
    let mut total = IntegrationStats::default();
    let mut t = t0;
    let mut leg = 0;
    observer.set_active(k, &full);
    // The prefix's state: the initial state (the equilibrium) in its own coordinates.
    let mut sub = prefix_chain(chain, k);
    let mut y_sub = {
        let map = StateMap::new(chain, &sub, k, t, &full, plan.wall_force);
        let mut y = map.prefix_state(&sub, &full);
        if k < n {
            y[..k].copy_from_slice(&sub.equilibrium_position);
        }
        y
    };
    let mut h_start = None;
    while leg < leg_ends.len() {
        let t_leg = leg_ends[leg];
        let map = StateMap::new(chain, &sub, k, t, &full, plan.wall_force);
        let integrator = build(&sub, h_start.take());
        let watched_rest = if k < n {
            sub.equilibrium_position[k - WATCH..k].to_vec()
        } else {
            Vec::new()
        };
        let mut obs = PrefixObserver {
            inner: observer,
            map,
            full: &mut full,
            watched_rest,
            threshold_x: plan.threshold_x,
            threshold_v: plan.threshold_v,
            grow: false,
            last: y_sub.clone(),
            last_step_s: None,
        };
        // Accepted and rejected attempts both count against the budget, as for the whole chain.
        let budget = max_steps.saturating_sub(total.attempts());
        let stats = crate::dispatch_chain_system!(&sub, |sys| integrator
            .integrate(&mut sys, t, &y_sub, t_leg, budget, &mut obs))
        .map_err(|e| match e {
            IntegrateError::StepBudget { t, .. } => IntegrateError::StepBudget { max_steps, t },
            other => other,
        })?;
        let (grow, last, last_step_s) = (obs.grow, obs.last, obs.last_step_s);
        total.add(&stats);
        if observer.stopped || total.attempts() >= max_steps {
            break;
        }
        t = observer.t_reached;
        y_sub = last;
        if grow {
            // The grown part goes on at the step size the front's motion had set: the particles
            // joining it rest, so they do not ask for a smaller one, and choosing afresh would
            // start from a guess the controller must first grow out of.
            h_start = last_step_s;
            let k_old = k;
            k = (k + BLOCK).min(n);
            observer.set_active(k, &full);
            sub = prefix_chain(chain, k);
            let map = StateMap::new(chain, &sub, k, t, &full, plan.wall_force);
            let mut y = map.prefix_state(&sub, &full);
            if k < n {
                // The old prefix's positions are measured from particle `k_old` at rest, which sits
                // at its equilibrium in the new prefix's coordinates; the particles joining rest.
                let origin = sub.equilibrium_position[k_old];
                for i in 0..k_old {
                    y[i] = y_sub[i] + origin;
                }
                y[k_old..k].copy_from_slice(&sub.equilibrium_position[k_old..k]);
            }
            y_sub = y;
        }
        if !grow || t >= t_leg {
            leg += 1;
            t = t_leg;
        }
    }
    Ok((total, k))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A step whose component `j` is the polynomial `j + (j + 1) t + t²` over `[0, 1e-6]`.
    struct Polynomials {
        end: Vec<f64>,
    }

    impl DenseStep for Polynomials {
        fn t_start(&self) -> f64 {
            0.0
        }
        fn t_end(&self) -> f64 {
            1e-6
        }
        fn y_end(&self) -> &[f64] {
            &self.end
        }
        fn eval_component(&self, t: f64, j: usize) -> f64 {
            j as f64 + (j as f64 + 1.0) * t + t * t
        }
    }

    #[test]
    fn the_batched_whole_state_is_component_for_component_the_single_one() {
        // A chain of 40 particles of which 24 are integrated, with its dissipated work and wall
        // impulse (the wall not in the prefix: it grows at the equilibrium wall force).
        let (n, k) = (40, 24);
        let map = StateMap {
            n,
            k,
            shift: 3.5e-5,
            work: Some((2 * n, Some(2 * k))),
            wall: Some((2 * n + 1, None)),
            wall_since: (2e-7, 1e-3),
            wall_force: 12.0,
            pulse: None,
        };
        let full: Vec<f64> = (0..2 * n + 2).map(|i| 1e-4 * i as f64 - 0.5).collect();
        let prefix = Polynomials {
            end: vec![0.0; 2 * k + 1],
        };
        let whole = WholeStep {
            step: &prefix,
            map: &map,
            full: &full,
        };
        let times: Vec<f64> = (0..37).map(|r| r as f64 * 2.7e-8).collect();
        // (The second and third: every component the prefix's, whose batch is not spread again,
        // the third with components repeated. The last two: more components than a batch holds,
        // and none.)
        let sets: [Vec<usize>; 8] = [
            vec![3, 4, n + 3, n + 4, 2 * n + 1],
            vec![n + 3, 3, 2 * n, k - 1, n + k - 1, 0],
            vec![3, 3, n + 3, 3, 0, n + 3],
            vec![k - 1, k, n + k - 1, n + k, 2 * n],
            vec![30, 31, n + 30],
            (0..2 * n + 2).step_by(5).collect(),
            (0..2 * n + 2).collect(),
            Vec::new(),
        ];
        for indices in &sets {
            let m = indices.len();
            let mut batched = vec![f64::NAN; times.len() * m];
            whole.eval_components_at(&times, indices, &mut batched);
            for (r, &t) in times.iter().enumerate() {
                for (c, &i) in indices.iter().enumerate() {
                    let single = whole.eval_component(t, i);
                    assert_eq!(
                        batched[r * m + c].to_bits(),
                        single.to_bits(),
                        "component {i} at {t:e} of {indices:?}"
                    );
                }
            }
            let mut at_once = vec![f64::NAN; full.len()];
            whole.eval_components(times[5], indices, &mut at_once);
            for &i in indices {
                assert_eq!(
                    at_once[i].to_bits(),
                    whole.eval_component(times[5], i).to_bits()
                );
            }
        }
        // The sources themselves: a shifted position, a resting one, a resting velocity, the ramp.
        let t = 5e-7;
        assert_eq!(whole.eval_component(t, 3), 3.0 + 4.0 * t + t * t + 3.5e-5);
        assert_eq!(whole.eval_component(t, 30), full[30]);
        assert_eq!(whole.eval_component(t, n + 30), 0.0);
        assert_eq!(whole.eval_component(t, 2 * n + 1), 1e-3 + 12.0 * (t - 2e-7));
    }
}
