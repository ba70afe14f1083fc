//! The equations of motion of a chain with Thornton's elastic–plastic contacts (see
//! [`crate::contact::Thornton`]): a right-hand side of its own, so that no other chain pays for
//! the history. Every other contact of such a chain takes the general law
//! ([`crate::contact::general_force`], any exponent, every dissipation model).
//!
//! State `[x (N), v (N), q, h]`: the quadratures of [`crate::motion::general::GeneralChainSystem`]
//! (dissipated work when any contact dissipates, wall impulse, work of the force pulse), then two
//! histories per plastic contact ([`crate::chain::model::Chain::history_index`]): the gap
//! `g = s − δ` between its largest overlap and the present one, which the law reads, and the
//! opening distance `o = δ − δ_p(s)` to its residual indentation. The gap stays exactly zero
//! while the contact loads on the plastic line, so the largest overlap is never compared with the
//! overlap it tracks. Its switching functions, each linear in the state, are `g` (first yield,
//! reloading past the largest overlap), `o` (opening and closing at the residual indentation,
//! where the force is `∝ (δ − δ_p)^{3/2}` as Hertz's is at zero) and the contact's relative
//! velocity (the turn from plastic loading to unloading), so that the adaptive integrators put
//! step boundaries where the law changes branch.

use crate::chain::model::{Chain, ContactEnds};
use crate::contact::{general_derivatives, general_force, ContactParams, Thornton, POWER};
use crate::integrate::{OdeSystem, Switch, Tridiagonal};
use crate::motion::{DriveTerm, MountTerm};

/// Right-hand side of a chain with elastic–plastic contacts.
#[derive(Debug, Clone)]
pub struct PlasticChainSystem {
    inv_mass: Vec<f64>,
    /// General law and dissipation of each contact (unused for the plastic ones).
    params: Vec<ContactParams>,
    /// Thornton's law and the index of its history in the state, per contact.
    plastic: Vec<Option<(Thornton, usize)>>,
    /// The plastic contacts, in order: `(contact, history index)`.
    histories: Vec<(usize, usize)>,
    /// What each contact joins.
    ends: Vec<ContactEnds>,
    damped: bool,
    gravity: f64,
    /// Whether a wall holds either end (the state then carries the walls' impulse).
    walls: bool,
    clip: bool,
    top: usize,
    precompression: f64,
    /// Half-sine pulse: amplitude (N), π/duration (1/s), duration (s); zero amplitude: none.
    pulse: (f64, f64, f64),
    force: Vec<f64>,
    switches: Vec<Switch>,
    /// A boundary drive, when there is one.
    drive: Option<DriveTerm>,
    /// The mount of the wall under the chain, when it has one.
    mount: Option<MountTerm>,
}

impl PlasticChainSystem {
    /// Builds the system of a chain with at least one plastic contact.
    pub fn new(chain: &Chain) -> Self {
        assert!(
            chain.has_plasticity(),
            "PlasticChainSystem needs a plastic contact"
        );
        let n = chain.n_particles();
        let m = chain.n_contacts();
        let params = (0..m).map(|c| chain.contact_params(c)).collect();
        let mut plastic = vec![None; m];
        let mut histories = Vec::new();
        let ends: Vec<ContactEnds> = (0..m).map(|c| chain.contact_ends(c)).collect();
        let mut switches: Vec<Switch> = ends.iter().map(crate::motion::contact_switch).collect();
        for (c, t, h) in chain.plastic_contacts() {
            plastic[c] = Some((t, h));
            histories.push((c, h));
            switches.push(Switch::between(h, None));
            switches.push(Switch::between(h + 1, None));
            // The overlap's rate (its sign only matters): a wall's side at rest, or moving at
            // the velocity the state holds beside its displacement.
            let e = ends[c];
            let wall_velocity = e.wall_state.map(|w| w + 1);
            let (plus, minus) = match (e.above, e.below) {
                (Some(a), b) => (n + a, b.map(|b| n + b).or(wall_velocity)),
                (None, b) => (n + b.expect("a particle"), wall_velocity),
            };
            switches.push(Switch::between(plus, minus));
        }
        let pulse = match chain.force_pulse {
            Some((amplitude, duration)) => (amplitude, std::f64::consts::PI / duration, duration),
            None => (0.0, 0.0, 0.0),
        };
        PlasticChainSystem {
            inv_mass: chain.mass.iter().map(|m| 1.0 / m).collect(),
            params,
            plastic,
            histories,
            ends,
            damped: chain.has_damping(),
            gravity: chain.gravity_m_s2,
            walls: chain.has_walls(),
            clip: chain.clip_tensile,
            top: chain.first_chain_particle(),
            precompression: chain.top_force_n(),
            pulse,
            force: vec![0.0; m],
            switches,
            drive: DriveTerm::of(chain),
            mount: MountTerm::of(chain),
        }
    }

    /// Overlap and its rate of contact `c` in state `(x, v)`.
    #[inline(always)]
    /// A moving wall's velocity is `wall_velocity` (the waveform's at the time of `y`, see
    /// [`DriveTerm::walls`]), not the state's copy.
    fn kinematics(&self, c: usize, y: &[f64], wall_velocity: f64) -> (f64, f64) {
        let n = self.inv_mass.len();
        let velocity_index = self.drive.as_ref().map(|d| d.work + 2);
        self.ends[c].kinematics(
            |i| y[i],
            |i| y[n + i],
            |i| {
                if Some(i) == velocity_index {
                    wall_velocity
                } else {
                    y[i]
                }
            },
        )
    }
}

impl OdeSystem for PlasticChainSystem {
    fn n_pos(&self) -> usize {
        self.inv_mass.len()
    }

