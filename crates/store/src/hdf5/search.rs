//! What a search adds to its output file: the searched fields as coordinates of its evaluations,
//! the objective of each evaluation, and each search's outcome over the sweep's axes.
//!
//! A search's runs are the points of a grid of the sweep's axes and one more dimension,
//! `evaluation` (each search's evaluations in the order it made them, padded where a search made
//! fewer): every summary is an ordinary column over it. Beside them:
//!
//! - each searched field, named like it, over (outer axes…, `evaluation`): a coordinate of every
//!   summary (NaN where there is no evaluation); `objective` and `evaluation_round` the same way;
//! - over the outer axes (the sweep's axes but the one the objective is taken across):
//!   `search_status` (flags), `search_runs`, `search_reason`, and `refine_error` for a
//!   refinement;
//! - for the items found (minima, maxima, roots), over (outer axes…, `minimum` | `maximum` |
//!   `root`): `<item>_<field>` and `<item>_<field>_uncertainty` per field, `<item>_objective`,
//!   `<item>_status`.

use hdf5::{Dataset, File};

use super::{
    attach_scale, attr_str, attr_vec, char_dataset, checked_dataset, filled_checked_dataset,
    read_text, set_scale, Text,
};
use chainsweep_sweep::error::Result;

/// One array of a search's tables over some of the file's dimensions.
pub struct Dims {
    /// The dimensions it spans: their names and lengths, outermost first.
    pub dims: Vec<(String, usize)>,
}

impl Dims {
    /// Its shape.
    pub fn shape(&self) -> Vec<usize> {
        self.dims.iter().map(|d| d.1).collect()
    }
}

/// A searched field's per-evaluation values and per-item results.
pub struct FieldTable {
    /// Its name (the coordinate's).
    pub name: String,
    /// Its dotted path.
    pub field: String,
    /// Its unit.
    pub units: String,
    /// Its value at every evaluation, over (outer…, evaluation); NaN where none.
    pub values: Vec<f64>,
    /// Where each item is, over (outer…, item); NaN where none.
    pub item: Vec<f64>,
    /// How far the true item may be from it.
    pub item_uncertainty: Vec<f64>,
}

/// Everything a search adds to its file.
pub struct SearchTables {
    /// The search, in a sentence (the `search` root attribute).
    pub description: String,
    /// The goal's name.
    pub goal: String,
    /// The outer axes' dimensions (the outcome's), with `evaluation` after them (per evaluation).
    pub outer: Dims,
    /// Evaluations per search (the `evaluation` dimension's length).
    pub evaluations: usize,
    /// The searched fields.
    pub fields: Vec<FieldTable>,
    /// What the objective is.
    pub objective_name: String,
    /// The objective's unit, where its summaries have one (`units` of every variable holding
    /// objective values).
    pub objective_units: Option<&'static str>,
    /// The objective at every evaluation; NaN where none or it gave no number.
    pub objective: Vec<f64>,
    /// The round of every evaluation (-1: none).
    pub round: Vec<i64>,
    /// Per search: status code, runs used, why it ended.
    pub status: Vec<u8>,
    /// Runs used.
    pub runs: Vec<i64>,
    /// Why it ended (or where it stands).
    pub reason: Vec<String>,
    /// Refine: the largest estimated interpolation error.
    pub refine_error: Option<Vec<f64>>,
    /// The items' dimension (`minimum`, `maximum`, `root`) and how many per search at most.
    pub items: Option<(String, usize)>,
    /// Each item's objective.
    pub item_value: Vec<f64>,
    /// Each item's status code.
    pub item_status: Vec<u8>,
    /// Flags of the statuses: (search codes, meanings), (item codes, meanings).
    pub flags: [(&'static [u8], &'static str); 2],
    /// A fit's statistics, data and prediction.
    pub fit: Option<super::fit::FitTables>,
}

/// The names the search tables give the file, beside the columns (for the `coordinates` of the
/// columns: the searched fields are coordinates of every evaluation).
pub fn coordinate_names(t: &SearchTables) -> Vec<String> {
    t.fields.iter().map(|f| f.name.clone()).collect()
}

fn attach(d: &Dataset, scales: &[(&Dataset, &str)]) -> Result<()> {
    for (k, (s, name)) in scales.iter().enumerate() {
        attach_scale(d, s, k, name)?;
    }
    Ok(())
}

