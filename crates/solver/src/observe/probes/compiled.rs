//! Probes compiled against a chain ([`ProbeSet`]): each probe reduced to the state components
//! and constants it reads, and its value computed by the same contact laws as the equations of
//! motion. Apart from the specification because it knows the chain's arrays and the contact
//! kernels, which a scene as written does not.

use crate::chain::model::{Chain, ContactMap};
use crate::contact::{
    general_force, hertz_force, paper_contact_force, ContactParams, Damping, Thornton, POWER,
};

use super::{Preload, Probe};

/// A probe compiled against a chain: state indices and constants.
#[derive(Debug, Clone, Copy)]
enum Compiled {
    /// Mean of `n` contact forces starting at contact index `first` (n = 1 or 2).
    Contacts {
        first: usize,
        count: usize,
        /// `1/count`, exact for a count of 1 or 2: multiplying by it gives the quotient's bits
        /// without a division's latency on every probe sample.
        inv_count: f64,
        offset: f64,
    },
    Overlap {
        contact: usize,
    },
    Displacement {
        index: usize,
        origin: f64,
    },
    Velocity {
        index: usize,
    },
    /// A mounted wall's force on the ground, `offset + k u + c w` (`u` at `index`, `w` after it).
    Mount {
        index: usize,
        offset: f64,
        stiffness: f64,
        damping: f64,
    },
}

/// Exponents, viscoelastic, Hunt–Crossley and (when any contact has it) Tsuji coefficients.
type GeneralLaws = (Vec<f64>, Vec<f64>, Vec<f64>, Option<Vec<f64>>);

/// Evaluates probes from a dense step or a state.
#[derive(Debug, Clone)]
pub(crate) struct ProbeSet {
    compiled: Vec<Compiled>,
    stiffness: Vec<f64>,
    damping: Vec<f64>,
    /// Exponents and the viscoelastic, Hunt–Crossley and (when any) Tsuji coefficients, for
    /// chains that are not the paper's physics.
    general: Option<GeneralLaws>,
    /// Thornton's law and the index of its history, per contact, when any contact has it.
    plastic: Option<Vec<Option<(Thornton, usize)>>>,
    clip: bool,
    /// What each contact joins.
    contacts: ContactMap,
    /// Reference scale of each probe for leading-pulse detection.
    pub scale: Vec<f64>,
}

impl ProbeSet {
    pub fn new(
        chain: &Chain,
        probes: &[Probe],
        preload: Preload,
        force_scale: f64,
        velocity_scale: f64,
        length_scale: f64,
    ) -> Self {
        let n = chain.n_particles();
        let static_mean = |first: usize, count: usize| -> f64 {
            (first..first + count)
                .map(|c| chain.static_force(c))
                .sum::<f64>()
                / count as f64
        };
        let mut compiled = Vec::new();
        let mut scale = Vec::new();
        let cylinders = chain.cylinders();
        for p in probes {
            let (c, s) = match *p {
                Probe::GaugeForce { cylinder } => (cylinders[cylinder - 1] - 1, 2),
                Probe::ParticleForce { particle } => (particle - 2, 2),
                Probe::ContactForce { contact } => (contact - 1, 1),
                Probe::WallForce => (n - 1, 1),
                Probe::Overlap { contact } => {
                    compiled.push(Compiled::Overlap {
                        contact: contact - 1,
                    });
                    scale.push(length_scale);
                    continue;
                }
                Probe::Displacement { particle } => {
                    compiled.push(Compiled::Displacement {
                        index: particle - 1,
                        origin: chain.equilibrium_position[particle - 1],
                    });
                    scale.push(length_scale);
                    continue;
                }
                Probe::Velocity { particle } => {
                    compiled.push(Compiled::Velocity {
                        index: n + particle - 1,
                    });
                    scale.push(velocity_scale);
                    continue;
                }
                Probe::MountDisplacement => {
                    compiled.push(Compiled::Displacement {
                        index: chain.mount_state_index().expect("validated: a mount"),
                        origin: 0.0,
                    });
                    scale.push(length_scale);
                    continue;
                }
                Probe::MountForce => {
                    let mount = chain.wall_mount.expect("validated: a mount");
                    compiled.push(Compiled::Mount {
                        index: chain.mount_state_index().expect("a mount"),
                        offset: match preload {
                            Preload::Include => chain.static_force(n - 1),
                            Preload::Subtract => 0.0,
                        },
                        stiffness: mount.stiffness_n_m,
                        damping: mount.damping_kg_s,
                    });
                    scale.push(force_scale);
                    continue;
                }
            };
            let offset = match preload {
                Preload::Include => 0.0,
                Preload::Subtract => static_mean(c, s),
            };
            debug_assert!(s == 1 || s == 2, "a probe averages one or two contacts");
            compiled.push(Compiled::Contacts {
                first: c,
                count: s,
                inv_count: 1.0 / s as f64,
                offset,
            });
            scale.push(force_scale);
        }
        ProbeSet {
            compiled,
            stiffness: chain.stiffness.clone(),
            damping: chain.damping.clone(),
            general: (!chain.is_paper_physics()).then(|| {
                (
                    chain.exponent.clone(),
                    chain.viscoelastic_damping.clone(),
                    chain.hunt_crossley_damping.clone(),
                    chain
                        .has_tsuji_damping()
                        .then(|| chain.tsuji_damping.clone()),
                )
            }),
            plastic: chain.has_plasticity().then(|| {
                let mut laws = vec![None; chain.n_contacts()];
                for (c, t, h) in chain.plastic_contacts() {
                    laws[c] = Some((t, h));
                }
                laws
            }),
            clip: chain.clip_tensile,
            contacts: ContactMap::of(chain),
            scale,
        }
    }

