//! Library-level tests of the store: segments, the lock, and the HDF5 round trip used by `merge`.

use chainsweep::exec::execute;
use chainsweep::grid::Grid;
use chainsweep::record::columns::{COLUMNS, HARMONIC, LAYOUT_NAMES};
use chainsweep::record::{VerifyInfo, VERIFY_NONE, VERIFY_OK};
use chainsweep::store::hdf5::read::PointRead;
use chainsweep::store::hdf5::write::presence;
use chainsweep::store::hdf5::{write_file, FileRecords, Provenance};
use chainsweep::store::segment::encode;
use chainsweep::store::{scan_segments, WorkDir};
use chainsweep::sweep::Sweep;

const SWEEP: &str = r#"{
  "base": {
    "chain": {"preset": "chain_055", "cylinders": 8},
    "physics": {"gravity": true, "damping_kg_s": 0.0, "wall": true},
    "striker_velocity_m_s": 1.3,
    "duration_s": 1e-4
  },
  "record": {"probes": [{"kind": "gauge_force", "cylinder": 2}], "history": true, "min_overlap": true},
  "axes": [
    {"field": "physics.damping_kg_s", "values": [0, 6]},
    {"field": "max_steps", "values": [100000000, 3]}
  ]
}"#;

fn prov() -> Provenance {
    Provenance {
        created_utc: "2026-01-01T00:00:00Z".into(),
        command_line: "test".into(),
    }
}

/// Writes the file of a complete sweep: every grid point with its record, none verified.
fn publish_every_point(
    out: &std::path::Path,
    sweep: &Sweep,
    grid: &Grid,
    records: &[chainsweep::record::RunRecord],
) {
    let points: Vec<usize> = (0..grid.len()).collect();
    write_file(
        out,
        sweep,
        grid,
        &points,
        None,
        &prov(),
        0.0,
        |i| Ok(Some(records[i].clone())),
        |_, _| Ok(VerifyInfo::none(1)),
        None,
        None,
    )
    .unwrap();
}

#[test]
fn records_survive_segments_and_hdf5_bitwise() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = Sweep::parse(SWEEP).unwrap();
    let grid = Grid::new(&sweep).unwrap();
    assert_eq!(grid.shape, vec![2, 2]);
    let out = dir.path().join("t.h5");
    let work = WorkDir::open(&out, None).unwrap();
    let mut records = Vec::new();
    for i in 0..grid.len() {
        let scene = grid.build(&sweep, i).unwrap();
        let rec = execute(&scene, grid.hashes[i], &sweep.limits, i);
        work.write_segment(&rec).unwrap();
        assert_eq!(
            encode(&work.read_segment(&grid.hashes[i]).unwrap().unwrap()),
            encode(&rec)
        );
        records.push(rec);
    }
    assert!(records[0].ok && records[2].ok);
    assert!(!records[1].ok && records[1].reason.contains("step budget"));
    let index = scan_segments(&work.dir).unwrap();
    assert_eq!(index.len(), 4);
    assert!(!index[&grid.hashes[1]]);

    let points: Vec<usize> = (0..grid.len()).collect();
    // Point 0 carries a verification outcome, the others none.
    let verified = VerifyInfo {
        status: VERIFY_OK,
        errors: vec![[1e-9, 2e-10, f64::NAN, 3e-10, f64::NAN]],
        run_errors: [4e-9, f64::NAN],
    };
    let counts = write_file(
        &out,
        &sweep,
        &grid,
        &points,
        None,
        &prov(),
        0.5,
        |i| Ok(Some(records[i].clone())),
        |i, _| {
            Ok(if i == 0 {
                verified.clone()
            } else {
                VerifyInfo::none(1)
            })
        },
        None,
        None,
    )
    .unwrap();
    let counts = counts.counts;
    assert_eq!((counts.ok, counts.failed, counts.pending), (2, 2, 0));
    // The file's root holds the axes, the layout's names, the runs' arrays and exactly the
    // table's columns: those
    // of the moving part only where some point integrates only its moving part (none here).
    assert!(!grid.moving_part);
    let mut names = hdf5::File::open(&out).unwrap().member_names().unwrap();
    names.sort();
    let mut want: Vec<String> = COLUMNS
        .iter()
        .filter(|c| c.is_written(presence(&grid)))
        .map(|c| c.name)
        // (`runs`: the run groups of layouts 4 and earlier, reserved, not written; `harmonic`:
        // only with the steady state)
        .chain(
            LAYOUT_NAMES
                .iter()
                .copied()
                .filter(|&n| n != "runs" && n != HARMONIC),
        )
        // the runs' arrays (one unit: one `history`; a common interval: no `sample`)
        .chain([
            "history",
            "history_samples",
            "time_s",
            "min_overlap_m",
            "contact",
        ])
        .chain(["damping_kg_s", "max_steps"])
        .map(String::from)
        .collect();
    want.sort();
    assert_eq!(names, want);
    let back = FileRecords::open(&out).unwrap();
    assert_eq!(back.sweep_text, SWEEP);
    for (i, rec) in records.iter().enumerate() {
        let PointRead::Run(r) = back.record(i, grid.hashes[i], &grid) else {
            panic!("point {i} reads back");
        };
        assert_eq!(encode(&r), encode(rec), "point {i}");
    }
    assert_eq!(back.verify_fraction, 0.5);
    let v = back.verify_info(0);
    assert_eq!(v.status, VERIFY_OK);
    assert_eq!(&v.errors[0][..2], &[1e-9, 2e-10]);
    assert!(v.errors[0][2].is_nan());
    assert_eq!(back.verify_info(1).status, VERIFY_NONE);
}

