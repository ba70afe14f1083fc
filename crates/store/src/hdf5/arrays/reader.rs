//! The reader of the runs' arrays ([`ArrayReader`]): every layout-5-or-later file's histories,
//! minimum overlaps, energy flow and fields read back run by run, checked chunk by chunk.

// The writer's layout: its names, chunk shapes, row selections and dataset parts.
use super::*;

/// The reader of a file's arrays: its datasets open, so that reading the runs in grid order
/// decompresses each chunk once.
pub struct ArrayReader {
    shape: Vec<usize>,
    /// The history datasets, each with the probes it holds.
    parts: Vec<(Dataset, Vec<usize>)>,
    probes: usize,
    samples: Vec<i64>,
    time: Time,
    min_overlap: Option<Dataset>,
    /// The energy flow's three variables, in [`ENERGY_FLOW`]'s order, when recorded.
    flow: Vec<Dataset>,
    fields: Option<FieldReader>,
}

struct FieldReader {
    /// Each quantity's dataset.
    parts: Vec<(FieldQuantity, Dataset)>,
    samples: Vec<i64>,
    time: Vec<f64>,
}

enum Time {
    None,
    /// The one time axis.
    Common(Vec<f64>),
    /// Every run's instants.
    PerRun(Dataset),
}

impl ArrayReader {
    /// Opens the arrays of `file` (layout 5 or later) as `grid` records them.
    pub fn open(file: &File, grid: &Grid) -> Result<ArrayReader> {
        let shape = grid.shape.clone();
        let mut parts = Vec::new();
        let mut samples = Vec::new();
        let mut time = Time::None;
        if grid.history {
            if !grid.probes.is_empty() {
                for (name, _, holds) in history_parts(grid) {
                    let which = (0..holds.len()).filter(|&k| holds[k]).collect();
                    parts.push((file.dataset(&name).map_err(crate::h5)?, which));
                }
            }
            let s = file.dataset(HISTORY_SAMPLES).map_err(crate::h5)?;
            // (Unchecked: a damaged count is caught by the run's checksum, and costs that run.)
            samples = read_unchecked::<i64>(&s)?;
            if samples.len() != grid.len() {
                return Err(Error::Other(format!(
                    "{HISTORY_SAMPLES} holds {} values for {} points",
                    samples.len(),
                    grid.len()
                )));
            }
            let t = file.dataset(TIME).map_err(crate::h5)?;
            time = if t.ndim() == 1 {
                Time::Common(read_unchecked::<f64>(&t)?)
            } else {
                Time::PerRun(t)
            };
        }
        let min_overlap = if grid.min_overlap {
            Some(file.dataset(MIN_OVERLAP).map_err(crate::h5)?)
        } else {
            None
        };
        let flow = if grid.energy_flow {
            ENERGY_FLOW
                .iter()
                .map(|(name, _, _)| file.dataset(name))
                .collect::<std::result::Result<Vec<_>, _>>()
                .map_err(crate::h5)?
        } else {
            Vec::new()
        };
        let fields = match &grid.fields {
            Some(spec) => {
                let parts = spec
                    .quantities
                    .iter()
                    .map(|&q| Ok((q, file.dataset(field_name(q)).map_err(crate::h5)?)))
                    .collect::<Result<Vec<_>>>()?;
                // (Unchecked: a damaged count or instant is caught by the run's checksum.)
                let samples =
                    read_unchecked::<i64>(&file.dataset(FIELD_SAMPLES).map_err(crate::h5)?)?;
                if samples.len() != grid.len() {
                    return Err(Error::Other(format!(
                        "{FIELD_SAMPLES} holds {} values for {} points",
                        samples.len(),
                        grid.len()
                    )));
                }
                let time = read_unchecked::<f64>(&file.dataset(FIELD_TIME).map_err(crate::h5)?)?;
                Some(FieldReader {
                    parts,
                    samples,
                    time,
                })
            }
            None => None,
        };
        Ok(ArrayReader {
            shape,
            parts,
            probes: grid.probes.len(),
            samples,
            time,
            min_overlap,
            flow,
            fields,
        })
    }