    pub fn len(&self) -> usize {
        self.compiled.len()
    }

    /// The state components the probes read, sorted, each once.
    pub(crate) fn components(&self) -> Vec<usize> {
        let mut read: Vec<usize> = (0..self.len())
            .flat_map(|k| self.components_of(k))
            .collect();
        read.sort_unstable();
        read.dedup();
        read
    }

    /// The state components probe `k` reads, sorted, each once.
    pub(crate) fn components_of(&self, k: usize) -> Vec<usize> {
        let read = std::cell::RefCell::new(Vec::new());
        let get = |i: usize| {
            read.borrow_mut().push(i);
            0.0
        };
        self.value(k, &get);
        let mut read = read.into_inner();
        read.sort_unstable();
        read.dedup();
        read
    }

    /// An upper bound of every value probe `k` takes, as computed by [`ProbeSet::value`], while
    /// each component `i` it reads stays within `range(i)` (as computed values); `None` for the
    /// probes it is not derived for. Derived for the force probes of the paper's law between
    /// neighbours, whose every operation is monotone in the overlap and the rate (IEEE rounding
    /// is monotone too, so the bound holds for the rounded values): the elastic term grows with
    /// the overlap, the viscous term `μ Δv` (`μ ≥ 0`) with the rate while compressed and is
    /// absent while open, and clipping at zero only lowers a value.
    pub(crate) fn upper_bound(
        &self,
        k: usize,
        range: &impl Fn(usize) -> Option<(f64, f64)>,
    ) -> Option<f64> {
        let Compiled::Contacts {
            first,
            count,
            inv_count,
            offset,
        } = self.compiled[k]
        else {
            return None;
        };
        if self.general.is_some() || self.plastic.is_some() {
            return None;
        }
        let mut s = 0.0;
        for c in first..first + count {
            let ([above, below], [v_above, v_below]) = self.contacts.between(c)?;
            let (a, mu) = (self.stiffness[c], self.damping[c]);
            let ((_, above_hi), (below_lo, _)) = (range(above)?, range(below)?);
            let elastic = hertz_force(a, (above_hi - below_lo).max(0.0));
            s += if mu == 0.0 {
                elastic
            } else {
                let ((_, above_hi), (below_lo, _)) = (range(v_above)?, range(v_below)?);
                (elastic + mu * (above_hi - below_lo)).max(0.0)
            };
        }
        Some(s * inv_count - offset)
    }

