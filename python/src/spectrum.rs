//! The linear spectrum at the static state of one scene (a sweep file's `base`) or one grid point
//! of a sweep file, for `chainsweep.spectrum`: the chain is built exactly as the runner builds
//! that point's scene, then linearised by the solver's `spectrum` module. Nothing is integrated.

use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use serde_json::Value;

use chainsweep::error::{Error, Result};
use chainsweep::grid::Grid;
use chainsweep::sweep::Sweep;
use chainsweep_solver::spectrum::{DampedMethod, LinearChain};
use chainsweep_solver::Scene;

/// A unit cell's particles, wavenumbers, dispersion (rad/s, `points × p`), bands' lower and upper
/// edges (rad/s).
struct Cell {
    particles: usize,
    wavenumber: Vec<f64>,
    dispersion: Vec<f64>,
    lower: Vec<f64>,
    upper: Vec<f64>,
}

/// What the spectrum of one point holds.
struct Out {
    first_particle: usize,
    lin: LinearChain,
    omega: Vec<f64>,
    modes: Option<Vec<f64>>,
    cell: Option<Cell>,
    damped: Option<(Vec<f64>, Vec<f64>, &'static str)>,
}

fn input(e: chainsweep_solver::spec::SpecError) -> Error {
    Error::input(e.field, e.message)
}

/// The scene of grid point `index` of a sweep (the integrator plays no part: an unresolved
/// `integrator: auto` is left to its default rather than run a pilot).
fn scene_of(mut sweep: Sweep, index: usize) -> Result<Scene> {
    if sweep.auto_unresolved() {
        if let Some(base) = sweep.base.as_object_mut() {
            base.remove("integrator");
        }
    }
    let grid = Grid::new(&sweep)?;
    if index >= grid.len() {
        return Err(Error::input(
            "index",
            format!("the sweep has {} grid points, got {index}", grid.len()),
        ));
    }
    grid.build(&sweep, index)
}

#[allow(clippy::too_many_arguments)]
fn compute(
    scene: Option<String>,
    path: Option<String>,
    index: usize,
    modes: bool,
    cell_particles: Option<usize>,
    dispersion_points: usize,
    damped: bool,
) -> Result<Out> {
    let sweep = match (scene, path) {
        (Some(text), None) => {
            let v: Value = serde_json::from_str(&text)
                .map_err(|e| Error::input("scene", format!("not valid JSON: {e}")))?;
            Sweep::of_scene(v, None, None)?.0
        }
        (None, Some(p)) => Sweep::load(&p)?,
        _ => {
            return Err(Error::input(
                "source",
                "give a scene or a sweep file, not both",
            ))
        }
    };
    let scene = scene_of(sweep, index)?;
    let chain = scene.validate().map_err(input)?;
    let lin = LinearChain::of(&chain).map_err(input)?;
    let s = lin.spectrum(modes);
    let cell_particles = cell_particles.or(scene.record.spectrum.and_then(|r| r.cell_particles));
    let cell = match cell_particles {
        Some(p) => {
            let cell = lin.unit_cell(p, "cell_particles").map_err(input)?;
            let (q, w) = cell.dispersion(dispersion_points);
            let bands = cell.bands();
            Some(Cell {
                particles: p,
                wavenumber: q,
                dispersion: w,
                lower: bands.iter().map(|b| b.lower_rad_s).collect(),
                upper: bands.iter().map(|b| b.upper_rad_s).collect(),
            })
        }
        None => None,
    };
    let damped = if damped {
        let (l, method) = lin.damped_eigenvalues("damped").map_err(input)?;
        let name = match method {
            DampedMethod::Undamped => "undamped",
            DampedMethod::Proportional => "proportional",
            DampedMethod::Companion => "companion",
        };
        Some((
            l.iter().map(|x| x.re).collect(),
            l.iter().map(|x| x.im).collect(),
            name,
        ))
    } else {
        None
    };
    Ok(Out {
        first_particle: s.first_particle,
        omega: s.angular_frequency_rad_s,
        modes: s.modes,
        lin,
        cell,
        damped,
    })
}

fn f64_bytes<'py>(py: Python<'py>, xs: &[f64]) -> Bound<'py, PyBytes> {
    let mut b = Vec::with_capacity(8 * xs.len());
    for x in xs {
        b.extend_from_slice(&x.to_le_bytes());
    }
    PyBytes::new(py, &b)
}

/// The linear spectrum of a scene (`scene`: a sweep file's `base` as JSON) or of grid point
/// `index` of the sweep file at `path`, with the GIL released: angular frequencies, mode shapes
/// (when `modes`), the Bloch dispersion on `dispersion_points` wavenumbers and the bands of the
/// unit cell of `cell_particles` particles (default: the scene's `record.spectrum.cell_particles`),
/// and the damped eigenvalues (when `damped`). Raises `chainsweep.InputError` naming the field.
#[pyfunction]
#[pyo3(signature = (scene=None, path=None, index=0, modes=true, cell_particles=None, dispersion_points=101, damped=false))]
#[allow(clippy::too_many_arguments)]
pub fn spectrum<'py>(
    py: Python<'py>,
    scene: Option<&str>,
    path: Option<&str>,
    index: usize,
    modes: bool,
    cell_particles: Option<usize>,
    dispersion_points: usize,
    damped: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let (scene, path) = (scene.map(str::to_string), path.map(str::to_string));
    let out = py
        .detach(move || {
            compute(
                scene,
                path,
                index,
                modes,
                cell_particles,
                dispersion_points,
                damped,
            )
        })
        .map_err(|e| crate::py_error(py, &e, "spectrum"))?;
    let d = PyDict::new(py);
    d.set_item("first_particle", out.first_particle + 1)?;
    d.set_item("mass_kg", f64_bytes(py, &out.lin.mass))?;
    let mut k = out.lin.stiffness.clone();
    k.push(out.lin.wall_stiffness);
    let mut c = out.lin.damping.clone();
    c.push(out.lin.wall_damping);
    d.set_item("stiffness_n_per_m", f64_bytes(py, &k))?;
    d.set_item("damping_kg_s", f64_bytes(py, &c))?;
    d.set_item("angular_frequency_rad_s", f64_bytes(py, &out.omega))?;
    match &out.modes {
        Some(m) => d.set_item("modes", f64_bytes(py, m))?,
        None => d.set_item("modes", py.None())?,
    }
    match &out.cell {
        Some(cell) => {
            d.set_item("cell_particles", cell.particles)?;
            d.set_item("wavenumber", f64_bytes(py, &cell.wavenumber))?;
            d.set_item("dispersion_rad_s", f64_bytes(py, &cell.dispersion))?;
            d.set_item("band_lower_rad_s", f64_bytes(py, &cell.lower))?;
            d.set_item("band_upper_rad_s", f64_bytes(py, &cell.upper))?;
        }
        None => d.set_item("cell_particles", py.None())?,
    }
    match &out.damped {
        Some((re, im, method)) => {
            d.set_item("damped_re", f64_bytes(py, re))?;
            d.set_item("damped_im", f64_bytes(py, im))?;
            d.set_item("damped_method", *method)?;
        }
        None => d.set_item("damped_method", py.None())?,
    }
    Ok(d)
}
