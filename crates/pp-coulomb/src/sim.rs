//! [`PpCoulomb`]: the direct-sum Coulomb simulation behind the common [`Simulation`] trait,
//! with blow-up checks inside `step` and checkpoints ([`Restart`]).

use serde::{Deserialize, Serialize};
use simkit_backend::{Backend, Error, Precision, Restart, Result, Simulation, checkpoint};

use crate::config::{Config, ForceLaw};
use crate::cpu;
use crate::diagnostics::{Diagnostics, diagnostics};
use crate::engine::Engine;
#[cfg(feature = "gpu")]
use crate::gpu;
use crate::guard::{Checks, Energy};
use crate::particles::Particles;

/// Direct-sum (particle–particle) Coulomb dynamics in normalised units (k_e = 1).
///
/// The acceleration of particle i is `a_i = (q_i / m_i) sum_{j != i} q_j f(r_ij)` with `f`
/// chosen by [`crate::ForceLaw`]; positions and velocities advance with the configured
/// [`crate::Integrator`]. Every step costs `N (N - 1)` pair interactions.
pub struct PpCoulomb {
    engine: Box<dyn Engine>,
    particles: Particles,
    config: Config,
    steps: u64,
    /// The step and simulated time at which the current `dt` took over: the time is
    /// `origin.1 + dt * (steps - origin.0)`, whatever the split into `step` calls.
    origin: (u64, f64),
    /// The energy at the last interval check that passed (exact law's energy guard).
    energy_ref: Option<Energy>,
}

/// Everything a checkpoint holds (see [`Restart`] on [`PpCoulomb`]).
#[derive(Serialize, Deserialize)]
struct Saved {
    config: Config,
    particles: Particles,
    accelerations: Option<Vec<[f64; 3]>>,
    steps: u64,
    origin: (u64, f64),
    energy_ref: Option<Energy>,
}