    /// Force of contact `c`, by the same law as the equations of motion. A contact without
    /// damping is read from its overlap alone: its dissipative terms are zeros added to the
    /// elastic force, which leave it as it is, so its rate is neither read nor interpolated at
    /// every sample.
    #[inline]
    fn contact_force(&self, c: usize, get: &impl Fn(usize) -> f64) -> f64 {
        let Some((p, tsuji)) = self.general_params(c) else {
            let (a, mu) = (self.stiffness[c], self.damping[c]);
            if mu == 0.0 {
                let overlap = self.contacts.overlap_read(c, get);
                return if self.clip {
                    paper_contact_force::<false, true>(a, mu, overlap, 0.0).0
                } else {
                    paper_contact_force::<false, false>(a, mu, overlap, 0.0).0
                };
            }
            let (overlap, rel) = self.contacts.kinematics(c, get);
            return if self.clip {
                paper_contact_force::<true, true>(a, mu, overlap, rel).0
            } else {
                paper_contact_force::<true, false>(a, mu, overlap, rel).0
            };
        };
        // Thornton's contacts (never in the paper's physics, whose path stays as it was).
        if let Some((law, h)) = self.plastic.as_ref().and_then(|p| p[c].as_ref()) {
            return plastic_force(law, self.contacts.overlap_read(c, get), get(*h));
        }
        if p.damping == Damping::NONE {
            let overlap = self.contacts.overlap_read(c, get);
            return general_force::<POWER, false, false>(&p, overlap, 0.0, self.clip).0;
        }
        let (overlap, rel) = self.contacts.kinematics(c, get);
        if tsuji {
            general_force::<POWER, true, true>(&p, overlap, rel, self.clip).0
        } else {
            general_force::<POWER, true, false>(&p, overlap, rel, self.clip).0
        }
    }

    /// The general law's parameters of contact `c`, and whether the chain's contacts carry
    /// Tsuji's term; `None` in the paper's physics.
    #[inline]
    fn general_params(&self, c: usize) -> Option<(ContactParams, bool)> {
        let (exponent, gamma, lambda, beta) = self.general.as_ref()?;
        let p = ContactParams {
            a: self.stiffness[c],
            n: exponent[c],
            damping: Damping {
                linear: self.damping[c],
                viscoelastic: gamma[c],
                hunt_crossley: lambda[c],
                tsuji: beta.as_ref().map_or(0.0, |b| b[c]),
            },
        };
        Some((p, beta.is_some()))
    }

    /// Value of probe `k` with state components supplied by `get`.
    #[inline]
    pub fn value(&self, k: usize, get: &impl Fn(usize) -> f64) -> f64 {
        match self.compiled[k] {
            Compiled::Contacts {
                first,
                count,
                inv_count,
                offset,
            } => mean_force(first..first + count, inv_count, offset, |c| {
                self.contact_force(c, get)
            }),
            Compiled::Overlap { contact } => self.contacts.overlap_read(contact, get),
            Compiled::Displacement { index, origin } => get(index) - origin,
            Compiled::Velocity { index } => get(index),
            Compiled::Mount {
                index,
                offset,
                stiffness,
                damping,
            } => offset + stiffness * get(index) + damping * get(index + 1),
        }
    }
}

/// A force probe's value: the mean of the forces (`force`) of `contacts`, `inv_count` being one
/// over their number, less `offset` (the static preload, when it is subtracted).
#[inline(always)]
fn mean_force(
    contacts: std::ops::Range<usize>,
    inv_count: f64,
    offset: f64,
    force: impl Fn(usize) -> f64,
) -> f64 {
    let mut s = 0.0;
    for c in contacts {
        s += force(c);
    }
    s * inv_count - offset
}

