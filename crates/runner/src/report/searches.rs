//! The report's figures of searches and fits: every evaluated point of each search against the
//! searched field, with the answers it found; a fit's data against its best fit with the data's
//! uncertainties, the normalised residuals, and each field's profile χ².

use std::path::Path;

use super::svg::{self, Series};
use super::{Builder, MAX_PROBES};
use crate::engine::status::FileStatus;
use crate::store::hdf5::fit::read_f64;
use crate::sweep::fit::Datum;
use crate::sweep::Sweep;

/// The searches' evaluations and, for a fit, its data, best fit, residuals and profiles.
pub(super) fn section(b: &mut Builder, path: &Path, sweep: &Sweep, status: &FileStatus) {
    let Some(search) = &sweep.search else {
        return;
    };
    b.body.push_str("<h2>Evaluations</h2><div class=\"plots\">");
    evaluations(b, path, search, status);
    b.body.push_str("</div>");
    if let Some(fit) = &search.fit {
        b.body
            .push_str("<h2>Fit: data and best fit</h2><div class=\"plots\">");
        fit_figures(b, path, search, fit);
        b.body.push_str("</div>");
    }
}

/// Each search field's evaluations against the objective, a curve per search (a point of the
/// ordinary axes), the answers in the caption.
fn evaluations(
    b: &mut Builder,
    path: &Path,
    search: &crate::sweep::search::SearchSpec,
    status: &FileStatus,
) {
    let (Some(objective), Some(evaluation)) =
        (read_f64(path, "objective"), read_f64(path, "evaluation"))
    else {
        return;
    };
    let e = evaluation.len();
    if e == 0 || objective.len() % e != 0 {
        return;
    }
    let searches = objective.len() / e;
    let lines = status.searches.as_deref().unwrap_or(&[]);
    let y_label = format!("objective: {}", search.objective.describe());
    for f in &search.fields {
        let Some(x) = read_f64(path, &f.name).filter(|x| x.len() == objective.len()) else {
            continue;
        };
        let series: Vec<Series> = (0..searches.min(MAX_PROBES))
            .map(|s| {
                let mut points: Vec<(f64, f64)> = (s * e..(s + 1) * e)
                    .map(|k| (x[k], objective[k]))
                    .filter(|p| p.0.is_finite() && p.1.is_finite())
                    .collect();
                points.sort_by(|a, b| a.0.total_cmp(&b.0));
                let label = lines
                    .get(s)
                    .map(|l| l.label.clone())
                    .filter(|l| !l.is_empty())
                    .unwrap_or_else(|| "search".into());
                Series::line(label, points)
            })
            .filter(|s| !s.points.is_empty())
            .collect();
        if series.is_empty() {
            continue;
        }
        let answers: Vec<String> = lines
            .iter()
            .take(MAX_PROBES)
            .flat_map(|l| {
                l.answers.iter().filter_map(|a| {
                    let (_, v, u) = a.fields.iter().find(|(n, _, _)| *n == f.name)?;
                    let at = if l.label.is_empty() {
                        String::new()
                    } else {
                        format!(" at {}", l.label)
                    };
                    Some(format!(
                        "{} {} ± {}{at}",
                        a.item,
                        svg::num(*v),
                        svg::num(*u)
                    ))
                })
            })
            .collect();
        let svg = svg::lines(
            &format!("{} evaluations over {}", search.goal.name(), f.name),
            &format!("{} [{}]", f.name, f.units),
            &y_label,
            &series,
            None,
        );
        let more = if searches > MAX_PROBES {
            format!(" (the first {MAX_PROBES} of {searches} searches)")
        } else {
            String::new()
        };
        let found = if answers.is_empty() {
            String::new()
        } else {
            format!("; found: {}", answers.join("; "))
        };
        b.figure(
            svg,
            &format!(
                "every point the search evaluated, in order of {}{more}{found}",
                f.name
            ),
        );
    }
}

/// The values of `name` for the first fit of the file (the first point of the ordinary axes and
/// the first data set), `len` of them, and how many fits the file holds.
fn first_fit(path: &Path, name: &str, len: usize) -> Option<(Vec<f64>, usize)> {
    let v = read_f64(path, name)?;
    if len == 0 || v.len() % len != 0 {
        return None;
    }
    Some((v[..len].to_vec(), v.len() / len))
}