/// Checks that every position, velocity, charge, mass and charge-to-mass ratio stays finite
/// in the run's precision (f32 ends at 3.4e38; `q / m` can overflow in either).
fn representable(p: &Particles, precision: Precision) -> Result<()> {
    let fits = |v: f64| match precision {
        Precision::F32 => (v as f32).is_finite(),
        Precision::F64 => v.is_finite(),
    };
    let name = match precision {
        Precision::F32 => "f32",
        Precision::F64 => "f64",
    };
    for i in 0..p.len() {
        let values = [
            ("position", p.position[i].to_vec()),
            ("velocity", p.velocity[i].to_vec()),
            ("charge", vec![p.charge[i]]),
            ("mass", vec![p.mass[i]]),
            ("charge / mass", vec![p.charge[i] / p.mass[i]]),
        ];
        for (what, v) in values {
            if let Some(bad) = v.iter().find(|v| !fits(**v)) {
                return Err(Error::invalid(
                    format!("{what} of particle {i}"),
                    bad,
                    format!(
                        "overflows the run's precision ({name}); use values of physical \
                         magnitude, or Precision::F64"
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// The checkpoint model string of a precision.
fn model(precision: Precision) -> String {
    let p = match precision {
        Precision::F32 => "f32",
        Precision::F64 => "f64",
    };
    format!("PpCoulomb<{p}>")
}

impl std::fmt::Debug for PpCoulomb {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PpCoulomb")
            .field("backend", &self.engine.name())
            .field("particles", &self.particles.len())
            .field("config", &self.config)
            .field("steps", &self.steps)
            .finish()
    }
}

impl PpCoulomb {
    /// Validates the particles and the configuration and builds the backend chosen by
    /// `backend` (the configuration is copied).
    ///
    /// Errors: NaN/infinite positions, velocities or charges, zero or negative masses, values
    /// (or a charge-to-mass ratio) that overflow the configured precision, a bad time step,
    /// force parameter or energy tolerance, a GPU without `SHADER_F64` for
    /// [`crate::Precision::F64`].
    /// Zero or one particle is fine (no force).
    pub fn new(particles: Particles, config: &Config, backend: Backend<'_>) -> Result<Self> {
        Self::build(particles, config, backend, None, None)
    }

    fn build(
        particles: Particles,
        config: &Config,
        backend: Backend<'_>,
        accelerations: Option<&[[f64; 3]]>,
        energy_ref: Option<Option<Energy>>,
    ) -> Result<Self> {
        particles.validate()?;
        config.validate()?;
        representable(&particles, config.precision)?;
        let engine = match backend {
            Backend::Cpu => cpu::engine(&particles, config, accelerations),
            #[cfg(feature = "gpu")]
            Backend::Gpu(ctx) => gpu::engine(ctx, &particles, config, accelerations)?,
        };
        let mut sim = Self {
            engine,
            particles,
            config: *config,
            steps: 0,
            origin: (0, 0.0),
            energy_ref: None,
        };
        if sim.energy_tolerance().is_some() {
            sim.energy_ref = match energy_ref {
                Some(kept) => kept,
                None => Some(sim.engine.energy()?),
            };
        }
        Ok(sim)
    }

    /// The energy tolerance in force: `Some` only under the exact law with interval checks
    /// on and particles to check.
    fn energy_tolerance(&self) -> Option<f64> {
        let on = self.config.force == ForceLaw::Exact
            && self.config.check_every > 0
            && !self.particles.is_empty();
        self.config.energy_tolerance.filter(|_| on)
    }

    /// The simulated time after `steps` steps at the current `dt`.
    fn time_at(&self, steps: u64) -> f64 {
        self.origin.1 + self.config.dt * steps.saturating_sub(self.origin.0) as f64
    }

    /// The configuration.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.particles.len()
    }

    /// Whether there are no particles.
    pub fn is_empty(&self) -> bool {
        self.particles.is_empty()
    }

    /// Simulated time (sum of the time steps taken; the steps since the last
    /// [`PpCoulomb::set_dt`] count as `dt` times their number, so the time does not depend on
    /// how a run is split into `step` calls).
    pub fn time(&self) -> f64 {
        self.time_at(self.steps)
    }

    /// Pair interactions evaluated per force evaluation, `N (N - 1)`.
    pub fn interactions_per_step(&self) -> f64 {
        let n = self.particles.len() as f64;
        n * (n - 1.0).max(0.0)
    }

    /// Changes the time step for the following steps (e.g. to grow it as a cloud expands).
    ///
    /// Errors: a `dt` that is not finite and > 0.
    pub fn set_dt(&mut self, dt: f64) -> Result<()> {
        simkit_backend::require_positive("dt", dt)?;
        self.engine.set_dt(dt)?;
        self.origin = (self.steps, self.time());
        self.config.dt = dt;
        Ok(())
    }

    /// Accelerations at the current positions (in the backend's precision, returned as f64).
    pub fn accelerations(&mut self) -> Result<Vec<[f64; 3]>> {
        self.engine.accelerations()
    }

    /// Energies, momentum, angular momentum and the sum of forces of the current state.
    ///
    /// The potential energy is summed in f64 on the CPU with the configured force law; the sum
    /// of forces uses the backend's accelerations.
    pub fn diagnostics(&mut self) -> Result<Diagnostics> {
        let state = self.state()?;
        let acc = self.engine.accelerations()?;
        Ok(diagnostics(&state, &acc, self.config.force))
    }
}

impl Simulation for PpCoulomb {
    type State = Particles;

    /// Advances `steps` steps with the blow-up checks of [`Config::check_every`].
    ///
    /// Errors: [`Error::BlowUp`] when a check fails (non-finite position or velocity, a
    /// coincident pair or an energy jump under the exact law); the run is then back at the
    /// step of the last check that passed (`steps_done()` and `state()` say so). A step count
    /// that would overflow the step counter or make the simulated time infinite is an
    /// [`Error::InvalidParameter`] and changes nothing.
    fn step(&mut self, steps: u32) -> Result<()> {
        let end = self
            .steps
            .checked_add(u64::from(steps))
            .filter(|e| e.checked_add(u64::from(self.config.check_every)).is_some())
            .ok_or_else(|| {
                Error::invalid(
                    "steps",
                    steps,
                    format!(
                        "{} steps are done; the step counter would overflow",
                        self.steps
                    ),
                )
            })?;
        if !self.time_at(end).is_finite() {
            return Err(Error::invalid(
                "steps",
                steps,
                format!(
                    "the simulated time would overflow (time {:e}, dt {:e}); use a smaller dt",
                    self.time(),
                    self.config.dt
                ),
            ));
        }
        if self.particles.is_empty() || steps == 0 {
            self.steps = end;
            return Ok(());
        }
        let energy_tolerance = self.energy_tolerance();
        let mut checks = Checks {
            done: self.steps,
            every: self.config.check_every,
            energy_tolerance,
            energy_ref: &mut self.energy_ref,
            charge: &self.particles.charge,
            mass: &self.particles.mass,
            dt: self.config.dt,
            integrator: self.config.integrator,
        };
        match self.engine.step(steps, &mut checks) {
            Ok(()) => {
                self.steps = end;
                Ok(())
            }
            Err(e) => {
                if let Error::BlowUp { rolled_back_to, .. } = e {
                    self.steps = rolled_back_to;
                }
                Err(e)
            }
        }
    }

    fn state(&mut self) -> Result<Particles> {
        let (position, velocity) = self.engine.state()?;
        let mut p = self.particles.clone();
        p.position = position;
        p.velocity = velocity;
        Ok(p)
    }

    fn steps_done(&self) -> u64 {
        self.steps
    }

    fn backend_name(&self) -> String {
        self.engine.name()
    }
}

impl Restart for PpCoulomb {
    /// The complete state: particles (positions, velocities, charges, masses, species), the
    /// configuration, the accelerations leapfrog keeps between calls, the step counter, the
    /// simulated time and the energy guard's reference. A GPU run downloads it.
    fn checkpoint(&mut self) -> Result<Vec<u8>> {
        let saved = Saved {
            config: self.config,
            particles: self.state()?,
            accelerations: if self.particles.is_empty() {
                None
            } else {
                self.engine.kept_accelerations()?
            },
            steps: self.steps,
            origin: self.origin,
            energy_ref: self.energy_ref,
        };
        checkpoint::encode(
            env!("CARGO_PKG_NAME"),
            env!("CARGO_PKG_VERSION"),
            &model(self.config.precision),
            &saved,
        )
    }

    /// Rebuilds the run on `backend`; the particles and the configuration are validated as
    /// by [`PpCoulomb::new`], and a checkpoint of another crate, version or model, a
    /// truncated or corrupt one, or one whose contents are inconsistent is an
    /// [`Error::Checkpoint`].
    fn resume(bytes: &[u8], backend: Backend<'_>) -> Result<Self> {
        let header = checkpoint::header(bytes)?;
        let precision = [Precision::F32, Precision::F64]
            .into_iter()
            .find(|p| model(*p) == header.model)
            .unwrap_or(Precision::F64);
        let saved: Saved = checkpoint::decode(
            bytes,
            env!("CARGO_PKG_NAME"),
            env!("CARGO_PKG_VERSION"),
            &model(precision),
        )?;
        if saved.config.precision != precision {
            return Err(Error::checkpoint(format!(
                "the header says {} but the state is {}; the file is \
                     inconsistent",
                model(precision),
                model(saved.config.precision)
            )));
        }
        let n = saved.particles.len();
        if let Some(a) = &saved.accelerations
            && (a.len() != n || a.iter().flatten().any(|c| !c.is_finite()))
        {
            return Err(Error::checkpoint(format!(
                "{} kept accelerations for {n} particles, or non-finite ones; the file is \
                 inconsistent",
                a.len()
            )));
        }
        let (origin_step, origin_time) = saved.origin;
        let energy_ok = saved.energy_ref.is_none_or(|e| e.is_finite());
        if origin_step > saved.steps || !origin_time.is_finite() || !energy_ok {
            return Err(Error::checkpoint(format!(
                "step {} with time origin ({origin_step}, {origin_time}) and energy reference                  {:?}; the file is \
                     inconsistent",
                saved.steps, saved.energy_ref
            )));
        }
        let mut sim = Self::build(
            saved.particles,
            &saved.config,
            backend,
            saved.accelerations.as_deref(),
            Some(saved.energy_ref),
        )?;
        sim.steps = saved.steps;
        sim.origin = saved.origin;
        if !sim.time().is_finite() {
            return Err(Error::checkpoint(format!(
                "step {} at dt {:e} gives a non-finite time",
                saved.steps, saved.config.dt
            )));
        }
        Ok(sim)
    }
}