/// Force of a contact with Thornton's law, kept out of line so that the probes of every other
/// chain compile as they did.
#[inline(never)]
fn plastic_force(law: &Thornton, overlap: f64, gap: f64) -> f64 {
    law.force(overlap, gap)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The force of contact `c` as it was computed before contacts without damping were read
    /// from their overlap alone: the law on the overlap and its rate, both always read.
    fn force_from_overlap_and_rate(probes: &ProbeSet, c: usize, get: impl Fn(usize) -> f64) -> f64 {
        let (overlap, rel) = probes.contacts.kinematics(c, get);
        let clip = probes.clip;
        let Some((p, tsuji)) = probes.general_params(c) else {
            let (a, mu) = (probes.stiffness[c], probes.damping[c]);
            return if clip {
                paper_contact_force::<true, true>(a, mu, overlap, rel).0
            } else {
                paper_contact_force::<true, false>(a, mu, overlap, rel).0
            };
        };
        if tsuji {
            general_force::<POWER, true, true>(&p, overlap, rel, clip).0
        } else {
            general_force::<POWER, true, false>(&p, overlap, rel, clip).0
        }
    }

    /// Without damping a contact's force does not depend on its rate: the force and overlap
    /// probes of an undamped chain read positions only (the sampling loop interpolates no
    /// velocity), those of a damped chain velocities too, and every probe gives, to the bit, the
    /// law evaluated on the contact's overlap and rate — the paper's chain with and without
    /// damping and clipping, and chains under a general law without damping and with each
    /// dissipation model.
    #[test]
    fn force_probes_read_velocities_only_where_damping_acts() {
        use crate::chain::model::{ChainSpec, PhysicsSpec};
        use crate::contact::DissipationSpec;
        use crate::problems::{chain, power_law, repeat, rule, sphere, STEEL};
        let paper = |damping_kg_s: f64, clip_tensile: bool| {
            let physics = PhysicsSpec {
                damping_kg_s,
                clip_tensile,
                ..PhysicsSpec::default()
            };
            let chain = Chain::build(&ChainSpec::chain_055(4), &physics).unwrap();
            (chain, damping_kg_s > 0.0, "the paper's chain")
        };
        let general = |dissipation: Option<DissipationSpec>, clip_tensile: bool| {
            let law = Some(power_law(2e9, 2.0));
            let spec = chain(
                &[("ball", sphere(STEEL, 8e-3, 2.085e-3))],
                vec![repeat(5, "ball")],
                Some("ball"),
                vec![
                    rule("ball", "ball", law, dissipation),
                    rule("ball", "wall", law, dissipation),
                ],
            );
            let physics = PhysicsSpec {
                clip_tensile,
                ..PhysicsSpec::default()
            };
            let chain = Chain::build(&ChainSpec::Sequence(spec), &physics).unwrap();
            assert!(!chain.is_paper_physics());
            (chain, dissipation.is_some(), "a chain under F = A δ²")
        };
        let chains = [
            paper(0.0, false),
            paper(0.0, true),
            paper(6.0, false),
            paper(6.0, true),
            general(None, false),
            general(None, true),
            general(
                Some(DissipationSpec::KuwabaraKono {
                    relaxation_time_s: 1e-6,
                }),
                true,
            ),
            general(
                Some(DissipationSpec::HuntCrossley {
                    restitution: 0.8,
                    impact_velocity_m_s: 1.0,
                }),
                false,
            ),
            general(Some(DissipationSpec::Tsuji { restitution: 0.8 }), false),
        ];
        let cylinder_probes = [
            Probe::GaugeForce { cylinder: 2 },
            Probe::ContactForce { contact: 4 },
            Probe::Overlap { contact: 2 },
            Probe::WallForce,
        ];
        let sphere_probes = [
            Probe::ParticleForce { particle: 3 },
            Probe::ContactForce { contact: 4 },
            Probe::Overlap { contact: 2 },
            Probe::WallForce,
        ];
        for (chain, damped, what) in chains {
            let list = if chain.cylinders().is_empty() {
                &sphere_probes
            } else {
                &cylinder_probes
            };
            let n = chain.n_particles();
            let probes = ProbeSet::new(&chain, list, Preload::Include, 1.0, 1.0, 1.0);
            let velocities = probes
                .components()
                .into_iter()
                .filter(|i| (n..2 * n).contains(i))
                .count();
            let clip = chain.clip_tensile;
            assert_eq!(velocities > 0, damped, "{what}, clip {clip}");
            // Contacts compressed, just touching and open, closing and opening.
            let mut y = chain.initial_state(0.0);
            let overlaps = [2e-6, 0.0, -1e-7, 3e-7, 1e-6];
            let rates = [-0.3, 0.2, -0.0, 1e-3, -2e-3];
            for c in 0..n - 1 {
                y[c + 1] = y[c] - overlaps[c % overlaps.len()];
                y[n + c + 1] = y[n + c] - rates[c % rates.len()];
            }
            let get = |i: usize| y[i];
            for (k, compiled) in probes.compiled.iter().enumerate() {
                let expected = match *compiled {
                    Compiled::Contacts {
                        first,
                        count,
                        inv_count,
                        offset,
                    } => mean_force(first..first + count, inv_count, offset, |c| {
                        force_from_overlap_and_rate(&probes, c, get)
                    }),
                    Compiled::Overlap { contact } => probes.contacts.kinematics(contact, get).0,
                    _ => unreachable!("only force and overlap probes here"),
                };
                let value = probes.value(k, &get);
                assert_eq!(
                    value.to_bits(),
                    expected.to_bits(),
                    "{what}, clip {clip}, probe {}: {value:e} against {expected:e}",
                    list[k].name()
                );
            }
        }
    }
}
