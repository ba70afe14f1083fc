//! The snapshot: a compact, checksummed second copy of the summaries the published output file
//! holds, `X.h5.d/snapshot`, written with every publish of `X.h5`.
//!
//! Once a sweep is complete its logs are compacted, and `X.h5` holds the only full copy of its
//! runs. When a damaged byte, a truncation or a lost superblock makes runs of `X.h5` unreadable,
//! the snapshot gives their summaries back, checked, without running them again; a run whose
//! histories were lost with it (they are kept in `X.h5` only, as they are most of its size) is
//! run again. The snapshot holds the file's summary columns ([`COLUMNS`], without the run hash
//! and the point checksum) in blocks of [`BLOCK_POINTS`] points, each column byte-shuffled and the
//! block deflate-compressed; each point is named by the first 8 bytes of its run hash. On the
//! paper's summary sweeps it takes 15–30 % of the output file's size.
//!
//! Format (little endian):
//!
//! ```text
//! magic "CSWSNAP\0" | version u32
//! sections, each: kind u8 | length u64 | payload (deflate) | SHA-256 of kind, length, payload
//!   kind 1, header: JSON (Header)
//!   kind 2, block: start u64 | count u64 | run-hash prefix u64 × count (0: pending) | columns
//!     a number column: its values' bytes shuffled (every value's byte 0, then byte 1, …);
//!     a string column: per value, length u32 | UTF-8
//! ```
//!
//! From version 3 on, a column of [`PREDICTED`] holds the XOR of its values' bits with those of
//! the column it mostly equals (`record_max` with `leading_peak`: the leading pulse is most often
//! the record's largest force), so that where they are equal it holds zeros, which deflate packs
//! to almost nothing: a quarter of the snapshot of a 100 000-point summary sweep. Equal values are
//! a whole column's width apart once shuffled, beyond deflate's window in a block of many points.
//!
//! A section whose checksum fails is skipped: its points are not in the snapshot.

use std::collections::HashMap;
use std::io::{Read, Write};
use std::sync::OnceLock;

use flate2::read::DeflateDecoder;
use flate2::write::DeflateEncoder;
use flate2::Compression;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use chainsweep_sweep::identity::RunHash;
use chainsweep_sweep::record::columns::{ColumnData, Fill, Presence, Table, COLUMNS};
use chainsweep_sweep::record::{RunRecord, STATUS_PENDING};

/// The snapshot's file name in a work directory.
pub const SNAPSHOT_FILE: &str = "snapshot";

const MAGIC: &[u8; 8] = b"CSWSNAP\0";
/// Version 2 added the spectrum columns (`lowest_frequency_hz` …) to the columns a snapshot
/// may hold (positional, as the header's presence says: only where `spectrum` is set); a
/// snapshot of version 1 holds none, and is read as one without them. Version 3 stores the
/// columns of [`PREDICTED`] as their XOR with their predictors. Version 4 holds the columns of
/// [`SINCE_4`] too (a snapshot of an earlier version is read without them: fills).
const VERSION: u32 = 4;
/// The columns first held by version 4: the wider verification and the energy ledger.
const SINCE_4: &[&str] = &[
    "verify_rel_error_record_max_time",
    "verify_rel_error_steady",
    "verify_rel_error_max_overlap",
    "verify_rel_error_energy_flow",
];
/// The first version that stores the columns of [`PREDICTED`] as their XOR with their predictors.
const FIRST_PREDICTED: u32 = 3;
/// The earliest version read.
const FIRST_VERSION: u32 = 1;
const KIND_HEADER: u8 = 1;
const KIND_BLOCK: u8 = 2;

/// Points per block: the unit a damaged byte of the snapshot costs.
pub const BLOCK_POINTS: usize = 4096;

