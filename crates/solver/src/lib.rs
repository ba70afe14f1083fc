//! # chainsweep-solver
//!
//! The strongly nonlinear, dissipative sphere–cylinder chain of Wang & Nesterenko, *Attenuation of
//! short strongly nonlinear stress pulses in dissipative granular chains*, Sec. III, Eqs. (1)–(12),
//! with the conventions of the project's `docs/MODEL.md`:
//!
//! - [`model`]: the chain's configuration with the paper's defaults and the built [`model::Chain`];
//! - [`system`]: the equations of motion as an ODE system, specialised at compile time on gravity,
//!   damping, wall and clipping, and the energy/momentum [`system::Ledger`];
//! - [`integrate`]: velocity Verlet, RK4, DOP853 (with contact-event location) and the stiff
//!   ROS34PW2 (with the chain's tridiagonal Jacobian) behind one [`integrate::Integrator`] interface;
//! - [`probes`]: observables sampled through dense output and on-the-fly peak summaries;
//! - [`scene`]: a whole simulation, [`scene::run`].
//!
//! Units are SI throughout. The crate knows nothing of files or command lines.
//!
//! ```
//! use chainsweep_solver::{model::ChainSpec, probes::Probe, scene::{run, Scene}};
//! let mut scene = Scene::new(ChainSpec::chain_098(10), 1.06, 2e-4);
//! scene.record.probes = vec![Probe::GaugeForce { cylinder: 4 }];
//! let out = run(&scene).unwrap();
//! assert!(out.probes[0].leading_peak > 50.0);
//! assert!(out.energy_drift_max < 1e-6);
//! ```
#![warn(missing_docs)]
#![forbid(unsafe_code)]

pub mod integrate;
mod jacobian;
pub mod model;
pub mod probes;
pub mod scene;
pub mod system;

pub use model::{Chain, ChainSpec, PhysicsSpec};
pub use probes::{Probe, RecordSpec};
pub use scene::{run, IntegratorSpec, RunOutput, Scene};
