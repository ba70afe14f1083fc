//! Append-only logs of run records: `X.h5.d/logs/<n>.log`.
//!
//! Each process that stores runs in a work directory appends them to a log of its own (a new
//! one each time it takes the lock), as frames of two kinds:
//!
//! ```text
//! plain:  length (u64, little endian) | segment bytes (see [`crate::segment`], ending in their SHA-256)
//! packed: length | 1 << 63 (u64) | back (u32) | raw deflate, with a dictionary, of the segment
//!         bytes with the first 8 bytes of their SHA-256 in place of all 32
//! ```
//!
//! A packed frame's dictionary is the segment bytes of its *key*, the plain frame that starts
//! `back` bytes before it in the same log. Every plain frame of at most [`PACK_MAX`] segment bytes
//! is the key of the packed frames after it, up to the next such frame; the writer ([`Framer`])
//! writes one at the start of a log, every [`KEY_EVERY`] frames, wherever packing would not save
//! a byte, and where a record holds much the key lacks ([`REKEY_GROWTH`]). A run's record shares
//! most of its bytes with its neighbour's (the format, the counters' high bytes, the warnings'
//! text), so a summary run's frame is a little over half as long packed (what is left is mostly
//! its hash and its floats), and what a damaged key costs is bounded: the packed frames after it
//! that copy from its damaged bytes fail their own checksum, and their runs are computed again.
//! Segments longer than [`PACK_MAX`] (histories, fields) are always plain: their floats would not
//! pay for the time to deflate them.
//!
//! A packed record keeps [`PACKED_SUM`] bytes of its SHA-256, as the output file keeps of each
//! point's (`summary_checksum`): the other 24 are incompressible, a tenth of the frame, and
//! computed again when it is read, once the 8 kept have been checked; the segment bytes read back
//! are bitwise those written, whole checksum included.
//!
//! A frame is written with one `write` call and made durable by `fdatasync` at the next
//! checkpoint ([`crate::WorkDir`]). A process killed in the middle of a frame leaves a torn tail;
//! a disk that flips bits leaves a record whose checksum fails (a packed one is checked after it
//! is inflated). [`scan`] reads past neither as a record: such a run is missing and is computed
//! again. A log is never appended to by a later process, so a torn tail is never followed by good
//! frames of another writer. (Versions before packed frames read a log up to its first packed
//! frame, as a torn tail.)

use std::cell::RefCell;
use std::fs::File;
use std::io::{self, BufReader, Read};
use std::os::unix::fs::FileExt;
use std::path::Path;
use std::sync::Mutex;

use flate2::{Compress, Compression, Decompress, FlushCompress, FlushDecompress, Status};

use chainsweep_sweep::identity::RunHash;

use crate::segment::{self, Checked};

/// The folder of the logs inside a work directory.
pub const LOG_DIR: &str = "logs";

/// Bytes of a frame's length field.
pub const FRAME_HEAD: u64 = 8;

/// The file name of the log with sequence number `seq` (zero-padded, so names sort by age).
pub fn log_name(seq: u64) -> String {
    format!("{seq:08}.log")
}

/// The sequence number of a log's file name; `None` for any other name.
pub fn log_seq(name: &str) -> Option<u64> {
    let stem = name.strip_suffix(".log")?;
    if stem.is_empty() || !stem.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    stem.parse().ok()
}

/// The bit of a frame's length field that marks it packed.
pub const PACKED: u64 = 1 << 63;

/// Segment bytes up to which a record is packed: a summary run's record is a few hundred (with a
/// dozen probes, under a thousand). A longer one is mostly floats of histories or fields, which
/// deflate does little for: packing a 20 000-run sweep of 3.5 kB records saved a fifth of its
/// bytes and cost 5–10 % of its wall time, as the packing is done under the log's lock.
pub const PACK_MAX: usize = 1024;

/// At most this many packed frames follow a key before the next key, so that a damaged key costs
/// at most as many runs, and the dictionary follows the records' drift through the grid.
pub const KEY_EVERY: u32 = 256;

/// Bytes of a packed frame's back reference.
const BACK: usize = 4;