/// What the snapshot is a copy of.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// The output file's layout version.
    pub layout_version: i64,
    /// Grid points.
    pub points: usize,
    /// Probes per point.
    pub probes: usize,
    /// Whether the grid has the moving-part columns.
    pub moving_part: bool,
    /// Whether runs record histories or minimum overlaps: those are not in the snapshot.
    pub run_groups: bool,
    /// Whether the grid records the linear spectrum (its columns). (Absent from snapshots of
    /// version 1, which predate it: false.)
    #[serde(default)]
    pub spectrum: bool,
    /// Harmonics of the steady state the grid records (its columns; 0 without, and then left out
    /// of the header, so that the snapshot of every other grid reads as before).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub harmonics: usize,
    /// Whether the grid records the energy ledger (its columns; left out of the header without).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub energy_ledger: bool,
    /// The sweep file's text.
    pub sweep: String,
    /// What `integrator: auto` chose (JSON; empty without).
    pub auto: String,
    /// The shard (`K/N`).
    pub shard: String,
    /// When the output file it copies was written.
    pub created_utc: String,
    /// The SHA-256 (hex) of the whole output file it was published with: a file whose bytes
    /// still hash to it is exactly what was published.
    pub file_sha256: String,
}

impl Header {
    fn presence(&self) -> Presence {
        Presence {
            probes: self.probes,
            moving_part: self.moving_part,
            run_groups: self.run_groups,
            spectrum: self.spectrum,
            harmonics: self.harmonics,
            energy_ledger: self.energy_ledger,
        }
    }
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// The run-hash prefix naming a point in a snapshot.
fn prefix(hash: &RunHash) -> u64 {
    u64::from_le_bytes(hash[..8].try_into().expect("8 bytes"))
}

/// Whether a column is kept in the snapshot: not the run hash (its prefix names the point) nor
/// the point checksum (recomputed from the values when a file is written again).
fn kept(fill: Fill) -> bool {
    !matches!(fill, Fill::RunHash | Fill::SummaryChecksum)
}

/// Whether a snapshot of `version` holds column `c` (where the header's presence has it).
fn stored_in(c: &chainsweep_sweep::record::columns::Column, version: u32) -> bool {
    kept(c.fill) && (version >= 4 || !(SINCE_4.contains(&c.name) || c.name.starts_with("ledger_")))
}

/// Number columns stored as the XOR of their bits with those of an earlier column of the same
/// width (its predictor), which they mostly equal: (column, predictor).
const PREDICTED: [(&str, &str); 3] = [
    // A drift that grows to the end of the run.
    ("energy_drift_final", "energy_drift_max"),
    // A leading pulse that is the record's largest force.
    ("record_max", "leading_peak"),
    ("record_max_time_s", "leading_peak_time_s"),
];

/// The index in [`COLUMNS`] of the predictor of column `at`, when it has one that `table` holds.
fn predictor(table: &Table, at: usize) -> Option<usize> {
    let (_, by) = PREDICTED.iter().find(|(c, _)| *c == COLUMNS[at].name)?;
    let p = COLUMNS.iter().position(|c| c.name == *by)?;
    debug_assert!(
        p < at,
        "a predictor is decoded before the column it predicts"
    );
    matches!(table.columns[p], Some(ColumnData::F64(_))).then_some(p)
}

/// `a` XOR `b`, bit for bit.
fn xor_bits(a: f64, b: f64) -> f64 {
    f64::from_bits(a.to_bits() ^ b.to_bits())
}

fn section(out: &mut Vec<u8>, kind: u8, raw: &[u8]) {
    let mut enc = DeflateEncoder::new(Vec::new(), Compression::new(3));
    enc.write_all(raw).expect("writing to memory");
    let payload = enc.finish().expect("writing to memory");
    let start = out.len();
    out.push(kind);
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&payload);
    let sum: [u8; 32] = Sha256::digest(&out[start..]).into();
    out.extend_from_slice(&sum);
}

fn shuffled<const K: usize>(out: &mut Vec<u8>, values: impl ExactSizeIterator<Item = [u8; K]>) {
    let n = values.len();
    let at = out.len();
    out.resize(at + n * K, 0);
    for (i, v) in values.enumerate() {
        for (b, byte) in v.iter().enumerate() {
            out[at + b * n + i] = *byte;
        }
    }
}

/// The snapshot of a file whose summary columns are `table`, whose points have the run hashes
/// `hashes` (the grid's), described by `header`.
pub fn encode(header: &Header, table: &Table, hashes: &[RunHash]) -> Vec<u8> {
    encode_version(header, table, hashes, VERSION)
}

