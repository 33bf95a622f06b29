//! The user-facing simulation object and its checkpoint format.

use serde::{Deserialize, Serialize};
use simkit_backend::particles::Dynamics;
use simkit_backend::{Backend, Error, Precision, Restart, Result, Simulation, checkpoint};

use crate::engine::{Engine, model_name};
use crate::{
    Config, Diagnostics, GpuKernel, Integrator, Langevin, LennardJones, PairLaw, State, System,
};

/// [`Config`] as a checkpoint stores it.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct ConfigRecord {
    dt: Option<f64>,
    integrator: Integrator,
    gpu_kernel: GpuKernel,
    single: bool,
    skin: f64,
    check_every: u32,
    shift: bool,
    allow_unstable_dt: bool,
    thermostat: Option<Langevin>,
}

impl From<&Config> for ConfigRecord {
    fn from(c: &Config) -> Self {
        Self {
            dt: c.dt,
            integrator: c.integrator,
            gpu_kernel: c.gpu_kernel,
            single: c.precision == Precision::F32,
            skin: c.skin,
            check_every: c.check_every,
            shift: c.shift,
            allow_unstable_dt: c.allow_unstable_dt,
            thermostat: c.thermostat,
        }
    }
}

impl From<ConfigRecord> for Config {
    fn from(c: ConfigRecord) -> Self {
        Self {
            dt: c.dt,
            integrator: c.integrator,
            gpu_kernel: c.gpu_kernel,
            precision: if c.single {
                Precision::F32
            } else {
                Precision::F64
            },
            skin: c.skin,
            check_every: c.check_every,
            shift: c.shift,
            allow_unstable_dt: c.allow_unstable_dt,
            thermostat: c.thermostat,
        }
    }
}

/// Everything a checkpoint holds: the inputs (validated again on resume) and the engine's
/// dynamic state.
#[derive(Serialize, Deserialize)]
#[serde(bound = "L: PairLaw")]
struct Payload<L> {
    system: System<L>,
    config: ConfigRecord,
    engine: Dynamics,
}

/// A checkpoint in the format of [`Md`]'s `Restart::checkpoint`: the system, the settings and
/// the engine state, under the model string `model`.
pub(crate) fn encode_checkpoint<L: PairLaw>(
    system: &System<L>,
    config: &Config,
    model: &str,
    engine: Dynamics,
) -> Result<Vec<u8>> {
    let payload = Payload {
        system: system.clone(),
        config: ConfigRecord::from(config),
        engine,
    };
    checkpoint::encode(
        env!("CARGO_PKG_NAME"),
        env!("CARGO_PKG_VERSION"),
        model,
        &payload,
    )
}

/// What [`encode_checkpoint`] wrote: the model string, the system (validated again), the
/// settings and the engine state.
pub(crate) type Decoded<L> = (String, System<L>, Config, Dynamics);

/// Reads a checkpoint of any model of this crate written with law `L` and validates its
/// system.
///
/// Errors: a checkpoint of another law (named in the model string) is refused before its
/// payload is read.
pub(crate) fn decode_checkpoint<L: PairLaw>(bytes: &[u8]) -> Result<Decoded<L>> {
    checkpoint::require_law(bytes, L::NAME, LennardJones::NAME)?;
    let (written, payload): (String, Payload<L>) =
        checkpoint::decode_any_model(bytes, env!("CARGO_PKG_NAME"), env!("CARGO_PKG_VERSION"))?;
    payload
        .system
        .validate()
        .map_err(|e| Error::checkpoint(format!("the stored system is not valid: {e}")))?;
    Ok((
        written,
        payload.system,
        Config::from(payload.config),
        payload.engine,
    ))
}

