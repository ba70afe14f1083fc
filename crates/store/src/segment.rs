//! Segment files: one [`RunRecord`] each.
//!
//! A segment holds one finished run (successful or failed) in a small binary format, little
//! endian, ending in the SHA-256 of everything before it:
//!
//! ```text
//! magic "CSWSEG\0\4" | run hash (32) | ok (u8) | reason (u32 length + UTF-8)
//! steps, rejected, rhs_evals, events (u64 ×4)
//! t_end_s, energy_drift_max, energy_drift_final, momentum_residual_max, impact_energy_j, wall_time_s,
//!   max_overlap_m (f64 ×7)
//! warnings (u32 length + UTF-8, one warning per line)
//! n_probes (u32) | per probe: leading_peak, leading_peak_time_s, record_max, record_max_time_s (f64 ×4)
//! has_min_overlap (u8) [n (u32) | f64 ×n]
//! has_history (u8) [n_series (u32) | n_samples (u64) | time_s f64 ×n_samples | series f64 ×n_samples each]
//! has_integrated (u8) [moving_part (u8: 0 whole chain, 1 moving part) | integrated_particles (u64)]
//! has_spectrum (u8) [lowest_frequency_hz, highest_frequency_hz, gap_lower_hz, gap_upper_hz,
//!   band_top_hz (f64 ×5)]
//! [fields, only for a run that recorded them: 1 (u8) | n_samples (u64) | time_s f64 ×n_samples |
//!   n_series (u32) | per series: quantity (u8: 0 contact_force, 1 displacement, 2 velocity) |
//!   width (u64) | values f64 ×(n_samples · width), time slowest]
//! [steady state, only for a run that recorded it: 2 (u8) | frequency_hz (f64) | n_probes (u32) |
//!   harmonics (u32) | per probe: mean, rms, settledness, transmission_db (f64 ×4), settled (u8),
//!   amplitude f64 ×harmonics, phase_rad f64 ×harmonics]
//! [energy flow, only for a run that recorded it: 3 (u8) | n_contacts (u32) |
//!   energy_passed_max_j f64 ×n_contacts | energy_passed_final_j f64 ×n_contacts |
//!   n_particles (u32) | max_kinetic_energy_j f64 ×n_particles]
//! [energy ledger, only for a run that recorded it: 4 (u8) | the ledger's 7 terms at the start,
//!   then at the end (f64 ×14)]
//! checksum (32)
//! ```
//!
//! The steady state (`record.steady_state`) is a second optional trailing part, told from the
//! fields by its first byte: records without it are byte for byte what earlier versions wrote;
//! earlier versions take one with it as damaged and compute the run again. The energy flow
//! (`record.energy_flow`) is a third, after it, the same way.
//!
//! The space–time fields (`record.fields`) are an optional trailing part of format 4: a record
//! without them is byte for byte what earlier versions wrote (which read it), one with them is
//! longer (earlier versions, which know no fields, take it as damaged and compute the run again).
//!
//! Floats are stored as their bits, so a record read back is bitwise the record written.
//!
//! Format 4 (this one) added `has_spectrum` and what follows it: the linear spectrum at the
//! static state (`record.spectrum`). Format 3 is format 4 without it, read with no spectrum (no
//! run of an earlier version recorded one). Format 3 added `has_integrated` and what follows it:
//! how much of the chain the run integrated. Format 2 is format 3 without it; its records are read (their runs keep their
//! hashes: the numerics did not change) with that part not known (`None`), so stores written by
//! earlier versions resume and merge without recomputing anything. Format 2 added `events`,
//! `max_overlap_m` and `warnings`. Segments of format 1 are not decoded (they read as missing);
//! they cannot be looked up anyway, since their runs were hashed with numerics version 1 and are
//! recomputed.

use chainsweep_solver::observe::probes::{
    FieldQuantity, FieldSeries, Fields, History, ProbeSummary,
};
use sha2::{Digest, Sha256};

use chainsweep_solver::observe::flow::EnergyFlow;
use chainsweep_solver::observe::steady::{SteadyProbe, SteadyState};
use chainsweep_solver::spectrum::SpectrumSummary;

use chainsweep_sweep::identity::RunHash;
use chainsweep_sweep::record::RunRecord;