/// A record that packs to this many bytes more than the last packed one starts a new key: it
/// holds what the key lacks (a warning or a failure reason the key's run did not have, which
/// would otherwise be written out whole in every such record up to the next key), and the records
/// after it are likely to hold it too. Records of one sweep pack to within a few bytes of each
/// other otherwise; a warning is 50–200 bytes of text. (At worst, runs whose texts alternate
/// from one to the next, every record is a key: the log is as long as it would be unpacked.)
pub const REKEY_GROWTH: usize = 64;

/// Bytes of its segment's SHA-256 a packed frame keeps (the first ones).
pub const PACKED_SUM: usize = 8;

/// The segment bytes of a packed frame's record as deflated: its SHA-256 cut to [`PACKED_SUM`]
/// bytes; `None` for bytes too short to end in a checksum.
fn cut_sum(segment_bytes: &[u8]) -> Option<&[u8]> {
    let n = segment_bytes.len().checked_sub(segment::CHECKSUM_BYTES)?;
    Some(&segment_bytes[..n + PACKED_SUM])
}

/// A plain frame of `segment_bytes`.
fn frame(segment_bytes: &[u8]) -> Vec<u8> {
    let mut f = Vec::with_capacity(segment_bytes.len() + FRAME_HEAD as usize);
    f.extend_from_slice(&(segment_bytes.len() as u64).to_le_bytes());
    f.extend_from_slice(segment_bytes);
    f
}

/// Frames the records one writer appends to one log, packing each against the last key.
pub struct Framer {
    deflate: Compress,
    /// The segment bytes of the key, and where its frame starts in the log.
    key: Vec<u8>,
    key_start: Option<u64>,
    since_key: u32,
    /// The length of the last packed frame.
    last_packed: Option<usize>,
}

impl std::fmt::Debug for Framer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Framer")
            .field("key_start", &self.key_start)
            .field("since_key", &self.since_key)
            .finish()
    }
}

impl Default for Framer {
    fn default() -> Self {
        Framer {
            deflate: Compress::new(Compression::fast(), false),
            key: Vec::new(),
            key_start: None,
            since_key: 0,
            last_packed: None,
        }
    }
}

impl Framer {
    /// The frame of `segment_bytes`, to be appended at byte `start` of the log, and whether it
    /// is packed.
    pub fn frame(&mut self, segment_bytes: &[u8], start: u64) -> (Vec<u8>, bool) {
        if segment_bytes.len() > PACK_MAX {
            return (frame(segment_bytes), false);
        }
        if let Some(key_start) = self.key_start.filter(|_| self.since_key < KEY_EVERY) {
            if let Some(packed) = self.pack(segment_bytes, start - key_start) {
                let resembles_key = self
                    .last_packed
                    .map_or(true, |last| packed.len() <= last + REKEY_GROWTH);
                if resembles_key {
                    self.since_key += 1;
                    self.last_packed = Some(packed.len());
                    return (packed, true);
                }
            }
        }
        self.key.clear();
        self.key.extend_from_slice(segment_bytes);
        self.key_start = Some(start);
        self.since_key = 0;
        (frame(segment_bytes), false)
    }

    /// Forgets the key: the last frame was not written after all (a write that failed and was cut
    /// off again), and it may have been the key.
    pub fn forget(&mut self) {
        self.key_start = None;
    }

    /// The packed frame of `segment_bytes`, `back` bytes after the key's; `None` when it would not
    /// be shorter than the plain one.
    fn pack(&mut self, segment_bytes: &[u8], back: u64) -> Option<Vec<u8>> {
        let back = u32::try_from(back).ok()?;
        let cut = cut_sum(segment_bytes)?;
        self.deflate.reset();
        self.deflate.set_dictionary(&self.key).ok()?;
        // Room for less than the plain frame: a stream that does not fit does not pay.
        let plain = FRAME_HEAD as usize + segment_bytes.len();
        let mut f = Vec::with_capacity(plain - 1);
        f.extend_from_slice(&[0; FRAME_HEAD as usize]);
        f.extend_from_slice(&back.to_le_bytes());
        match self
            .deflate
            .compress_vec(cut, &mut f, FlushCompress::Finish)
        {
            Ok(Status::StreamEnd) if f.len() < plain => {}
            _ => return None,
        }
        let len = (f.len() as u64 - FRAME_HEAD) | PACKED;
        f[..FRAME_HEAD as usize].copy_from_slice(&len.to_le_bytes());
        Some(f)
    }
}

