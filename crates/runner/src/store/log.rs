//! Append-only logs of run records: `X.h5.d/logs/<n>.log`.
//!
//! Each process that stores runs in a work directory appends them to a log of its own (a new
//! one each time it takes the lock), as frames
//!
//! ```text
//! length (u64, little endian) | segment bytes (see [`super::segment`], ending in their SHA-256)
//! ```
//!
//! A frame is written with one `write` call and made durable by `fdatasync` at the next
//! checkpoint ([`super::WorkDir`]). A process killed in the middle of a frame leaves a torn tail;
//! a disk that flips bits leaves a record whose checksum fails. [`scan`] reads past neither as a
//! record: such a run is missing and is computed again. A log is never appended to by a later
//! process, so a torn tail is never followed by good frames of another writer.

use std::fs::File;
use std::io::{self, BufReader, Read};
use std::path::Path;

use crate::identity::RunHash;

use super::segment;

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

/// A frame of `segment_bytes`, ready to append.
pub fn frame(segment_bytes: &[u8]) -> Vec<u8> {
    let mut f = Vec::with_capacity(segment_bytes.len() + FRAME_HEAD as usize);
    f.extend_from_slice(&(segment_bytes.len() as u64).to_le_bytes());
    f.extend_from_slice(segment_bytes);
    f
}

/// A whole, checksummed record found in a log.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Found {
    /// The run's hash.
    pub hash: RunHash,
    /// Whether the run succeeded.
    pub ok: bool,
    /// Where its segment bytes start in the log.
    pub offset: u64,
    /// How many segment bytes.
    pub len: u64,
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

/// Reads the log at `path` from byte `from` (the start of a frame), calling `found` for every
/// record whose checksum holds, in the order written. One record is in memory at a time.
pub fn scan(path: &Path, from: u64, mut found: impl FnMut(Found)) -> io::Result<ScanEnd> {
    let file = File::open(path)?;
    let size = file.metadata()?.len();
    let mut r = BufReader::with_capacity(1 << 16, file);
    if from > 0 {
        io::copy(&mut Read::by_ref(&mut r).take(from), &mut io::sink())?;
    }
    let mut at = from;
    let mut out = ScanEnd {
        end: from,
        ..ScanEnd::default()
    };
    let mut buf = Vec::new();
    while at < size {
        let mut head = [0u8; FRAME_HEAD as usize];
        if size - at < FRAME_HEAD {
            out.torn = true;
            break;
        }
        r.read_exact(&mut head)?;
        let len = u64::from_le_bytes(head);
        if len > size - at - FRAME_HEAD {
            out.torn = true;
            break;
        }
        buf.clear();
        Read::by_ref(&mut r).take(len).read_to_end(&mut buf)?;
        let offset = at + FRAME_HEAD;
        at = offset + len;
        out.end = at;
        match segment::verify(&buf) {
            Some((hash, ok)) => found(Found {
                hash,
                ok,
                offset,
                len,
            }),
            None => out.corrupt += 1,
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::RunRecord;
    use std::io::Write;

    fn rec(n: u8) -> RunRecord {
        RunRecord::failed([n; 32], format!("reason {n}"), 0.5)
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
        let end = scan(&path, 0, |f| got.push(f.hash[0])).unwrap();
        assert_eq!(got, vec![1, 3]);
        assert_eq!(end.corrupt, 1);
        assert!(end.torn);
        assert_eq!(end.end, frames.iter().map(|f| f.len() as u64).sum::<u64>());
        // Scanning on from the end of the whole frames finds nothing new.
        let mut more = 0;
        scan(&path, end.end, |_| more += 1).unwrap();
        assert_eq!(more, 0);
        assert_eq!(log_seq("00000012.log"), Some(12));
        assert_eq!(log_seq("x.log"), None);
        assert_eq!(log_seq("12.log.tmp"), None);
    }
}
