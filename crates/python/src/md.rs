//! `simkit.Md`: multi-species molecular dynamics with Lennard-Jones pairs.

use std::path::PathBuf;

use numpy::PyArray2;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use simkit::backend::Simulation;
use simkit::md::{Config, Dim, Integrator, LennardJones, PairTable, System, scenes};

use crate::arrays;
use crate::backend::{precision, precision_name};
use crate::common::{self, Owned, pydict};
use crate::errors::IntoPy;

/// Molecular dynamics of point particles with Lennard-Jones pairs
/// `4 eps ((sigma/r)^12 - (sigma/r)^6)` cut at `cutoff` (one entry per species pair), in a
/// periodic or walled box, velocity Verlet at constant energy.
///
/// `Md(positions, velocities=None, *, box_lo, box_hi, ...)`: `positions` of shape `(n, 2)`
/// or `(n, 3)` (the dimension), `species` one integer per particle (default 0), `masses` one
/// per species (default `[1.0]`), `epsilon`, `sigma`, `cutoff` scalars (every pair) or
/// `(S, S)` symmetric arrays. `dt=None` picks a stable step from the potential;
/// `shift=True` shifts the energy to 0 at the cutoff. `Md.fcc(...)` builds the `in.lj`
/// state of LAMMPS's benchmark.
#[pyclass(module = "simkit")]
pub(crate) struct Md {
    inner: Owned<simkit::md::Md>,
    dim: usize,
}

/// The config from the keyword arguments (unset ones keep `Config::default()`'s values).
#[allow(clippy::too_many_arguments)]
fn config(
    dt: Option<f64>,
    shift: bool,
    integrator: &str,
    precision_arg: &str,
    skin: Option<f64>,
    check_every: Option<u32>,
    allow_unstable_dt: bool,
) -> PyResult<Config> {
    let mut c = Config::default()
        .with_shift(shift)
        .with_precision(precision(precision_arg)?)
        .with_integrator(match integrator {
            "velocity_verlet" => Integrator::VelocityVerlet,
            "leapfrog" => Integrator::Leapfrog,
            other => {
                return Err(PyValueError::new_err(format!(
                    "invalid integrator: {other:?} (use 'velocity_verlet' or 'leapfrog')"
                )));
            }
        });
    c.dt = dt;
    if let Some(s) = skin {
        c.skin = s;
    }
    if let Some(k) = check_every {
        c.check_every = k;
    }
    c.allow_unstable_dt = allow_unstable_dt;
    c.validate().py()?;
    Ok(c)
}

/// A scalar or an `(S, S)` array of a pair parameter, as the value for pair `(a, b)`.
fn pair_values(obj: &Bound<'_, PyAny>, name: &str, s: usize) -> PyResult<Vec<f64>> {
    if let Ok(x) = obj.extract::<f64>() {
        return Ok(vec![x; s * s]);
    }
    let v = arrays::rows_dyn(obj, name, s)?;
    if v.len() != s * s {
        return Err(PyValueError::new_err(format!(
            "{name}: must be a number or an array of shape ({s}, {s}) (one value per species pair)"
        )));
    }
    Ok(v)
}

/// The Lennard-Jones table of `s` species.
fn lj_table(
    s: usize,
    epsilon: &Bound<'_, PyAny>,
    sigma: &Bound<'_, PyAny>,
    cutoff: &Bound<'_, PyAny>,
) -> PyResult<PairTable> {
    let (e, sg, rc) = (
        pair_values(epsilon, "epsilon", s)?,
        pair_values(sigma, "sigma", s)?,
        pair_values(cutoff, "cutoff", s)?,
    );
    let mut table = PairTable::uniform(s, LennardJones::new(e[0], sg[0], rc[0])).py()?;
    for a in 0..s {
        for b in a..s {
            let (k, t) = (a * s + b, b * s + a);
            if e[k] != e[t] || sg[k] != sg[t] || rc[k] != rc[t] {
                return Err(PyValueError::new_err(format!(
                    "epsilon, sigma, cutoff: the ({a}, {b}) and ({b}, {a}) entries differ; a \
                     pair law is symmetric"
                )));
            }
            table
                .set(a, b, LennardJones::new(e[k], sg[k], rc[k]))
                .py()?;
        }
    }
    Ok(table)
}

/// The simulation of `system` with `c` on the named backend (built with the GIL released).
fn start(py: Python<'_>, system: System, c: &Config, backend: &str, dim: usize) -> PyResult<Md> {
    let b = crate::backend::backend(backend)?;
    let inner = py.detach(|| simkit::md::Md::new(system, c, b)).py()?;
    Ok(Md {
        inner: Owned::new(inner),
        dim,
    })
}

