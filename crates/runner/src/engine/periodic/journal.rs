//! A branch's journal, `periodic/<point>.log` in the work directory: a line naming what it is
//! the branch of, a line per accepted orbit, a line for how it ended, each with the first 16 hex
//! digits of its SHA-256 (the module docs of [`super`] give what is read back and when).

use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::Path;

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use chainsweep_solver::observe::steady::SteadyProbe;
use chainsweep_solver::periodic::{AutonomousOrbit, BranchPoint};

use crate::grid::Grid;
use crate::sweep::Sweep;

/// One line of a branch's journal.
#[derive(Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(super) enum Entry {
    /// What the journal is the branch of.
    Identity { hash: String },
    /// An accepted orbit, with the run of two orbit periods from it (`None`: that run failed,
    /// with why).
    Point {
        point: Box<BranchPoint>,
        probes: Option<Vec<SteadyProbe>>,
        max: Option<Vec<f64>>,
        run_error: Option<String>,
    },
    /// A free orbit of an `autonomous` block's family, with the run of two orbit periods from
    /// its turning point (`None`: that run failed, with why).
    Free {
        orbit: Box<AutonomousOrbit>,
        probes: Option<Vec<SteadyProbe>>,
        max: Option<Vec<f64>>,
        run_error: Option<String>,
    },
    /// How the branch ended.
    End {
        end: String,
        warnings: Vec<String>,
        maps: u64,
    },
    /// No first orbit: why.
    Failed { reason: String },
    /// Where the branch switched to starts (`switch: period_doubling`): the field's value at the
    /// period doubling of the point's branch, located exactly as the continuation locates it.
    Doubling { parameter: f64 },
}

/// A branch as its journal holds it.
#[derive(Default)]
pub(super) struct Journal {
    pub(super) doubling: Option<f64>,
    pub(super) points: Vec<Entry>,
    pub(super) end: Option<Entry>,
}

pub(super) fn line_of(entry: &Entry) -> String {
    let json = serde_json::to_string(entry).expect("a journal entry serialises");
    format!("{} {json}\n", checksum(&json))
}

fn checksum(text: &str) -> String {
    let sum = Sha256::digest(text.as_bytes());
    sum[..8].iter().map(|b| format!("{b:02x}")).collect()
}

/// The journal at `path` if it is this branch's (`identity`): its lines up to the first that
/// does not read back (a torn tail, a damaged line: what follows it is never read); `None` when
/// absent or another sweep's.
pub(super) fn read_journal(path: &Path, identity: &str) -> Option<Journal> {
    let file = File::open(path).ok()?;
    let mut journal = Journal::default();
    let mut first = true;
    for line in BufReader::new(file).lines() {
        let Some(entry) = line.ok().and_then(|line| {
            let (sum, json) = line.split_once(' ')?;
            (checksum(json) == sum)
                .then(|| serde_json::from_str::<Entry>(json).ok())
                .flatten()
        }) else {
            break;
        };
        match entry {
            Entry::Identity { hash } => {
                if !first || hash != identity {
                    return None;
                }
            }
            _ if first => return None,
            Entry::Doubling { parameter } => journal.doubling = Some(parameter),
            Entry::Point { .. } | Entry::Free { .. } => journal.points.push(entry),
            Entry::End { .. } | Entry::Failed { .. } => {
                journal.end = Some(entry);
                break;
            }
        }
        first = false;
    }
    (!first).then_some(journal)
}

/// What identifies branch `index`: the sweep's text, the point's scene and the engine's versions.
pub(super) fn identity(sweep: &Sweep, grid: &Grid, index: usize) -> String {
    let mut h = Sha256::new();
    for part in [
        sweep.text.as_str(),
        &grid.point_value(sweep, index).to_string(),
        crate::ENGINE_VERSION,
        crate::SOLVER_VERSION,
        &crate::NUMERICS_VERSION.to_string(),
    ] {
        h.update(part.as_bytes());
        h.update([0]);
    }
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}
