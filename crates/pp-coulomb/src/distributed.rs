//! [`DistributedCoulomb`]: the CPU run over the ranks of a [`Comm`] with replicated data,
//! bit-identical to the single-process CPU run.

use std::hash::{Hash, Hasher};
use std::ops::Range;

use simkit_backend::comm::Comm;
use simkit_backend::{Distributed, Precision, Result, Simulation};

use crate::config::Config;
use crate::cpu::{CpuEngine, Ranks, Share};
use crate::diagnostics::{Diagnostics, potential_rows, with_potential};
use crate::engine::Engine;
use crate::guard::Energy;
use crate::particles::Particles;
use crate::run::Run;

/// Direct-sum Coulomb dynamics over the ranks of a [`Comm`] (CPU backend, replicated data).
///
/// Every rank holds all `N` particles. Rank `r` of `P` owns the contiguous block `r` of
/// particles (the first `N mod P` blocks one particle longer; [`DistributedCoulomb::own`]):
/// each force evaluation computes the accelerations of its own particles against all `N`
/// with the kernel of [`crate::PpCoulomb`] on [`crate::Backend::Cpu`], the integrator
/// advances its own particles, and one all-gather per drift gives every rank the new
/// positions of all. The velocities are gathered at every blow-up check (every
/// [`Config::check_every`] steps and at the end of every `step` call), so between calls
/// the whole state is on every rank and [`Simulation::state`] needs no communication.
///
/// The field of a particle is summed in an order set by the sources alone (SIMD lanes over
/// the sources, then blocks of sources, in f64), not by which targets are computed together,
/// and the integrator's update of a particle reads only that particle. So positions,
/// velocities and accelerations are **bit-identical** to the single-process CPU run (same
/// precision and `rsqrt` setting) for every rank count, whether or not `N` divides by `P`.
/// The energy guard's potential energy is computed per particle by the owning rank and
/// summed over the gathered terms in particle order, so it too has the bits of one
/// process, and every blow-up check ([`Config::check_every`]) stops every rank at the same
/// step with the same [`simkit_backend::Error::BlowUp`] (each rank decides from the same replicated values).
/// [`DistributedCoulomb::diagnostics`] is bit-identical to [`crate::PpCoulomb::diagnostics`]
/// on the CPU as well (the potential rows are gathered and summed in particle order).
///
/// Cost per step and rank: `N^2 / P` pair terms (the force pass) and, per force
/// evaluation, one all-gather of `3 ceil(N / P)` values of the run's precision from each
/// rank, `3 P ceil(N / P) ≈ 3 N` values received (12 N bytes in f32, 24 N in f64); one
/// more all-gather of the velocities per check.
///
/// Every method that takes `&mut self`, and the constructors, are collective: all ranks
/// call them in the same order with the same arguments (the constructors check that the
/// ranks' particles, configurations and CPU kernels agree).
///
/// ```
/// use simkit_backend::comm::Comm;
/// use simkit_backend::{Backend, Simulation};
/// use simkit_pp_coulomb::{
///     Config, DistributedCoulomb, ForceLaw, Particles, PpCoulomb, Region, Species, Velocities,
/// };
/// # fn main() -> simkit_backend::Result<()> {
/// let mut p = Particles::new();
/// let e = p.add_species(Species::new("electron", -1.0, 1.0))?;
/// let cube = Region::Cube { min: [0.0; 3], length: 10.0 };
/// p.fill(e, 101, cube, Velocities::Maxwellian { thermal_speed: 0.3 }, 7)?;
/// let config = Config::new(0.05, ForceLaw::Plummer { epsilon: 0.5 });
/// // `Comm::mpi()?` under `mpirun -np P` (feature `mpi`); here one process.
/// let mut dist = DistributedCoulomb::new(p.clone(), &config, Comm::serial())?;
/// dist.step(10)?;
/// let mut one = PpCoulomb::new(p, &config, Backend::Cpu)?;
/// one.step(10)?;
/// assert_eq!(dist.state()?, one.state()?); // on every rank
/// assert_eq!(dist.diagnostics()?, one.diagnostics()?);
/// # Ok(())
/// # }
/// ```
pub struct DistributedCoulomb {
    comm: Comm,
    engine: Engines,
    run: Run,
}

/// The CPU engine in the configured state precision (f64 for the mixed mode).
enum Engines {
    F32(CpuEngine<f32>),
    F64(CpuEngine<f64>),
}