const MAGIC: &[u8; 8] = b"CSWSEG\x00\x04";
/// Bytes of the SHA-256 that ends a segment.
pub const CHECKSUM_BYTES: usize = 32;
/// Magic of format 3: format 4 without the spectrum (read, with none).
const MAGIC_V3: &[u8; 8] = b"CSWSEG\x00\x03";
/// Magic of format 2: format 3 without what the run integrated (read, that part not known).
const MAGIC_V2: &[u8; 8] = b"CSWSEG\x00\x02";
/// Magic of format 1 (read only by [`peek_status`]).
const MAGIC_V1: &[u8; 8] = b"CSWSEG\x00\x01";

/// Encodes a record as segment bytes.
pub fn encode(rec: &RunRecord) -> Vec<u8> {
    let mut b = Vec::with_capacity(256);
    b.extend_from_slice(MAGIC);
    b.extend_from_slice(&rec.hash);
    b.push(rec.ok as u8);
    put_u32(&mut b, rec.reason.len() as u32);
    b.extend_from_slice(rec.reason.as_bytes());
    for x in [rec.steps, rec.rejected, rec.rhs_evals, rec.events] {
        b.extend_from_slice(&x.to_le_bytes());
    }
    for x in [
        rec.t_end_s,
        rec.energy_drift_max,
        rec.energy_drift_final,
        rec.momentum_residual_max,
        rec.impact_energy_j,
        rec.wall_time_s,
        rec.max_overlap_m,
    ] {
        put_f64(&mut b, x);
    }
    put_u32(&mut b, rec.warnings.len() as u32);
    b.extend_from_slice(rec.warnings.as_bytes());
    put_u32(&mut b, rec.probes.len() as u32);
    for p in &rec.probes {
        for x in [
            p.leading_peak,
            p.leading_peak_time_s,
            p.record_max,
            p.record_max_time_s,
        ] {
            put_f64(&mut b, x);
        }
    }
    match &rec.min_overlap_m {
        None => b.push(0),
        Some(v) => {
            b.push(1);
            put_u32(&mut b, v.len() as u32);
            v.iter().for_each(|&x| put_f64(&mut b, x));
        }
    }
    match &rec.history {
        None => b.push(0),
        Some(h) => {
            b.push(1);
            put_u32(&mut b, h.values.len() as u32);
            b.extend_from_slice(&(h.time_s.len() as u64).to_le_bytes());
            h.time_s.iter().for_each(|&x| put_f64(&mut b, x));
            for s in &h.values {
                s.iter().for_each(|&x| put_f64(&mut b, x));
            }
        }
    }
    match (rec.moving_part, rec.integrated_particles) {
        (Some(moving), Some(n)) => {
            b.push(1);
            b.push(moving as u8);
            b.extend_from_slice(&n.to_le_bytes());
        }
        _ => b.push(0),
    }
    match &rec.spectrum {
        None => b.push(0),
        Some(s) => {
            b.push(1);
            for x in [
                s.lowest_frequency_hz,
                s.highest_frequency_hz,
                s.gap_lower_hz,
                s.gap_upper_hz,
                s.band_top_hz,
            ] {
                put_f64(&mut b, x);
            }
        }
    }
    if let Some(f) = &rec.fields {
        b.push(FIELDS_TAG);
        b.extend_from_slice(&(f.time_s.len() as u64).to_le_bytes());
        f.time_s.iter().for_each(|&x| put_f64(&mut b, x));
        put_u32(&mut b, f.series.len() as u32);
        for s in &f.series {
            b.push(s.quantity.code());
            b.extend_from_slice(&(s.width as u64).to_le_bytes());
            s.values.iter().for_each(|&x| put_f64(&mut b, x));
        }
    }
    if let Some(st) = &rec.steady_state {
        b.push(STEADY_TAG);
        put_f64(&mut b, st.frequency_hz);
        put_u32(&mut b, st.probes.len() as u32);
        let h = st.probes.first().map_or(0, |p| p.amplitude.len());
        put_u32(&mut b, h as u32);
        for p in &st.probes {
            for x in [p.mean, p.rms, p.settledness, p.transmission_db] {
                put_f64(&mut b, x);
            }
            b.push(p.settled as u8);
            debug_assert_eq!((p.amplitude.len(), p.phase_rad.len()), (h, h));
            p.amplitude.iter().for_each(|&x| put_f64(&mut b, x));
            p.phase_rad.iter().for_each(|&x| put_f64(&mut b, x));
        }
    }
    if let Some(f) = &rec.energy_flow {
        b.push(FLOW_TAG);
        put_u32(&mut b, f.energy_passed_max_j.len() as u32);
        debug_assert_eq!(f.energy_passed_final_j.len(), f.energy_passed_max_j.len());
        f.energy_passed_max_j
            .iter()
            .for_each(|&x| put_f64(&mut b, x));
        f.energy_passed_final_j
            .iter()
            .for_each(|&x| put_f64(&mut b, x));
        put_u32(&mut b, f.max_kinetic_energy_j.len() as u32);
        f.max_kinetic_energy_j
            .iter()
            .for_each(|&x| put_f64(&mut b, x));
    }
    if let Some(terms) = &rec.energy_ledger {
        b.push(LEDGER_TAG);
        terms.iter().flatten().for_each(|&x| put_f64(&mut b, x));
    }
    let sum: [u8; CHECKSUM_BYTES] = Sha256::digest(&b).into();
    b.extend_from_slice(&sum);
    b
}