/// How far before a packed frame's start its key frame starts.
fn back_of(payload: &[u8]) -> Option<u64> {
    let b: [u8; BACK] = payload.get(..BACK)?.try_into().ok()?;
    Some(u32::from_le_bytes(b) as u64)
}

thread_local! {
    /// One inflater a thread, reset for every packed frame (its window is kept, not reallocated).
    static INFLATE: RefCell<Decompress> = RefCell::new(Decompress::new(false));
}

/// The segment bytes of a packed frame's `payload`, given its key's segment bytes, whole checksum
/// included and checked ([`Checked::restore`]); `None` when they do not inflate to a whole stream
/// of at most [`PACK_MAX`] bytes whose kept checksum bytes hold.
fn unpack(payload: &[u8], key: &[u8]) -> Option<Checked> {
    let stream = payload.get(BACK..)?;
    INFLATE
        .with_borrow_mut(|inflate| {
            inflate.reset(false);
            inflate.set_dictionary(key).ok()?;
            let before = inflate.total_in();
            let mut out = Vec::with_capacity(PACK_MAX + 1);
            match inflate.decompress_vec(stream, &mut out, FlushDecompress::Finish) {
                Ok(Status::StreamEnd)
                    if inflate.total_in() - before == stream.len() as u64
                        && out.len() <= PACK_MAX =>
                {
                    Some(out)
                }
                _ => None,
            }
        })
        .and_then(|cut| Checked::restore(cut, PACKED_SUM))
}

/// The last key [`read_at`] read from a log, where its frame starts: the packed frames after a
/// key are mostly read one after another.
pub type KeyCache = Mutex<Option<(u64, Vec<u8>)>>;

/// Reads the segment bytes of the frame whose payload is `len` bytes at `offset` of `log`
/// (inflated, when `packed`, with its key, from `keys` or read from the log), checked; `None` when
/// their checksum fails, or a packed frame's key is no plain frame of at most [`PACK_MAX`] bytes,
/// or it does not inflate.
pub fn read_at(
    log: &File,
    offset: u64,
    len: u64,
    packed: bool,
    keys: &KeyCache,
) -> io::Result<Option<Checked>> {
    let mut payload = vec![0u8; len as usize];
    log.read_exact_at(&mut payload, offset)?;
    if !packed {
        return Ok(Checked::verify(payload));
    }
    let Some(key_start) = back_of(&payload).and_then(|b| (offset - FRAME_HEAD).checked_sub(b))
    else {
        return Ok(None);
    };
    let mut cached = keys.lock().unwrap_or_else(|e| e.into_inner());
    if cached.as_ref().map(|(at, _)| *at) != Some(key_start) {
        let mut head = [0u8; FRAME_HEAD as usize];
        log.read_exact_at(&mut head, key_start)?;
        let key_len = u64::from_le_bytes(head);
        if key_len > PACK_MAX as u64 {
            return Ok(None);
        }
        let mut key = vec![0u8; key_len as usize];
        match log.read_exact_at(&mut key, key_start + FRAME_HEAD) {
            Err(e) if e.kind() == io::ErrorKind::UnexpectedEof => return Ok(None),
            r => r?,
        }
        *cached = Some((key_start, key));
    }
    let key = &cached.as_ref().expect("just read").1;
    Ok(unpack(&payload, key))
}

/// A whole, checksummed record found in a log.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Found {
    /// The run's hash.
    pub hash: RunHash,
    /// Whether the run succeeded.
    pub ok: bool,
    /// Where its frame's payload starts in the log.
    pub offset: u64,
    /// How many payload bytes.
    pub len: u64,
    /// Whether the frame is packed (its payload is not the segment bytes themselves).
    pub packed: bool,
}

