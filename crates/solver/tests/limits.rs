//! Every run ends: a deadline stops a run that would go on for hours, and is cheap to check.

use std::time::{Duration, Instant};

use chainsweep_solver::chain::model::{ChainSpec, PhysicsSpec};
use chainsweep_solver::{run, run_until, RunError, Scene, DEADLINE_CHECK_STEPS};

/// The runaway scene: a 1000 m/s striker into a chain damped at 1e9 kg/s, whose
/// explicit steps are held near m/μ (femtoseconds) over a 0.2 ms run.
fn runaway() -> Scene {
    let mut s = Scene::new(ChainSpec::chain_055(10), 1000.0, 2e-4);
    s.physics = PhysicsSpec {
        damping_kg_s: 1e9,
        ..PhysicsSpec::default()
    };
    s
}

#[test]
fn a_runaway_run_ends_at_its_deadline_with_how_far_it_got() {
    let limit = Duration::from_millis(300);
    let start = Instant::now();
    let r = run_until(&runaway(), Some(start + limit));
    let took = start.elapsed();
    match r {
        Err(RunError::Deadline { t_s, steps, .. }) => {
            assert!(t_s > 0.0 && t_s < 2e-4, "t = {t_s}");
            assert!(steps >= u64::from(DEADLINE_CHECK_STEPS), "{steps} steps");
            assert_eq!(steps % u64::from(DEADLINE_CHECK_STEPS), 0, "{steps} steps");
        }
        other => panic!("expected the deadline, got {other:?}"),
    }
    assert!(took >= limit, "{took:?}");
    // Within a generous margin of the deadline (a check every 64 steps of a 23-particle chain).
    assert!(took < limit + Duration::from_secs(2), "{took:?}");
    let message = run_until(&runaway(), Some(Instant::now()))
        .unwrap_err()
        .to_string();
    assert!(message.starts_with("deadline reached at t = "), "{message}");
}

#[test]
fn a_deadline_far_away_changes_nothing() {
    let s = Scene::new(ChainSpec::chain_055(10), 1.3, 1e-4);
    let free = run(&s).unwrap();
    let bounded = run_until(&s, Some(Instant::now() + Duration::from_secs(3600))).unwrap();
    assert_eq!(free, bounded);
}
