//! `simkit.PpCoulomb`: direct-sum Coulomb dynamics of point charges.

use std::path::PathBuf;

use numpy::PyArray2;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use simkit::backend::Simulation;
use simkit::pp_coulomb::scenes::cold_sphere;
use simkit::pp_coulomb::{Config, ForceLaw, Integrator, Particles, Species};

use crate::arrays;
use crate::backend::{precision, precision_name};
use crate::common::{self, Owned, pydict};
use crate::errors::IntoPy;

/// Point charges moving under their mutual Coulomb forces `F_ij = q_i q_j r_ij / |r_ij|^3`
/// (units with `1 / (4 pi eps0) = 1`), summed over every pair (no cutoff, open boundaries).
///
/// `PpCoulomb(positions, charges, masses, velocities=None, *, dt, ...)`: `positions` of shape
/// `(n, 3)`, `charges` and `masses` one per particle (or one number for all). `force` is
/// `"exact"`, `"plummer"` (`F ~ r / (r^2 + softening^2)^(3/2)`) or `"exclusion"` (no force
/// inside `softening`); `integrator` `"leapfrog"` (kick–drift–kick) or `"symplectic_euler"`.
/// `PpCoulomb.cold_sphere(...)` builds the Coulomb-explosion start.
#[pyclass(module = "simkit")]
pub(crate) struct PpCoulomb {
    inner: Owned<simkit::pp_coulomb::PpCoulomb>,
}

/// The config from the keyword arguments.
fn config(
    dt: f64,
    force: &str,
    softening: Option<f64>,
    integrator: &str,
    precision_arg: &str,
    check_every: Option<u32>,
) -> PyResult<Config> {
    let law = match (force, softening) {
        ("exact", None) => ForceLaw::Exact,
        ("plummer", Some(epsilon)) => ForceLaw::Plummer { epsilon },
        ("exclusion", Some(radius)) => ForceLaw::Exclusion { radius },
        ("exact", Some(_)) => {
            return Err(PyValueError::new_err(
                "softening: not used by force='exact' (use 'plummer' or 'exclusion')",
            ));
        }
        ("plummer" | "exclusion", None) => {
            return Err(PyValueError::new_err(format!(
                "softening: force={force:?} needs a softening length"
            )));
        }
        (other, _) => {
            return Err(PyValueError::new_err(format!(
                "invalid force: {other:?} (use 'exact', 'plummer' or 'exclusion')"
            )));
        }
    };
    let integrator = match integrator {
        "leapfrog" => Integrator::Leapfrog,
        "symplectic_euler" => Integrator::SymplecticEuler,
        other => {
            return Err(PyValueError::new_err(format!(
                "invalid integrator: {other:?} (use 'leapfrog' or 'symplectic_euler')"
            )));
        }
    };
    let mut c = Config::new(dt, law)
        .with_integrator(integrator)
        .with_precision(precision(precision_arg)?);
    if let Some(k) = check_every {
        c = c.with_check_every(k);
    }
    c.validate().py()?;
    Ok(c)
}

/// Starts the particles on the named backend.
fn start(py: Python<'_>, p: Particles, c: &Config, backend: &str) -> PyResult<PpCoulomb> {
    let b = crate::backend::backend(backend)?;
    let inner = py
        .detach(|| simkit::pp_coulomb::PpCoulomb::new(p, c, b))
        .py()?;
    Ok(PpCoulomb {
        inner: Owned::new(inner),
    })
}

/// One value per particle from a number or a length-`n` array.
fn per_particle(obj: &Bound<'_, PyAny>, name: &str, n: usize) -> PyResult<Vec<f64>> {
    match obj.extract::<f64>() {
        Ok(x) => Ok(vec![x; n]),
        Err(_) => arrays::values(obj, name, Some(n)),
    }
}