/// How a scan of a log ended.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ScanEnd {
    /// The end of the last whole frame (a torn tail starts here).
    pub end: u64,
    /// Whole frames whose record failed its checksum (skipped).
    pub corrupt: usize,
    /// Whether the log ends in a torn frame (a writer killed mid-write, or a corrupt length).
    pub torn: bool,
}

/// Reads the log at `path` from its start (a packed frame needs its key, found earlier in the
/// log), calling `found` for every record whose checksum holds, in the order written. One record
/// is in memory at a time, besides the last key.
pub fn scan(path: &Path, mut found: impl FnMut(Found)) -> io::Result<ScanEnd> {
    let file = File::open(path)?;
    let size = file.metadata()?.len();
    let mut r = BufReader::with_capacity(1 << 16, file);
    let mut at = 0;
    let mut out = ScanEnd::default();
    let mut buf = Vec::new();
    // The frames that may be the key of a packed frame, where they start and their bytes: the last
    // plain frame of at most PACK_MAX bytes that is whole, and the last that is not. A key is only
    // a dictionary, and a packed record is checked by its own SHA-256, so a damaged key loses only
    // the records that copy from its damaged bytes; and a packed frame whose flag a damaged byte
    // cleared (read as a damaged plain frame) does not displace the key of the frames after it.
    let mut key: Option<(u64, Vec<u8>)> = None;
    let mut damaged_key: Option<(u64, Vec<u8>)> = None;
    while at < size {
        let mut head = [0u8; FRAME_HEAD as usize];
        if size - at < FRAME_HEAD {
            out.torn = true;
            break;
        }
        r.read_exact(&mut head)?;
        let head = u64::from_le_bytes(head);
        let (len, packed) = (head & !PACKED, head & PACKED != 0);
        if len > size - at - FRAME_HEAD {
            out.torn = true;
            break;
        }
        buf.clear();
        Read::by_ref(&mut r).take(len).read_to_end(&mut buf)?;
        let start = at;
        let offset = at + FRAME_HEAD;
        at = offset + len;
        out.end = at;
        let checked = if packed {
            let from_key = back_of(&buf).and_then(|b| start.checked_sub(b));
            [&key, &damaged_key]
                .into_iter()
                .flatten()
                .find(|(key_start, _)| Some(*key_start) == from_key)
                .and_then(|(_, k)| unpack(&buf, k))
                .map(|seg| (seg.hash(), seg.ok()))
        } else {
            let checked = segment::verify(&buf);
            if buf.len() <= PACK_MAX {
                let slot = if checked.is_some() {
                    &mut key
                } else {
                    &mut damaged_key
                };
                *slot = Some((start, buf.clone()));
            }
            checked
        };
        match checked {
            Some((hash, ok)) => found(Found {
                hash,
                ok,
                offset,
                len,
                packed,
            }),
            None => out.corrupt += 1,
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use chainsweep_sweep::record::RunRecord;
    use std::io::Write;

    fn rec(n: u8) -> RunRecord {
        RunRecord::failed([n; 32], format!("reason {n}"), 0.5)
    }

    /// A log's bytes, each frame's start and whether it is packed, and each record's segment
    /// bytes.
    type FramedLog = (Vec<u8>, Vec<(usize, bool)>, Vec<Vec<u8>>);

    /// A log of `n` records as one writer frames them.
    fn framed_log(n: u32) -> FramedLog {
        let mut framer = Framer::default();
        let (mut log, mut frames, mut segs) = (Vec::new(), Vec::new(), Vec::new());
        for i in 0..n {
            let mut hash = [0u8; 32];
            hash[..4].copy_from_slice(&i.to_le_bytes());
            // Summaries that differ from run to run, a warning shared by most.
            let mut r = RunRecord::failed(hash, String::new(), 0.1 + f64::from(i) * 1.3e-7);
            r.warnings = format!(
                "impact pulse of {:.3e} s is short",
                2.3e-5 + f64::from(i % 7) * 1e-8
            );
            let seg = segment::encode(&r);
            let (f, packed) = framer.frame(&seg, log.len() as u64);
            frames.push((log.len(), packed));
            log.extend_from_slice(&f);
            segs.push(seg);
        }
        (log, frames, segs)
    }

    fn scan_bytes(bytes: &[u8]) -> (Vec<Found>, ScanEnd) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(log_name(1));
        File::create(&path).unwrap().write_all(bytes).unwrap();
        let mut got = Vec::new();
        let end = scan(&path, |f| got.push(f)).unwrap();
        (got, end)
    }

    #[test]
    fn packed_frames_read_back_bitwise_and_a_damaged_key_costs_only_its_own() {
        let n = 2 * KEY_EVERY + 40;
        let (log, frames, segs) = framed_log(n);
        // A key every KEY_EVERY + 1 frames, the rest packed, and packing pays: under two thirds.
        let keys: Vec<usize> = (0..frames.len()).filter(|&i| !frames[i].1).collect();
        assert_eq!(keys, vec![0, 257, 514]);
        let plain: usize = segs.iter().map(|s| s.len() + FRAME_HEAD as usize).sum();
        assert!(log.len() * 3 < plain * 2, "{} of {plain}", log.len());
        let (got, end) = scan_bytes(&log);
        assert_eq!((got.len(), end.corrupt, end.torn), (n as usize, 0, false));
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(log_name(1));
        File::create(&path).unwrap().write_all(&log).unwrap();
        let file = File::open(&path).unwrap();
        let keys = KeyCache::default();
        for (f, seg) in got.iter().zip(&segs) {
            let back = read_at(&file, f.offset, f.len, f.packed, &keys).unwrap();
            assert_eq!(back.as_ref().map(Checked::bytes), Some(&seg[..]));
        }
        let hashes = |got: &[Found]| -> Vec<u32> {
            got.iter()
                .map(|f| u32::from_le_bytes(f.hash[..4].try_into().unwrap()))
                .collect()
        };
        // A flipped byte in the magic of the second key, which every record copies: the key and
        // the packed frames after it are damaged, up to the third key; every other record reads.
        let mut bad = log.clone();
        bad[frames[257].0 + FRAME_HEAD as usize + 2] ^= 0x04;
        let (got, end) = scan_bytes(&bad);
        assert_eq!(end.corrupt, 257);
        let want: Vec<u32> = (0..257).chain(514..n).collect();
        assert_eq!(hashes(&got), want);
        // A flipped byte in the key's own checksum, which no record copies: only the key is lost
        // (a key is a dictionary; each packed record is checked by its own SHA-256).
        let mut bad = log.clone();
        let key_end = frames[257].0 + FRAME_HEAD as usize + segs[257].len();
        bad[key_end - 5] ^= 0x04;
        let (got, end) = scan_bytes(&bad);
        assert_eq!(end.corrupt, 1);
        let want: Vec<u32> = (0..257).chain(258..n).collect();
        assert_eq!(hashes(&got), want);
        // A packed frame whose flag a damaged byte cleared reads as a damaged plain frame, and
        // does not take the key from the frames after it.
        let mut bad = log.clone();
        bad[frames[5].0 + 7] &= 0x7f;
        let (got, end) = scan_bytes(&bad);
        assert_eq!(end.corrupt, 1);
        let want: Vec<u32> = (0..5).chain(6..n).collect();
        assert_eq!(hashes(&got), want);
        // A flipped byte in a packed frame costs that frame alone; a packed frame torn in half is
        // a torn tail.
        let mut bad = log.clone();
        bad[frames[3].0 + FRAME_HEAD as usize + 30] ^= 0x01;
        let torn_at = frames[n as usize - 1].0 + 20;
        bad.truncate(torn_at);
        let (got, end) = scan_bytes(&bad);
        assert_eq!(
            (got.len(), end.corrupt, end.torn),
            (n as usize - 2, 1, true)
        );
        assert_eq!(end.end, frames[n as usize - 1].0 as u64);
        // A packed frame whose key went (the log cut before it is rewritten elsewhere) reads as
        // damaged, never as another record.
        let (got, end) = scan_bytes(&log[frames[300].0..frames[514].0]);
        assert!(got.is_empty() && !end.torn);
        assert_eq!(end.corrupt, 514 - 300);
    }

    #[test]
    fn a_packed_record_keeps_eight_bytes_of_its_checksum_and_they_are_checked() {
        let (log, frames, segs) = framed_log(3);
        assert_eq!(
            frames.iter().map(|f| f.1).collect::<Vec<_>>(),
            [false, true, true]
        );
        // What frame 1 deflates: its segment bytes with the first PACKED_SUM bytes of the SHA-256.
        let payload = &log[frames[1].0 + FRAME_HEAD as usize + BACK..frames[2].0];
        let mut inflate = Decompress::new(false);
        inflate.set_dictionary(&segs[0]).unwrap();
        let mut out = Vec::with_capacity(PACK_MAX);
        let status = inflate
            .decompress_vec(payload, &mut out, FlushDecompress::Finish)
            .unwrap();
        assert_eq!(status, Status::StreamEnd);
        let n = segs[1].len() - segment::CHECKSUM_BYTES + PACKED_SUM;
        assert_eq!(out, segs[1][..n]);
        // A record whose body does not match its checksum, packed as it is: the bytes kept tell.
        let mut bad = segs[2].clone();
        bad[45] ^= 0x10;
        let mut framer = Framer::default();
        let (key, _) = framer.frame(&segs[0], 0);
        let (packed, is_packed) = framer.frame(&bad, key.len() as u64);
        assert!(is_packed);
        let (got, end) = scan_bytes(&[key, packed].concat());
        assert_eq!((got.len(), end.corrupt, end.torn), (1, 1, false));
    }

    #[test]
    fn a_record_holding_what_the_key_lacks_becomes_the_key() {
        // Twenty runs without a warning, then twenty with one: the first of those would carry its
        // warning's text whole against the key, so it is written plain, as the key of the rest.
        let mut framer = Framer::default();
        let (mut log, mut frames) = (Vec::new(), Vec::new());
        for i in 0..40u32 {
            let mut hash = [0u8; 32];
            hash[..4].copy_from_slice(&i.to_le_bytes());
            let mut r = RunRecord::failed(hash, String::new(), 0.1 + f64::from(i) * 1.3e-7);
            if i >= 20 {
                r.warnings = format!(
                    "energy drift {:.2e} exceeds the limit 1e-4: the run's results are doubtful; \
                     tighten the integrator's rtol or shorten the step",
                    1.5e-4 + f64::from(i) * 1e-7
                );
            }
            let seg = segment::encode(&r);
            let (f, packed) = framer.frame(&seg, log.len() as u64);
            frames.push((packed, f.len(), seg.len()));
            log.extend_from_slice(&f);
        }
        let keys: Vec<usize> = (0..40).filter(|&i| !frames[i].0).collect();
        assert_eq!(keys, vec![0, 20]);
        // Every warned record after the new key packs to well under half of its plain frame.
        for &(_, len, seg) in &frames[21..] {
            assert!(2 * len < seg + FRAME_HEAD as usize, "{len} of {seg}");
        }
        let (got, end) = scan_bytes(&log);
        assert_eq!((got.len(), end.corrupt), (40, 0));
    }

    #[test]
    fn torn_tails_and_corrupt_records_are_skipped() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(log_name(1));
        let frames: Vec<Vec<u8>> = (1..=3).map(|n| frame(&segment::encode(&rec(n)))).collect();
        let mut bytes: Vec<u8> = frames.concat();
        // The middle record's body flipped: skipped, the third still found.
        let mid = frames[0].len() + 20;
        bytes[mid] ^= 0x40;
        // A torn fourth frame.
        let fourth = frame(&segment::encode(&rec(4)));
        bytes.extend_from_slice(&fourth[..fourth.len() / 2]);
        File::create(&path).unwrap().write_all(&bytes).unwrap();
        let mut got = Vec::new();
        let end = scan(&path, |f| got.push(f.hash[0])).unwrap();
        assert_eq!(got, vec![1, 3]);
        assert_eq!(end.corrupt, 1);
        assert!(end.torn);
        assert_eq!(end.end, frames.iter().map(|f| f.len() as u64).sum::<u64>());
        assert_eq!(log_seq("00000012.log"), Some(12));
        assert_eq!(log_seq("x.log"), None);
        assert_eq!(log_seq("12.log.tmp"), None);
    }
}
