//! The reader: an output file's records read back (for `merge` and `status`), column by column
//! as [`COLUMNS`] defines them.

use std::path::Path;

use chainsweep_solver::probes::{History, ProbeSummary};
use hdf5::types::VarLenUnicode;
use hdf5::File;

use super::{read_attr_str, run_group_name_in, LAYOUT_VERSION};
use crate::error::{Error, Result};
use crate::grid::Grid;
use crate::identity::RunHash;
use crate::record::columns::{ColumnData, Dtype, Fill, Written, COLUMNS};
use crate::record::{RunRecord, VerifyInfo, STATUS_FAILED, STATUS_PENDING, VERIFY_NONE, VERIFY_OK};

/// A sweep file's records read back from an HDF5 file.
pub struct FileRecords {
    /// The `sweep` root attribute (the sweep file's text).
    pub sweep_text: String,
    /// The `verify_fraction` root attribute (0 in files without it).
    pub verify_fraction: f64,
    /// The `shard` root attribute (`K/N`).
    pub shard: String,
    /// The `layout_version` root attribute (1 in files without it).
    pub layout_version: i64,
    file: File,
    /// Every column of [`COLUMNS`] the file has, in the table's order.
    columns: Vec<Option<ColumnData>>,
    status: Vec<u8>,
    n: usize,
}

fn read_column(file: &File, name: &str, dtype: Dtype) -> Result<ColumnData> {
    let d = file.dataset(name)?;
    Ok(match dtype {
        Dtype::F64 => ColumnData::F64(d.read_raw()?),
        Dtype::I64 => ColumnData::I64(d.read_raw()?),
        Dtype::U8 => ColumnData::U8(d.read_raw()?),
        Dtype::Str => ColumnData::Str(
            d.read_raw::<VarLenUnicode>()?
                .iter()
                .map(|s| s.as_str().to_string())
                .collect(),
        ),
    })
}

impl FileRecords {
    /// Opens a file and reads its columns (a required column missing is an error; the others
    /// read as their fill).
    pub fn open(path: &Path) -> Result<FileRecords> {
        FileRecords::read(path)
            .map_err(|e| e.hdf5_context(|| format!("reading {}", path.display())))
    }

    fn read(path: &Path) -> Result<FileRecords> {
        let file = File::open(path)?;
        let has_attr =
            |name: &str| -> Result<bool> { Ok(file.attr_names()?.iter().any(|a| a == name)) };
        let layout_version = if has_attr("layout_version")? {
            file.attr("layout_version")?.read_scalar::<i64>()?
        } else {
            1
        };
        if layout_version > LAYOUT_VERSION {
            return Err(Error::Other(format!(
                "the file has layout version {layout_version}, this chainsweep reads versions up to {LAYOUT_VERSION}: it was made by a newer chainsweep"
            )));
        }
        let sweep_text = read_attr_str(&file, "sweep")?;
        let shard = read_attr_str(&file, "shard")?;
        let mut columns = Vec::with_capacity(COLUMNS.len());
        for c in COLUMNS {
            columns.push(if c.required || file.link_exists(c.name) {
                Some(read_column(&file, c.name, c.dtype)?)
            } else {
                None
            });
        }
        let status = match column_data(&columns, "status") {
            Some(ColumnData::U8(s)) => s.clone(),
            _ => unreachable!("status is a required u8 column"),
        };
        let verify_fraction = if has_attr("verify_fraction")? {
            file.attr("verify_fraction")?.read_scalar::<f64>()?
        } else {
            0.0
        };
        Ok(FileRecords {
            sweep_text,
            verify_fraction,
            shard,
            layout_version,
            file,
            n: status.len(),
            status,
            columns,
        })
    }

    /// Number of grid points in the file.
    pub fn len(&self) -> usize {
        self.n
    }

    /// Whether the file has no grid points.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Status code of point `i` ([`crate::record::STATUS_OK`], [`STATUS_FAILED`] or
    /// [`STATUS_PENDING`]).
    pub fn status(&self, i: usize) -> u8 {
        self.status[i]
    }

    /// Why point `i` failed (empty unless it did).
    pub fn reason(&self, i: usize) -> &str {
        self.str_at("reason", i)
    }

