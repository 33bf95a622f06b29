//! `simkit.Dem`: granular discs and spheres with the linear spring–dashpot contact law.

use std::path::PathBuf;

use numpy::PyArray2;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use simkit::backend::Simulation;
use simkit::dem::scenes::{BedParams, granular_box, vibrating_bed};
use simkit::dem::{Config, Dim, Integrator, Material, Particle, Scene};

use crate::arrays;
use crate::backend::{precision, precision_name};
use crate::common::{self, Owned, pydict};
use crate::errors::IntoPy;

/// Discrete-element simulation of solid discs (2D) or spheres (3D) with the linear
/// spring–dashpot contact law: a normal spring and dashpot set from the restitution
/// coefficient `restitution` and the contact duration `contact_time` (for any mass pair),
/// and a tangential force `min(mu_s |F_n|, mu_k m_ij |v_t|)`; rotation (torques, angular
/// velocities) when `rotation=True`.
///
/// `Dem(positions, radii, *, box_lo, box_hi, contact_time, ...)`: `positions` of shape
/// `(n, 2)` or `(n, 3)`, `radii` one per particle, `masses` one per particle (default: solid
/// of density 1, `pi r^2` or `4/3 pi r^3`). Plane walls close every non-periodic face when
/// `walls=True`; `gravity` pulls along -y (2D) or -z (3D); `vibration=(amplitude, omega)`
/// shakes the walls sinusoidally. `dt=None` picks `contact_time / 30`.
#[pyclass(module = "simkit")]
pub(crate) struct Dem {
    inner: Owned<simkit::dem::Dem>,
    dim: usize,
}