/// First byte of the fields' trailing part.
const FIELDS_TAG: u8 = 1;
/// First byte of the steady state's trailing part.
const STEADY_TAG: u8 = 2;
/// First byte of the energy flow's trailing part.
const FLOW_TAG: u8 = 3;
/// First byte of the energy ledger's trailing part.
const LEDGER_TAG: u8 = 4;

/// Decodes segment bytes; `None` if they are truncated, corrupt or not a segment.
pub fn decode(bytes: &[u8]) -> Option<RunRecord> {
    Checked::verify(bytes.to_vec())?.decode()
}

/// The record of a segment's `body` (its bytes before the checksum), not checked against it.
fn parse(body: &[u8]) -> Option<RunRecord> {
    let mut r = Reader { b: body, at: 0 };
    let magic = r.take(8)?;
    if magic != MAGIC && magic != MAGIC_V3 && magic != MAGIC_V2 {
        return None;
    }
    let hash: RunHash = r.take(32)?.try_into().ok()?;
    let ok = r.take(1)?[0] == 1;
    let n = r.u32()? as usize;
    let reason = String::from_utf8(r.take(n)?.to_vec()).ok()?;
    let steps = r.u64()?;
    let rejected = r.u64()?;
    let rhs_evals = r.u64()?;
    let events = r.u64()?;
    let mut f = [0.0; 7];
    for x in &mut f {
        *x = r.f64()?;
    }
    let n = r.u32()? as usize;
    let warnings = String::from_utf8(r.take(n)?.to_vec()).ok()?;
    let n_probes = r.u32()? as usize;
    let mut probes = Vec::with_capacity(n_probes);
    for _ in 0..n_probes {
        probes.push(ProbeSummary {
            leading_peak: r.f64()?,
            leading_peak_time_s: r.f64()?,
            record_max: r.f64()?,
            record_max_time_s: r.f64()?,
        });
    }
    let min_overlap_m = if r.take(1)?[0] == 1 {
        let n = r.u32()? as usize;
        Some(r.f64s(n)?)
    } else {
        None
    };
    let history = if r.take(1)?[0] == 1 {
        let series = r.u32()? as usize;
        let samples = r.u64()? as usize;
        let time_s = r.f64s(samples)?;
        let mut values = Vec::with_capacity(series);
        for _ in 0..series {
            values.push(r.f64s(samples)?);
        }
        Some(History { time_s, values })
    } else {
        None
    };
    let (moving_part, integrated_particles) = if magic != MAGIC_V2 && r.take(1)?[0] == 1 {
        let moving = r.take(1)?[0] == 1;
        (Some(moving), Some(r.u64()?))
    } else {
        (None, None)
    };
    let spectrum = if magic == MAGIC && r.take(1)?[0] == 1 {
        Some(SpectrumSummary {
            lowest_frequency_hz: r.f64()?,
            highest_frequency_hz: r.f64()?,
            gap_lower_hz: r.f64()?,
            gap_upper_hz: r.f64()?,
            band_top_hz: r.f64()?,
        })
    } else {
        None
    };
    let fields = if magic == MAGIC && r.at < body.len() && body[r.at] == FIELDS_TAG {
        r.take(1)?;
        let samples = r.u64()? as usize;
        let time_s = r.f64s(samples)?;
        let n = r.u32()? as usize;
        let mut series = Vec::with_capacity(n.min(FieldQuantity::ALL.len()));
        for _ in 0..n {
            let quantity = FieldQuantity::from_code(r.take(1)?[0])?;
            let width = r.u64()? as usize;
            let values = r.f64s(samples.checked_mul(width)?)?;
            series.push(FieldSeries {
                quantity,
                width,
                values,
            });
        }
        Some(Fields { time_s, series })
    } else {
        None
    };
    let steady_state = if magic == MAGIC && r.at < body.len() && body[r.at] == STEADY_TAG {
        r.take(1)?;
        let frequency_hz = r.f64()?;
        let n = r.u32()? as usize;
        let h = r.u32()? as usize;
        // (Bounded by the record's length: each probe takes at least 33 bytes.)
        let mut probes = Vec::with_capacity(n.min(body.len() / 33));
        for _ in 0..n {
            let (mean, rms, settledness, transmission_db) =
                (r.f64()?, r.f64()?, r.f64()?, r.f64()?);
            let settled = match r.take(1)?[0] {
                0 => false,
                1 => true,
                _ => return None,
            };
            probes.push(SteadyProbe {
                mean,
                rms,
                amplitude: r.f64s(h)?,
                phase_rad: r.f64s(h)?,
                settledness,
                settled,
                transmission_db,
            });
        }
        Some(SteadyState {
            frequency_hz,
            probes,
        })
    } else {
        None
    };
    let energy_flow = if magic == MAGIC && r.at < body.len() && body[r.at] == FLOW_TAG {
        r.take(1)?;
        let n = r.u32()? as usize;
        let energy_passed_max_j = r.f64s(n)?;
        let energy_passed_final_j = r.f64s(n)?;
        let n = r.u32()? as usize;
        Some(EnergyFlow {
            energy_passed_max_j,
            energy_passed_final_j,
            max_kinetic_energy_j: r.f64s(n)?,
        })
    } else {
        None
    };
    let energy_ledger = if magic == MAGIC && r.at < body.len() {
        if r.take(1)?[0] != LEDGER_TAG {
            return None;
        }
        let v = r.f64s(14)?;
        let mut terms = [[0.0; 7]; 2];
        for (t, x) in terms.iter_mut().flatten().zip(v) {
            *t = x;
        }
        Some(terms)
    } else {
        None
    };
    if r.at != body.len() {
        return None;
    }
    Some(RunRecord {
        hash,
        ok,
        reason,
        steps,
        rejected,
        rhs_evals,
        events,
        t_end_s: f[0],
        energy_drift_max: f[1],
        energy_drift_final: f[2],
        momentum_residual_max: f[3],
        impact_energy_j: f[4],
        wall_time_s: f[5],
        max_overlap_m: f[6],
        warnings,
        integrated_particles,
        moving_part,
        probes,
        min_overlap_m,
        history,
        fields,
        energy_flow,
        spectrum,
        steady_state,
        energy_ledger,
    })
}