/// A long chain (601 particles: it qualifies) with the moving part on and off, and a failed run.
const LONG_SWEEP: &str = r#"{
  "base": {
    "chain": {"preset": "chain_055", "cylinders": 300},
    "physics": {"gravity": true, "damping_kg_s": 6.0, "wall": true},
    "striker_velocity_m_s": 1.3,
    "duration_s": 2e-4,
    "integrator": {"method": "dop853", "rtol": 1e-7}
  },
  "record": {"probes": [{"kind": "gauge_force", "cylinder": 4}]},
  "axes": [
    {"field": "active_region", "values": ["auto", "off"]},
    {"field": "max_steps", "values": [100000000, 3]}
  ]
}"#;

#[test]
fn what_each_run_integrated_survives_logs_and_hdf5_bitwise() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = Sweep::parse(LONG_SWEEP).unwrap();
    let grid = Grid::new(&sweep).unwrap();
    assert!(grid.moving_part);
    assert_eq!(grid.particles, vec![602; 4]);
    let out = dir.path().join("long.h5");
    let work = WorkDir::open(&out, None).unwrap();
    let records: Vec<_> = (0..grid.len())
        .map(|i| {
            let scene = grid.build(&sweep, i).unwrap();
            let rec = execute(&scene, grid.hashes[i], &sweep.limits, i);
            work.write_segment(&rec).unwrap();
            rec
        })
        .collect();
    // auto: the moving part, a prefix shorter than the chain; off: the whole chain; the runs
    // stopped by their step budget: not known.
    assert_eq!(records[0].moving_part, Some(true));
    let k = records[0].integrated_particles.unwrap();
    assert!((16..602).contains(&k), "{k}");
    assert_eq!(
        (records[2].moving_part, records[2].integrated_particles),
        (Some(false), Some(602))
    );
    assert!(!records[1].ok && !records[3].ok);
    assert_eq!(
        (records[1].moving_part, records[1].integrated_particles),
        (None, None)
    );
    for rec in &records {
        let back = work.read_segment(&rec.hash).unwrap().unwrap();
        assert_eq!(encode(&back), encode(rec));
    }
    publish_every_point(&out, &sweep, &grid, &records);
    let f = hdf5::File::open(&out).unwrap();
    let n = f.dataset("integrated_particles").unwrap();
    assert_eq!(n.read_raw::<i64>().unwrap(), vec![k as i64, -1, 602, -1]);
    assert_eq!(
        f.dataset("moving_part").unwrap().read_raw::<u8>().unwrap(),
        vec![2, 0, 1, 0]
    );
    drop((n, f));
    let back = FileRecords::open(&out).unwrap();
    for (i, rec) in records.iter().enumerate() {
        let PointRead::Run(r) = back.record(i, grid.hashes[i], &grid) else {
            panic!("point {i} reads back");
        };
        assert_eq!(encode(&r), encode(rec), "point {i}");
    }
}

