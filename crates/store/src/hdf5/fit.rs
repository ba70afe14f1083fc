//! What a fit adds to its output file, beside a search's tables: the answer's statistics over the
//! outer axes (intervals, covariance and correlation over two field dimensions, χ² and its
//! p-value, warnings), each field's profile, the nuisance parameters of recorded signals, and
//! the data with the best fit's prediction and residuals over dimensions of their own (a signal
//! over its instants, a spectrum over its frequencies, the scalars over `scalar_datum`).
//!
//! The tables are a list of variables over the outer axes and further dimensions
//! ([`FitTables`]); the engine fills them, this module writes them as CF variables.

use hdf5::{Dataset, File};

use super::{
    attach_scale, attr_str, attr_vec, char_dataset, checked_dataset, filled_checked_dataset,
    set_scale, Text,
};
use chainsweep_sweep::error::Result;

/// A dimension of a fit's tables, with its coordinate.
#[derive(Debug, Clone)]
pub struct FitDim {
    /// Its name (and its coordinate's).
    pub name: String,
    /// Coordinate values.
    pub values: Vec<f64>,
    /// Their unit.
    pub units: String,
    /// What they are.
    pub long_name: String,
    /// Whether the values are indices (written as integers).
    pub index: bool,
}

/// A variable's values.
#[derive(Debug, Clone)]
pub enum FitData {
    /// Numbers (NaN: none).
    F64(Vec<f64>),
    /// Counts (-1: none).
    I64(Vec<i64>),
    /// Flags, with their meanings: (values, meanings).
    Flags(Vec<u8>, &'static [u8], &'static str),
    /// Texts.
    Text(Vec<String>),
}

/// A variable of a fit's tables.
#[derive(Debug, Clone)]
pub struct FitVar {
    /// Its name.
    pub name: String,
    /// Whether it spans the outer axes (first).
    pub outer: bool,
    /// The further dimensions it spans (indices into [`FitTables::dims`]).
    pub dims: Vec<usize>,
    /// Its values, row-major.
    pub data: FitData,
    /// Its unit (`None`: it has none, a text or values of several units).
    pub units: Option<String>,
    /// What it is.
    pub long_name: String,
}

/// Everything a fit adds to its file.
#[derive(Debug, Clone, Default)]
pub struct FitTables {
    /// Its own dimensions.
    pub dims: Vec<FitDim>,
    /// Its variables.
    pub vars: Vec<FitVar>,
}

impl FitTables {
    /// Adds a dimension; its index.
    pub fn dim(&mut self, name: &str, values: Vec<f64>, units: &str, long_name: &str) -> usize {
        self.dims.push(FitDim {
            name: name.into(),
            values,
            units: units.into(),
            long_name: long_name.into(),
            index: false,
        });
        self.dims.len() - 1
    }

    /// Adds a dimension of `n` indices (0, 1, …); its index.
    pub fn index_dim(&mut self, name: &str, n: usize, long_name: &str) -> usize {
        self.dims.push(FitDim {
            name: name.into(),
            values: (0..n).map(|k| k as f64).collect(),
            units: "1".into(),
            long_name: long_name.into(),
            index: true,
        });
        self.dims.len() - 1
    }

    /// Adds a variable.
    pub fn var(
        &mut self,
        name: &str,
        outer: bool,
        dims: &[usize],
        data: FitData,
        units: Option<&str>,
        long_name: &str,
    ) {
        self.vars.push(FitVar {
            name: name.into(),
            outer,
            dims: dims.to_vec(),
            data,
            units: units.map(str::to_string),
            long_name: long_name.into(),
        });
    }
}

/// Writes the tables `t` into `file`, its variables over the outer axes attached to their
/// scales `outer` (with their shape `outer_shape`).
pub fn write(
    file: &File,
    t: &FitTables,
    outer: &[(&Dataset, &str)],
    outer_shape: &[usize],
) -> Result<()> {
    let mut scales = Vec::new();
    for d in &t.dims {
        let s = if d.index {
            let ids: Vec<i64> = (0..d.values.len() as i64).collect();
            checked_dataset(file, &d.name, &[ids.len()], &ids)?
        } else {
            checked_dataset(file, &d.name, &[d.values.len()], &d.values)?
        };
        set_scale(&s, &d.name)?;
        attr_str(&s, "dimension", &d.name)?;
        attr_str(&s, "units", &d.units)?;
        attr_str(&s, "long_name", &d.long_name)?;
        scales.push(s);
    }
    for v in &t.vars {
        let mut shape = if v.outer {
            outer_shape.to_vec()
        } else {
            Vec::new()
        };
        let mut attach: Vec<(&Dataset, &str)> = if v.outer { outer.to_vec() } else { Vec::new() };
        for &k in &v.dims {
            shape.push(t.dims[k].values.len());
            attach.push((&scales[k], t.dims[k].name.as_str()));
        }
        let d = match &v.data {
            FitData::F64(x) => filled_checked_dataset(file, &v.name, &shape, x, f64::NAN)?,
            FitData::I64(x) => filled_checked_dataset(file, &v.name, &shape, x, -1i64)?,
            FitData::Flags(x, values, meanings) => {
                let d = checked_dataset(file, &v.name, &shape, x)?;
                attr_vec(&d, "flag_values", values)?;
                attr_str(&d, "flag_meanings", meanings)?;
                d
            }
            FitData::Text(x) => char_dataset(file, &v.name, &shape, x, None, Text::Free)?.data,
        };
        for (k, (s, name)) in attach.iter().enumerate() {
            attach_scale(&d, s, k, name)?;
        }
        if let Some(u) = &v.units {
            attr_str(&d, "units", u)?;
        }
        attr_str(&d, "long_name", &v.long_name)?;
    }
    Ok(())
}

/// What an ensemble adds to its file: its tables over the ordinary axes (every dimension but
/// `member`) and root attributes (its design, round, size and whether it has ended).
#[derive(Debug, Clone, Default)]
pub struct EnsembleTables {
    /// The statistics, sensitivities and their dimensions.
    pub tables: FitTables,
    /// Root attributes (name, value).
    pub attrs: Vec<(&'static str, String)>,
}

/// Root attributes `names` of the file at `path`, as text (`None`: a file without them all).
pub fn read_attrs(path: &std::path::Path, names: &[&str]) -> Option<Vec<String>> {
    let file = File::open(path).ok()?;
    names
        .iter()
        .map(|n| {
            file.attr(n)
                .ok()?
                .read_scalar::<hdf5::types::VarLenUnicode>()
                .ok()
                .map(|s| s.to_string())
        })
        .collect()
}

/// The numbers of dataset `name` of the file at `path`, row-major (`None`: none such).
pub fn read_f64(path: &std::path::Path, name: &str) -> Option<Vec<f64>> {
    File::open(path)
        .ok()?
        .dataset(name)
        .ok()?
        .read_raw::<f64>()
        .ok()
}