/// The run hash and status of segment bytes whose checksum holds; `None` if they are truncated,
/// corrupt or not a segment of a format [`decode`] reads (4, 3 or 2). Reads no more than the header past the checksum.
pub fn verify(bytes: &[u8]) -> Option<(RunHash, bool)> {
    if bytes.len() < MAGIC.len() + 32 + 1 + CHECKSUM_BYTES {
        return None;
    }
    let (body, sum) = bytes.split_at(bytes.len() - CHECKSUM_BYTES);
    let check: [u8; CHECKSUM_BYTES] = Sha256::digest(body).into();
    if check != sum {
        return None;
    }
    header(body)
}

/// The run hash and status in a segment's `body`, if it is of a format [`decode`] reads.
fn header(body: &[u8]) -> Option<(RunHash, bool)> {
    if body.len() < MAGIC.len() + 32 + 1
        || ![MAGIC, MAGIC_V3, MAGIC_V2].contains(&body[..8].try_into().ok()?)
    {
        return None;
    }
    let hash: RunHash = body[8..40].try_into().ok()?;
    Some((hash, body[40] == 1))
}

/// Segment bytes whose SHA-256 has been checked, and whose header is of a format [`decode`] reads:
/// made only here, by checking the whole checksum ([`Checked::verify`]) or the bytes of it a packed
/// log record keeps ([`Checked::restore`]), so that a reader trusts a record checked once instead
/// of hashing it again.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Checked {
    bytes: Vec<u8>,
    hash: RunHash,
    ok: bool,
}