#[test]
fn a_second_lock_on_the_same_output_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.h5");
    let first = WorkDir::open(&out, None).unwrap();
    let err = WorkDir::open(&out, None).unwrap_err().to_string();
    assert!(err.contains("another chainsweep process"), "{err}");
    assert!(
        err.contains(&format!("pid {}", std::process::id())),
        "{err}"
    );
    drop(first);
    WorkDir::open(&out, None).unwrap();
}

#[test]
fn run_hash_follows_exactly_the_scene() {
    let a = Sweep::parse(SWEEP).unwrap();
    let ga = Grid::new(&a).unwrap();
    // Same scenes, different file text (description, axis order of values kept): same hashes.
    let b = Sweep::parse(&SWEEP.replacen(
        "{\n  \"base\"",
        "{\n  \"description\": \"x\",\n  \"base\"",
        1,
    ))
    .unwrap();
    assert_eq!(Grid::new(&b).unwrap().hashes, ga.hashes);
    // One damping value changed: exactly the points with that value change.
    let c = Sweep::parse(&SWEEP.replace("[0, 6]", "[0, 7]")).unwrap();
    let gc = Grid::new(&c).unwrap();
    assert_eq!(gc.hashes[0], ga.hashes[0]);
    assert_eq!(gc.hashes[1], ga.hashes[1]);
    assert_ne!(gc.hashes[2], ga.hashes[2]);
    assert_ne!(gc.hashes[3], ga.hashes[3]);
    // Every distinct point has a distinct hash.
    let mut h = ga.hashes.clone();
    h.sort();
    h.dedup();
    assert_eq!(h.len(), 4);
}

#[test]
fn example_sweeps_are_valid() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../sweeps");
    let mut n = 0;
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "json") {
            let sweep = Sweep::load(path.to_str().unwrap()).unwrap_or_else(|e| panic!("{e}"));
            Grid::new(&sweep).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            n += 1;
        }
    }
    assert!(n >= 1);
}

/// A failed record of hash `[n; 32]`: enough to exercise the store.
fn fake_record(n: u8) -> chainsweep::record::RunRecord {
    chainsweep::record::RunRecord::failed([n; 32], format!("reason {n}"), 0.25)
}

