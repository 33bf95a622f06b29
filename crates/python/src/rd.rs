//! `simkit.Rd`: reaction–diffusion on a 2D grid (Gray–Scott, bacterial colony, pure
//! diffusion), in f64 or f32.

use std::path::PathBuf;

use numpy::{IntoPyArray, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use simkit::backend::{Real, Restart, Simulation};
use simkit::rd::scenes::{colony_scene, gray_scott_square};
use simkit::rd::{
    Boundaries, Boundary, Colony, Config, Diffusion, GrayScott, Grid, Model, Stepping,
};

use crate::arrays;
use crate::common::{self, Owned};
use crate::errors::IntoPy;

/// One of the models in one of the precisions.
enum Sim {
    GrayScott64(simkit::rd::Rd<f64, GrayScott>),
    GrayScott32(simkit::rd::Rd<f32, GrayScott>),
    Colony64(simkit::rd::Rd<f64, Colony>),
    Colony32(simkit::rd::Rd<f32, Colony>),
    Diffusion64(simkit::rd::Rd<f64, Diffusion>),
    Diffusion32(simkit::rd::Rd<f32, Diffusion>),
}

/// Runs `$body` with `$s` bound to the simulation, whatever its model and precision.
macro_rules! each {
    ($sim:expr, $s:ident => $body:expr) => {
        match $sim {
            Sim::GrayScott64($s) => $body,
            Sim::GrayScott32($s) => $body,
            Sim::Colony64($s) => $body,
            Sim::Colony32($s) => $body,
            Sim::Diffusion64($s) => $body,
            Sim::Diffusion32($s) => $body,
        }
    };
}

/// Reaction–diffusion of `S` species on an `nx x ny` grid of spacing `h` (five-point
/// Laplacian, explicit Euler or Heun steps with the stability bound enforced).
///
/// Built by `Rd.gray_scott(...)`, `Rd.diffusion(...)`, `Rd.gray_scott_square(...)` or
/// `Rd.colony(...)`. `fields` (input and output) has shape `(S, ny, nx)`: `fields[s, j, i]`
/// is species `s` at cell `(i, j)`. `boundary` is `"periodic"`, `"no_flux"`, or a list of
/// one fixed value per species (Dirichlet) on all four edges.
#[pyclass(module = "simkit")]
pub(crate) struct Rd {
    inner: Owned<Sim>,
}

/// The grid of `fields` (shape `(S, ny, nx)`) in precision `T`.
fn grid<T: Real>(
    fields: &Bound<'_, PyAny>,
    h: f64,
    boundary: &Bound<'_, PyAny>,
) -> PyResult<Grid<T>> {
    let np = fields.py().import("numpy")?;
    let a = np
        .call_method1("ascontiguousarray", (fields, "float64"))
        .map_err(|e| pyo3::exceptions::PyTypeError::new_err(format!("fields: {e}")))?;
    let a = a.cast::<numpy::PyArray3<f64>>().map_err(|_| {
        PyValueError::new_err("fields: must be a 3-D array of shape (species, ny, nx)")
    })?;
    let [s, ny, nx]: [usize; 3] = a.shape().try_into().map_err(|_| {
        PyValueError::new_err("fields: must be a 3-D array of shape (species, ny, nx)")
    })?;
    let ro = a.readonly();
    let flat = ro.as_slice()?;
    let per = nx * ny;
    let fields: Vec<Vec<T>> = (0..s)
        .map(|k| {
            flat[k * per..(k + 1) * per]
                .iter()
                .map(|&v| T::from_f64(v))
                .collect()
        })
        .collect();
    let boundaries = if let Ok(name) = boundary.extract::<String>() {
        match name.as_str() {
            "periodic" => Boundaries::periodic(),
            "no_flux" => Boundaries::no_flux(),
            other => {
                return Err(PyValueError::new_err(format!(
                    "boundary: {other:?} (use 'periodic', 'no_flux' or a list of one value \
                     per species for fixed values)"
                )));
            }
        }
    } else {
        Boundaries::all(Boundary::Dirichlet(arrays::values(
            boundary,
            "boundary",
            Some(s),
        )?))
    };
    Grid::new(nx, ny, h, boundaries, fields).py()
}

/// The stepping from `dt` and the integrator's name.
fn stepping(dt: f64, integrator: &str) -> PyResult<Config> {
    let s = match integrator {
        "euler" => Stepping::euler(dt),
        "heun" => Stepping::heun(dt),
        other => {
            return Err(PyValueError::new_err(format!(
                "invalid integrator: {other:?} (use 'euler' or 'heun')"
            )));
        }
    };
    let c = Config::new(s);
    c.validate().py()?;
    Ok(c)
}

/// Starts `model` on `fields` in the named precision; `wrap` picks the variant.
#[allow(clippy::too_many_arguments)]
fn start<M: Model + Send + 'static>(
    py: Python<'_>,
    fields: &Bound<'_, PyAny>,
    h: f64,
    boundary: &Bound<'_, PyAny>,
    model: M,
    config: &Config,
    precision: &str,
    backend: &str,
    wrap64: fn(simkit::rd::Rd<f64, M>) -> Sim,
    wrap32: fn(simkit::rd::Rd<f32, M>) -> Sim,
) -> PyResult<Rd> {
    let b = crate::backend::backend(backend)?;
    let sim = match crate::backend::precision(precision)? {
        simkit::backend::Precision::F64 => {
            let g = grid::<f64>(fields, h, boundary)?;
            wrap64(
                py.detach(|| simkit::rd::Rd::new(g, model, config, b))
                    .py()?,
            )
        }
        simkit::backend::Precision::F32 => {
            let g = grid::<f32>(fields, h, boundary)?;
            wrap32(
                py.detach(|| simkit::rd::Rd::new(g, model, config, b))
                    .py()?,
            )
        }
    };
    Ok(Rd {
        inner: Owned::new(sim),
    })
}