/// Runs `$body` with `$e` bound to the engine, whatever its precision.
macro_rules! with_engine {
    ($engines:expr, $e:ident => $body:expr) => {
        match $engines {
            Engines::F32($e) => $body,
            Engines::F64($e) => $body,
        }
    };
}

impl std::fmt::Debug for DistributedCoulomb {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DistributedCoulomb")
            .field("comm", &self.comm)
            .field("backend", &self.backend_name())
            .field("particles", &self.run.particles.len())
            .field("config", &self.run.config)
            .field("steps", &self.run.steps)
            .finish()
    }
}

/// A digest of everything the ranks must agree on: the particles, the configuration, the
/// step counter and the kernel this CPU runs (a rank with another SIMD path would compute
/// other bits and the replicated copies would drift apart).
fn fingerprint(run: &Run, kernel: &str) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    let p = &run.particles;
    let values = p
        .position
        .iter()
        .chain(&p.velocity)
        .flatten()
        .chain(&p.charge)
        .chain(&p.mass);
    for v in values {
        v.to_bits().hash(&mut h);
    }
    p.species.hash(&mut h);
    format!("{:?}", run.config).hash(&mut h);
    run.steps.hash(&mut h);
    kernel.hash(&mut h);
    h.finish()
}

impl DistributedCoulomb {
    /// Validates the particles and the configuration as [`crate::PpCoulomb::new`] does (the
    /// same errors, on every rank) and builds this rank's CPU engine. Collective; every rank
    /// passes the same particles and configuration.
    ///
    /// Errors: those of [`crate::PpCoulomb::new`] on the CPU; ranks whose particles,
    /// configuration or CPU kernel (AVX-512 or portable) differ. An error on one rank is an
    /// error on every rank (the others name the rank that failed).
    pub fn new(particles: Particles, config: &Config, comm: Comm) -> Result<Self> {
        let run = comm.agree(Run::new(particles, config))?;
        Self::build(run, comm, None, None)
    }

    fn build(
        run: Run,
        comm: Comm,
        accelerations: Option<&[[f64; 3]]>,
        energy_ref: Option<Option<Energy>>,
    ) -> Result<Self> {
        let (p, c) = (&run.particles, &run.config);
        let engine = match c.mode().state() {
            Precision::F32 => Engines::F32(CpuEngine::new(p, c, accelerations)),
            Precision::F64 => Engines::F64(CpuEngine::new(p, c, accelerations)),
        };
        let mut sim = Self { comm, engine, run };
        let kernel = with_engine!(&sim.engine, e => Engine::name(e));
        sim.comm.check_same(
            fingerprint(&sim.run, &kernel),
            "DistributedCoulomb inputs",
            "every rank must pass the same particles and configuration (or checkpoint), and \
             run on CPUs with the same SIMD kernel (set Config::rsqrt = false on mixed \
             machines)",
        )?;
        let (engine, share) = (&mut sim.engine, Ranks(&sim.comm));
        sim.run.set_energy_ref(
            energy_ref,
            || with_engine!(engine, e => e.energy_now(&share)),
        )?;
        Ok(sim)
    }

    /// The particles this rank computes and integrates: block `rank` of `size` contiguous
    /// blocks, the first `N mod size` one particle longer.
    pub fn own(&self) -> Range<usize> {
        Ranks(&self.comm).own(self.run.particles.len())
    }

    /// The configuration.
    pub fn config(&self) -> &Config {
        &self.run.config
    }

    /// Number of particles (all ranks hold all of them).
    pub fn len(&self) -> usize {
        self.run.particles.len()
    }

    /// Whether there are no particles.
    pub fn is_empty(&self) -> bool {
        self.run.particles.is_empty()
    }

    /// Simulated time (as [`crate::PpCoulomb::time`]).
    pub fn time(&self) -> f64 {
        self.run.time()
    }

    /// Pair interactions per force evaluation over all ranks, `N (N - 1)`; each rank
    /// evaluates the share of its own particles.
    pub fn interactions_per_step(&self) -> f64 {
        self.run.interactions_per_step()
    }

    /// Changes the time step for the following steps (as [`crate::PpCoulomb::set_dt`]).
    /// Collective.
    ///
    /// Errors: a `dt` that is not finite and > 0.
    pub fn set_dt(&mut self, dt: f64) -> Result<()> {
        self.run.set_dt(dt)?;
        with_engine!(&mut self.engine, e => e.set_time_step(dt));
        Ok(())
    }