/// Writes the tables of `t` into `file`, attached to the dimension scales `outer` (the outer
/// axes', in order) and `evaluation`.
pub fn write(
    file: &File,
    t: &SearchTables,
    outer: &[(&Dataset, &str)],
    evaluation: &Dataset,
) -> Result<()> {
    attr_str(file, "search", &t.description)?;
    attr_str(file, "search_goal", &t.goal)?;
    let outer_shape = t.outer.shape();
    let mut eval_shape = outer_shape.clone();
    eval_shape.push(t.evaluations);
    let mut eval_scales: Vec<(&Dataset, &str)> = outer.to_vec();
    eval_scales.push((evaluation, "evaluation"));
    let field_names: Vec<&str> = t.fields.iter().map(|f| f.name.as_str()).collect();
    for f in &t.fields {
        let d = filled_checked_dataset(file, &f.name, &eval_shape, &f.values, f64::NAN)?;
        attach(&d, &eval_scales)?;
        attr_str(&d, "units", &f.units)?;
        attr_str(&d, "field", &f.field)?;
        // A short name a plot can use as its axis label; what the values are, in `comment`.
        attr_str(
            &d,
            "long_name",
            &chainsweep_sweep::sweep::human_name(&f.name),
        )?;
        attr_str(
            &d,
            "comment",
            &format!("{} of each evaluation of the search", f.name),
        )?;
    }
    let d = filled_checked_dataset(file, "objective", &eval_shape, &t.objective, f64::NAN)?;
    attach(&d, &eval_scales)?;
    attr_str(&d, "long_name", "objective")?;
    attr_str(
        &d,
        "comment",
        &format!("objective of the search: {}", t.objective_name),
    )?;
    if let Some(u) = t.objective_units {
        attr_str(&d, "units", u)?;
    }
    attr_str(&d, "coordinates", &field_names.join(" "))?;
    let d = filled_checked_dataset(file, "evaluation_round", &eval_shape, &t.round, -1i64)?;
    attach(&d, &eval_scales)?;
    attr_str(
        &d,
        "long_name",
        "round of the search that proposed the evaluation",
    )?;
    attr_str(&d, "units", "1")?;
    attr_str(&d, "coordinates", &field_names.join(" "))?;
    // The outcome of each search.
    let d = checked_dataset(file, "search_status", &outer_shape, &t.status)?;
    attach(&d, outer)?;
    attr_vec(&d, "flag_values", t.flags[0].0)?;
    attr_str(&d, "flag_meanings", t.flags[0].1)?;
    attr_str(&d, "long_name", "how each search ended")?;
    let d = filled_checked_dataset(file, "search_runs", &outer_shape, &t.runs, -1i64)?;
    attach(&d, outer)?;
    attr_str(&d, "units", "1")?;
    attr_str(&d, "long_name", "runs each search used")?;
    let d = char_dataset(
        file,
        "search_reason",
        &outer_shape,
        &t.reason,
        None,
        Text::Free,
    )?
    .data;
    attach(&d, outer)?;
    attr_str(&d, "long_name", "why each search ended, in a sentence")?;
    if let Some(e) = &t.refine_error {
        let d = filled_checked_dataset(file, "refine_error", &outer_shape, e, f64::NAN)?;
        attach(&d, outer)?;
        attr_str(
            &d,
            "long_name",
            "largest estimated error of interpolating the refined samples (objective units)",
        )?;
        if let Some(u) = t.objective_units {
            attr_str(&d, "units", u)?;
        }
    }
    if let Some((item, n)) = &t.items {
        let ids: Vec<i64> = (0..*n as i64).collect();
        let scale = checked_dataset(file, item, &[*n], &ids)?;
        set_scale(&scale, item)?;
        attr_str(&scale, "dimension", item)?;
        attr_str(&scale, "units", "1")?;
        attr_str(
            &scale,
            "long_name",
            &format!("{item} found, in the order found"),
        )?;
        let mut item_shape = outer_shape.clone();
        item_shape.push(*n);
        let mut item_scales: Vec<(&Dataset, &str)> = outer.to_vec();
        item_scales.push((&scale, item));
        for f in &t.fields {
            let d = filled_checked_dataset(
                file,
                &format!("{item}_{}", f.name),
                &item_shape,
                &f.item,
                f64::NAN,
            )?;
            attach(&d, &item_scales)?;
            attr_str(&d, "units", &f.units)?;
            attr_str(&d, "long_name", &format!("{} of each {item} found", f.name))?;
            let d = filled_checked_dataset(
                file,
                &format!("{item}_{}_uncertainty", f.name),
                &item_shape,
                &f.item_uncertainty,
                f64::NAN,
            )?;
            attach(&d, &item_scales)?;
            attr_str(&d, "units", &f.units)?;
            attr_str(
                &d,
                "long_name",
                &format!(
                    "how far the true {item} may be from {item}_{} (its bracket)",
                    f.name
                ),
            )?;
        }
        let d = filled_checked_dataset(
            file,
            &format!("{item}_objective"),
            &item_shape,
            &t.item_value,
            f64::NAN,
        )?;
        attach(&d, &item_scales)?;
        attr_str(&d, "long_name", &format!("objective at each {item} found"))?;
        if let Some(u) = t.objective_units {
            attr_str(&d, "units", u)?;
        }
        let d = checked_dataset(file, &format!("{item}_status"), &item_shape, &t.item_status)?;
        attach(&d, &item_scales)?;
        attr_vec(&d, "flag_values", t.flags[1].0)?;
        attr_str(&d, "flag_meanings", t.flags[1].1)?;
        attr_str(&d, "long_name", &format!("how each {item} stands"))?;
    }
    Ok(())
}

