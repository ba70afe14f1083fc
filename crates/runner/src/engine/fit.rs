//! The output file's tables of a sweep's fits: the statistics of each fit's answer, its profiles,
//! its nuisance parameters, and its data with the best fit's prediction and residuals (the model
//! is computed again from the best evaluation's stored runs).

use std::collections::HashMap;

use crate::error::Result;
use crate::record::RunRecord;
use crate::search::fit::model;
use crate::store::hdf5::fit::{FitData, FitTables};
use crate::store::RunStore;
use crate::sweep::fit::{Datum, SigmaRule, SpectrumQuantity, BLOCK_SUFFIXES, SCALAR_PREFIX};

use super::search::{Driver, Search};

const BOUND_FLAGS: (&[u8], &str) = (&[0, 1], "interior at_bound");
const OPEN_FLAGS: (&[u8], &str) = (
    &[0, 1, 2, 3],
    "closed lower_at_bound upper_at_bound both_at_bound",
);

/// The fit tables of `searches` (`None` without a fit).
pub fn tables(
    driver: &Driver<'_>,
    searches: &[Search],
    store: &dyn RunStore,
) -> Result<Option<FitTables>> {
    let Some(fit) = &driver.spec.fit else {
        return Ok(None);
    };
    let spec = driver.spec;
    let n = driver.layout.n_outer();
    let p = spec.fields.len();
    let by_outer: HashMap<usize, &Search> = searches.iter().map(|s| (s.outer, s)).collect();
    let mut t = FitTables::default();
    let field_dim = t.index_dim("fit_field", p, "index of a fitted field (fit_field_name)");
    let field_dim2 = t.index_dim(
        "fit_field_2",
        p,
        "index of a fitted field, the second of a pair (fit_field_name)",
    );
    t.var(
        "fit_field_name",
        false,
        &[field_dim],
        FitData::Text(spec.fields.iter().map(|f| f.name.clone()).collect()),
        None,
        "name of each fitted field",
    );
    let mut se = vec![vec![f64::NAN; n]; p];
    let mut lin = vec![[vec![f64::NAN; n], vec![f64::NAN; n]]; p];
    let mut prof = vec![[vec![f64::NAN; n], vec![f64::NAN; n]]; p];
    let mut open = vec![vec![0u8; n]; p];
    let mut bound = vec![vec![0u8; n]; p];
    let mut cov = vec![f64::NAN; n * p * p];
    let mut cor = vec![f64::NAN; n * p * p];
    let mut chi2 = vec![f64::NAN; n];
    let mut dof = vec![-1i64; n];
    let mut pval = vec![f64::NAN; n];
    let mut scale = vec![f64::NAN; n];
    let mut cond = vec![f64::NAN; n];
    let mut warning = vec![String::new(); n];
    let points = searches
        .iter()
        .filter_map(|s| s.outcome.fit.as_ref())
        .flat_map(|f| f.profile.iter().map(|p| p.points.len()))
        .max()
        .unwrap_or(0)
        .max(1);
    let mut prof_x = vec![vec![f64::NAN; n * points]; p];
    let mut prof_c = vec![vec![f64::NAN; n * points]; p];
    let set0 = &fit.sets[0];
    let rows = set0.len();
    let q = set0.nuisances();
    let mut nu = vec![f64::NAN; n * q];
    let mut nu_se = vec![f64::NAN; n * q];
    let mut data = vec![f64::NAN; n * rows];
    let mut sigma = vec![f64::NAN; n * rows];
    let mut predicted = vec![f64::NAN; n * rows];
    let signals = set0
        .data
        .iter()
        .filter(|d| matches!(d, Datum::Signal(_)))
        .count();
    let mut interp = vec![f64::NAN; n * signals];
    for o in 0..n {
        let set = &fit.sets[driver.data_set(o)];
        let (v, s) = model::data_rows(set);
        data[o * rows..(o + 1) * rows].copy_from_slice(&v);
        sigma[o * rows..(o + 1) * rows].copy_from_slice(&s);
        let Some(search) = by_outer.get(&o) else {
            continue;
        };
        let Some(f) = &search.outcome.fit else {
            continue;
        };
        let Some(st) = &f.stats else { continue };
        for k in 0..p {
            se[k][o] = st.standard_error[k];
            lin[k][0][o] = f.linear[k][0];
            lin[k][1][o] = f.linear[k][1];
            bound[k][o] = f.at_bound[k] as u8;
            if let Some(pr) = f.profile.get(k) {
                prof[k][0][o] = pr.lower;
                prof[k][1][o] = pr.upper;
                open[k][o] = pr.lower_open as u8 + 2 * pr.upper_open as u8;
                for (j, &(x, c)) in pr.points.iter().enumerate().take(points) {
                    prof_x[k][o * points + j] = x;
                    prof_c[k][o * points + j] = c;
                }
            }
        }
        cov[o * p * p..(o + 1) * p * p].copy_from_slice(&st.covariance);
        cor[o * p * p..(o + 1) * p * p].copy_from_slice(&st.correlation);
        chi2[o] = st.chi_square;
        dof[o] = st.dof as i64;
        pval[o] = st.p_value;
        scale[o] = st.scale.sqrt();
        cond[o] = st.condition;
        warning[o] = f.warnings.join("; ");
        for (i, &(v, e)) in f.nuisance.iter().enumerate().take(q) {
            nu[o * q + i] = v;
            nu_se[o * q + i] = e;
        }
        // The best evaluation's prediction.
        let (stream, index) = f.best;
        let Some(ev) = search
            .evals
            .iter()
            .filter(|e| e.stream == stream)
            .nth(index)
        else {
            continue;
        };
        let records: Vec<Option<RunRecord>> = ev
            .hashes
            .iter()
            .map(|h| store.read(h))
            .collect::<Result<_>>()?;
        let refs: Vec<Option<&RunRecord>> = records.iter().map(Option::as_ref).collect();
        if let Ok(pr) = model::predict(fit, set, &refs) {
            predicted[o * rows..(o + 1) * rows].copy_from_slice(&pr.model);
        }
        // How well the histories resolve the signals, at the best fit.
        let (mut shifts, mut gains) = (Vec::new(), Vec::new());
        let mut at = 0;
        for d in &set.data {
            let Datum::Signal(sg) = d else { continue };
            let names = sg.nuisance_names();
            let get = |what: &str| {
                names
                    .iter()
                    .position(|n| *n == what)
                    .map(|i| f.nuisance[at + i].0)
            };
            shifts.push(get("time_shift_s").unwrap_or(0.0));
            gains.push(get("gain").unwrap_or(1.0));
            at += names.len();
        }
        let errors =
            model::interpolation_errors(set, refs.first().copied().flatten(), &shifts, &gains);
        let mut k = 0;
        for d in &set.data {
            let Datum::Signal(sg) = d else { continue };
            let e = errors[k];
            interp[o * signals + k] = e;
            k += 1;
            // Beside σ (or the estimated σ), an interpolation error above a tenth of it is told.
            let sigma = match &sg.sigma {
                Some(s) => s.iter().copied().fold(f64::INFINITY, f64::min),
                None => st.scale.sqrt(),
            };
            if e > 0.1 * sigma {
                if !warning[o].is_empty() {
                    warning[o].push_str("; ");
                }
                warning[o].push_str(&format!(
                    "{}: interpolating the history at the data instants errs by up to {e:.3e} {}, more than a tenth of sigma: lower record.history_interval_s",
                    sg.name, sg.units
                ));
            }
        }
    }
    for (k, f) in spec.fields.iter().enumerate() {
        let u = Some(f.units.as_str());
        let name = &f.name;
        t.var(
            &format!("fit_{name}_standard_error"),
            true,
            &[],
            FitData::F64(se[k].clone()),
            u,
            &format!("standard error of the fitted {name}"),
        );
        for (side, which) in [(0, "lower"), (1, "upper")] {
            t.var(
                &format!("fit_{name}_{which}"),
                true,
                &[],
                FitData::F64(lin[k][side].clone()),
                u,
                &format!("{which} end of the linearised 95 % interval of {name}"),
            );
            t.var(
                &format!("fit_{name}_profile_{which}"),
                true,
                &[],
                FitData::F64(prof[k][side].clone()),
                u,
                &format!("{which} end of the profile-likelihood 95 % interval of {name}"),
            );
        }
        t.var(
            &format!("fit_{name}_at_bound"),
            true,
            &[],
            FitData::Flags(bound[k].clone(), BOUND_FLAGS.0, BOUND_FLAGS.1),
            None,
            &format!("whether the fitted {name} is at a bound of its interval"),
        );
        t.var(
            &format!("fit_{name}_profile_open"),
            true,
            &[],
            FitData::Flags(open[k].clone(), OPEN_FLAGS.0, OPEN_FLAGS.1),
            None,
            &format!("which ends of the profile interval of {name} are the bounds of its interval (the data do not bound it there)"),
        );
    }
    // (One unit when the fields share one; else element (i, j) is in field i's unit times
    // field j's, which no one unit attribute can say.)
    let shared = spec
        .fields
        .iter()
        .all(|f| f.units == spec.fields[0].units)
        .then(|| match spec.fields[0].units.as_str() {
            "1" => "1".to_string(),
            u => format!("({u})^2"),
        });
    t.var(
        "fit_covariance",
        true,
        &[field_dim, field_dim2],
        FitData::F64(cov),
        shared.as_deref(),
        "covariance of the fitted fields (element (i, j) in the unit of field i times that of field j; infinite along combinations the data do not determine)",
    );
    t.var(
        "fit_correlation",
        true,
        &[field_dim, field_dim2],
        FitData::F64(cor),
        Some("1"),
        "correlation of the fitted fields",
    );
    t.var(
        "fit_chi_square",
        true,
        &[],
        FitData::F64(chi2),
        Some("1"),
        "chi-square of the best fit: the sum of the squared residuals over sigma (over the estimated sigma's unit when sigma is estimated)",
    );
    t.var(
        "fit_dof",
        true,
        &[],
        FitData::I64(dof),
        Some("1"),
        "degrees of freedom: data less fitted fields less nuisance parameters",
    );
    t.var(
        "fit_p_value",
        true,
        &[],
        FitData::F64(pval),
        Some("1"),
        "probability of a chi-square at least as large if the model and sigma are right (NaN when sigma is estimated)",
    );
    // With σ estimated, every datum shares a unit (checked when the sweep is read): the
    // estimate's.
    let sigma_units = match fit.sigma {
        SigmaRule::Given => "1".to_string(),
        SigmaRule::Estimated => match &set0.data[0] {
            Datum::Scalar(s) => s
                .quantity
                .units(&driver.grid.probes)
                .unwrap_or("1")
                .to_string(),
            Datum::Signal(s) => s.units.to_string(),
            Datum::Spectrum(s) => s.units.to_string(),
        },
    };
    t.var(
        "fit_sigma_scale",
        true,
        &[],
        FitData::F64(scale.clone()),
        Some(&sigma_units),
        "sqrt(chi_square/dof) when sigma is estimated: the estimated sigma of every datum, in their unit; 1 when sigma is given",
    );
    t.var(
        "fit_condition_number",
        true,
        &[],
        FitData::F64(cond),
        Some("1"),
        "condition number of the column-normalised Jacobian: large when the data hardly tell the fields apart",
    );
    t.var(
        "fit_warning",
        true,
        &[],
        FitData::Text(warning),
        None,
        "what the fit's answer must be read with: unidentifiable combinations, strong correlations, bounds, other minima, a poor fit",
    );
    let pdim = t.index_dim(
        "profile_point",
        points,
        "point of a field's profile likelihood, in increasing value of the field",
    );
    for (k, f) in spec.fields.iter().enumerate() {
        let name = &f.name;
        t.var(
            &format!("fit_{name}_profile_value"),
            true,
            &[pdim],
            FitData::F64(prof_x[k].clone()),
            Some(&f.units),
            &format!("{name} held at each point of its profile"),
        );
        t.var(
            &format!("fit_{name}_profile_chi_square"),
            true,
            &[pdim],
            FitData::F64(prof_c[k].clone()),
            Some("1"),
            &format!("chi-square of the other fields fitted with {name} held at fit_{name}_profile_value"),
        );
    }
    // Nuisance parameters, and the interpolation error of each signal.
    let mut i = 0;
    for (k, sg) in set0
        .data
        .iter()
        .filter_map(|d| match d {
            Datum::Signal(s) => Some(s),
            _ => None,
        })
        .enumerate()
    {
        t.var(
            &format!("{}_interpolation_error", sg.name),
            true,
            &[],
            FitData::F64((0..n).map(|o| interp[o * signals + k]).collect()),
            Some(sg.units),
            &format!("{}: estimated error of interpolating the probe's history at the data instants, at the best fit (the spline through every second sample against all, over 15)", sg.name),
        );
        for kind in sg.nuisance_names() {
            let units = match kind {
                "time_shift_s" => "s",
                "gain" => "1",
                _ => sg.units,
            };
            let what = match kind {
                "time_shift_s" => "the run's instant of the recording's zero",
                "gain" => "the gain multiplying the probe",
                _ => "the offset added to the probe",
            };
            t.var(
                &format!("{}_{kind}", sg.name),
                true,
                &[],
                FitData::F64((0..n).map(|o| nu[o * q + i]).collect()),
                Some(units),
                &format!("{}: {what}, fitted with the fields", sg.name),
            );
            t.var(
                &format!("{}_{kind}_standard_error", sg.name),
                true,
                &[],
                FitData::F64((0..n).map(|o| nu_se[o * q + i]).collect()),
                Some(units),
                &format!(
                    "{}: standard error of {kind} (the fields' uncertainty included)",
                    sg.name
                ),
            );
            i += 1;
        }
    }
    // The data, the prediction and the residuals, per datum.
    let mut row = 0;
    let scalars: Vec<(usize, String, String)> = set0
        .data
        .iter()
        .scan(0usize, |r, d| {
            let at = *r;
            *r += d.len();
            Some((at, d))
        })
        .filter_map(|(at, d)| match d {
            Datum::Scalar(s) => Some((
                at,
                s.name.clone(),
                s.quantity
                    .units(&driver.grid.probes)
                    .unwrap_or("")
                    .to_string(),
            )),
            _ => None,
        })
        .collect();
    let estimated = fit.sigma == SigmaRule::Estimated;
    let block = |t: &mut FitTables,
                 prefix: &str,
                 dim: usize,
                 at: &[usize],
                 units: Option<&str>,
                 what: &str,
                 angles: bool| {
        let take = |v: &[f64]| -> Vec<f64> {
            (0..n)
                .flat_map(|o| at.iter().map(move |&r| v[o * rows + r]))
                .collect()
        };
        let d = take(&data);
        let s = take(&sigma);
        let m = take(&predicted);
        let r: Vec<f64> = m
            .iter()
            .zip(&d)
            .map(|(m, d)| if angles { model::wrap(m - d) } else { m - d })
            .collect();
        let nr: Vec<f64> = r
            .iter()
            .zip(&s)
            .enumerate()
            .map(|(j, (r, s))| {
                if estimated {
                    r / scale[j / at.len().max(1)]
                } else {
                    r / s
                }
            })
            .collect();
        let vars = [
            (d, units, format!("{what}: measured")),
            (s, units, format!("{what}: standard uncertainty of the measured values (NaN: estimated, fit_sigma_scale)")),
            (m, units, format!("{what}: the best fit's prediction")),
            (r, units, format!("{what}: prediction less measured")),
            (nr, Some("1"), format!("{what}: residual over its sigma (given or estimated)")),
        ];
        for (suffix, (values, units, description)) in BLOCK_SUFFIXES.iter().zip(vars) {
            t.var(
                &format!("{prefix}_{suffix}"),
                true,
                &[dim],
                FitData::F64(values),
                units,
                &description,
            );
        }
    };
    if !scalars.is_empty() {
        let dim = t.index_dim(
            "scalar_datum",
            scalars.len(),
            "measured scalar (scalar_datum_name)",
        );
        t.var(
            "scalar_datum_name",
            false,
            &[dim],
            FitData::Text(scalars.iter().map(|s| s.1.clone()).collect()),
            None,
            "what each measured scalar is compared with",
        );
        t.var(
            "scalar_datum_units",
            false,
            &[dim],
            FitData::Text(scalars.iter().map(|s| s.2.clone()).collect()),
            None,
            "unit of each measured scalar",
        );
        let at: Vec<usize> = scalars.iter().map(|s| s.0).collect();
        let same = scalars.iter().all(|s| s.2 == scalars[0].2);
        let units = same
            .then_some(scalars[0].2.as_str())
            .filter(|u| !u.is_empty());
        block(
            &mut t,
            SCALAR_PREFIX,
            dim,
            &at,
            units,
            "measured scalars",
            false,
        );
    }
    for d in &set0.data {
        match d {
            Datum::Scalar(_) => {}
            Datum::Signal(sg) => {
                let dim = t.dim(
                    &format!("{}_time_s", sg.name),
                    sg.time_s.clone(),
                    "s",
                    &format!(
                        "instants of the recorded signal {} (the recording's own time)",
                        sg.name
                    ),
                );
                let at: Vec<usize> = (row..row + sg.time_s.len()).collect();
                block(
                    &mut t,
                    &sg.name,
                    dim,
                    &at,
                    Some(sg.units),
                    &format!("signal {} of {}", sg.name, sg.probe.1),
                    false,
                );
            }
            Datum::Spectrum(sp) => {
                let dim = t.dim(
                    &format!("{}_frequency_hz", sp.name),
                    sp.frequency_hz.clone(),
                    "Hz",
                    &format!("frequencies of the measured spectrum {}", sp.name),
                );
                let nf = sp.frequency_hz.len();
                let at: Vec<usize> = (row..row + nf).collect();
                let what = match sp.quantity {
                    SpectrumQuantity::Amplitude => "steady amplitude",
                    SpectrumQuantity::TransmissionDb => "steady transmission",
                };
                block(
                    &mut t,
                    &sp.name,
                    dim,
                    &at,
                    Some(sp.units),
                    &format!("spectrum {} ({what} of {})", sp.name, sp.probe.1),
                    false,
                );
                if sp.phase.is_some() {
                    let at: Vec<usize> = (row + nf..row + 2 * nf).collect();
                    block(
                        &mut t,
                        &format!("{}_phase", sp.name),
                        dim,
                        &at,
                        Some("rad"),
                        &format!("spectrum {} (phase against the reference probe)", sp.name),
                        true,
                    );
                }
            }
        }
        row += d.len();
    }
    Ok(Some(t))
}
