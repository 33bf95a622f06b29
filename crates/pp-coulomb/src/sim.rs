//! [`PpCoulomb`]: the direct-sum Coulomb simulation behind the common [`Simulation`] trait.

use simkit_backend::{Backend, Result, Simulation};

use crate::config::Config;
use crate::cpu;
use crate::diagnostics::{Diagnostics, diagnostics};
use crate::engine::Engine;
#[cfg(feature = "gpu")]
use crate::gpu;
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
    time: f64,
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
    /// Errors: NaN/infinite positions, velocities or charges, zero or negative masses, a bad
    /// time step or force parameter, a GPU without `SHADER_F64` for [`crate::Precision::F64`].
    /// Zero or one particle is fine (no force).
    pub fn new(particles: Particles, config: &Config, backend: Backend<'_>) -> Result<Self> {
        particles.validate()?;
        config.validate()?;
        let engine = match backend {
            Backend::Cpu => cpu::engine(&particles, config),
            #[cfg(feature = "gpu")]
            Backend::Gpu(ctx) => gpu::engine(ctx, &particles, config)?,
        };
        Ok(Self {
            engine,
            particles,
            config: *config,
            steps: 0,
            time: 0.0,
        })
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

    /// Simulated time (sum of the time steps taken).
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Pair interactions evaluated per force evaluation, `N (N - 1)`.
    pub fn interactions_per_step(&self) -> f64 {
        let n = self.particles.len() as f64;
        n * (n - 1.0).max(0.0)
    }

    /// Changes the time step for the following steps (e.g. to grow it as a cloud expands).
    pub fn set_dt(&mut self, dt: f64) -> Result<()> {
        simkit_backend::require_positive("dt", dt)?;
        self.engine.set_dt(dt)?;
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

    fn step(&mut self, steps: u32) -> Result<()> {
        if self.particles.is_empty() {
            self.steps += u64::from(steps);
            self.time += self.config.dt * f64::from(steps);
            return Ok(());
        }
        self.engine.step(steps)?;
        self.steps += u64::from(steps);
        self.time += self.config.dt * f64::from(steps);
        Ok(())
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