/// The config from the keyword arguments (unset ones keep `Config::default()`'s values).
#[allow(clippy::too_many_arguments)]
fn config(
    dt: Option<f64>,
    integrator: &str,
    precision_arg: &str,
    skin: Option<f64>,
    check_every: Option<u32>,
    max_overlap: Option<f64>,
    allow_unstable_dt: bool,
) -> PyResult<Config> {
    let mut c = Config::default()
        .with_precision(precision(precision_arg)?)
        .with_integrator(match integrator {
            "velocity_verlet" => Integrator::VelocityVerlet,
            "position_verlet" => Integrator::PositionVerlet,
            other => {
                return Err(PyValueError::new_err(format!(
                    "invalid integrator: {other:?} (use 'velocity_verlet' or 'position_verlet')"
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
    if let Some(m) = max_overlap {
        c.max_overlap = m;
    }
    c.allow_unstable_dt = allow_unstable_dt;
    c.validate().py()?;
    Ok(c)
}

/// The simulation of `scene` with `config` on the named backend (built with the GIL released).
fn start(py: Python<'_>, scene: Scene, c: &Config, backend: &str) -> PyResult<Dem> {
    let dim = scene.dim().axes();
    let b = crate::backend::backend(backend)?;
    let inner = py.detach(|| simkit::dem::Dem::new(scene, c, b)).py()?;
    Ok(Dem {
        inner: Owned::new(inner),
        dim,
    })
}

#[pymethods]
impl Dem {
    #[new]
    #[pyo3(signature = (positions, radii, masses=None, velocities=None,
        angular_velocities=None, *, box_lo, box_hi, contact_time, restitution=0.9,
        mu_s=0.0, mu_k=0.0, wall_restitution=None, walls=true, periodic=None, gravity=0.0,
        vibration=None, rotation=false, dt=None, integrator="velocity_verlet",
        precision="f64", skin=None, check_every=None, max_overlap=None,
        allow_unstable_dt=false, backend="cpu"))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        positions: &Bound<'_, PyAny>,
        radii: &Bound<'_, PyAny>,
        masses: Option<&Bound<'_, PyAny>>,
        velocities: Option<&Bound<'_, PyAny>>,
        angular_velocities: Option<&Bound<'_, PyAny>>,
        box_lo: &Bound<'_, PyAny>,
        box_hi: &Bound<'_, PyAny>,
        contact_time: f64,
        restitution: f64,
        mu_s: f64,
        mu_k: f64,
        wall_restitution: Option<f64>,
        walls: bool,
        periodic: Option<&Bound<'_, PyAny>>,
        gravity: f64,
        vibration: Option<(f64, f64)>,
        rotation: bool,
        dt: Option<f64>,
        integrator: &str,
        precision: &str,
        skin: Option<f64>,
        check_every: Option<u32>,
        max_overlap: Option<f64>,
        allow_unstable_dt: bool,
        backend: &str,
    ) -> PyResult<Self> {
        let dim = arrays::columns(positions, "positions")?;
        let pos = arrays::vectors(positions, "positions", dim)?;
        let n = pos.len();
        let radii = arrays::values(radii, "radii", Some(n))?;
        let masses = match masses {
            Some(m) => arrays::values(m, "masses", Some(n))?,
            None => radii
                .iter()
                .map(|r| {
                    if dim == 2 {
                        std::f64::consts::PI * r * r
                    } else {
                        4.0 / 3.0 * std::f64::consts::PI * r * r * r
                    }
                })
                .collect(),
        };
        let per_particle = |v: Option<&Bound<'_, PyAny>>, name: &str, cols: usize| match v {
            Some(v) => {
                let rows = arrays::vectors(v, name, cols)?;
                if rows.len() == n {
                    Ok(rows)
                } else {
                    Err(PyValueError::new_err(format!(
                        "{name}: {} rows, must be {n} (one per particle)",
                        rows.len()
                    )))
                }
            }
            None => Ok(vec![[0.0; 3]; n]),
        };
        let vel = per_particle(velocities, "velocities", dim)?;
        // A disc spins about z only: one component per particle in 2D.
        let omega = match (angular_velocities, dim) {
            (Some(w), 2) => arrays::values(w, "angular_velocities", Some(n))?
                .into_iter()
                .map(|w| [0.0, 0.0, w])
                .collect(),
            (w, _) => per_particle(w, "angular_velocities", 3)?,
        };
        let material = Material::new(restitution, contact_time).with_friction(mu_s, mu_k);
        let lo = arrays::corner(box_lo, "box_lo", dim)?;
        let hi = arrays::corner(box_hi, "box_hi", dim)?;
        let dims = if dim == 2 { Dim::Two } else { Dim::Three };
        let mut scene = Scene::new(dims, lo, hi, material).py()?;
        if let Some(p) = periodic {
            scene.set_periodic(arrays::flags(p, "periodic", dim)?);
        }
        scene.set_rotation(rotation);
        scene.set_gravity(gravity).py()?;
        if let Some((amplitude, omega)) = vibration {
            scene.set_vibration(amplitude, omega).py()?;
        }
        if walls {
            let wall = Material {
                restitution: wall_restitution.unwrap_or(restitution),
                ..material
            };
            scene.add_box_walls(wall, vibration.is_some()).py()?;
        }
        for k in 0..n {
            scene
                .add_particle(Particle {
                    velocity: vel[k],
                    angular_velocity: omega[k],
                    ..Particle::new(pos[k], radii[k], masses[k])
                })
                .py()?;
        }
        let c = config(
            dt,
            integrator,
            precision,
            skin,
            check_every,
            max_overlap,
            allow_unstable_dt,
        )?;
        start(positions.py(), scene, &c, backend)
    }

    /// The 2D vibrated bed in reduced units (grain diameter and mass 1): `n` discs in a box
    /// `width` diameters wide whose floor and lid vibrate with acceleration `gamma` g at
    /// `freq_hz`; restitution `e_pp` between grains, `e_pw` with the walls, friction `mu`,
    /// contact time `contact_time_s` seconds.
    #[staticmethod]
    #[pyo3(signature = (n=128, width=16, *, gamma=3.0, freq_hz=20.0, e_pp=0.9, e_pw=0.8,
        mu=0.3, contact_time_s=5e-4, precision="f64", backend="cpu"))]
    #[allow(clippy::too_many_arguments)]
    fn vibrating_bed(
        py: Python<'_>,
        n: usize,
        width: usize,
        gamma: f64,
        freq_hz: f64,
        e_pp: f64,
        e_pw: f64,
        mu: f64,
        contact_time_s: f64,
        precision: &str,
        backend: &str,
    ) -> PyResult<Self> {
        let params = BedParams {
            n,
            width,
            gamma,
            freq_hz,
            e_pp,
            e_pw,
            mu,
            contact_time_s,
        };
        let (scene, _) = vibrating_bed(&params).py()?;
        let c = config(None, "velocity_verlet", precision, None, None, None, false)?;
        start(py, scene, &c, backend)
    }

    /// A box of `nx * ny * nz` spheres on a jittered lattice (seed `seed`) settling under
    /// gravity onto the floor.
    #[staticmethod]
    #[pyo3(signature = (nx, ny, nz, seed=1, *, precision="f64", backend="cpu"))]
    fn granular_box(
        py: Python<'_>,
        nx: usize,
        ny: usize,
        nz: usize,
        seed: u32,
        precision: &str,
        backend: &str,
    ) -> PyResult<Self> {
        let scene = granular_box(nx, ny, nz, seed).py()?;
        let c = config(None, "velocity_verlet", precision, None, None, None, false)?;
        start(py, scene, &c, backend)
    }

    /// Advances `n` steps (the GIL is released meanwhile). Raises `simkit.BlowUp` when the
    /// run turns non-finite or overlaps grow past `max_overlap`.
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

    /// Angular velocities, shape `(n, 3)` (in 2D only the z column is non-zero; zeros in a
    /// scene without rotation).
    #[getter]
    fn angular_velocities<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let s = self.inner.get().state().py()?;
        let n = s.positions.len();
        let w = if s.angular_velocities.len() == n {
            s.angular_velocities
        } else {
            vec![[0.0; 3]; n]
        };
        arrays::to_vectors(py, &w, 3)
    }

    /// Radii, shape `(n,)`.
    #[getter]
    fn radii<'py>(&mut self, py: Python<'py>) -> Bound<'py, numpy::PyArray1<f64>> {
        let r = self
            .inner
            .get()
            .scene()
            .particles()
            .iter()
            .map(|p| p.radius);
        arrays::to_array(py, r.collect())
    }

    /// Energies (`kinetic`, `rotational`, `elastic`, `potential`), `momentum`, the deepest
    /// overlap (`max_overlap`, `max_overlap_ratio` to the radius), contact counts
    /// (`contacts`, `wall_contacts`), `granular_temperature`, `com_height`, `time` and
    /// `finite`.
    fn diagnostics<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = self.inner.get().diagnostics().py()?;
        Ok(pydict!(py,
            "time" => d.time,
            "kinetic" => d.kinetic,
            "rotational" => d.rotational,
            "elastic" => d.elastic,
            "potential" => d.potential,
            "momentum" => d.momentum,
            "max_overlap" => d.max_overlap,
            "max_overlap_ratio" => d.max_overlap_ratio,
            "contacts" => d.contacts,
            "wall_contacts" => d.wall_contacts,
            "granular_temperature" => d.granular_temperature,
            "com_height" => d.com_height,
            "finite" => d.finite,
        ))
    }

    /// Writes a checkpoint (the whole state, contact history included) to `path`.
    fn write_checkpoint(&mut self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        common::write_checkpoint(py, self.inner.get(), path)
    }

    /// Resumes from a checkpoint written by `write_checkpoint`, on `backend`.
    #[staticmethod]
    #[pyo3(signature = (path, backend="cpu"))]
    fn resume(py: Python<'_>, path: PathBuf, backend: &str) -> PyResult<Self> {
        let inner: simkit::dem::Dem = common::resume(py, path, backend)?;
        let dim = inner.scene().dim().axes();
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
        self.inner.get().scene().particles().len()
    }

    /// 2 or 3.
    #[getter]
    fn dim(&self) -> usize {
        self.dim
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

    fn __repr__(&mut self) -> String {
        let sim = self.inner.get();
        format!(
            "Dem({} particles, {}D, {}, step {})",
            sim.scene().particles().len(),
            self.dim,
            sim.backend_name(),
            sim.steps_done()
        )
    }
}