    fn n_quad(&self) -> usize {
        self.damped as usize
            + self.walls as usize
            + (self.pulse.0 != 0.0) as usize
            + self
                .drive
                .as_ref()
                .map_or(0, |d| 2 + d.point.moves_a_wall() as usize)
            + 2 * self.mount.is_some() as usize
            + 2 * self.histories.len()
    }

    fn switches(&self) -> &[Switch] {
        &self.switches
    }

    fn acceleration_jacobian(
        &self,
        t: f64,
        y: &[f64],
        kx: &mut Tridiagonal,
        kv: &mut Tridiagonal,
    ) -> bool {
        let n = self.inv_mass.len();
        let wall_velocity = DriveTerm::at(&self.drive, t).1;
        // Zeroed in place: allocates only if the order differs.
        for m in [&mut *kx, &mut *kv] {
            for part in [&mut m.lower, &mut m.upper] {
                part.clear();
                part.resize(n.saturating_sub(1), 0.0);
            }
            m.diag.clear();
            m.diag.resize(n, 0.0);
        }
        let im = &self.inv_mass;
        for c in 0..self.params.len() {
            let (d, dv) = self.kinematics(c, y, wall_velocity);
            // The plastic law at its present largest overlap (the history held fixed: the
            // linearly implicit method needs only an approximation of the Jacobian).
            let (k, eta) = match self.plastic[c] {
                Some((t, h)) => (t.stiffness(d, y[h]), 0.0),
                None => general_derivatives::<POWER, true, true>(&self.params[c], d, dv, self.clip),
            };
            let e = self.ends[c];
            for i in [e.above, e.below].into_iter().flatten() {
                kx.diag[i] -= k * im[i];
                kv.diag[i] -= eta * im[i];
            }
            // Neighbours couple within the tridiagonal band; a ring's closing contact couples the
            // two ends, outside it, and is left out (a W-method needs only an approximation).
            if let (Some(a), Some(b)) = (e.above, e.below) {
                if b == a + 1 {
                    kx.upper[a] += k * im[a];
                    kx.lower[a] += k * im[b];
                    kv.upper[a] += eta * im[a];
                    kv.lower[a] += eta * im[b];
                }
            }
        }
        true
    }

    fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]) {
        let n = self.inv_mass.len();
        let wave = DriveTerm::at(&self.drive, t);
        let v = &y[n..2 * n];
        let (dx, rest) = dy.split_at_mut(n);
        let (dv, dq) = rest.split_at_mut(n);
        dx.copy_from_slice(v);
        let mut dissipated = 0.0;
        for c in 0..self.params.len() {
            let (d, rate) = self.kinematics(c, y, wave.1);
            self.force[c] = match self.plastic[c] {
                Some((law, h)) => law.force(d, y[h]),
                None => {
                    let (f, p) =
                        general_force::<POWER, true, true>(&self.params[c], d, rate, self.clip);
                    dissipated += p;
                    f
                }
            };
        }
        // Neighbours' contacts first, in the order every other kernel sums them; then the wall
        // under the chain or the ring's closing contact (contact N − 1), then the top wall.
        let m = n - 1;
        let force = &self.force;
        let below = |c: usize| self.ends.get(c).filter(|e| e.below.is_none());
        let wall_force = if below(m).is_some() { force[m] } else { 0.0 };
        let g = self.gravity;
        let im = &self.inv_mass;
        if n == 1 {
            dv[0] = g - wall_force * im[0];
        } else {
            dv[0] = g - force[0] * im[0];
            for i in 1..n - 1 {
                dv[i] = g + (force[i - 1] - force[i]) * im[i];
            }
            dv[n - 1] = g + (force[n - 2] - wall_force) * im[n - 1];
        }
        let mut top_force = 0.0;
        for (e, &f) in self.ends.iter().zip(force).skip(m) {
            match (e.above, e.below) {
                // The ring's closing contact, between particles N and 1.
                (Some(a), Some(b)) => {
                    dv[a] -= f * im[a];
                    dv[b] += f * im[b];
                }
                (None, Some(b)) => {
                    dv[b] += f * im[b];
                    top_force = f;
                }
                _ => {}
            }
        }
        let wall_force = wall_force - top_force;
        let (amplitude, omega, duration) = self.pulse;
        let pulse = if amplitude != 0.0 && t < duration {
            amplitude * (omega * t).sin()
        } else {
            0.0
        };
        let drive_force = self.drive.as_ref().map_or(0.0, |d| d.force(wave));
        let external = self.precompression + pulse + drive_force;
        if external != 0.0 {
            dv[self.top] += external * im[self.top];
        }
        if let Some(mount) = &self.mount {
            let base_force = if below(m).is_some() { force[m] } else { 0.0 };
            dissipated += mount.rates(y, base_force, dq, 2 * n);
        }
        let mut k = 0;
        if self.damped {
            dq[k] = dissipated;
            k += 1;
        }
        if self.walls {
            dq[k] = wall_force;
            k += 1;
        }
        if amplitude != 0.0 {
            dq[k] = pulse * v[self.top];
        }
        if let Some(d) = &self.drive {
            let base_force = if below(m).is_some() { force[m] } else { 0.0 };
            d.rates(wave, v[self.top], top_force, -base_force, dq, 2 * n);
        }
        for &(c, h) in &self.histories {
            let (d, rate) = self.kinematics(c, y, wave.1);
            let law = self.plastic[c].expect("a plastic contact").0;
            dy[h] = Thornton::gap_rate(rate, y[h]);
            dy[h + 1] = law.opening_rate(d, rate, y[h]);
        }
    }
}