/// [`encode`] in format `version` (2 or [`VERSION`]; earlier ones are only read).
fn encode_version(header: &Header, table: &Table, hashes: &[RunHash], version: u32) -> Vec<u8> {
    let mut out = Vec::with_capacity(64 + table.n * 64);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&version.to_le_bytes());
    section(
        &mut out,
        KIND_HEADER,
        serde_json::to_string(header).expect("json").as_bytes(),
    );
    let mut start = 0;
    while start < table.n {
        let count = BLOCK_POINTS.min(table.n - start);
        let mut raw = Vec::new();
        raw.extend_from_slice(&(start as u64).to_le_bytes());
        raw.extend_from_slice(&(count as u64).to_le_bytes());
        for (i, h) in hashes.iter().enumerate().skip(start).take(count) {
            let p = if table.status(i) == STATUS_PENDING {
                0
            } else {
                prefix(h)
            };
            raw.extend_from_slice(&p.to_le_bytes());
        }
        for (at, (c, data)) in COLUMNS.iter().zip(&table.columns).enumerate() {
            let Some(d) = data.as_ref().filter(|_| stored_in(c, version)) else {
                continue;
            };
            let k = c.width(table.np, table.nh);
            let range = start * k..(start + count) * k;
            let by = predictor(table, at).filter(|_| version >= FIRST_PREDICTED);
            match (d, by.and_then(|p| table.columns[p].as_ref())) {
                (ColumnData::F64(v), Some(ColumnData::F64(pv))) => shuffled(
                    &mut raw,
                    v[range.clone()]
                        .iter()
                        .zip(&pv[range])
                        .map(|(x, p)| xor_bits(*x, *p).to_bits().to_le_bytes()),
                ),
                (ColumnData::F64(v), _) => {
                    shuffled(&mut raw, v[range].iter().map(|x| x.to_bits().to_le_bytes()))
                }
                (ColumnData::I64(v), _) => {
                    shuffled(&mut raw, v[range].iter().map(|x| x.to_le_bytes()))
                }
                (ColumnData::U64(v), _) => {
                    shuffled(&mut raw, v[range].iter().map(|x| x.to_le_bytes()))
                }
                (ColumnData::U8(v), _) => raw.extend_from_slice(&v[range]),
                (ColumnData::Str(v), _) => {
                    for s in &v[range] {
                        raw.extend_from_slice(&(s.len() as u32).to_le_bytes());
                        raw.extend_from_slice(s.as_bytes());
                    }
                }
            }
        }
        section(&mut out, KIND_BLOCK, &raw);
        start += count;
    }
    out
}

/// A snapshot read back: its header and the checksums of its sections checked when it is read;
/// its blocks inflated and decoded only when a run is first asked of it. A file published with
/// it and unchanged since (the common case: a sweep resumed, `status`) is read from the file
/// alone, and the snapshot's 4 096-point blocks were decoded for nothing: a tenth of a resume
/// of 100 000 runs with nothing to do.
#[derive(Debug, Clone)]
pub struct Snapshot {
    /// What it is a copy of.
    pub header: Header,
    /// Blocks whose checksum failed or that are cut off (their points are not in the snapshot).
    pub damaged_blocks: usize,
    version: u32,
    bytes: Vec<u8>,
    /// Where the payload of each block whose checksum holds lies in `bytes`.
    blocks: Vec<std::ops::Range<usize>>,
    contents: OnceLock<Contents>,
}

/// A snapshot's blocks, decoded.
#[derive(Debug, Clone)]
struct Contents {
    table: Table,
    by_prefix: HashMap<u64, usize>,
}

/// Why a snapshot cannot be used at all.
#[derive(Debug, Clone, PartialEq)]
pub struct Unusable(pub String);

struct Sections<'a> {
    b: &'a [u8],
    at: usize,
}

/// A section: its kind and payload, `None` when its checksum fails.
type Section<'a> = (u8, Option<&'a [u8]>);

impl<'a> Iterator for Sections<'a> {
    type Item = Section<'a>;
    fn next(&mut self) -> Option<Section<'a>> {
        let rest = &self.b[self.at..];
        if rest.len() < 9 + 32 {
            return None;
        }
        let kind = rest[0];
        let len = u64::from_le_bytes(rest[1..9].try_into().expect("8 bytes"));
        // A damaged length: nothing after it can be found.
        let end = usize::try_from(len)
            .ok()
            .and_then(|l| l.checked_add(9))
            .filter(|&e| e.checked_add(32).is_some_and(|t| t <= rest.len()))?;
        let sum: [u8; 32] = Sha256::digest(&rest[..end]).into();
        self.at += end + 32;
        let ok = sum[..] == rest[end..end + 32];
        Some((kind, ok.then(|| &rest[9..end])))
    }
}

