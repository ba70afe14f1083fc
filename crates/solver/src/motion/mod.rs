//! The equations of motion: the paper's chain specialised at compile time on its physics switches,
//! with the energy and momentum ledger and the dispatch to a compiled right-hand side
//! ([`system`]); every other chain, with per-contact laws and dissipation ([`general`]); chains with Thornton's elastic–plastic
//! contacts, whose history is part of the state ([`plastic`]); and the
//! chain's tridiagonal Jacobian for the linearly implicit integrator (`jacobian`).

pub mod general;
mod jacobian;
pub mod plastic;
pub mod system;

use crate::chain::model::ContactEnds;
use crate::integrate::Switch;

/// A contact's overlap as a switching function of the positions (zero where it opens), for the
/// integrators that put step boundaries there.
pub(crate) fn contact_switch(e: &ContactEnds) -> Switch {
    match (e.above, e.below) {
        (Some(a), b) => Switch {
            plus: a,
            minus: b,
            offset: e.offset,
        },
        // `x_top − x₁` vanishes where `x₁ − x_top` does.
        (None, Some(b)) => Switch {
            plus: b,
            minus: None,
            offset: -e.offset,
        },
        (None, None) => unreachable!("a contact touches a particle"),
    }
}
