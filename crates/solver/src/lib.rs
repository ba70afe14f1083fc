//! # chainsweep-solver
//!
//! The strongly nonlinear, dissipative sphere–cylinder chain of Wang & Nesterenko, *Attenuation of
//! short strongly nonlinear stress pulses in dissipative granular chains*, Sec. III, Eqs. (1)–(12),
//! as the default (with the conventions of the project's `docs/MODEL.md`), and any one-dimensional
//! granular chain beyond it (`docs/CHAINS.md` teaches how to describe one):
//!
//! - [`spec`]: errors of a specification, naming the field;
//! - [`parts`]: what a chain is made of: materials, shapes, particles, the Hertz coefficient;
//! - [`model`]: the chain's configuration with the paper's defaults and the built [`model::Chain`];
//! - [`sequence`]: chains as sequences of named particle types, with taper and disorder;
//! - [`contact`]: the contact laws (Hertz, power laws) and dissipation models (linear viscous,
//!   Kuwabara–Kono, Hunt–Crossley), the one home of their formulas;
//! - [`system`]: the paper's equations of motion as an ODE system, specialised at compile time on
//!   gravity, damping, wall and clipping, the energy/momentum [`system::Ledger`], and the dispatch
//!   to [`general`]'s kernels for every other chain;
//! - [`integrate`]: velocity Verlet, RK4, DOP853 (with contact-event location) and the stiff
//!   ROS34PW2 (with the chain's tridiagonal Jacobian) behind one [`integrate::Integrator`] interface;
//! - [`probes`]: observables sampled through dense output and on-the-fly peak summaries;
//! - [`scene`]: a whole simulation as written (chain, physics, excitation, integrator, record);
//! - [`active`]: long chains integrated only where they move;
//! - [`solve`]: running a scene, [`solve::run`];
//! - [`problems`]: reference problems with closed-form answers (tests, benchmarks, examples).
//!
//! Units are SI throughout. The crate knows nothing of files or command lines.
//!
//! ```
//! use chainsweep_solver::{model::ChainSpec, probes::Probe, run, Scene};
//! let mut scene = Scene::new(ChainSpec::chain_098(10), 1.06, 2e-4);
//! scene.record.probes = vec![Probe::GaugeForce { cylinder: 4 }];
//! let out = run(&scene).unwrap();
//! assert!(out.probes[0].leading_peak > 50.0);
//! assert!(out.energy_drift_max < 1e-6);
//! ```
#![warn(missing_docs)]
#![forbid(unsafe_code)]

pub mod active;
pub mod contact;
pub mod general;
pub mod integrate;
mod jacobian;
pub mod model;
pub mod parts;
pub mod probes;
pub mod problems;
pub mod scene;
pub mod sequence;
pub mod solve;
pub mod spec;
pub mod system;

pub use active::{integrates_moving_part, integrates_moving_part_of, ActiveRegion};
pub use chainsweep_cpu as cpu;
pub use integrate::AdaptiveOptions;
pub use model::{Chain, ChainSpec, DimerSpec, PhysicsSpec};
pub use probes::{Probe, RecordSpec};
pub use scene::{Excitation, IntegratorSpec, Method, Scene, DEADLINE_CHECK_STEPS};
pub use sequence::SequenceSpec;
pub use solve::{run, run_until, RunError, RunOutput};