/// Inflates `payload`, refusing more than `limit` bytes (a damaged stream cannot exhaust memory).
fn inflate(payload: &[u8], limit: u64) -> Option<Vec<u8>> {
    let mut out = Vec::new();
    DeflateDecoder::new(payload)
        .take(limit + 1)
        .read_to_end(&mut out)
        .ok()?;
    (out.len() as u64 <= limit).then_some(out)
}

struct Cursor<'a> {
    b: &'a [u8],
    at: usize,
}

impl<'a> Cursor<'a> {
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let end = self.at.checked_add(n)?;
        let s = self.b.get(self.at..end)?;
        self.at = end;
        Some(s)
    }
    fn u64(&mut self) -> Option<u64> {
        Some(u64::from_le_bytes(self.take(8)?.try_into().ok()?))
    }
    fn unshuffled<const K: usize>(&mut self, n: usize) -> Option<Vec<[u8; K]>> {
        let bytes = self.take(n.checked_mul(K)?)?;
        Some(
            (0..n)
                .map(|i| std::array::from_fn(|b| bytes[b * n + i]))
                .collect(),
        )
    }
}

/// Most bytes a block inflates to: far more than any block of [`BLOCK_POINTS`] points holds
/// (strings included), so that only a damaged stream reaches it.
const BLOCK_LIMIT: u64 = 1 << 30;

impl Snapshot {
    /// Reads snapshot bytes; an error when they are no snapshot or its header is damaged. Damaged
    /// blocks are skipped and counted. The blocks are decoded when a run is first asked of the
    /// snapshot.
    pub fn decode(bytes: Vec<u8>) -> std::result::Result<Snapshot, Unusable> {
        if bytes.len() < 12 || &bytes[..8] != MAGIC {
            return Err(Unusable("it is not a chainsweep snapshot".into()));
        }
        let version = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
        if !(FIRST_VERSION..=VERSION).contains(&version) {
            return Err(Unusable(format!(
                "its format version {version} is not one of {FIRST_VERSION} to {VERSION}"
            )));
        }
        let mut sections = Sections { b: &bytes, at: 12 };
        let header: Header = match sections.next() {
            Some((KIND_HEADER, Some(p))) => inflate(p, 1 << 28)
                .and_then(|raw| serde_json::from_slice(&raw).ok())
                .ok_or_else(|| Unusable("its header cannot be decoded".into()))?,
            _ => return Err(Unusable("its header is damaged".into())),
        };
        let mut blocks = Vec::new();
        let mut damaged_blocks = 0;
        for (kind, payload) in sections {
            match payload.filter(|_| kind == KIND_BLOCK) {
                Some(p) => {
                    let start = p.as_ptr() as usize - bytes.as_ptr() as usize;
                    blocks.push(start..start + p.len());
                }
                None => damaged_blocks += 1,
            }
        }
        // A truncated snapshot: the blocks cut off are damaged too.
        let expected = header.points.div_ceil(BLOCK_POINTS);
        damaged_blocks = damaged_blocks.max(expected.saturating_sub(blocks.len()));
        Ok(Snapshot {
            header,
            damaged_blocks,
            version,
            bytes,
            blocks,
            contents: OnceLock::new(),
        })
    }

    /// The blocks, decoded on first use. A block whose checksum holds but that does not decode
    /// (which no version of the engine writes) gives nothing, like a damaged one.
    fn contents(&self) -> &Contents {
        self.contents.get_or_init(|| {
            let mut table = Table::empty(self.header.points, self.header.presence());
            let mut by_prefix = HashMap::new();
            for block in &self.blocks {
                // (A malformed block changes nothing of the table: see `read_block`.)
                let _ = inflate(&self.bytes[block.clone()], BLOCK_LIMIT).and_then(|raw| {
                    Self::read_block(&raw, self.version, &mut table, &mut by_prefix)
                });
            }
            for (c, d) in COLUMNS.iter().zip(table.columns.iter_mut()) {
                if !kept(c.fill) {
                    *d = None;
                }
            }
            Contents { table, by_prefix }
        })
    }

