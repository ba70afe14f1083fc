//! The natural scales of an excitation ([`ImpactScales`]): the two-body impact of a striker or an
//! impulse, a force pulse, an initial state, a drive. Apart from the scene because they are
//! closed forms of the contact laws, which the tolerances, the leading-pulse thresholds and the
//! plausibility warnings are all measured against.

use crate::chain::drive::{Drive, DrivePoint};
use crate::chain::model::Chain;

/// Natural scales of an excitation: for a striker (or a δ-force impulse) the two-body collision of
/// particle 1 with particle 2 under contact 1's law; for a force pulse its amplitude and the
/// response of particle 1 to it.
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
    /// Duration of the excitation's pulse, s: the two-body impact's, or the force pulse's.
    pub duration_s: f64,
}

impl ImpactScales {
    /// Duration of the two-body striker impact, s: `2 δm / v0 · ∫₀¹ (1 − x^{n+1})^{-1/2} dx`
    /// (2.943 δm / v0 for Hertz, the closed form checked in `tests/dynamics.rs`), or of the force
    /// pulse.
    pub fn contact_duration_s(&self) -> f64 {
        self.duration_s
    }

    /// Scales for particle 1 moving at `v0` into particle 2 (a striker, or a δ-force impulse), or
    /// into its wall when it is alone.
    pub fn new(chain: &Chain, v0: f64) -> Self {
        let m1 = chain.mass[0];
        let reduced = match chain.mass.get(1) {
            Some(&m2) => m1 * m2 / (m1 + m2),
            None => m1,
        };
        let (a1, n) = (chain.stiffness[0], chain.exponent[0]);
        let (overlap, force, duration) = if n == 1.5 {
            let overlap = (1.25 * reduced * v0 * v0 / a1).powf(0.4);
            (overlap, a1 * overlap * overlap.sqrt(), 2.943 * overlap / v0)
        } else {
            // Energy balance at the peak: ½ m v0² = A δm^{n+1}/(n+1).
            let overlap = (0.5 * (n + 1.0) * reduced * v0 * v0 / a1).powf(1.0 / (n + 1.0));
            (
                overlap,
                crate::contact::elastic_force(a1, n, overlap),
                crate::contact::impact_duration_factor(n) * overlap / v0,
            )
        };
        ImpactScales {
            overlap_m: overlap,
            force_n: force,
            velocity_m_s: v0,
            energy_j: 0.5 * m1 * v0 * v0,
            momentum: m1 * v0,
            duration_s: duration,
        }
    }

    /// Scales for an initial state `y0` of the chain: those of a striker on contact 1 whose kinetic
    /// energy is the energy the initial state puts in (kinetic and elastic, above the static
    /// state's), so that a displaced particle counts like a moving one.
    pub fn initial_state(chain: &Chain, y0: &[f64]) -> Self {
        let ledger = crate::motion::system::Ledger::new(chain);
        let at_rest = ledger.energy(&chain.initial_state(0.0));
        let started = ledger.energy(y0);
        let energy = (started.kinetic + started.elastic - at_rest.elastic).max(f64::MIN_POSITIVE);
        ImpactScales::new(chain, (2.0 * energy / chain.mass[0]).sqrt())
    }

    /// Scales for a drive: a force drive as a force pulse of its peak over half its shortest
    /// period; a moving wall as a striker at the wall's peak velocity, whose overlap scale is at
    /// least the drive's amplitude.
    pub fn drive(chain: &Chain, drive: &Drive) -> Self {
        let signal = &drive.waveform;
        let half_period = 0.5 / signal.highest_frequency_hz();
        match drive.point {
            DrivePoint::Force => ImpactScales::force_pulse(chain, signal.peak(), half_period),
            DrivePoint::Actuator | DrivePoint::Base => {
                let velocity = signal.peak_rate().max(f64::MIN_POSITIVE);
                let mut s = ImpactScales::new(chain, velocity);
                s.overlap_m = s.overlap_m.max(signal.peak());
                s.duration_s = half_period;
                s
            }
        }
    }

    /// Scales for a half-sine force pulse of `amplitude` N and `duration` s on particle 1: the
    /// overlap `δ_F` at which contact 1 carries the amplitude, the particle velocity
    /// `min(I/m₁, √(F δ_F / m₁))` (a free particle's after the pulse's impulse `I = 2FT/π`, or
    /// that of a strongly nonlinear wave of force `F`), the pulse's impulse and the work of a
    /// force of mean `2F/π` at that velocity over the pulse.
    pub fn force_pulse(chain: &Chain, amplitude: f64, duration: f64) -> Self {
        let m1 = chain.mass[0];
        let overlap =
            crate::contact::overlap_at_force(chain.stiffness[0], chain.exponent[0], amplitude);
        let impulse = 2.0 * amplitude * duration / std::f64::consts::PI;
        let velocity = (impulse / m1).min((amplitude * overlap / m1).sqrt());
        ImpactScales {
            overlap_m: overlap,
            force_n: amplitude,
            velocity_m_s: velocity,
            energy_j: impulse * velocity,
            momentum: impulse,
            duration_s: duration,
        }
    }
}
