//! What each contact of a built chain joins ([`ContactEnds`], [`ContactMap`]): neighbours, the
//! wall under the chain, a ring's closing contact, the top wall, and a wall that a drive or a
//! mount moves. Apart from the chain's construction because everything that reads a state's
//! overlaps (the ledger, the probes, the observers) reads them through it.

use crate::chain::drive::DrivePoint;

use super::Chain;
// Named only by the docs.
#[cfg(doc)]
use crate::chain::mount::WallMount;

/// What a contact joins: its overlap is `x[above] − x[below] + offset`, a missing side being a
/// fixed wall at position 0 (the wall under the chain: `below` is `None`) or at `offset` (the
/// wall at the top: `above` is `None`). The force pushes `above` up (towards −x) and `below`
/// down. A wall that a drive moves is displaced by the state's component `wall_state` (its
/// velocity the next), positive downwards for the base, into the chain for the actuator: the
/// overlap is then `x[n−1] − u` under the chain, `offset + u − x[0]` at the top. A mounted wall
/// under the chain ([`WallMount`]) is displaced the same way, by its own state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactEnds {
    /// The particle above the contact, if any.
    pub above: Option<usize>,
    /// The particle below the contact, if any.
    pub below: Option<usize>,
    /// Position of the wall at the top, m (zero for every other contact).
    pub offset: f64,
    /// Index in the state of the displacement of the wall a drive moves (its velocity at the
    /// next index), when this contact's wall moves.
    pub wall_state: Option<usize>,
}

impl ContactEnds {
    /// Overlap and its rate in state `(x, v)`, read through `x(i)` and `v(i)`; a moving wall's
    /// displacement and velocity through `wall(k)` (`k` its index in the state).
    #[inline(always)]
    pub fn kinematics(
        &self,
        x: impl Fn(usize) -> f64,
        v: impl Fn(usize) -> f64,
        wall: impl Fn(usize) -> f64,
    ) -> (f64, f64) {
        let read = |f: &dyn Fn(usize) -> f64, i: Option<usize>| i.map_or(0.0, f);
        let mut rate = read(&v, self.above) - read(&v, self.below);
        if let Some(w) = self.wall_state {
            rate += self.wall_sign() * wall(w + 1);
        }
        (self.overlap(x, wall), rate)
    }

    /// The overlap alone (what [`ContactEnds::kinematics`] gives first), reading no velocity.
    #[inline(always)]
    pub fn overlap(&self, x: impl Fn(usize) -> f64, wall: impl Fn(usize) -> f64) -> f64 {
        let read = |i: Option<usize>| i.map_or(0.0, &x);
        let overlap = read(self.above) - read(self.below) + self.offset;
        match self.wall_state {
            Some(w) => overlap + self.wall_sign() * wall(w),
            None => overlap,
        }
    }

    /// How a moving wall's displacement enters the overlap: the wall is the missing side, above
    /// the chain it adds, below it takes away.
    #[inline(always)]
    fn wall_sign(&self) -> f64 {
        if self.above.is_none() {
            1.0
        } else {
            -1.0
        }
    }
}

/// What every contact of a chain joins, to read overlaps from a state `[x, v, …]` (the ledger,
/// the probes, the observers): neighbours inline, the few contacts beyond them from a table.
#[derive(Debug, Clone)]
pub struct ContactMap {
    n: usize,
    /// Contacts `N − 1` on: the wall under the chain, a ring's closing contact, the top wall.
    ends: Vec<ContactEnds>,
}

impl ContactMap {
    /// The state components an interior contact `c` reads: the positions of the particles it
    /// joins, `c` above and `c + 1` below, and their velocities (`None` for the contacts from
    /// `N − 1` on: a wall's, a ring's closing contact, the top wall's).
    #[inline(always)]
    pub fn between(&self, c: usize) -> Option<([usize; 2], [usize; 2])> {
        let n = self.n;
        (c + 1 < n).then_some(([c, c + 1], [n + c, n + c + 1]))
    }

    /// The map of `chain`.
    pub fn of(chain: &Chain) -> Self {
        let n = chain.n_particles();
        ContactMap {
            n,
            ends: (n - 1..chain.n_contacts())
                .map(|c| chain.contact_ends(c))
                .collect(),
        }
    }

    /// The contacts beyond the neighbours' (`N − 1` on), in order.
    pub fn ends(&self) -> &[ContactEnds] {
        &self.ends
    }

    /// Overlap of contact `c` and its rate, the state read through `get` (positions at `0..N`,
    /// velocities at `N..2N`).
    #[inline(always)]
    pub fn kinematics(&self, c: usize, get: impl Fn(usize) -> f64) -> (f64, f64) {
        match self.between(c) {
            Some(([above, below], [v_above, v_below])) => {
                (get(above) - get(below), get(v_above) - get(v_below))
            }
            None => {
                let n = self.n;
                self.ends[c + 1 - n].kinematics(&get, |i| get(n + i), &get)
            }
        }
    }

    /// Overlap of contact `c` in state `y` (negative: open): positions first, then whatever a
    /// moving wall's displacement needs.
    #[inline(always)]
    pub fn overlap(&self, c: usize, y: &[f64]) -> f64 {
        self.overlap_read(c, |i| y[i])
    }

    /// [`ContactMap::overlap`] with the state read through `get`: the overlap that
    /// [`ContactMap::kinematics`] gives, reading no velocity.
    #[inline(always)]
    pub fn overlap_read(&self, c: usize, get: impl Fn(usize) -> f64) -> f64 {
        match self.between(c) {
            Some(([above, below], _)) => get(above) - get(below),
            None => self.ends[c + 1 - self.n].overlap(&get, &get),
        }
    }
}

/// [`Chain::contact_ends`] from the chain's shape: contacts `0..N−1` join neighbours, then come
/// the wall under the last particle or the ring's closing contact, then the wall at the top at
/// `top_wall_m`; `moving` is the wall a drive moves and its displacement's index in the state,
/// `mount` the index of a mounted wall's displacement (the wall under the chain).
pub(super) fn contact_ends(
    n: usize,
    wall: bool,
    ring: bool,
    top_wall_m: Option<f64>,
    moving: Option<(DrivePoint, usize)>,
    mount: Option<usize>,
    c: usize,
) -> ContactEnds {
    let (above, below, offset) = if c + 1 < n {
        (Some(c), Some(c + 1), 0.0)
    } else if c + 1 == n && wall {
        (Some(n - 1), None, 0.0)
    } else if c + 1 == n && ring {
        (Some(n - 1), Some(0), 0.0)
    } else {
        (
            None,
            Some(0),
            top_wall_m.expect("the last contact is the top wall's"),
        )
    };
    let wall_state = match moving {
        Some((DrivePoint::Base, w)) if below.is_none() => Some(w),
        Some((DrivePoint::Actuator, w)) if above.is_none() => Some(w),
        _ if below.is_none() => mount,
        _ => None,
    };
    ContactEnds {
        above,
        below,
        offset,
        wall_state,
    }
}