#[test]
fn logs_stay_few_survive_torn_tails_and_prune_only_what_is_not_needed() {
    use chainsweep::store::RunStore;
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t.h5");
    // One process after another, each storing one run: each has a log of its own, and the
    // next to open compacts them once there are more than MAX_LOGS.
    for n in 1..=40u8 {
        let work = WorkDir::open(&out, None).unwrap();
        assert_eq!(work.index().unwrap().len(), usize::from(n) - 1);
        work.write(&fake_record(n)).unwrap();
        work.sync().unwrap();
        assert!(work.store_files() <= chainsweep::store::MAX_LOGS + 1);
    }
    let logs = |d: &std::path::Path| std::fs::read_dir(d.join("t.h5.d/logs")).unwrap().count();
    assert!(logs(dir.path()) <= chainsweep::store::MAX_LOGS + 1);
    // A torn tail (a process killed mid-write) and a flipped byte are left out, nothing else.
    let log_dir = dir.path().join("t.h5.d/logs");
    let mut last: Vec<_> = std::fs::read_dir(&log_dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    last.sort();
    let newest = last.last().unwrap().clone();
    let mut bytes = std::fs::read(&newest).unwrap();
    let whole = bytes.len();
    bytes.extend_from_slice(&[200, 0, 0, 0, 0, 0, 0, 0, 1, 2, 3]);
    std::fs::write(&newest, &bytes).unwrap();
    let work = WorkDir::open(&out, None).unwrap();
    assert_eq!(work.index().unwrap().len(), 40);
    for n in 1..=40u8 {
        assert_eq!(
            encode(&work.read(&[n; 32]).unwrap().unwrap()),
            encode(&fake_record(n))
        );
    }
    drop(work);
    bytes[whole - 40] ^= 1;
    std::fs::write(&newest, &bytes[..whole]).unwrap();
    let work = WorkDir::open(&out, None).unwrap();
    let index = work.index().unwrap();
    assert_eq!(index.len(), 39, "exactly the corrupt record is missing");
    // Read through every log first: each log's read handle is open when pruning replaces them.
    let n_read = (1..=40u8)
        .filter(|&n| work.read(&[n; 32]).unwrap().is_some())
        .count();
    assert_eq!(n_read, 39);
    assert!(
        !index.contains_key(&[40; 32]),
        "the corrupt record is the last one written"
    );
    // Pruning keeps every run named as needed, removes the others. (Every third run: the kept
    // records lie at other offsets in the new log than in the old ones.)
    let c = work.prune(&|h| h[0] % 3 == 0, false).unwrap();
    assert_eq!(c.removed, 26);
    let index = work.index().unwrap();
    assert!((3..=39u8).step_by(3).all(|n| index.contains_key(&[n; 32])));
    assert_eq!(index.len(), 13);
    assert_eq!(work.store_files(), 1);
    // The kept runs read back bitwise from the new log (not through a handle of a removed one),
    // and so does a run stored after it.
    work.write(&fake_record(77)).unwrap();
    for n in (3..=39u8).step_by(3).chain([77]) {
        assert_eq!(
            encode(&work.read(&[n; 32]).unwrap().unwrap()),
            encode(&fake_record(n))
        );
    }
    drop(work);
    let again = scan_segments(&dir.path().join("t.h5.d")).unwrap();
    assert_eq!(again.len(), 14);
}

/// After a complete file is published, the store reads its runs back from it: with the grid the
/// caller gives when the file's run hashes are that grid's, and with the grid of the file's own
/// sweep otherwise (here a grid whose record block differs: no histories, which would lose them).
/// Either way every record reads back bitwise, and the logs beside the file are dropped.
#[test]
fn compaction_reads_the_published_file_back_with_its_own_grid() {
    let sweep = Sweep::parse(SWEEP).unwrap();
    let grid = Grid::new(&sweep).unwrap();
    let other = Sweep::parse(&SWEEP.replace(r#""history": true"#, r#""history": false"#)).unwrap();
    let other_grid = Grid::new(&other).unwrap();
    assert!(grid.history && !other_grid.history);
    for given in [&grid, &other_grid] {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("t.h5");
        let work = WorkDir::open(&out, None).unwrap();
        let records: Vec<_> = (0..grid.len())
            .map(|i| {
                let rec = execute(
                    &grid.build(&sweep, i).unwrap(),
                    grid.hashes[i],
                    &sweep.limits,
                    i,
                );
                work.write_segment(&rec).unwrap();
                rec
            })
            .collect();
        publish_every_point(&out, &sweep, &grid, &records);
        work.compact_after_publish(given).unwrap();
        assert!(scan_segments(&work.dir).unwrap().is_empty());
        for (i, rec) in records.iter().enumerate() {
            let back = work.read_segment(&grid.hashes[i]).unwrap().unwrap();
            assert_eq!(encode(&back), encode(rec), "point {i}");
        }
    }
}