/// The fields of `g` as a `(S, ny, nx)` array in its own precision.
fn fields_array<'py, T: Real + numpy::Element>(
    py: Python<'py>,
    g: &Grid<T>,
) -> PyResult<Bound<'py, PyAny>> {
    let flat: Vec<T> = g.fields().iter().flatten().copied().collect();
    Ok(flat
        .into_pyarray(py)
        .reshape([g.species(), g.ny(), g.nx()])?
        .into_any())
}

#[pymethods]
impl Rd {
    /// Gray–Scott: `du/dt = du lap(u) - u v^2 + feed (1 - u)`,
    /// `dv/dt = dv lap(v) + u v^2 - (feed + kill) v`; `fields` of shape `(2, ny, nx)`.
    #[staticmethod]
    #[pyo3(signature = (fields, *, du, dv, feed, kill, dt, h=1.0, boundary=None,
        integrator="euler", precision="f64", backend="cpu"))]
    #[allow(clippy::too_many_arguments)]
    fn gray_scott(
        fields: &Bound<'_, PyAny>,
        du: f64,
        dv: f64,
        feed: f64,
        kill: f64,
        dt: f64,
        h: f64,
        boundary: Option<&Bound<'_, PyAny>>,
        integrator: &str,
        precision: &str,
        backend: &str,
    ) -> PyResult<Self> {
        let py = fields.py();
        let model = GrayScott::new(du, dv, feed, kill).py()?;
        let periodic = pyo3::types::PyString::new(py, "periodic").into_any();
        let c = stepping(dt, integrator)?;
        start(
            py,
            fields,
            h,
            boundary.unwrap_or(&periodic),
            model,
            &c,
            precision,
            backend,
            Sim::GrayScott64,
            Sim::GrayScott32,
        )
    }

    /// Pearson's Gray–Scott start on a periodic `n x n` grid: `u = 1`, `v = 0` except a
    /// centred square of `side` cells at `u = 0.5`, `v = 0.25`, with 1 % noise from `seed`;
    /// `h` defaults to Pearson's 2.5 / 256 and the rates to his pattern (`du = 2e-5`,
    /// `dv = 1e-5`, `feed = 0.04`, `kill = 0.06`).
    #[staticmethod]
    #[pyo3(signature = (n, *, side=None, seed=1, h=None, du=2e-5, dv=1e-5, feed=0.04,
        kill=0.06, dt=1.0, integrator="euler", precision="f64", backend="cpu"))]
    #[allow(clippy::too_many_arguments)]
    fn gray_scott_square(
        py: Python<'_>,
        n: usize,
        side: Option<usize>,
        seed: u32,
        h: Option<f64>,
        du: f64,
        dv: f64,
        feed: f64,
        kill: f64,
        dt: f64,
        integrator: &str,
        precision: &str,
        backend: &str,
    ) -> PyResult<Self> {
        let h = h.unwrap_or(GrayScott::PEARSON_H);
        let g = gray_scott_square::<f64>(n, h, side.unwrap_or(n / 8), seed).py()?;
        let fields = fields_array(py, &g)?;
        let periodic = pyo3::types::PyString::new(py, "periodic").into_any();
        let model = GrayScott::new(du, dv, feed, kill).py()?;
        let c = stepping(dt, integrator)?;
        start(
            py,
            &fields,
            h,
            &periodic,
            model,
            &c,
            precision,
            backend,
            Sim::GrayScott64,
            Sim::GrayScott32,
        )
    }

    /// Pure diffusion `dc_s/dt = D_s lap(c_s)`, one diffusivity per species.
    #[staticmethod]
    #[pyo3(signature = (fields, *, diffusivity, dt, h=1.0, boundary=None,
        integrator="euler", precision="f64", backend="cpu"))]
    #[allow(clippy::too_many_arguments)]
    fn diffusion(
        fields: &Bound<'_, PyAny>,
        diffusivity: &Bound<'_, PyAny>,
        dt: f64,
        h: f64,
        boundary: Option<&Bound<'_, PyAny>>,
        integrator: &str,
        precision: &str,
        backend: &str,
    ) -> PyResult<Self> {
        let py = fields.py();
        let d = arrays::values(diffusivity, "diffusivity", None)?;
        let model = Diffusion::new(&d).py()?;
        let periodic = pyo3::types::PyString::new(py, "periodic").into_any();
        let c = stepping(dt, integrator)?;
        start(
            py,
            fields,
            h,
            boundary.unwrap_or(&periodic),
            model,
            &c,
            precision,
            backend,
            Sim::Diffusion64,
            Sim::Diffusion32,
        )
    }

    /// The bacterial-colony scene (bacteria `b` spreading with density-dependent
    /// diffusion and eating nutrient `n`) on an `nx x ny` grid from `seed`.
    #[staticmethod]
    #[pyo3(signature = (nx, ny, seed=7, *, dt=0.005, integrator="euler", precision="f32",
        backend="cpu"))]
    #[allow(clippy::too_many_arguments)]
    fn colony(
        py: Python<'_>,
        nx: usize,
        ny: usize,
        seed: u32,
        dt: f64,
        integrator: &str,
        precision: &str,
        backend: &str,
    ) -> PyResult<Self> {
        let c = stepping(dt, integrator)?;
        let b = crate::backend::backend(backend)?;
        let sim = match crate::backend::precision(precision)? {
            simkit::backend::Precision::F64 => {
                let (g, model) = colony_scene::<f64>(nx, ny, seed).py()?;
                Sim::Colony64(py.detach(|| simkit::rd::Rd::new(g, model, &c, b)).py()?)
            }
            simkit::backend::Precision::F32 => {
                let (g, model) = colony_scene::<f32>(nx, ny, seed).py()?;
                Sim::Colony32(py.detach(|| simkit::rd::Rd::new(g, model, &c, b)).py()?)
            }
        };
        Ok(Self {
            inner: Owned::new(sim),
        })
    }

    /// Advances `n` steps (the GIL is released meanwhile). Raises `simkit.BlowUp` when a
    /// value turns non-finite.
    fn step(&mut self, py: Python<'_>, n: u32) -> PyResult<()> {
        each!(self.inner.get(), s => common::step(py, s, n))
    }

    /// The fields, shape `(S, ny, nx)`, float64 or float32 as the run's precision (a copy).
    #[getter]
    fn fields<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        each!(self.inner.get(), s => {
            let g = s.state().py()?;
            fields_array(py, &g)
        })
    }

    /// The sum of species `s` over the grid (times nothing: a plain sum of cell values).
    fn total(&mut self, s: usize) -> PyResult<f64> {
        each!(self.inner.get(), sim => {
            let g = sim.state().py()?;
            if s >= g.species() {
                return Err(PyValueError::new_err(format!(
                    "species {s}: the model has {} species", g.species()
                )));
            }
            Ok(g.total(s))
        })
    }

    /// The largest stable time step of the model on this grid.
    fn stable_dt(&mut self) -> PyResult<f64> {
        each!(self.inner.get(), s => s.stable_dt().py())
    }

    /// Writes a checkpoint (grid, model, step count) to `path`.
    fn write_checkpoint(&mut self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        each!(self.inner.get(), s => common::write_checkpoint(py, s, path))
    }

    /// Resumes from a checkpoint written by `write_checkpoint` (the model and precision are
    /// read from the file), on `backend`.
    #[staticmethod]
    #[pyo3(signature = (path, backend="cpu"))]
    fn resume(py: Python<'_>, path: PathBuf, backend: &str) -> PyResult<Self> {
        let b = crate::backend::backend(backend)?;
        let bytes = std::fs::read(&path).map_err(|e| {
            pyo3::exceptions::PyOSError::new_err(format!("{}: {e}", path.display()))
        })?;
        let sim = py.detach(|| {
            // The checkpoint names its model and precision: try each reader in turn and
            // keep the first that accepts the file (the others refuse it by name).
            let mut first_error = None;
            macro_rules! attempt {
                ($variant:ident, $t:ty, $m:ty) => {
                    match simkit::rd::Rd::<$t, $m>::resume(&bytes, b) {
                        Ok(s) => return Ok(Sim::$variant(s)),
                        Err(e) => {
                            first_error.get_or_insert(e);
                        }
                    }
                };
            }
            attempt!(GrayScott64, f64, GrayScott);
            attempt!(GrayScott32, f32, GrayScott);
            attempt!(Colony64, f64, Colony);
            attempt!(Colony32, f32, Colony);
            attempt!(Diffusion64, f64, Diffusion);
            attempt!(Diffusion32, f32, Diffusion);
            Err(first_error.expect("at least one reader ran"))
        });
        Ok(Self {
            inner: Owned::new(sim.py()?),
        })
    }

    /// Simulation time.
    #[getter]
    fn time(&mut self) -> f64 {
        each!(self.inner.get(), s => s.time())
    }

    /// Steps taken since the start (checkpoints keep the count).
    #[getter]
    fn steps_done(&mut self) -> u64 {
        each!(self.inner.get(), s => s.steps_done())
    }

    /// The backend and precision running the simulation.
    #[getter]
    fn backend_name(&mut self) -> String {
        each!(self.inner.get(), s => s.backend_name())
    }

    fn __repr__(&mut self) -> String {
        each!(self.inner.get(), s => format!(
            "Rd({}, step {})",
            s.backend_name(),
            s.steps_done()
        ))
    }
}
