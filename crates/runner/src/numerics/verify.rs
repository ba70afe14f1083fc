//! `run --verify FRACTION`: a deterministic sample of grid points is run again at a tighter
//! setting, and the observed relative error of each summary is stored with the sweep.
//!
//! - The sample is a pure function of the grid: the points are ordered by the SHA-256 of the
//!   sweep key (the SHA-256 of every run hash, in grid order) and the point's flat index, and the
//!   first `ceil(FRACTION × n)` are taken. Every shard computes the same sample and runs the
//!   verifications of its own points, so a merge of shards equals a single-machine run.
//! - The tighter setting: DOP853 and ROS34PW2 at `rtol / 100` (and `atol / 100` when given),
//!   RK4 and Verlet at `dt / 4`; the step budget is multiplied by 4 (fixed-step methods need four
//!   times the steps); histories and minimum overlaps are not recorded by verification runs.
//! - A verification run is a run like any other: its record is stored in the work directory,
//!   under the hash of the tightened scene with a marker ([`verify_hash`]), so an interrupted
//!   verification resumes, and a point once verified stays verified in later assemblies.

use chainsweep_solver::{AdaptiveOptions, IntegratorSpec, Scene};
use sha2::{Digest, Sha256};

use super::probe_errors;
use crate::grid::Grid;
use crate::identity::{verify_hash, RunHash};
use crate::record::{RunRecord, VerifyInfo, VERIFY_FAILED, VERIFY_OK};
use crate::sweep::Sweep;

/// The integrator one notch tighter (see the module docs).
pub fn tighten(spec: IntegratorSpec) -> IntegratorSpec {
    match spec {
        IntegratorSpec::Verlet { dt_s } => IntegratorSpec::Verlet { dt_s: dt_s / 4.0 },
        IntegratorSpec::Rk4 { dt_s } => IntegratorSpec::Rk4 { dt_s: dt_s / 4.0 },
        IntegratorSpec::Dop853(o) => IntegratorSpec::Dop853(tighten_adaptive(o)),
        IntegratorSpec::Ros34pw2(o) => IntegratorSpec::Ros34pw2(tighten_adaptive(o)),
        IntegratorSpec::Vern6(o) => IntegratorSpec::Vern6(tighten_adaptive(o)),
    }
}

/// An adaptive method's options a hundred times tighter (within the ranges a scene allows).
fn tighten_adaptive(o: AdaptiveOptions) -> AdaptiveOptions {
    AdaptiveOptions {
        rtol: (o.rtol / 100.0).max(1e-15),
        atol: o.atol.map(|a| (a / 100.0).max(1e-18)),
        ..o
    }
}

/// The verification scene of a grid point's scene.
pub fn tight_scene(scene: &Scene) -> Scene {
    let mut s = scene.clone();
    s.integrator = tighten(scene.integrator);
    s.max_steps = scene.max_steps.saturating_mul(4);
    s.record.history = false;
    s.record.min_overlap = false;
    s.record.energy_flow = false;
    s.record.fields = None;
    s
}

/// The key of a sweep for sampling: the SHA-256 of every run hash in grid order.
pub fn sweep_key(grid: &Grid) -> [u8; 32] {
    let mut h = Sha256::new();
    h.update(b"chainsweep verification sample v1\n");
    for x in &grid.hashes {
        h.update(x);
    }
    h.finalize().into()
}

/// Which grid points are verified at `fraction` (in [0, 1]): exactly `ceil(fraction × n)` of
/// them, a deterministic pseudo-random sample seeded by the sweep key.
pub fn sample(grid: &Grid, fraction: f64) -> Vec<bool> {
    let n = grid.len();
    let mut chosen = vec![false; n];
    if fraction.is_nan() || fraction <= 0.0 {
        return chosen;
    }
    let k = ((fraction.min(1.0) * n as f64).ceil() as usize).min(n);
    let key = sweep_key(grid);
    let mut order: Vec<(u64, usize)> = (0..n)
        .map(|i| {
            let mut h = Sha256::new();
            h.update(key);
            h.update((i as u64).to_le_bytes());
            let d: [u8; 32] = h.finalize().into();
            (u64::from_le_bytes(d[..8].try_into().expect("8 bytes")), i)
        })
        .collect();
    order.sort_unstable();
    for &(_, i) in &order[..k] {
        chosen[i] = true;
    }
    chosen
}

/// The verification outcome of a point from its run and its verification run.
pub fn compare(base: &RunRecord, tight: Option<&RunRecord>, n_probes: usize) -> VerifyInfo {
    let Some(tight) = tight else {
        return VerifyInfo::none(n_probes);
    };
    if !tight.ok {
        return VerifyInfo {
            status: VERIFY_FAILED,
            ..VerifyInfo::none(n_probes)
        };
    }
    if !base.ok {
        return VerifyInfo::none(n_probes);
    }
    let errors = probe_errors(&base.probes, &tight.probes);
    VerifyInfo {
        status: VERIFY_OK,
        errors,
    }
}

/// The verification scene and hash of point `i`.
pub fn point_verification(sweep: &Sweep, grid: &Grid, i: usize) -> (Scene, RunHash) {
    let scene = grid.build(sweep, i).expect("every point was validated");
    let tight = tight_scene(&scene);
    let h = verify_hash(&grid.hashes[i], &tight);
    (tight, h)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tightening() {
        assert_eq!(
            tighten(IntegratorSpec::Rk4 { dt_s: 4e-8 }),
            IntegratorSpec::Rk4 { dt_s: 1e-8 }
        );
        match tighten(IntegratorSpec::default()) {
            IntegratorSpec::Dop853(AdaptiveOptions { rtol, atol, .. }) => {
                assert!((rtol - 1e-11).abs() < 1e-25);
                assert_eq!(atol, None);
            }
            other => panic!("{other:?}"),
        }
    }
}