impl Checked {
    /// `bytes` checked against the SHA-256 they end in; `None` when it does not hold (or they are
    /// no segment [`decode`] reads).
    pub fn verify(bytes: Vec<u8>) -> Option<Checked> {
        let (hash, ok) = verify(&bytes)?;
        Some(Checked { bytes, hash, ok })
    }

    /// The segment bytes of a record stored with only the first `kept` bytes of its SHA-256
    /// (`cut`: its body, then those bytes), whole again: the SHA-256 of the body, provided it
    /// begins with the bytes kept; `None` when it does not (damaged).
    pub fn restore(mut cut: Vec<u8>, kept: usize) -> Option<Checked> {
        let body = cut.len().checked_sub(kept)?;
        let sum: [u8; CHECKSUM_BYTES] = Sha256::digest(&cut[..body]).into();
        if kept > CHECKSUM_BYTES || cut[body..] != sum[..kept] {
            return None;
        }
        let (hash, ok) = header(&cut[..body])?;
        cut.truncate(body);
        cut.extend_from_slice(&sum);
        Some(Checked {
            bytes: cut,
            hash,
            ok,
        })
    }

    /// The run's hash.
    pub fn hash(&self) -> RunHash {
        self.hash
    }

    /// Whether the run succeeded.
    pub fn ok(&self) -> bool {
        self.ok
    }

    /// The record (its checksum is not computed again).
    pub fn decode(&self) -> Option<RunRecord> {
        parse(&self.bytes[..self.bytes.len() - CHECKSUM_BYTES])
    }

    /// The segment bytes, checksum included.
    pub fn bytes(&self) -> &[u8] {
        &self.bytes
    }
}

/// Reads only the status part of segment bytes (no checksum check): `(ok, reason)`.
pub fn peek_status(bytes: &[u8]) -> Option<(bool, String)> {
    let mut r = Reader { b: bytes, at: 0 };
    let magic = r.take(8)?;
    if ![MAGIC, MAGIC_V3, MAGIC_V2, MAGIC_V1].contains(&magic.try_into().ok()?) {
        return None;
    }
    r.take(32)?;
    let ok = r.take(1)?[0] == 1;
    let n = r.u32()? as usize;
    let reason = String::from_utf8_lossy(r.take(n)?).into_owned();
    Some((ok, reason))
}

fn put_u32(b: &mut Vec<u8>, x: u32) {
    b.extend_from_slice(&x.to_le_bytes());
}

fn put_f64(b: &mut Vec<u8>, x: f64) {
    b.extend_from_slice(&x.to_bits().to_le_bytes());
}