/// A molecular-dynamics run of a [`System`] with pair law `L` on a chosen backend.
///
/// ```
/// use simkit_backend::{Backend, Simulation};
/// use simkit_md::{Config, Dim, LennardJones, Md, PairTable, System};
/// # fn main() -> simkit_backend::Result<()> {
/// let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5))?;
/// let mut sys = System::new(Dim::Three, [0.0; 3], [6.0; 3], [true; 3], vec![1.0], table)?;
/// // Two atoms 1.5 sigma apart attract each other.
/// sys.add_particle(0, [2.0, 3.0, 3.0], [0.0; 3])?;
/// sys.add_particle(0, [3.5, 3.0, 3.0], [0.0; 3])?;
/// let mut md = Md::new(sys, &Config::default(), Backend::Cpu)?;
/// let e0 = md.diagnostics()?.total;
/// md.step(20)?;
/// let v = md.state()?.velocities;
/// assert!(v[0][0] > 0.0 && v[1][0] < 0.0);
/// assert!((md.diagnostics()?.total - e0).abs() < 1e-4);
/// # Ok(())
/// # }
/// ```
pub struct Md<L = LennardJones> {
    engine: Box<dyn Engine>,
    system: System<L>,
    config: Config,
    dt: f64,
}

impl<L: PairLaw> Md<L> {
    /// Validates the system and settings and builds the backend.
    ///
    /// Errors: invalid settings or a time step over the safe bound (see
    /// [`Config::resolve_dt`]), particles so close that a force is not finite, or any GPU
    /// failure (the GPU computes in `f32` whatever [`Config::precision`] says, and refuses
    /// a cell of the neighbour grid, at least `max r_c` wide, holding more particles than
    /// the adapter's loop limit allows: [`Error::Unsupported`]).
    pub fn new(system: System<L>, config: &Config, backend: Backend<'_>) -> Result<Self> {
        Self::build(system, config, backend, None)
    }

    fn build(
        system: System<L>,
        config: &Config,
        backend: Backend<'_>,
        saved: Option<&Dynamics>,
    ) -> Result<Self> {
        let dt = config.resolve_dt(&system)?;
        let engine = crate::build::engine_for(&system, config, dt, backend, saved)?;
        Ok(Self {
            engine,
            system,
            config: *config,
            dt,
        })
    }

    /// The time step in use.
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// The system the run started from.
    pub fn system(&self) -> &System<L> {
        &self.system
    }

    /// The settings of the run.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// Energies, virial pressure and per-species temperatures of the current state.
    pub fn diagnostics(&mut self) -> Result<Diagnostics> {
        self.engine.diagnostics()
    }

    /// The force on every particle at the current positions (`[fx, fy, 0]` in 2D; 0 on the
    /// particles of a frozen species, whose forces are not integrated).
    pub fn forces(&mut self) -> Result<Vec<[f64; 3]>> {
        self.engine.forces()
    }
}

impl<L: PairLaw> Simulation for Md<L> {
    type State = State;

    /// Advances `steps` steps, checking the state every [`Config::check_every`] steps and
    /// at the end; a failed check returns [`Error::BlowUp`] with the run rolled back to the
    /// last state that passed ([`Simulation::steps_done`] and [`Simulation::state`] give
    /// it).
    fn step(&mut self, steps: u32) -> Result<()> {
        self.engine.step(steps)
    }

    fn state(&mut self) -> Result<State> {
        self.engine.state()
    }

    fn steps_done(&self) -> u64 {
        self.engine.steps_done()
    }

    fn backend_name(&self) -> String {
        self.engine.name()
    }
}

/// Checkpoints hold the system, the settings, the step count, the positions and the
/// velocities as the integrator stores them; forces are recomputed on resume, bit for bit:
/// on the CPU from the same half list, rebuilt from the stored slot order and positions of
/// the last list build; on the GPU from the same cell order, since the cell list is
/// rebuilt from the same positions. A checkpoint resumes on the backend and precision that
/// wrote it.
impl<L: PairLaw> Restart for Md<L> {
    fn checkpoint(&mut self) -> Result<Vec<u8>> {
        let engine = self.engine.save()?;
        encode_checkpoint(&self.system, &self.config, &self.engine.model(), engine)
    }

    fn resume(bytes: &[u8], backend: Backend<'_>) -> Result<Self> {
        let (written, system, config, engine) = decode_checkpoint(bytes)?;
        let want = model_name::<L>(backend.is_gpu(), config.precision, system.dim().axes());
        if written != want {
            return Err(Error::checkpoint(format!(
                "holds a {} run, and {} on this backend would be a {want} run; resume it on \
                 the backend that wrote it",
                written,
                backend.name()
            )));
        }
        Self::build(system, &config, backend, Some(&engine))
    }
}