/// Measured (with ±σ as a band where σ is given) against the best fit over `x`, and the
/// normalised residuals; `prefix` names the datum's variables.
#[allow(clippy::too_many_arguments)]
fn data_and_model(
    b: &mut Builder,
    path: &Path,
    prefix: &str,
    x: &[f64],
    x_label: &str,
    text_x: Option<&[String]>,
    units: &str,
    what: &str,
) {
    let n = x.len();
    let (Some((data, fits)), Some((model, _))) = (
        first_fit(path, &format!("{prefix}_data"), n),
        first_fit(path, &format!("{prefix}_model"), n),
    ) else {
        return;
    };
    // A phase's prediction drawn within half a turn of the measured value (the residual is
    // wrapped so), not across the ±π seam from it.
    let model = match (units, first_fit(path, &format!("{prefix}_residual"), n)) {
        ("rad", Some((r, _))) => data.iter().zip(&r).map(|(d, r)| d + r).collect(),
        _ => model,
    };
    let mut sigma = first_fit(path, &format!("{prefix}_sigma"), n).map(|s| s.0);
    // Scalars (each its own quantity, in its own unit and size: a peak in N, a time in s)
    // against their measured values: 1 ± σ/|measured| and the prediction over the measured
    // value, not on one axis where the small ones sit on zero.
    let relative = text_x.is_some() && data.iter().all(|d| d.is_finite() && *d != 0.0);
    let (data, model, units) = if relative {
        sigma = sigma.map(|s| s.iter().zip(&data).map(|(s, d)| s / d.abs()).collect());
        let model = model.iter().zip(&data).map(|(m, d)| m / d).collect();
        (vec![1.0; n], model, "1, relative to the measured value")
    } else {
        (data, model, units)
    };
    let band: Vec<(f64, f64)> = match &sigma {
        Some(s) if s.iter().all(|s| s.is_finite()) => {
            data.iter().zip(s).map(|(d, s)| (d - s, d + s)).collect()
        }
        _ => Vec::new(),
    };
    let label = if band.is_empty() {
        "measured"
    } else {
        "measured ± σ"
    };
    let measured = Series {
        band,
        ..Series::line(label, x.iter().copied().zip(data.iter().copied()).collect())
    };
    let best = Series::line(
        "best fit",
        x.iter().copied().zip(model.iter().copied()).collect(),
    );
    let of = if fits > 1 {
        format!(" (the first of {fits} fits)")
    } else {
        String::new()
    };
    b.figure(
        svg::lines(
            what,
            x_label,
            &format!("[{units}]"),
            &[measured, best],
            text_x,
        ),
        &format!("{what}: measured and the best fit's prediction{of}"),
    );
    if let Some((r, _)) = first_fit(path, &format!("{prefix}_normalised_residual"), n) {
        let residual = Series::line("residual / σ", x.iter().copied().zip(r).collect());
        b.figure(
            svg::lines(
                &format!("{what}: residuals"),
                x_label,
                "(model − measured) / σ",
                &[residual],
                text_x,
            ),
            &format!(
                "{what}: each residual over its σ (given, or estimated from the residuals){of}"
            ),
        );
    }
}

fn fit_figures(
    b: &mut Builder,
    path: &Path,
    search: &crate::sweep::search::SearchSpec,
    fit: &crate::sweep::fit::FitSpec,
) {
    let Some(set) = fit.sets.first() else {
        return;
    };
    let scalars: Vec<String> = set
        .data
        .iter()
        .filter_map(|d| match d {
            Datum::Scalar(s) => Some(s.name.clone()),
            _ => None,
        })
        .collect();
    if !scalars.is_empty() {
        let x: Vec<f64> = (0..scalars.len()).map(|i| i as f64).collect();
        data_and_model(
            b,
            path,
            "scalar",
            &x,
            "measured scalar",
            Some(&scalars),
            "",
            "measured scalars",
        );
    }
    for d in &set.data {
        match d {
            Datum::Scalar(_) => {}
            Datum::Signal(s) => data_and_model(
                b,
                path,
                &s.name,
                &s.time_s,
                "time in the recording [s]",
                None,
                s.units,
                &format!("{} ({})", s.name, s.probe.1),
            ),
            Datum::Spectrum(s) => {
                data_and_model(
                    b,
                    path,
                    &s.name,
                    &s.frequency_hz,
                    "frequency [Hz]",
                    None,
                    s.units,
                    &format!("{} ({})", s.name, s.probe.1),
                );
                if s.phase.is_some() {
                    data_and_model(
                        b,
                        path,
                        &format!("{}_phase", s.name),
                        &s.frequency_hz,
                        "frequency [Hz]",
                        None,
                        "rad",
                        &format!("{} phase ({})", s.name, s.probe.1),
                    );
                }
            }
        }
    }
    // Each field's profile: χ² with the other fields refitted, against the field held.
    for f in &search.fields {
        let (Some(value), Some(chi2)) = (
            read_f64(path, &format!("fit_{}_profile_value", f.name)),
            read_f64(path, &format!("fit_{}_profile_chi_square", f.name)),
        ) else {
            continue;
        };
        let n = value.len().min(chi2.len());
        let mut points: Vec<(f64, f64)> = (0..n)
            .map(|k| (value[k], chi2[k]))
            .filter(|p| p.0.is_finite() && p.1.is_finite())
            .collect();
        if points.is_empty() {
            continue;
        }
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        let interval = match (
            read_f64(path, &format!("fit_{}_profile_lower", f.name)),
            read_f64(path, &format!("fit_{}_profile_upper", f.name)),
        ) {
            (Some(lo), Some(hi)) if !lo.is_empty() && !hi.is_empty() => format!(
                "; its 95 % profile interval [{}, {}]",
                svg::num(lo[0]),
                svg::num(hi[0])
            ),
            _ => String::new(),
        };
        let profile = Series::line("χ² profile", points);
        b.figure(
            svg::lines(
                &format!("profile of {}", f.name),
                &format!("{} [{}]", f.name, f.units),
                "χ² with the other fields refitted",
                &[profile],
                None,
            ),
            &format!(
                "χ² with {} held at each value and every other field fitted{interval}",
                f.name
            ),
        );
    }
}