    /// Decodes one block into `table`; its point count, `None` when it is malformed (nothing of
    /// it is then taken).
    fn read_block(
        raw: &[u8],
        version: u32,
        table: &mut Table,
        by_prefix: &mut HashMap<u64, usize>,
    ) -> Option<usize> {
        let mut r = Cursor { b: raw, at: 0 };
        let start = usize::try_from(r.u64()?).ok()?;
        let count = usize::try_from(r.u64()?).ok()?;
        if count > BLOCK_POINTS || start.checked_add(count)? > table.n {
            return None;
        }
        let prefixes: Vec<u64> = (0..count).map(|_| r.u64()).collect::<Option<_>>()?;
        let (np, nh) = (table.np, table.nh);
        // Decoded into new columns first: a block malformed halfway changes nothing.
        let mut decoded: Vec<(usize, ColumnData)> = Vec::new();
        for (at, (c, data)) in COLUMNS.iter().zip(&table.columns).enumerate() {
            let Some(d) = data.as_ref().filter(|_| stored_in(c, version)) else {
                continue;
            };
            let n = count * c.width(np, nh);
            let col = match d {
                ColumnData::F64(_) => ColumnData::F64(
                    r.unshuffled::<8>(n)?
                        .into_iter()
                        .map(|b| f64::from_bits(u64::from_le_bytes(b)))
                        .collect(),
                ),
                ColumnData::I64(_) => ColumnData::I64(
                    r.unshuffled::<8>(n)?
                        .into_iter()
                        .map(i64::from_le_bytes)
                        .collect(),
                ),
                ColumnData::U64(_) => ColumnData::U64(
                    r.unshuffled::<8>(n)?
                        .into_iter()
                        .map(u64::from_le_bytes)
                        .collect(),
                ),
                ColumnData::U8(_) => ColumnData::U8(r.take(n)?.to_vec()),
                ColumnData::Str(_) => ColumnData::Str(
                    (0..n)
                        .map(|_| {
                            let len = u32::from_le_bytes(r.take(4)?.try_into().ok()?) as usize;
                            String::from_utf8(r.take(len)?.to_vec()).ok()
                        })
                        .collect::<Option<_>>()?,
                ),
            };
            decoded.push((at, col));
        }
        if r.at != raw.len() {
            return None;
        }
        if version >= FIRST_PREDICTED {
            for j in 0..decoded.len() {
                let Some(p) = predictor(table, decoded[j].0) else {
                    continue;
                };
                let (before, rest) = decoded.split_at_mut(j);
                let by = before.iter().find(|(at, _)| *at == p);
                if let (Some((_, ColumnData::F64(pv))), (_, ColumnData::F64(v))) =
                    (by, &mut rest[0])
                {
                    v.iter_mut()
                        .zip(pv)
                        .for_each(|(x, p)| *x = xor_bits(*x, *p));
                }
            }
        }
        for (at, col) in decoded {
            let k = COLUMNS[at].width(np, nh);
            let range = start * k..(start + count) * k;
            match (table.columns[at].as_mut(), col) {
                (Some(ColumnData::F64(v)), ColumnData::F64(c)) => v[range].copy_from_slice(&c),
                (Some(ColumnData::I64(v)), ColumnData::I64(c)) => v[range].copy_from_slice(&c),
                (Some(ColumnData::U64(v)), ColumnData::U64(c)) => v[range].copy_from_slice(&c),
                (Some(ColumnData::U8(v)), ColumnData::U8(c)) => v[range].copy_from_slice(&c),
                (Some(ColumnData::Str(v)), ColumnData::Str(c)) => {
                    v[range].iter_mut().zip(c).for_each(|(a, b)| *a = b)
                }
                _ => unreachable!("decoded as the table's own type"),
            }
        }
        for (j, p) in prefixes.into_iter().enumerate() {
            if p != 0 && table.status(start + j) != STATUS_PENDING {
                by_prefix.insert(p, start + j);
            }
        }
        Some(count)
    }

    /// Runs the snapshot holds (ok or failed), in intact blocks.
    pub fn len(&self) -> usize {
        self.contents().by_prefix.len()
    }

