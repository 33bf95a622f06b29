//! [`PpCoulomb`]: the direct-sum Coulomb simulation behind the common [`Simulation`] trait,
//! with blow-up checks inside `step` and checkpoints ([`Restart`]).

use simkit_backend::{Backend, Restart, Result, Simulation};

use crate::config::Config;
use crate::cpu;
use crate::diagnostics::{Diagnostics, state_diagnostics};
use crate::engine::Engine;
#[cfg(feature = "gpu")]
use crate::gpu;
use crate::guard::Energy;
use crate::particles::Particles;
use crate::run::Run;

/// Direct-sum (particle–particle) Coulomb dynamics in normalised units (k_e = 1).
///
/// The acceleration of particle i is `a_i = (q_i / m_i) sum_{j != i} q_j f(r_ij)` with `f`
/// chosen by [`crate::ForceLaw`]; positions and velocities advance with the configured
/// [`crate::Integrator`]. Every step costs `N (N - 1)` pair interactions.
pub struct PpCoulomb {
    engine: Box<dyn Engine>,
    run: Run,
}

impl std::fmt::Debug for PpCoulomb {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PpCoulomb")
            .field("backend", &self.engine.name())
            .field("particles", &self.run.particles.len())
            .field("config", &self.run.config)
            .field("steps", &self.run.steps)
            .finish()
    }
}

impl PpCoulomb {
    /// Validates the particles and the configuration and builds the backend chosen by
    /// `backend` (the configuration is copied).
    ///
    /// Errors: NaN/infinite positions, velocities or charges, zero or negative masses, values
    /// (or a charge-to-mass ratio) that overflow the configured precision, a bad time step,
    /// force parameter or energy tolerance, [`Config::mixed`] with [`crate::Precision::F64`],
    /// a GPU without `SHADER_F64` for [`crate::Precision::F64`], the mixed mode on the GPU
    /// (`Error::Unsupported`).
    /// Zero or one particle is fine (no force).
    pub fn new(particles: Particles, config: &Config, backend: Backend<'_>) -> Result<Self> {
        Self::build(Run::new(particles, config)?, backend, None, None)
    }

    fn build(
        run: Run,
        backend: Backend<'_>,
        accelerations: Option<&[[f64; 3]]>,
        energy_ref: Option<Option<Energy>>,
    ) -> Result<Self> {
        let engine = match backend {
            Backend::Cpu => cpu::engine(&run.particles, &run.config, accelerations),
            #[cfg(feature = "gpu")]
            Backend::Gpu(ctx) => gpu::engine(ctx, &run.particles, &run.config, accelerations)?,
        };
        let mut sim = Self { engine, run };
        let engine = &mut sim.engine;
        sim.run.set_energy_ref(energy_ref, || engine.energy())?;
        Ok(sim)
    }

    /// The configuration.
    pub fn config(&self) -> &Config {
        &self.run.config
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.run.particles.len()
    }

    /// Whether there are no particles.
    pub fn is_empty(&self) -> bool {
        self.run.particles.is_empty()
    }

    /// Simulated time (sum of the time steps taken; the steps since the last
    /// [`PpCoulomb::set_dt`] count as `dt` times their number, so the time does not depend on
    /// how a run is split into `step` calls).
    pub fn time(&self) -> f64 {
        self.run.time()
    }

    /// Pair interactions evaluated per force evaluation, `N (N - 1)`.
    pub fn interactions_per_step(&self) -> f64 {
        self.run.interactions_per_step()
    }

    /// Changes the time step for the following steps (e.g. to grow it as a cloud expands).
    ///
    /// Errors: a `dt` that is not finite and > 0.
    pub fn set_dt(&mut self, dt: f64) -> Result<()> {
        simkit_backend::require_positive("dt", dt)?;
        self.engine.set_dt(dt)?;
        self.run.set_dt(dt)
    }

    /// Accelerations at the current positions (in the backend's precision, returned as f64;
    /// the mixed mode keeps them in f64).
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
        Ok(state_diagnostics(&state, &acc, self.run.config.force))
    }
}

impl Simulation for PpCoulomb {
    type State = Particles;

    /// Advances `steps` steps with the blow-up checks of [`Config::check_every`].
    ///
    /// Errors: [`Error::BlowUp`](simkit_backend::Error::BlowUp) when a check fails (non-finite position or velocity, a
    /// coincident pair or an energy jump under the exact law); the run is then back at the
    /// step of the last check that passed (`steps_done()` and `state()` say so). A step count
    /// that would overflow the step counter or make the simulated time infinite is an
    /// [`Error::InvalidParameter`](simkit_backend::Error::InvalidParameter) and changes nothing.
    fn step(&mut self, steps: u32) -> Result<()> {
        let engine = &mut self.engine;
        self.run.step(steps, |checks| engine.step(steps, checks))
    }

    fn state(&mut self) -> Result<Particles> {
        Ok(self.run.particles_at(self.engine.state()?))
    }

    fn steps_done(&self) -> u64 {
        self.run.steps
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
        let now = self.state()?;
        let accelerations = if self.run.particles.is_empty() {
            None
        } else {
            self.engine.kept_accelerations()?
        };
        self.run.checkpoint(now, accelerations)
    }

    /// Rebuilds the run on `backend`; the particles and the configuration are validated as
    /// by [`PpCoulomb::new`], and a checkpoint of another crate, version or model, a
    /// truncated or corrupt one, or one whose contents are inconsistent is an
    /// [`Error::Checkpoint`](simkit_backend::Error::Checkpoint).
    fn resume(bytes: &[u8], backend: Backend<'_>) -> Result<Self> {
        let saved = Run::resume(bytes)?;
        Self::build(
            saved.run,
            backend,
            saved.accelerations.as_deref(),
            Some(saved.energy_ref),
        )
    }
}