/// How each search of an output file ended, as its tables say: status code, runs used, why.
pub fn read_outcomes(path: &std::path::Path) -> Result<Option<Vec<(u8, i64, String)>>> {
    let f = File::open(path).map_err(crate::h5)?;
    if !f.link_exists("search_status") {
        return Ok(None);
    }
    // (Checked by HDF5's Fletcher-32: a damaged chunk is an error, never a wrong status.)
    let status: Vec<u8> = f
        .dataset("search_status")
        .map_err(crate::h5)?
        .read_raw()
        .map_err(crate::h5)?;
    let runs: Vec<i64> = f
        .dataset("search_runs")
        .map_err(crate::h5)?
        .read_raw()
        .map_err(crate::h5)?;
    let reason = read_text(&f.dataset("search_reason").map_err(crate::h5)?)?;
    Ok(Some(
        status
            .into_iter()
            .zip(runs)
            .zip(reason)
            .map(|((s, r), t)| (s, r, t))
            .collect(),
    ))
}

/// What a search file holds of the items found (minima, maxima, roots) at each outer point:
/// per item, the searched fields' values and uncertainties (in `field_names`' order), the
/// objective (NaN: none) and the status code; `None` where the file holds no such items.
pub type FoundItems = Vec<Vec<(Vec<f64>, Vec<f64>, f64, u8)>>;

/// The items a search file holds (see [`FoundItems`]), `item` their name (`minimum`, …),
/// `field_names` the searched fields' names. (Checked by HDF5's Fletcher-32 as every search
/// table is.)
pub fn read_items(
    path: &std::path::Path,
    item: &str,
    field_names: &[&str],
) -> Result<Option<FoundItems>> {
    let f = File::open(path).map_err(crate::h5)?;
    if !f.link_exists(&format!("{item}_status")) {
        return Ok(None);
    }
    let status_ds = f.dataset(&format!("{item}_status")).map_err(crate::h5)?;
    let shape = status_ds.shape();
    let per_outer = shape.last().copied().unwrap_or(0).max(1);
    let status: Vec<u8> = status_ds.read_raw().map_err(crate::h5)?;
    let objective: Vec<f64> = f
        .dataset(&format!("{item}_objective"))
        .map_err(crate::h5)?
        .read_raw()
        .map_err(crate::h5)?;
    let mut x = Vec::new();
    let mut u = Vec::new();
    for name in field_names {
        x.push(
            f.dataset(&format!("{item}_{name}"))
                .map_err(crate::h5)?
                .read_raw::<f64>()
                .map_err(crate::h5)?,
        );
        u.push(
            f.dataset(&format!("{item}_{name}_uncertainty"))
                .map_err(crate::h5)?
                .read_raw::<f64>()
                .map_err(crate::h5)?,
        );
    }
    let outer = status.len() / per_outer;
    Ok(Some(
        (0..outer)
            .map(|k| {
                (0..per_outer)
                    .map(|j| k * per_outer + j)
                    .filter(|&at| x.iter().all(|v| !v[at].is_nan()))
                    .map(|at| {
                        (
                            x.iter().map(|v| v[at]).collect(),
                            u.iter().map(|v| v[at]).collect(),
                            objective[at],
                            status[at],
                        )
                    })
                    .collect()
            })
            .collect(),
    ))
}

/// A fit file's 95 % intervals, per outer point and field (in `field_names`' order): linearised
/// and profile-likelihood, `[lower, upper]` each (NaN where not computed). (Checked by HDF5's
/// Fletcher-32 as every search table is.)
pub fn read_fit_intervals(
    path: &std::path::Path,
    field_names: &[&str],
) -> Result<Vec<Vec<[[f64; 2]; 2]>>> {
    let f = File::open(path).map_err(crate::h5)?;
    let mut per_field = Vec::new();
    for name in field_names {
        let mut four = Vec::new();
        for end in ["lower", "upper", "profile_lower", "profile_upper"] {
            let v = format!("fit_{name}_{end}");
            if !f.link_exists(&v) {
                return Ok(Vec::new());
            }
            four.push(
                f.dataset(&v)
                    .map_err(crate::h5)?
                    .read_raw::<f64>()
                    .map_err(crate::h5)?,
            );
        }
        per_field.push(four);
    }
    let n = per_field.first().map_or(0, |v| v[0].len());
    Ok((0..n)
        .map(|o| {
            per_field
                .iter()
                .map(|v| [[v[0][o], v[1][o]], [v[2][o], v[3][o]]])
                .collect()
        })
        .collect())
}