    /// Whether it holds no run.
    pub fn is_empty(&self) -> bool {
        self.contents().by_prefix.is_empty()
    }

    /// The point holding the run `hash`, if the snapshot has it (in an intact block).
    pub fn find(&self, hash: &RunHash) -> Option<usize> {
        self.contents().by_prefix.get(&prefix(hash)).copied()
    }

    /// The summaries of the run `hash` (without its run group), if the snapshot holds it;
    /// `whole_chain` as for [`Table::record`]. With the checksum of its run group (0: none).
    pub fn record(&self, hash: &RunHash, whole_chain: Option<u64>) -> Option<(RunRecord, u64)> {
        let j = self.find(hash)?;
        let table = &self.contents().table;
        let rec = table.record(j, *hash, whole_chain)?;
        Some((rec, table.checksum_at("history_checksum", j)))
    }

    /// Whether point `j` of the snapshot succeeded (`None`: not in the snapshot).
    pub fn ok(&self, hash: &RunHash) -> Option<bool> {
        self.find(hash)
            .map(|j| chainsweep_sweep::record::holds_values(self.contents().table.status(j)))
    }

    /// The status code of the run `hash`, if the snapshot holds it.
    pub fn status(&self, hash: &RunHash) -> Option<u8> {
        self.find(hash).map(|j| self.contents().table.status(j))
    }

    /// The verification outcome of the run `hash`, if the snapshot holds it.
    pub fn verify_info(&self, hash: &RunHash) -> Option<chainsweep_sweep::record::VerifyInfo> {
        self.find(hash)
            .map(|j| self.contents().table.verify_info(j))
    }

