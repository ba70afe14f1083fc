//! # chainsweep-solver
//!
//! The strongly nonlinear, dissipative sphere–cylinder chain of Wang & Nesterenko, *Attenuation of
//! short strongly nonlinear stress pulses in dissipative granular chains*, Sec. III, Eqs. (1)–(12),
//! as the default (with the conventions of the project's `docs/MODEL.md`), and any one-dimensional
//! granular chain beyond it (`docs/CHAINS.md` teaches how to describe one).
//!
//! Its folders, one concept each, each importing only those listed before it:
//!
//! - [`spec`]: errors of a specification, naming the field, and the checks every spec shares;
//! - [`contact`]: the contact laws (Hertz, power laws) and dissipation models (linear viscous,
//!   Kuwabara–Kono, Hunt–Crossley), the one home of their formulas;
//! - [`chain`]: what a chain is made of, from the specification to the built [`Chain`]: parts
//!   (materials, shapes, particles), sequences with taper and disorder, the paper's presets;
//! - [`spectrum`]: the linear spectrum at the static state: natural frequencies, mode shapes,
//!   damped eigenvalues and a periodic chain's Bloch bands, without time integration;
//! - [`integrate`]: velocity Verlet, RK4, DOP853 and Vern6 (tableaus over one explicit
//!   Runge–Kutta core, with contact-event location) and the stiff ROS34PW2 (with the chain's
//!   tridiagonal Jacobian) behind one [`integrate::Integrator`] interface;
//! - [`problems`]: reference problems with closed-form answers (tests, benchmarks, examples);
//! - [`motion`]: the equations of motion: the paper's, specialised at compile time on gravity,
//!   damping, wall and clipping, with the energy/momentum ledger, and every other chain's;
//! - [`observe`]: observables sampled through dense output and on-the-fly peak summaries;
//! - [`scene`]: a whole simulation as written (chain, physics, excitation, integrator, record),
//!   running one ([`run`]) and long chains integrated only where they move.
//!
//! Units are SI throughout. The crate knows nothing of files or command lines.
//!
//! ```
//! use chainsweep_solver::{run, ChainSpec, Probe, Scene};
//! let mut scene = Scene::new(ChainSpec::chain_098(10), 1.06, 2e-4);
//! scene.record.probes = vec![Probe::GaugeForce { cylinder: 4 }];
//! let out = run(&scene).unwrap();
//! assert!(out.probes[0].leading_peak > 50.0);
//! assert!(out.energy_drift_max < 1e-6);
//! ```
#![warn(missing_docs)]
#![forbid(unsafe_code)]

pub mod chain;
pub mod contact;
pub mod integrate;
pub mod motion;
pub mod observe;
pub mod periodic;
pub mod problems;
pub mod scene;
pub mod spec;
pub mod spectrum;

pub use chain::model::{Chain, ChainSpec, DimerSpec, PhysicsSpec};
pub use chain::sequence::SequenceSpec;
pub use chainsweep_cpu as cpu;
pub use integrate::AdaptiveOptions;
pub use observe::probes::{Probe, RecordSpec};
pub use scene::active::{integrates_moving_part, integrates_moving_part_of, ActiveRegion};
pub use scene::solve::{run, run_until, RunError, RunOutput};
pub use scene::{Excitation, IntegratorSpec, Method, Scene, DEADLINE_CHECK_STEPS};
