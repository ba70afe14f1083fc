//! How a chain without a striker is set in motion ([`Excitation`]): an impulse, a half-sine force,
//! an initial state of any particles, or a driven boundary. Apart from the scene because the
//! initial state has its own checks and its own random velocities.

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

use crate::chain::drive::DriveSpec;
use crate::chain::model::{spec_err, SpecError};

/// How a chain without a striker is set in motion.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(
    feature = "serde",
    serde(rename_all = "snake_case", deny_unknown_fields)
)]
pub enum Excitation {
    /// A δ-force impulse: particle 1 starts towards the wall at `velocity_m_s`, the rest of the
    /// chain otherwise at its initial state (static equilibrium on a wall, zero overlaps without one;
    /// the excitation of the paper's ref. [20]).
    Impulse {
        /// Initial velocity of particle 1, m/s.
        velocity_m_s: f64,
    },
    /// A prescribed force on particle 1, `F(t) = amplitude sin(π t / duration)` for
    /// `0 ≤ t ≤ duration`, zero after (an actuator's half-sine pulse).
    HalfSineForce {
        /// Peak force, N.
        amplitude_n: f64,
        /// Duration of the pulse, s.
        duration_s: f64,
    },
    /// Any particles moving and/or displaced at `t = 0` from the chain's static state: several
    /// strikers, two chains running into each other, a random state from a seed.
    InitialState(InitialState),
    /// A boundary driven for the whole run: a force on particle 1 (`force_n`), an actuator at the
    /// top (`actuator_m`, the top wall moving) or a moving base (`base_m`), each following a
    /// waveform; static precompression combines with it.
    Drive(DriveSpec),
}

/// Velocities and displacements at `t = 0`, added to the static state (the equilibrium on the
/// wall, or the just-touching chain).
#[derive(Debug, Clone, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct InitialState {
    /// Particles given a velocity and/or a displacement, each at most once.
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Vec::is_empty")
    )]
    pub particles: Vec<ParticleStart>,
    /// Random velocities of every particle, added to those of `particles`.
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Option::is_none")
    )]
    pub random_velocity: Option<RandomVelocity>,
}

/// One particle's velocity and displacement at `t = 0`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct ParticleStart {
    /// The particle, 1 (the top) to N.
    pub particle: usize,
    /// Velocity, m/s, positive towards the wall (down the chain).
    #[cfg_attr(feature = "serde", serde(default))]
    pub velocity_m_s: f64,
    /// Displacement from the static state, m, positive towards the wall.
    #[cfg_attr(feature = "serde", serde(default))]
    pub displacement_m: f64,
}

/// Independent normal velocities of mean zero and standard deviation `rms_m_s` for every
/// particle, drawn from `seed` (the same seed, the same velocities, on any machine).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct RandomVelocity {
    /// Standard deviation of each velocity, m/s.
    pub rms_m_s: f64,
    /// Seed of the generator.
    pub seed: u64,
}

impl InitialState {
    /// Checks the particles and values against a chain of `n` particles; the error names the
    /// field (relative to `excitation.initial_state`).
    pub(super) fn validate(&self, n: usize) -> Result<(), SpecError> {
        let base = "excitation.initial_state";
        let mut seen = vec![false; n];
        for (i, p) in self.particles.iter().enumerate() {
            let field = format!("{base}.particles[{i}]");
            if p.particle == 0 || p.particle > n {
                return Err(spec_err(
                    &format!("{field}.particle"),
                    format!(
                        "must be from 1 to {n} (the chain's particles), got {}",
                        p.particle
                    ),
                ));
            }
            if std::mem::replace(&mut seen[p.particle - 1], true) {
                return Err(spec_err(
                    &format!("{field}.particle"),
                    format!("particle {} is given twice", p.particle),
                ));
            }
            for (name, v) in [
                ("velocity_m_s", p.velocity_m_s),
                ("displacement_m", p.displacement_m),
            ] {
                if !v.is_finite() {
                    return Err(spec_err(
                        &format!("{field}.{name}"),
                        format!("must be a finite number, got {v}"),
                    ));
                }
            }
        }
        if let Some(r) = &self.random_velocity {
            crate::spec::check_positive(&format!("{base}.random_velocity.rms_m_s"), r.rms_m_s)?;
        }
        let moving = self.random_velocity.is_some()
            || self
                .particles
                .iter()
                .any(|p| p.velocity_m_s != 0.0 || p.displacement_m != 0.0);
        if !moving {
            return Err(spec_err(
                base,
                "sets nothing in motion: give a particle a velocity_m_s or displacement_m, or random_velocity",
            ));
        }
        Ok(())
    }

    /// Adds the velocities and displacements to the state `y = [x, v, …]` of `n` particles.
    pub fn apply(&self, y: &mut [f64], n: usize) {
        if let Some(r) = &self.random_velocity {
            let mut rng = crate::contact::SplitMix64(r.seed);
            // Box–Muller: two uniforms in (0, 1] and [0, 1) give two independent normals.
            let mut spare: Option<f64> = None;
            for v in &mut y[n..2 * n] {
                let z = match spare.take() {
                    Some(z) => z,
                    None => {
                        let u1 = 1.0 - 0.5 * (rng.symmetric() + 1.0);
                        let u2 = 0.5 * (rng.symmetric() + 1.0);
                        let radius = (-2.0 * u1.ln()).sqrt();
                        let angle = 2.0 * std::f64::consts::PI * u2;
                        spare = Some(radius * angle.sin());
                        radius * angle.cos()
                    }
                };
                *v += r.rms_m_s * z;
            }
        }
        for p in &self.particles {
            y[p.particle - 1] += p.displacement_m;
            y[n + p.particle - 1] += p.velocity_m_s;
        }
    }
}
