//! Uncertainty quantification as pure functions: distributions of scene fields and their
//! dependence ([`dist`]), the designs that place an ensemble's samples in the unit hypercube
//! ([`design`]: scrambled Sobol', Latin hypercube, Monte Carlo, Saltelli's and Morris's designs),
//! the statistics of an ensemble with their confidence intervals ([`stats`]) and the global
//! sensitivities of a quantity to its inputs ([`sensitivity`]: Sobol' indices, Morris's
//! elementary effects). Nothing here runs a scene: the sweep turns a design into runs, the engine
//! hands their values back.

pub mod design;
pub mod dist;
pub mod sensitivity;
pub mod stats;

/// SplitMix64's finaliser (Steele, Lea & Flood 2014): a bijective 64-bit mix, the hash under every
/// random choice of the designs, so that each is a pure function of its seed and position.
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A hash of several words (each mixed into the running state).
pub fn hash(words: &[u64]) -> u64 {
    words.iter().fold(0x243f_6a88_85a3_08d3, |h, &w| {
        mix64(h.wrapping_add(0x9e37_79b9_7f4a_7c15) ^ mix64(w))
    })
}

/// A number in (0, 1) from 64 random bits: the top 53 bits, offset by half a step. (The
/// largest, (2⁵³ − ½)/2⁵³, rounds to 1: [`clamp_unit`] keeps it, and any probability a design
/// or the copula gives, within [`UNIT_LOWEST`, `UNIT_HIGHEST`].)
pub fn unit(bits: u64) -> f64 {
    ((bits >> 11) as f64 + 0.5) / (1u64 << 53) as f64
}

/// The least probability a distribution is drawn at: `unit(0)`, 2⁻⁵⁴ (a normal's −8.3 sd).
pub const UNIT_LOWEST: f64 = 0.5 / 9_007_199_254_740_992.0;
/// The greatest probability a distribution is drawn at: the largest number below 1, 1 − 2⁻⁵³ (a
/// normal's +8.2 sd), where a normal's quantile is still finite.
pub const UNIT_HIGHEST: f64 = 1.0 - 1.0 / 9_007_199_254_740_992.0;

/// `u` within [`UNIT_LOWEST`, `UNIT_HIGHEST`]: every draw is a quantile at a probability there,
/// so that checking a distribution at both ends when the sweep is read covers every value any
/// design can draw (a stratum of a Latin hypercube or the copula's correlated scores could
/// otherwise go further out, and 1 itself gives a normal's +∞).
pub fn clamp_unit(u: f64) -> f64 {
    u.clamp(UNIT_LOWEST, UNIT_HIGHEST)
}

/// A counter-based stream of random numbers: draw `k` of stream `key` is `hash(key ++ [k])`.
#[derive(Debug, Clone)]
pub struct Stream {
    key: u64,
    next: u64,
}

impl Stream {
    /// The stream of the words `key`.
    pub fn new(key: &[u64]) -> Stream {
        Stream {
            key: hash(key),
            next: 0,
        }
    }

    /// The next 64 random bits.
    pub fn bits(&mut self) -> u64 {
        self.next += 1;
        mix64(self.key ^ mix64(self.next))
    }

    /// The next number in (0, 1).
    pub fn uniform(&mut self) -> f64 {
        unit(self.bits())
    }

    /// A uniform index in `0..n` (n > 0), without modulo bias worth speaking of (n ≪ 2⁶⁴).
    pub fn below(&mut self, n: usize) -> usize {
        ((self.bits() as u128 * n as u128) >> 64) as usize
    }
}