    /// Run hash (hex) stored for point `i`.
    pub fn hash_hex(&self, i: usize) -> &str {
        self.str_at("run_hash", i)
    }

    fn str_at(&self, name: &str, i: usize) -> &str {
        match column_data(&self.columns, name) {
            Some(ColumnData::Str(v)) => &v[i],
            _ => unreachable!("{name} is a required string column"),
        }
    }

    /// The verification outcome stored for point `i` (`np` probes).
    pub fn verify_info(&self, i: usize, np: usize) -> VerifyInfo {
        let status = match column_data(&self.columns, "verified") {
            Some(ColumnData::U8(v)) => v[i],
            _ => VERIFY_NONE,
        };
        let mut errors = vec![[f64::NAN; 3]; np];
        let per_probe: Vec<(usize, &Vec<f64>)> = COLUMNS
            .iter()
            .zip(&self.columns)
            .filter_map(|(c, data)| match (c.fill, data) {
                (Fill::VerifyProbe(k), Some(ColumnData::F64(v))) => Some((k, v)),
                _ => None,
            })
            .collect();
        if status == VERIFY_OK && per_probe.len() == 3 {
            for (p, e) in errors.iter_mut().enumerate() {
                for &(k, v) in &per_probe {
                    e[k] = v[i * np + p];
                }
            }
        }
        VerifyInfo { status, errors }
    }

    /// The record of point `i`, or `None` if it is pending in this file.
    pub fn record(&self, i: usize, hash: RunHash, grid: &Grid) -> Result<Option<RunRecord>> {
        let st = self.status[i];
        if st == STATUS_PENDING {
            return Ok(None);
        }
        let np = grid.probes.len();
        let mut rec = RunRecord::failed(hash, String::new(), f64::NAN);
        if st != STATUS_FAILED {
            rec.ok = true;
            rec.probes = vec![
                ProbeSummary {
                    leading_peak: f64::NAN,
                    leading_peak_time_s: f64::NAN,
                    record_max: f64::NAN,
                    record_max_time_s: f64::NAN,
                };
                np
            ];
        }
        // A column the file lacks leaves the value of a failed run's record (NaN, 0, empty).
        for (c, data) in COLUMNS.iter().zip(&self.columns) {
            if let Some(d) = data {
                c.restore(d, i, np, &mut rec);
            }
        }
        // Files of grids where no point integrates only its moving part leave out how much each
        // run integrated: its whole chain, whichever version ran it. (A file of a grid where some
        // point does, without the columns, was written before they existed: not known.)
        let has_moving_part = COLUMNS
            .iter()
            .zip(&self.columns)
            .any(|(c, d)| c.written == Written::WithMovingPart && d.is_some());
        if rec.ok && !has_moving_part && !grid.moving_part {
            rec.moving_part = Some(false);
            rec.integrated_particles = Some(u64::from(grid.particles[i]));
        }
        if rec.ok && (grid.history || grid.min_overlap) {
            self.read_run_group(i, grid, &mut rec)?;
        }
        Ok(Some(rec))
    }

    /// Histories and minimum overlaps of point `i` from its group under `runs/`.
    fn read_run_group(&self, i: usize, grid: &Grid, rec: &mut RunRecord) -> Result<()> {
        let name = run_group_name_in(self.layout_version, grid.len(), i);
        let g = self.file.group(&format!("runs/{name}"))?;
        if grid.history {
            let time_s = g.dataset("time_s")?.read_raw::<f64>()?;
            let mut values = Vec::with_capacity(grid.probes.len());
            for p in &grid.probes {
                values.push(g.dataset(&p.name())?.read_raw::<f64>()?);
            }
            rec.history = Some(History { time_s, values });
        }
        if grid.min_overlap {
            rec.min_overlap_m = Some(g.dataset("min_overlap_m")?.read_raw::<f64>()?);
        }
        Ok(())
    }
}

/// The data of column `name` among `columns` (in [`COLUMNS`] order), if the file has it.
fn column_data<'a>(columns: &'a [Option<ColumnData>], name: &str) -> Option<&'a ColumnData> {
    let at = COLUMNS
        .iter()
        .position(|c| c.name == name)
        .expect("a column of the table");
    columns[at].as_ref()
}