#[pymethods]
impl Md {
    #[new]
    #[pyo3(signature = (positions, velocities=None, *, box_lo, box_hi, species=None,
        masses=None, epsilon=None, sigma=None, cutoff=None, periodic=None, dt=None,
        shift=false, integrator="velocity_verlet", precision="f64", skin=None,
        check_every=None, allow_unstable_dt=false, backend="cpu"))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        positions: &Bound<'_, PyAny>,
        velocities: Option<&Bound<'_, PyAny>>,
        box_lo: &Bound<'_, PyAny>,
        box_hi: &Bound<'_, PyAny>,
        species: Option<&Bound<'_, PyAny>>,
        masses: Option<&Bound<'_, PyAny>>,
        epsilon: Option<&Bound<'_, PyAny>>,
        sigma: Option<&Bound<'_, PyAny>>,
        cutoff: Option<&Bound<'_, PyAny>>,
        periodic: Option<&Bound<'_, PyAny>>,
        dt: Option<f64>,
        shift: bool,
        integrator: &str,
        precision: &str,
        skin: Option<f64>,
        check_every: Option<u32>,
        allow_unstable_dt: bool,
        backend: &str,
    ) -> PyResult<Self> {
        let py = positions.py();
        let dim = arrays::columns(positions, "positions")?;
        let pos = arrays::vectors(positions, "positions", dim)?;
        let n = pos.len();
        let vel = match velocities {
            Some(v) => arrays::vectors(v, "velocities", dim)?,
            None => vec![[0.0; 3]; n],
        };
        if vel.len() != n {
            return Err(PyValueError::new_err(format!(
                "velocities: {} rows, must be {n} (one per position)",
                vel.len()
            )));
        }
        let masses = match masses {
            Some(m) => arrays::values(m, "masses", None)?,
            None => vec![1.0],
        };
        let s = masses.len();
        let species = match species {
            Some(sp) => arrays::indices(sp, "species", Some(n))?,
            None => vec![0; n],
        };
        let one = pyo3::types::PyFloat::new(py, 1.0).into_any();
        let rc = pyo3::types::PyFloat::new(py, 2.5).into_any();
        let table = lj_table(
            s,
            epsilon.unwrap_or(&one),
            sigma.unwrap_or(&one),
            cutoff.unwrap_or(&rc),
        )?;
        let lo = arrays::corner(box_lo, "box_lo", dim)?;
        let hi = arrays::corner(box_hi, "box_hi", dim)?;
        let len: [f64; 3] = std::array::from_fn(|d| if d < dim { hi[d] - lo[d] } else { 1.0 });
        let periodic = match periodic {
            Some(p) => arrays::flags(p, "periodic", dim)?,
            None => [true; 3],
        };
        let dims = if dim == 2 { Dim::Two } else { Dim::Three };
        let mut system = System::new(dims, lo, len, periodic, masses, table).py()?;
        system.set_particles(&species, &pos, &vel).py()?;
        let c = config(
            dt,
            shift,
            integrator,
            precision,
            skin,
            check_every,
            allow_unstable_dt,
        )?;
        start(py, system, &c, backend, dim)
    }

    /// The `in.lj` state of LAMMPS's benchmark (or any FCC crystal): `cells` FCC unit cells
    /// per axis (an int or 3 ints, default 5; 4 atoms each) at number density `density`, velocities
    /// drawn for `temperature` from `seed` with zero total momentum, one species of mass 1
    /// with Lennard-Jones `epsilon`, `sigma`, `cutoff`. Other keywords as for `Md(...)`.
    #[staticmethod]
    #[pyo3(signature = (cells=None, density=0.8442, temperature=1.44, seed=87287, *,
        epsilon=1.0, sigma=1.0, cutoff=2.5, dt=None, shift=false,
        integrator="velocity_verlet", precision="f64", skin=None, check_every=None,
        allow_unstable_dt=false, backend="cpu"))]
    #[allow(clippy::too_many_arguments)]
    fn fcc(
        py: Python<'_>,
        cells: Option<&Bound<'_, PyAny>>,
        density: f64,
        temperature: f64,
        seed: u64,
        epsilon: f64,
        sigma: f64,
        cutoff: f64,
        dt: Option<f64>,
        shift: bool,
        integrator: &str,
        precision: &str,
        skin: Option<f64>,
        check_every: Option<u32>,
        allow_unstable_dt: bool,
        backend: &str,
    ) -> PyResult<Self> {
        let cells: [usize; 3] = match cells {
            None => [5; 3],
            Some(c) => match c.extract::<usize>() {
                Ok(c) => [c; 3],
                Err(_) => c.extract().map_err(|_| {
                    pyo3::exceptions::PyTypeError::new_err("cells: an int or a sequence of 3 ints")
                })?,
            },
        };
        let table = PairTable::uniform(1, LennardJones::new(epsilon, sigma, cutoff)).py()?;
        let system = scenes::fcc_lattice(cells, density, temperature, table, &[0], seed).py()?;
        let c = config(
            dt,
            shift,
            integrator,
            precision,
            skin,
            check_every,
            allow_unstable_dt,
        )?;
        start(py, system, &c, backend, 3)
    }

    /// Advances `n` steps (the GIL is released meanwhile). Raises `simkit.BlowUp` when the
    /// run turns non-finite; the simulation then holds the last state that passed the check.
    fn step(&mut self, py: Python<'_>, n: u32) -> PyResult<()> {
        common::step(py, self.inner.get(), n)
    }

    /// Positions, shape `(n, dim)` (a copy).
    #[getter]
    fn positions<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let s = self.inner.get().state().py()?;
        arrays::to_vectors(py, &s.positions, self.dim)
    }

    /// Velocities, shape `(n, dim)` (a copy).
    #[getter]
    fn velocities<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let s = self.inner.get().state().py()?;
        arrays::to_vectors(py, &s.velocities, self.dim)
    }

    /// Species of every particle, shape `(n,)`, uint32.
    #[getter]
    fn species<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, numpy::PyArray1<u32>>> {
        let s = self.inner.get().state().py()?;
        Ok(arrays::to_array(py, s.species))
    }

    /// Forces on every particle at the current positions, shape `(n, dim)`.
    fn forces<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let f = self.inner.get().forces().py()?;
        arrays::to_vectors(py, &f, self.dim)
    }

    /// Energies (`kinetic`, `potential`, `total`), `virial`, `pressure`, `time` and
    /// `species_temperature` (one per species) of the current state.
    fn diagnostics<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = self.inner.get().diagnostics().py()?;
        Ok(pydict!(py,
            "time" => d.time,
            "kinetic" => d.kinetic,
            "potential" => d.potential,
            "total" => d.total,
            "virial" => d.virial,
            "pressure" => d.pressure,
            "species_temperature" => d.species_temperature,
        ))
    }

    /// Writes a checkpoint (the whole state, bit for bit) to `path`.
    fn write_checkpoint(&mut self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        common::write_checkpoint(py, self.inner.get(), path)
    }

    /// Resumes from a checkpoint written by `write_checkpoint`, on `backend`.
    #[staticmethod]
    #[pyo3(signature = (path, backend="cpu"))]
    fn resume(py: Python<'_>, path: PathBuf, backend: &str) -> PyResult<Self> {
        let inner: simkit::md::Md = common::resume(py, path, backend)?;
        let dim = inner.system().dim().axes();
        Ok(Self {
            inner: Owned::new(inner),
            dim,
        })
    }

    /// Simulation time.
    #[getter]
    fn time(&mut self) -> PyResult<f64> {
        Ok(self.inner.get().state().py()?.time)
    }

    /// Steps taken since the start (checkpoints keep the count).
    #[getter]
    fn steps_done(&mut self) -> u64 {
        self.inner.get().steps_done()
    }

    /// The time step in use.
    #[getter]
    fn dt(&mut self) -> f64 {
        self.inner.get().dt()
    }

    /// Number of particles.
    fn __len__(&mut self) -> usize {
        self.inner.get().system().particle_count()
    }

    /// 2 or 3.
    #[getter]
    fn dim(&mut self) -> usize {
        self.dim
    }

    /// The backend and precision running the simulation (e.g. `"cpu f64"`).
    #[getter]
    fn backend_name(&mut self) -> String {
        self.inner.get().backend_name()
    }

    /// The precision (`"f64"` or `"f32"`).
    #[getter]
    fn precision(&mut self) -> &'static str {
        precision_name(self.inner.get().config().precision)
    }

    fn __repr__(&mut self) -> String {
        let sim = self.inner.get();
        format!(
            "Md({} particles, {}D, {}, step {})",
            sim.system().particle_count(),
            self.dim,
            sim.backend_name(),
            sim.steps_done()
        )
    }
}
