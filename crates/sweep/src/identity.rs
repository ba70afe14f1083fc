//! Run identity: the SHA-256 hashes that name a run and a verification run.
//!
//! A run's hash is what resume, `status`, `merge` and the segment store look runs up by, so the
//! bytes hashed here are a file format: changing them recomputes every sweep ever run. They are
//! the runner's numerics version, the solver's version, the failure limit on the energy drift and
//! the point's full scene as canonical JSON, so any change to a parameter that enters a run
//! changes its hash, and nothing else does.

use sha2::{Digest, Sha256};

use chainsweep_solver::Scene;

/// SHA-256 identity of a run.
pub type RunHash = [u8; 32];

/// How the tighter setting of a verification run is made (part of its identity, and recorded in
/// output files as `verify_tightening`).
pub const TIGHTENING: &str =
    "dop853/ros34pw2: rtol/100 (atol/100 when given); rk4/verlet: dt_s/4; max_steps x4";

/// The first 8 bytes (little endian) of the SHA-256 of what `feed` writes into it: the checksums
/// an output file stores. 64 bits: a damaged value goes unnoticed with probability 2^-64.
pub fn checksum64(feed: impl FnOnce(&mut Sha256)) -> u64 {
    let mut h = Sha256::new();
    feed(&mut h);
    let d: [u8; 32] = h.finalize().into();
    u64::from_le_bytes(d[..8].try_into().expect("8 bytes"))
}

/// Lower-case hex of a run hash.
pub fn hex(hash: &RunHash) -> String {
    let mut s = String::with_capacity(64);
    for &b in hash {
        s.push(char::from(HEX_DIGITS[usize::from(b >> 4)]));
        s.push(char::from(HEX_DIGITS[usize::from(b & 0xf)]));
    }
    s
}

const HEX_DIGITS: &[u8; 16] = b"0123456789abcdef";

/// Whether `text` is the lower-case hex of `hash` (as [`hex`] writes it), compared without
/// writing it out (a file's run hashes are compared point by point).
pub fn is_hex_of(text: &str, hash: &RunHash) -> bool {
    let t = text.as_bytes();
    t.len() == 64
        && hash.iter().enumerate().all(|(k, &b)| {
            t[2 * k] == HEX_DIGITS[usize::from(b >> 4)]
                && t[2 * k + 1] == HEX_DIGITS[usize::from(b & 0xf)]
        })
}

/// The run hash written as 64 hex digits, read back; `None` for anything else.
pub fn from_hex(text: &str) -> Option<RunHash> {
    if text.len() != 64 || !text.is_ascii() {
        return None;
    }
    let mut out = [0u8; 32];
    for (i, o) in out.iter_mut().enumerate() {
        *o = u8::from_str_radix(&text[2 * i..2 * i + 2], 16).ok()?;
    }
    Some(out)
}

/// Identity of the run of `scene` under the energy-drift limit `energy_drift_max` (`None`: no
/// limit). A run that integrates only the moving part of its chain
/// ([`chainsweep_solver::integrates_moving_part`]) adds a line saying so, with the version of that
/// path: its results differ from the whole chain's in the last digits, so runs stored before that
/// path existed, or by an earlier version of it, are recomputed rather than mixed with its results,
/// while every other run keeps its hash (a bump of `NUMERICS_VERSION` would recompute those too).
/// Version 2: the moving part of chains from 32 particles (the floor was 512), grown in blocks of 8
/// at the step size reached.
pub fn run_hash(scene: &Scene, energy_drift_max: Option<f64>) -> RunHash {
    let moving_part = chainsweep_solver::integrates_moving_part(scene);
    run_hash_with(scene, energy_drift_max, moving_part)
}