struct Reader<'a> {
    b: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let end = self.at.checked_add(n)?;
        let s = self.b.get(self.at..end)?;
        self.at = end;
        Some(s)
    }
    fn u32(&mut self) -> Option<u32> {
        Some(u32::from_le_bytes(self.take(4)?.try_into().ok()?))
    }
    fn u64(&mut self) -> Option<u64> {
        Some(u64::from_le_bytes(self.take(8)?.try_into().ok()?))
    }
    fn f64(&mut self) -> Option<f64> {
        Some(f64::from_bits(self.u64()?))
    }
    fn f64s(&mut self, n: usize) -> Option<Vec<f64>> {
        let bytes = self.take(n.checked_mul(8)?)?;
        Some(
            bytes
                .chunks_exact(8)
                .map(|c| f64::from_bits(u64::from_le_bytes(c.try_into().expect("8 bytes"))))
                .collect(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_is_bitwise() {
        let rec = RunRecord {
            hash: [7; 32],
            ok: true,
            reason: String::new(),
            steps: 10,
            rejected: 2,
            rhs_evals: 130,
            events: 12,
            t_end_s: 1e-3,
            energy_drift_max: 1e-9,
            energy_drift_final: 5e-10,
            momentum_residual_max: 1e-12,
            impact_energy_j: 0.0017,
            wall_time_s: 0.01,
            max_overlap_m: 2.5e-6,
            warnings: "first\nsecond ü".to_string(),
            integrated_particles: Some(192),
            moving_part: Some(true),
            probes: vec![ProbeSummary {
                leading_peak: 100.0,
                leading_peak_time_s: f64::NAN,
                record_max: 110.5,
                record_max_time_s: 2e-5,
            }],
            min_overlap_m: Some(vec![-1e-7, 3e-6]),
            history: Some(History {
                time_s: vec![0.0, 1e-6],
                values: vec![vec![1.0, 2.0]],
            }),
            fields: Some(Fields {
                time_s: vec![0.0, 1e-6],
                series: vec![
                    FieldSeries {
                        quantity: FieldQuantity::ContactForce,
                        width: 3,
                        values: vec![0.0, 1.5, -0.0, 2.0, f64::NAN, 4.0],
                    },
                    FieldSeries {
                        quantity: FieldQuantity::Velocity,
                        width: 2,
                        values: vec![1.3, 0.0, 1.2, 0.1],
                    },
                ],
            }),
            spectrum: Some(SpectrumSummary {
                lowest_frequency_hz: 17.0,
                highest_frequency_hz: 2.4e4,
                gap_lower_hz: 1.1e4,
                gap_upper_hz: 1.6e4,
                band_top_hz: 2.5e4,
            }),
            steady_state: Some(SteadyState {
                frequency_hz: 1302.5,
                probes: vec![SteadyProbe {
                    mean: 10.0,
                    rms: 10.5,
                    amplitude: vec![3.1, 1e-12, f64::NAN],
                    phase_rad: vec![-3.0, 0.5, f64::NAN],
                    settledness: 2e-3,
                    settled: false,
                    transmission_db: f64::NEG_INFINITY,
                }],
            }),
            energy_flow: Some(EnergyFlow {
                energy_passed_max_j: vec![1e-3, 5e-4, -0.0],
                energy_passed_final_j: vec![9e-4, -1e-6, 0.0],
                max_kinetic_energy_j: vec![1e-3, 2e-4],
            }),
            energy_ledger: Some([
                [1e-3, 0.0, -1e-9, 0.0, 0.0, 0.0, 0.0],
                [2e-4, 3e-4, -2e-9, 4e-4, 1e-4, -0.0, f64::NAN],
            ]),
        };
        let bytes = encode(&rec);
        let back = decode(&bytes).unwrap();
        assert_eq!(back.energy_flow, rec.energy_flow);
        assert_eq!(
            back.energy_ledger.map(|t| t.map(|r| r.map(f64::to_bits))),
            rec.energy_ledger.map(|t| t.map(|r| r.map(f64::to_bits)))
        );
        // The energy flow alone, the steady state alone and the ledger alone read back.
        for (steady, flow, ledger) in [
            (true, false, false),
            (false, true, false),
            (false, false, true),
            (true, false, true),
        ] {
            let part = RunRecord {
                fields: None,
                steady_state: rec.steady_state.clone().filter(|_| steady),
                energy_flow: rec.energy_flow.clone().filter(|_| flow),
                energy_ledger: rec.energy_ledger.filter(|_| ledger),
                ..rec.clone()
            };
            let b = encode(&part);
            assert_eq!(encode(&decode(&b).unwrap()), b);
        }
        let st = back.steady_state.as_ref().unwrap();
        assert_eq!((st.frequency_hz, st.probes[0].settled), (1302.5, false));
        assert_eq!(st.probes[0].phase_rad[..2], [-3.0, 0.5]);
        // Without the fields before it, the steady state alone still reads back.
        let mut alone = rec.clone();
        alone.fields = None;
        alone.energy_flow = None;
        alone.energy_ledger = None;
        let alone_bytes = encode(&alone);
        assert_eq!(encode(&decode(&alone_bytes).unwrap()), alone_bytes);
        // A record cut inside its steady state is damaged, never read short.
        let mut cut = alone_bytes[..alone_bytes.len() - 32 - 8].to_vec();
        let sum: [u8; 32] = Sha256::digest(&cut).into();
        cut.extend_from_slice(&sum);
        assert!(decode(&cut).is_none());
        assert_eq!(encode(&back), bytes);
        assert!(back.probes[0].leading_peak_time_s.is_nan());
        assert_eq!(
            (back.events, back.max_overlap_m.to_bits()),
            (12, 2.5e-6f64.to_bits())
        );
        assert_eq!(back.warnings, "first\nsecond ü");
        let f = back.fields.as_ref().unwrap();
        assert_eq!(f.series[1].quantity, FieldQuantity::Velocity);
        assert_eq!(f.series[0].values[2].to_bits(), (-0.0f64).to_bits());
        // Without fields, the record is what earlier versions wrote: the fields' part is all it
        // adds (1 + 8 + 2 × 8 + 4 + 2 × (1 + 8) + 10 × 8 bytes).
        // (The fields' part, of a record without the steady state after it.)
        let bytes = encode(&RunRecord {
            steady_state: None,
            energy_flow: None,
            energy_ledger: None,
            ..rec.clone()
        });
        let without = encode(&RunRecord {
            fields: None,
            steady_state: None,
            energy_flow: None,
            energy_ledger: None,
            ..rec.clone()
        });
        assert_eq!(bytes.len() - without.len(), 1 + 8 + 16 + 4 + 18 + 80);
        assert!(decode(&without).unwrap().fields.is_none());
        // A fields part with a bad marker or quantity is damage.
        let mut bad = bytes.clone();
        let at = without.len() - 32;
        bad[at] = 9;
        let n = bad.len() - 32;
        let sum: [u8; 32] = Sha256::digest(&bad[..n]).into();
        bad[n..].copy_from_slice(&sum);
        assert!(decode(&bad).is_none());
        assert_eq!(
            (back.integrated_particles, back.moving_part),
            (Some(192), Some(true))
        );
        let whole = RunRecord {
            fields: None,
            integrated_particles: Some(601),
            moving_part: Some(false),
            ..rec.clone()
        };
        let back = decode(&encode(&whole)).unwrap();
        assert_eq!(
            (back.integrated_particles, back.moving_part),
            (Some(601), Some(false))
        );
        assert_eq!(peek_status(&bytes), Some((true, String::new())));
        assert_eq!(verify(&bytes), Some(([7; 32], true)));
        // Any truncation or flipped byte is detected.
        assert!(decode(&bytes[..bytes.len() - 1]).is_none());
        let mut bad = bytes.clone();
        bad[50] ^= 1;
        assert!(decode(&bad).is_none());
        assert!(verify(&bad).is_none());
    }

    /// Segment bytes of an earlier format, as earlier versions wrote them: format 4 without its
    /// trailing `has_spectrum` byte (format 3) and, for format 2, without `has_integrated` before
    /// it, under that format's magic, with their own checksum.
    fn as_format(rec: &RunRecord, magic: &[u8; 8]) -> Vec<u8> {
        assert!(rec.spectrum.is_none());
        let v4 = encode(rec);
        let cut = if magic == MAGIC_V2 {
            assert!(rec.integrated_particles.is_none() && rec.moving_part.is_none());
            assert_eq!(v4[v4.len() - 34], 0, "the trailing has_integrated byte");
            34
        } else {
            33
        };
        assert_eq!(v4[v4.len() - 33], 0, "the trailing has_spectrum byte");
        let mut body = v4[..v4.len() - cut].to_vec();
        body[..8].copy_from_slice(magic);
        let sum: [u8; 32] = Sha256::digest(&body).into();
        body.extend_from_slice(&sum);
        body
    }

    fn as_format_2(rec: &RunRecord) -> Vec<u8> {
        as_format(rec, MAGIC_V2)
    }

    #[test]
    fn a_checked_record_is_checked_once_by_its_whole_checksum_or_the_bytes_kept() {
        let mut rec = RunRecord::failed([3; 32], "why".into(), 0.5);
        rec.warnings = "a warning".into();
        let seg = encode(&rec);
        let body = seg.len() - CHECKSUM_BYTES;
        let whole = Checked::verify(seg.clone()).unwrap();
        assert_eq!((whole.hash(), whole.ok()), ([3; 32], false));
        // (Compared as encoded: the failed run's NaNs are not equal to themselves.)
        assert_eq!(whole.decode().map(|r| encode(&r)), Some(seg.clone()));
        assert_eq!(whole.bytes(), &seg[..]);
        // Eight bytes of the checksum kept: the whole segment back, the same record.
        let restored = Checked::restore(seg[..body + 8].to_vec(), 8).unwrap();
        assert_eq!(restored, whole);
        // A flipped bit anywhere, in the body or in the checksum (kept or whole), is caught.
        for at in [0, 9, 40, body - 1, body, body + 7] {
            let mut bad = seg.clone();
            bad[at] ^= 0x08;
            assert_eq!(Checked::verify(bad.clone()), None, "byte {at}");
            assert_eq!(
                Checked::restore(bad[..body + 8].to_vec(), 8),
                None,
                "byte {at}"
            );
        }
        // Too short to hold the bytes said to be kept, or more kept than a checksum has.
        assert_eq!(Checked::restore(vec![1, 2, 3], 8), None);
        assert_eq!(Checked::restore(seg.clone(), CHECKSUM_BYTES + 1), None);
    }

    #[test]
    fn format_3_is_read_without_a_spectrum() {
        let mut rec = RunRecord::failed([5; 32], String::new(), 0.5);
        rec.ok = true;
        rec.integrated_particles = Some(40);
        rec.moving_part = Some(false);
        let old = as_format(&rec, MAGIC_V3);
        assert_eq!(verify(&old), Some(([5; 32], true)));
        let back = decode(&old).expect("format 3 decodes");
        assert_eq!((back.integrated_particles, back.spectrum), (Some(40), None));
        // A spectrum grows the record by its 40 bytes, bitwise kept.
        rec.spectrum = Some(SpectrumSummary {
            lowest_frequency_hz: 12.5,
            highest_frequency_hz: 3.5e4,
            gap_lower_hz: f64::NAN,
            gap_upper_hz: f64::NAN,
            band_top_hz: 3.6e4,
        });
        let new = encode(&rec);
        assert_eq!(new.len(), old.len() + 1 + 40);
        let s = decode(&new).unwrap().spectrum.unwrap();
        assert_eq!(
            (
                s.lowest_frequency_hz,
                s.band_top_hz,
                s.gap_lower_hz.is_nan()
            ),
            (12.5, 3.6e4, true)
        );
    }

    #[test]
    fn format_2_is_read_with_the_integrated_part_not_known() {
        let mut rec = RunRecord::failed([9; 32], String::new(), 0.25);
        rec.ok = true;
        rec.steps = 77;
        rec.probes = vec![ProbeSummary {
            leading_peak: 1.5,
            leading_peak_time_s: 2e-5,
            record_max: 1.75,
            record_max_time_s: 3e-5,
        }];
        let old = as_format_2(&rec);
        assert_eq!(&old[..8], b"CSWSEG\x00\x02");
        assert_eq!(verify(&old), Some(([9; 32], true)));
        assert_eq!(peek_status(&old), Some((true, String::new())));
        let back = decode(&old).expect("format 2 decodes");
        assert_eq!((back.integrated_particles, back.moving_part), (None, None));
        assert_eq!((back.steps, back.probes[0].record_max), (77, 1.75));
        // What format 2 ends with is not read as format 3's part, nor the other way round.
        let mut v3_magic = old.clone();
        v3_magic[..8].copy_from_slice(MAGIC_V3);
        let n = v3_magic.len() - 32;
        let sum: [u8; 32] = Sha256::digest(&v3_magic[..n]).into();
        v3_magic[n..].copy_from_slice(&sum);
        assert!(decode(&v3_magic).is_none());
        // A record that knows the part grows by its 10 bytes (and format 4's has_spectrum byte),
        // and keeps them.
        rec.integrated_particles = Some(128);
        rec.moving_part = Some(true);
        let new = encode(&rec);
        assert_eq!(new.len(), old.len() + 1 + 1 + 8 + 1);
        assert_eq!(decode(&new).unwrap().integrated_particles, Some(128));
    }
}