    /// Accelerations of all particles at the current positions (each rank computes its own
    /// and they are gathered), on every rank. Collective.
    ///
    /// Errors: under the exact law, two coincident particles (named as by
    /// [`crate::PpCoulomb::accelerations`]).
    pub fn accelerations(&mut self) -> Result<Vec<[f64; 3]>> {
        let share = Ranks(&self.comm);
        with_engine!(&mut self.engine, e => e.accelerations_with(&share))
    }

    /// The diagnostics of [`crate::PpCoulomb::diagnostics`], with the same bits, on every
    /// rank: each rank sums the potential-energy rows of its own particles, the rows are
    /// gathered and added in particle order. Collective.
    ///
    /// Errors: those of [`DistributedCoulomb::accelerations`].
    pub fn diagnostics(&mut self) -> Result<Diagnostics> {
        let state = self.state()?;
        let acc = self.accelerations()?;
        let share = Ranks(&self.comm);
        let n = state.len();
        let mut rows = vec![0.0; n];
        potential_rows(&state, self.run.config.force, share.own(n), &mut rows);
        share.gather(&mut [&mut rows], n)?;
        Ok(with_potential(&state, &acc, rows.iter().sum()))
    }
}

impl Distributed for DistributedCoulomb {
    fn comm(&self) -> &Comm {
        &self.comm
    }

    /// The complete state as the checkpoint bytes of [`crate::PpCoulomb`] (model
    /// `PpCoulomb<f64>` or `PpCoulomb<f32>`), the same on every rank
    /// ([`Distributed::write_checkpoint`] writes them from rank 0). They resume with
    /// [`Distributed::resume`] on any rank count, or with `PpCoulomb::resume` on
    /// one process. Collective (the kept accelerations are gathered).
    fn checkpoint(&mut self) -> Result<Vec<u8>> {
        let now = self.state()?;
        let share = Ranks(&self.comm);
        let accelerations = if self.run.particles.is_empty() {
            None
        } else {
            with_engine!(&mut self.engine, e => e.kept_accelerations_with(&share))?
        };
        self.run.checkpoint(now, accelerations)
    }

    /// Rebuilds a run from checkpoint bytes of [`Distributed::checkpoint`] or of
    /// [`crate::PpCoulomb`]'s `Restart::checkpoint` on the CPU, on any rank count: the data
    /// are replicated, so the checkpoint does not depend on the rank count that wrote it,
    /// and the resumed run continues with the bits of the uninterrupted one. Collective;
    /// every rank passes the same bytes (checked; [`Distributed::resume_file`] reads a
    /// file on rank 0 and sends it).
    ///
    /// Errors: those of `PpCoulomb::resume` (another crate's or model's checkpoint, a
    /// truncated, corrupt or inconsistent one); ranks that pass different checkpoints. An
    /// error on one rank is an error on every rank.
    fn resume(bytes: &[u8], comm: Comm) -> Result<Self> {
        let saved = comm.agree(Run::resume(bytes))?;
        Self::build(
            saved.run,
            comm,
            saved.accelerations.as_deref(),
            Some(saved.energy_ref),
        )
    }
}

impl Simulation for DistributedCoulomb {
    type State = Particles;

    /// Advances `steps` steps with the blow-up checks of [`crate::PpCoulomb`] (same steps
    /// checked, same errors, same rollback, on every rank). Collective.
    fn step(&mut self, steps: u32) -> Result<()> {
        self.comm.agree_steps(steps)?;
        let (engine, share) = (&mut self.engine, Ranks(&self.comm));
        self.run.step(
            steps,
            |checks| with_engine!(engine, e => e.run(steps, checks, &share)),
        )
    }

    /// All particles as they are now (the same on every rank; no communication).
    fn state(&mut self) -> Result<Particles> {
        Ok(self
            .run
            .particles_at(with_engine!(&self.engine, e => e.state_now())))
    }

    fn steps_done(&self) -> u64 {
        self.run.steps
    }

    /// The CPU kernel's name and the rank count, e.g. `cpu-f64 (portable), 4 ranks (mpi)`.
    fn backend_name(&self) -> String {
        let kernel = with_engine!(&self.engine, e => Engine::name(e));
        format!(
            "{kernel}, {} ranks ({})",
            self.comm.size(),
            self.comm.name()
        )
    }
}