#[pymethods]
impl PpCoulomb {
    #[new]
    #[pyo3(signature = (positions, charges, masses, velocities=None, *, dt, force="exact",
        softening=None, integrator="leapfrog", precision="f64", check_every=None,
        backend="cpu"))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        positions: &Bound<'_, PyAny>,
        charges: &Bound<'_, PyAny>,
        masses: &Bound<'_, PyAny>,
        velocities: Option<&Bound<'_, PyAny>>,
        dt: f64,
        force: &str,
        softening: Option<f64>,
        integrator: &str,
        precision: &str,
        check_every: Option<u32>,
        backend: &str,
    ) -> PyResult<Self> {
        let pos = arrays::rows::<3>(positions, "positions")?;
        let n = pos.len();
        let vel = match velocities {
            Some(v) => arrays::rows::<3>(v, "velocities")?,
            None => vec![[0.0; 3]; n],
        };
        if vel.len() != n {
            return Err(PyValueError::new_err(format!(
                "velocities: {} rows, must be {n} (one per position)",
                vel.len()
            )));
        }
        let q = per_particle(charges, "charges", n)?;
        let m = per_particle(masses, "masses", n)?;
        // One species per distinct (charge, mass) pair, in order of first appearance.
        let mut p = Particles::new();
        let mut kinds: Vec<(u64, u64, u32)> = Vec::new();
        for k in 0..n {
            let key = (q[k].to_bits(), m[k].to_bits());
            let s = match kinds.iter().find(|(a, b, _)| (*a, *b) == key) {
                Some(&(_, _, s)) => s,
                None => {
                    let s = p
                        .add_species(Species::new(format!("q{}_m{}", q[k], m[k]), q[k], m[k]))
                        .py()?;
                    kinds.push((key.0, key.1, s));
                    s
                }
            };
            p.push(s, pos[k], vel[k]).py()?;
        }
        let c = config(dt, force, softening, integrator, precision, check_every)?;
        start(positions.py(), p, &c, backend)
    }

    /// `n` equal charges (total charge 1, total mass 1) at rest, uniformly in a sphere of
    /// `radius` (from `seed`): the Coulomb-explosion start.
    #[staticmethod]
    #[pyo3(signature = (n, radius=1.0, seed=7, *, dt, force="exact", softening=None,
        integrator="leapfrog", precision="f64", check_every=None, backend="cpu"))]
    #[allow(clippy::too_many_arguments)]
    fn cold_sphere(
        py: Python<'_>,
        n: usize,
        radius: f64,
        seed: u64,
        dt: f64,
        force: &str,
        softening: Option<f64>,
        integrator: &str,
        precision: &str,
        check_every: Option<u32>,
        backend: &str,
    ) -> PyResult<Self> {
        let p = cold_sphere(n, radius, seed).py()?;
        let c = config(dt, force, softening, integrator, precision, check_every)?;
        start(py, p, &c, backend)
    }

    /// Advances `n` steps (the GIL is released meanwhile). Raises `simkit.BlowUp` when the
    /// run turns non-finite or the energy drifts past the tolerance.
    fn step(&mut self, py: Python<'_>, n: u32) -> PyResult<()> {
        common::step(py, self.inner.get(), n)
    }

    /// Positions, shape `(n, 3)` (a copy).
    #[getter]
    fn positions<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let s = self.inner.get().state().py()?;
        arrays::to_rows(py, &s.position)
    }

    /// Velocities, shape `(n, 3)` (a copy).
    #[getter]
    fn velocities<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let s = self.inner.get().state().py()?;
        arrays::to_rows(py, &s.velocity)
    }

    /// Accelerations at the current positions, shape `(n, 3)`.
    fn accelerations<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let a = self.inner.get().accelerations().py()?;
        arrays::to_rows(py, &a)
    }

    /// Energies (`kinetic`, `potential`, `total`), `momentum`, `angular_momentum`,
    /// `force_sum` and `force_magnitude_sum` of the current state.
    fn diagnostics<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = self.inner.get().diagnostics().py()?;
        Ok(pydict!(py,
            "kinetic" => d.kinetic,
            "potential" => d.potential,
            "total" => d.total,
            "momentum" => d.momentum,
            "angular_momentum" => d.angular_momentum,
            "force_sum" => d.force_sum,
            "force_magnitude_sum" => d.force_magnitude_sum,
        ))
    }

    /// Changes the time step (e.g. to follow an expanding system).
    fn set_dt(&mut self, dt: f64) -> PyResult<()> {
        self.inner.get().set_dt(dt).py()
    }

    /// Writes a checkpoint (particles, config, time, step count) to `path`.
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

    /// Simulation time.
    #[getter]
    fn time(&mut self) -> f64 {
        self.inner.get().time()
    }

    /// Pair interactions evaluated per step.
    #[getter]
    fn interactions_per_step(&mut self) -> f64 {
        self.inner.get().interactions_per_step()
    }

    /// Steps taken since the start (checkpoints keep the count).
    #[getter]
    fn steps_done(&mut self) -> u64 {
        self.inner.get().steps_done()
    }

    /// The backend and precision running the simulation.
    #[getter]
    fn backend_name(&mut self) -> String {
        self.inner.get().backend_name()
    }

    /// The precision (`"f64"` or `"f32"`).
    #[getter]
    fn precision(&mut self) -> &'static str {
        precision_name(self.inner.get().config().precision)
    }

    /// Number of particles.
    fn __len__(&mut self) -> usize {
        self.inner.get().len()
    }

    fn __repr__(&mut self) -> String {
        let sim = self.inner.get();
        format!(
            "PpCoulomb({} particles, {}, step {})",
            sim.len(),
            sim.backend_name(),
            sim.steps_done()
        )
    }
}