/// [`run_hash`] for a scene of which the caller already knows whether it integrates only its
/// moving part (`moving_part`: [`chainsweep_solver::integrates_moving_part`] of the scene), which
/// costs a right-hand side of the whole chain to find out.
pub fn run_hash_with(scene: &Scene, energy_drift_max: Option<f64>, moving_part: bool) -> RunHash {
    use std::io::Write as _;
    let mut h = HashWriter(Sha256::new());
    h.0.update(b"chainsweep run identity v1\n");
    // Written straight into the hash (no string is built: a grid hashes millions of scenes).
    let _ = writeln!(h, "numerics_version={}", crate::NUMERICS_VERSION);
    let _ = write!(
        h,
        "solver_version={}\nenergy_drift_max=",
        crate::SOLVER_VERSION
    );
    match energy_drift_max {
        Some(x) => serde_json::to_writer(&mut h, &x).expect("f64 serialises"),
        None => h.0.update(b"null"),
    }
    h.0.update(b"\n");
    if moving_part {
        h.0.update(MOVING_PART_LINE);
    }
    h.0.update(b"scene=");
    serde_json::to_writer(&mut h, scene).expect("Scene serialises");
    h.0.finalize().into()
}

/// The identity's line for a run of the moving part only: see [`run_hash`].
const MOVING_PART_LINE: &[u8] = b"moving_part=2\n";

/// Bytes written into a SHA-256.
struct HashWriter(Sha256);

impl std::io::Write for HashWriter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.update(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// Identity of a search point whose scene is invalid (it is stored as a failed run, with why):
/// the numerics version and the scene's JSON as it stands (no scene could be built to hash).
pub fn invalid_scene_hash(scene: &serde_json::Value) -> RunHash {
    let mut h = Sha256::new();
    h.update(b"chainsweep invalid scene v1\n");
    h.update(format!("numerics_version={}\n", crate::NUMERICS_VERSION).as_bytes());
    h.update(serde_json::to_string(scene).expect("json").as_bytes());
    h.finalize().into()
}

/// Identity of a run on a continuation axis: its own run hash `own` (its scene's) and the identity
/// of the run it starts from, `previous` (itself continued, back to the line's first point), so
/// that a change anywhere up the line is a different run.
pub fn continued_hash(own: &RunHash, previous: &RunHash) -> RunHash {
    let mut h = Sha256::new();
    h.update(b"chainsweep continued run v1\n");
    h.update(format!("own={}\nfrom={}\n", hex(own), hex(previous)).as_bytes());
    h.finalize().into()
}

/// Identity of the verification run of the point whose run hash is `base` and whose verification
/// scene is `tight`: a different marker than run hashes, so the two never collide.
pub fn verify_hash(base: &RunHash, tight: &Scene) -> RunHash {
    let mut h = Sha256::new();
    h.update(b"chainsweep verification run v1\n");
    h.update(format!("base_run={}\n", hex(base)).as_bytes());
    h.update(b"tightening=");
    h.update(TIGHTENING.as_bytes());
    h.update(b"\nscene=");
    h.update(
        serde_json::to_string(tight)
            .expect("Scene serialises")
            .as_bytes(),
    );
    h.finalize().into()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hex_round_trips() {
        let h: RunHash = std::array::from_fn(|i| (i * 37) as u8);
        assert_eq!(from_hex(&hex(&h)), Some(h));
        assert_eq!(from_hex("00"), None);
        assert_eq!(from_hex(&"g".repeat(64)), None);
        let spelled: String = h.iter().map(|b| format!("{b:02x}")).collect();
        assert_eq!(hex(&h), spelled);
        assert!(is_hex_of(&spelled, &h));
        assert!(!is_hex_of(&spelled.to_uppercase(), &h));
        assert!(!is_hex_of(&spelled[..62], &h));
        let mut other = h;
        other[31] ^= 1;
        assert!(!is_hex_of(&spelled, &other));
    }

    #[test]
    fn hashes_follow_the_scene_and_the_limit() {
        let scene = Scene::new(chainsweep_solver::ChainSpec::chain_055(3), 1.3, 1e-4);
        let h = run_hash(&scene, Some(1e-3));
        assert_ne!(h, run_hash(&scene, None));
        let mut other = scene.clone();
        other.striker_velocity_m_s = Some(1.31);
        assert_ne!(h, run_hash(&other, Some(1e-3)));
        assert_ne!(verify_hash(&h, &scene), h);
        assert_eq!(run_hash(&scene, Some(1e-3)), h);
    }
}