    /// The history, minimum overlaps and fields (each when recorded) of the run at flat index
    /// `index`, as stored.
    pub fn read(&self, index: usize) -> Result<RunArrays> {
        let history = match &self.time {
            Time::None => None,
            time => {
                let len = self.samples[index];
                if len < 0 {
                    return Err(Error::Other(format!(
                        "{HISTORY_SAMPLES} says the run has no history"
                    )));
                }
                let len = len as usize;
                let time_s = match time {
                    Time::Common(t) => t
                        .get(..len)
                        .ok_or_else(|| {
                            Error::Other(format!(
                                "{HISTORY_SAMPLES} ({len}) exceeds the time axis ({})",
                                t.len()
                            ))
                        })?
                        .to_vec(),
                    Time::PerRun(d) => read_rows(d, &self.shape, index, &[len])?,
                    Time::None => unreachable!(),
                };
                let mut values = vec![Vec::new(); self.probes];
                for (d, which) in &self.parts {
                    let rows = read_rows(d, &self.shape, index, &[self.probes, len])?;
                    for &k in which {
                        values[k] = rows[k * len..(k + 1) * len].to_vec();
                    }
                }
                Some(History { time_s, values })
            }
        };
        // A run's contacts or particles are the ones before the fill (a minimum overlap is a
        // number, +inf for a contact the run never moved; an energy a finite number: never NaN).
        let per_element = |d: &Dataset| -> Result<Vec<f64>> {
            let width = d.shape().last().copied().unwrap_or(0);
            let mut m = read_rows(d, &self.shape, index, &[width])?;
            while m.last().is_some_and(|x| x.is_nan()) {
                m.pop();
            }
            Ok(m)
        };
        let min_overlap = self.min_overlap.as_ref().map(per_element).transpose()?;
        let energy_flow = if self.flow.is_empty() {
            None
        } else {
            Some(EnergyFlow {
                energy_passed_max_j: per_element(&self.flow[0])?,
                energy_passed_final_j: per_element(&self.flow[1])?,
                max_kinetic_energy_j: per_element(&self.flow[2])?,
            })
        };
        let fields = match &self.fields {
            Some(r) => Some(r.read(&self.shape, index)?),
            None => None,
        };
        Ok((history, min_overlap, fields, energy_flow))
    }
}

impl FieldReader {
    /// The fields of the run at flat index `index`, as stored: its instants, and each quantity
    /// over its own contacts or particles (those before the fill: a field value is a finite
    /// number, never NaN).
    fn read(&self, shape: &[usize], index: usize) -> Result<Fields> {
        let len = self.samples[index];
        if len < 0 {
            return Err(Error::Other(format!(
                "{FIELD_SAMPLES} says the run has no fields"
            )));
        }
        let len = len as usize;
        let time_s = self
            .time
            .get(..len)
            .ok_or_else(|| {
                Error::Other(format!(
                    "{FIELD_SAMPLES} ({len}) exceeds the time axis ({})",
                    self.time.len()
                ))
            })?
            .to_vec();
        let mut series = Vec::with_capacity(self.parts.len());
        for (quantity, d) in &self.parts {
            let all = d.shape().last().copied().unwrap_or(0);
            let rows = read_rows(d, shape, index, &[len, all])?;
            let width = rows
                .get(..all.min(rows.len()))
                .map_or(0, |first| first.iter().take_while(|x| !x.is_nan()).count());
            let mut values = Vec::with_capacity(len * width);
            for row in rows.chunks_exact(all.max(1)) {
                values.extend_from_slice(&row[..width]);
            }
            series.push(FieldSeries {
                quantity: *quantity,
                width,
                values,
            });
        }
        Ok(Fields { time_s, series })
    }
}