    /// Whether its blocks have been decoded (a run was asked of it).
    #[cfg(test)]
    fn decoded(&self) -> bool {
        self.contents.get().is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use chainsweep_solver::observe::probes::ProbeSummary;
    use chainsweep_sweep::record::columns::PointOutcome;
    use chainsweep_sweep::record::VerifyInfo;

    fn header(n: usize) -> Header {
        Header {
            layout_version: 3,
            points: n,
            probes: 2,
            moving_part: false,
            run_groups: false,
            spectrum: false,
            harmonics: 0,
            energy_ledger: false,
            sweep: "{}".into(),
            auto: String::new(),
            shard: "1/1".into(),
            created_utc: "2026-01-01T00:00:00Z".into(),
            file_sha256: String::new(),
        }
    }

    /// A table of `n` points: every third pending, every fifth failed, the rest ok.
    fn table(n: usize) -> (Table, Vec<RunHash>) {
        let presence = Presence {
            probes: 2,
            moving_part: false,
            run_groups: false,
            spectrum: false,
            harmonics: 0,
            energy_ledger: false,
        };
        let mut t = Table::empty(n, presence);
        let hashes: Vec<RunHash> = (0..n)
            .map(|i| {
                let mut h = [0u8; 32];
                h[..8].copy_from_slice(&(i as u64 * 7919 + 1).to_le_bytes());
                h[31] = i as u8;
                h
            })
            .collect();
        for (i, hash) in hashes.iter().enumerate() {
            let mut rec = RunRecord::failed(*hash, format!("failed {i}"), 0.5);
            if i % 5 != 0 {
                rec.ok = true;
                rec.reason.clear();
                rec.steps = i as u64;
                rec.t_end_s = 1e-3 * i as f64;
                rec.warnings = if i % 2 == 0 {
                    "w".into()
                } else {
                    String::new()
                };
                // Drifts and record maxima equal to their predictors at most points, not all.
                rec.energy_drift_max = 1e-7 * (i as f64).sqrt();
                rec.energy_drift_final = if i % 4 == 1 {
                    0.5 * rec.energy_drift_max
                } else {
                    rec.energy_drift_max
                };
                let peak = 200.0 + (i as f64).ln();
                rec.probes = vec![
                    ProbeSummary {
                        leading_peak: peak,
                        leading_peak_time_s: 2e-5 + 1e-9 * i as f64,
                        record_max: if i % 7 == 1 { peak * 1.01 } else { peak },
                        record_max_time_s: if i % 7 == 1 {
                            3e-5
                        } else {
                            2e-5 + 1e-9 * i as f64
                        },
                    };
                    2
                ];
                rec.probes[1].record_max_time_s = f64::NAN;
            }
            let verify = VerifyInfo::none(2);
            let hex = chainsweep_sweep::identity::hex(hash);
            let pending = i % 3 == 0;
            t.fill_point(
                i,
                &PointOutcome {
                    hash_hex: &hex,
                    record: (!pending).then_some(&rec),
                    verify: (!pending).then_some(&verify),
                },
            );
        }
        (t, hashes)
    }

    #[test]
    fn a_snapshot_gives_back_every_finished_run_bitwise() {
        let n = 2 * BLOCK_POINTS + 17;
        let (t, hashes) = table(n);
        let bytes = encode(&header(n), &t, &hashes);
        let s = Snapshot::decode(bytes.clone()).unwrap();
        assert_eq!(s.header, header(n));
        assert_eq!(s.damaged_blocks, 0);
        // Read, its checksums checked, but no block decoded until a run is asked of it.
        assert!(!s.decoded());
        for (i, h) in hashes.iter().enumerate() {
            let want = t.record(i, *h, Some(12));
            let got = s.record(h, Some(12)).map(|(r, _)| r);
            assert_eq!(
                want.as_ref().map(crate::segment::encode),
                got.as_ref().map(crate::segment::encode),
                "point {i}"
            );
        }
        assert_eq!(s.len(), (0..n).filter(|i| i % 3 != 0).count());
    }

    #[test]
    fn version_3_stores_what_its_predictors_tell_as_zeros_and_version_2_still_reads() {
        let n = 2 * BLOCK_POINTS + 17;
        let (t, hashes) = table(n);
        let v3 = encode(&header(n), &t, &hashes);
        let v2 = encode_version(&header(n), &t, &hashes, 2);
        assert_eq!(u32::from_le_bytes(v3[8..12].try_into().unwrap()), VERSION);
        // The record maxima, the second probe's times aside, and three drifts in four are their
        // predictors': those bytes go.
        assert!(
            v3.len() * 10 < v2.len() * 9,
            "{} against {}",
            v3.len(),
            v2.len()
        );
        let (a, b) = (
            Snapshot::decode(v3.clone()).unwrap(),
            Snapshot::decode(v2.clone()).unwrap(),
        );
        let enc = crate::segment::encode;
        for (i, h) in hashes.iter().enumerate() {
            let want = t.record(i, *h, None).as_ref().map(enc);
            assert_eq!(a.record(h, None).map(|(r, _)| enc(&r)), want, "point {i}");
            assert_eq!(b.record(h, None).map(|(r, _)| enc(&r)), want, "point {i}");
        }
    }

    #[test]
    fn a_damaged_block_costs_its_points_only() {
        let n = 3 * BLOCK_POINTS;
        let (t, hashes) = table(n);
        let mut bytes = encode(&header(n), &t, &hashes);
        // A byte in the middle of the file: inside the second block (the header is short).
        let at = bytes.len() / 2;
        bytes[at] ^= 0x10;
        let s = Snapshot::decode(bytes.clone()).unwrap();
        assert_eq!(s.damaged_blocks, 1);
        let held: Vec<usize> = (0..n).filter(|&i| s.find(&hashes[i]).is_some()).collect();
        assert!(held.iter().all(|&i| i % 3 != 0));
        let lost = (0..n).filter(|&i| i % 3 != 0).count() - held.len();
        assert!(lost > 0 && lost <= BLOCK_POINTS, "{lost}");
        // Every run it still gives is the original.
        for &i in &held {
            let (r, _) = s.record(&hashes[i], None).unwrap();
            let want = t.record(i, hashes[i], None).unwrap();
            let enc = crate::segment::encode;
            assert_eq!(enc(&r), enc(&want));
        }
        // Truncated: the blocks cut off are gone, the others stay.
        let cut = Snapshot::decode(bytes[..bytes.len() - 100].to_vec()).unwrap();
        assert_eq!(cut.damaged_blocks, 2);
        // A damaged header: unusable, said so.
        let mut bad = encode(&header(n), &t, &hashes);
        bad[20] ^= 1;
        assert!(Snapshot::decode(bad.clone()).is_err());
        assert!(Snapshot::decode(b"CSWSEG\x00\x03".to_vec()).is_err());
    }
}
