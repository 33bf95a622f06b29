//! `simkit.LatticeGas`: the FHP lattice gas on a hexagonal lattice.

use std::path::PathBuf;

use numpy::{PyArray2, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use simkit::backend::Simulation;
use simkit::lattice_gas::{BlockField, Config, CpuMethod, Lattice, Obstacle, RuleSet};

use crate::arrays;
use crate::common::{self, Owned, pydict};
use crate::errors::IntoPy;

/// The FHP lattice gas (D2Q6): one byte per site, bits 0–5 the six moving particles, bit 6
/// the rest particle (FHP-II/III), bit 7 a solid site (bounce-back). Collisions from the
/// rule set (`"fhp_i"` or `"full"`, the full FHP-III table), with one random bit per site
/// from `seed` for the chiral choices.
///
/// `LatticeGas(cells, *, ...)`: `cells` a uint8 array of shape `(height, width)` (rows of
/// the lattice, even `height` for periodic y); keywords as the Rust `Config`: `rules`,
/// `seed`, `periodic_x`, `periodic_y`, `inflow`, `outflow` (refill / empty the end columns,
/// non-periodic x only), `body_force` (the probability per site and step of a push along
/// +x), `cpu_method` (`"auto"`, `"lut"`, `"lut_portable"`, `"multi_spin"`).
/// `LatticeGas.channel(...)` builds a channel past a disc.
#[pyclass(module = "simkit")]
pub(crate) struct LatticeGas {
    inner: Owned<simkit::lattice_gas::LatticeGas>,
}

/// The config from the keyword arguments.
#[allow(clippy::too_many_arguments)]
fn config(
    rules: &str,
    seed: u32,
    periodic_x: bool,
    periodic_y: bool,
    inflow: bool,
    outflow: bool,
    body_force: f64,
    cpu_method: &str,
) -> PyResult<Config> {
    let rules = match rules {
        "fhp_i" => RuleSet::FhpI,
        "full" => RuleSet::Full,
        other => {
            return Err(PyValueError::new_err(format!(
                "invalid rules: {other:?} (use 'fhp_i' or 'full')"
            )));
        }
    };
    let cpu = match cpu_method {
        "auto" => CpuMethod::Auto,
        "lut" => CpuMethod::Lut,
        "lut_portable" => CpuMethod::LutPortable,
        "multi_spin" => CpuMethod::MultiSpin,
        other => {
            return Err(PyValueError::new_err(format!(
                "invalid cpu_method: {other:?} (use 'auto', 'lut', 'lut_portable' or \
                 'multi_spin')"
            )));
        }
    };
    let c = Config {
        rules,
        seed,
        periodic_x,
        periodic_y,
        inflow,
        outflow,
        body_force,
        cpu,
        ..Config::default()
    };
    c.validate().py()?;
    Ok(c)
}

/// Starts the lattice on the named backend.
fn start(py: Python<'_>, lattice: Lattice, c: &Config, backend: &str) -> PyResult<LatticeGas> {
    let b = crate::backend::backend(backend)?;
    let inner = py
        .detach(|| simkit::lattice_gas::LatticeGas::new(lattice, c, b))
        .py()?;
    Ok(LatticeGas {
        inner: Owned::new(inner),
    })
}

#[pymethods]
impl LatticeGas {
    #[new]
    #[pyo3(signature = (cells, *, rules="fhp_i", seed=1, periodic_x=true, periodic_y=true,
        inflow=false, outflow=false, body_force=0.0, cpu_method="auto", backend="cpu"))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        cells: &Bound<'_, PyAny>,
        rules: &str,
        seed: u32,
        periodic_x: bool,
        periodic_y: bool,
        inflow: bool,
        outflow: bool,
        body_force: f64,
        cpu_method: &str,
        backend: &str,
    ) -> PyResult<Self> {
        let py = cells.py();
        let a = py
            .import("numpy")?
            .call_method1("ascontiguousarray", (cells, "uint8"))
            .map_err(|e| pyo3::exceptions::PyTypeError::new_err(format!("cells: {e}")))?;
        let a = a.cast::<PyArray2<u8>>().map_err(|_| {
            PyValueError::new_err("cells: must be a 2-D uint8 array of shape (height, width)")
        })?;
        let [height, width]: [usize; 2] = a.shape().try_into().map_err(|_| {
            PyValueError::new_err("cells: must be a 2-D uint8 array of shape (height, width)")
        })?;
        let lattice = Lattice::from_cells(width, height, a.readonly().as_slice()?.to_vec()).py()?;
        let c = config(
            rules, seed, periodic_x, periodic_y, inflow, outflow, body_force, cpu_method,
        )?;
        start(py, lattice, &c, backend)
    }

    /// A channel `width x height` (wall rows at top and bottom, inflow and outflow columns)
    /// past a disc of radius `height / 10` row spacings at a quarter of the length, filled
    /// with `density_forward` particles per site on the +x direction and `density_other`
    /// on the others (drawn from `fill_seed`); the full collision table, `seed` for the
    /// collisions.
    #[staticmethod]
    #[pyo3(signature = (width=256, height=128, *, density_forward=0.5, density_other=0.15,
        fill_seed=3, seed=2026, backend="cpu"))]
    #[allow(clippy::too_many_arguments)]
    fn channel(
        py: Python<'_>,
        width: usize,
        height: usize,
        density_forward: f64,
        density_other: f64,
        fill_seed: u32,
        seed: u32,
        backend: &str,
    ) -> PyResult<Self> {
        let mut lattice = Lattice::new(width, height).py()?;
        lattice.add_wall_rows();
        let channel = height as f64 * simkit::lattice_gas::ROW_SPACING;
        lattice
            .add_obstacle(&Obstacle::Disc {
                cx: 0.25 * width as f64,
                cy: 0.5 * channel,
                radius: channel / 10.0,
            })
            .py()?;
        lattice
            .fill_with(fill_seed, |_, _, k| {
                if k == 0 {
                    density_forward
                } else {
                    density_other
                }
            })
            .py()?;
        let c = config("full", seed, false, false, true, true, 0.0, "auto")?;
        start(py, lattice, &c, backend)
    }

    /// A periodic `width x height` lattice with every moving direction occupied with
    /// probability `density` (from `fill_seed`).
    #[staticmethod]
    #[pyo3(signature = (width, height, density, fill_seed=1, *, rules="fhp_i", seed=1,
        backend="cpu"))]
    #[allow(clippy::too_many_arguments)]
    fn random(
        py: Python<'_>,
        width: usize,
        height: usize,
        density: f64,
        fill_seed: u32,
        rules: &str,
        seed: u32,
        backend: &str,
    ) -> PyResult<Self> {
        let mut lattice = Lattice::new(width, height).py()?;
        lattice.fill_random(density, fill_seed).py()?;
        let c = config(rules, seed, true, true, false, false, 0.0, "auto")?;
        start(py, lattice, &c, backend)
    }

    /// Advances `n` steps (the GIL is released meanwhile).
    fn step(&mut self, py: Python<'_>, n: u32) -> PyResult<()> {
        common::step(py, self.inner.get(), n)
    }

    /// The sites, uint8, shape `(height, width)` (a copy).
    #[getter]
    fn cells<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<u8>>> {
        let l = self.inner.get().state().py()?;
        let (w, h) = (l.width(), l.height());
        arrays::to_array(py, l.cells().to_vec()).reshape([h, w])
    }

    /// Particles and momentum (in lattice units) of the whole lattice.
    fn totals<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let l = self.inner.get().state().py()?;
        let (px, py_) = l.momentum_units();
        Ok(pydict!(py,
            "particles" => l.particle_count(),
            "momentum_units" => (px, py_),
        ))
    }

    /// Density and velocity averaged over `block x block` sites: a dict of `density`,
    /// `ux`, `uy` arrays of shape `(height / block, width / block)`.
    #[pyo3(signature = (block=8))]
    fn block_field<'py>(&mut self, py: Python<'py>, block: usize) -> PyResult<Bound<'py, PyDict>> {
        let f: BlockField = self.inner.get().block_field(block).py()?;
        let (ux, uy) = f.velocity();
        let (nx, ny) = f.blocks();
        let shape = [ny, nx];
        let grid = |v: Vec<f64>| -> PyResult<Bound<'py, PyArray2<f64>>> {
            arrays::to_array(py, v).reshape(shape)
        };
        Ok(pydict!(py,
            "density" => grid(f.density())?,
            "ux" => grid(ux)?,
            "uy" => grid(uy)?,
        ))
    }

    /// Writes a checkpoint (lattice, config, step count) to `path`.
    fn write_checkpoint(&mut self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        common::write_checkpoint(py, self.inner.get(), path)
    }

    /// Resumes from a checkpoint written by `write_checkpoint`, on `backend`.
    #[staticmethod]
    #[pyo3(signature = (path, backend="cpu"))]
    fn resume(py: Python<'_>, path: PathBuf, backend: &str) -> PyResult<Self> {
        Ok(Self {
            inner: Owned::new(common::resume(py, path, backend)?),
        })
    }

    /// Steps taken since the start (checkpoints keep the count).
    #[getter]
    fn steps_done(&mut self) -> u64 {
        self.inner.get().steps_done()
    }

    /// The backend running the simulation.
    #[getter]
    fn backend_name(&mut self) -> String {
        self.inner.get().backend_name()
    }

    fn __repr__(&mut self) -> String {
        let sim = self.inner.get();
        format!(
            "LatticeGas({}, step {})",
            sim.backend_name(),
            sim.steps_done()
        )
    }
}
