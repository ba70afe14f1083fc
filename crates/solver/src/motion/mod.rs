//! The equations of motion: the paper's chain specialised at compile time on its physics switches,
//! with the energy and momentum ledger and the dispatch to a compiled right-hand side
//! ([`system`]); every other chain, with per-contact laws and dissipation ([`general`]); chains with Thornton's elastic–plastic
//! contacts, whose history is part of the state ([`plastic`]); and the
//! chain's tridiagonal Jacobian for the linearly implicit integrator (`jacobian`).

pub mod general;
mod jacobian;
pub mod plastic;
pub mod system;
