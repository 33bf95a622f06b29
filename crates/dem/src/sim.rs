//! The user-facing simulation object and its state snapshot.

use serde::{Deserialize, Serialize};
use simkit_backend::{Backend, Error, Restart, Result, Simulation, checkpoint};

use crate::diagnostics;
use crate::engine::{Engine, model_name};
use crate::input::SceneRecord;
use crate::prepared::Prepared;
use crate::{Config, ContactLaw, Diagnostics, Integrator, Material, Precision, Scene, State};
use simkit_backend::particles::Dynamics;

/// [`Config`] as a checkpoint stores it.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct ConfigRecord {
    dt: Option<f64>,
    integrator: Integrator,
    single: bool,
    allow_unstable_dt: bool,
    skin: f64,
    check_every: u32,
    max_overlap: f64,
}

impl From<&Config> for ConfigRecord {
    fn from(c: &Config) -> Self {
        Self {
            dt: c.dt,
            integrator: c.integrator,
            single: c.precision == Precision::F32,
            allow_unstable_dt: c.allow_unstable_dt,
            skin: c.skin,
            check_every: c.check_every,
            max_overlap: c.max_overlap,
        }
    }
}

impl From<ConfigRecord> for Config {
    fn from(c: ConfigRecord) -> Self {
        Self {
            dt: c.dt,
            integrator: c.integrator,
            precision: if c.single {
                Precision::F32
            } else {
                Precision::F64
            },
            allow_unstable_dt: c.allow_unstable_dt,
            skin: c.skin,
            check_every: c.check_every,
            max_overlap: c.max_overlap,
        }
    }
}

/// Everything a checkpoint holds: the inputs (validated again on resume) and the engine's
/// dynamic state.
#[derive(Serialize, Deserialize)]
#[serde(bound = "L: ContactLaw")]
struct Payload<L> {
    scene: SceneRecord<L>,
    config: ConfigRecord,
    engine: Dynamics,
}

/// The force and torque on every particle, in scene order ([`Dem::forces`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Forces {
    /// Force on each particle (`[x, y, 0]` in 2D).
    pub force: Vec<[f64; 3]>,
    /// Torque on each particle (`[0, 0, t_z]` in 2D; zero without rotation).
    pub torque: Vec<[f64; 3]>,
}

/// A granular DEM simulation of a [`Scene`] with contact law `L` on a chosen backend.
///
/// ```
/// use simkit_backend::{Backend, Simulation};
/// use simkit_dem::{Config, Dem, Dim, Material, Particle, Scene};
/// # fn main() -> simkit_backend::Result<()> {
/// let mut scene = Scene::new(Dim::Two, [0.0; 3], [4.0, 4.0, 0.0], Material::new(0.9, 0.05))?;
/// scene.add_particle(Particle::new([1.0, 2.0, 0.0], 0.5, 1.0).with_velocity([1.0, 0.0, 0.0]))?;
/// scene.add_particle(Particle::new([2.5, 2.0, 0.0], 0.5, 1.0))?;
/// let mut sim = Dem::new(scene, &Config::default(), Backend::Cpu)?;
/// // dt = t_c / 30: the gap of 0.5 closes after 300 steps, the contact lasts 30 more.
/// sim.step(400)?;
/// let v = sim.state()?.velocities;
/// // Equal masses, e = 0.9: v0' = (1 - e) / 2, v1' = (1 + e) / 2.
/// assert!((v[0][0] - 0.05).abs() < 0.01 && (v[1][0] - 0.95).abs() < 0.01);
/// # Ok(())
/// # }
/// ```
pub struct Dem<L: ContactLaw = Material> {
    engine: Box<dyn Engine<L>>,
    scene: Scene<L>,
    config: Config,
}

impl<L: ContactLaw> Dem<L> {
    /// Validates the scene and settings and builds the backend.
    ///
    /// Errors: an empty scene, a particle outside the box, a time step over the safe bound
    /// (see [`Config::resolve_dt`]), initial overlaps deeper than [`crate::MAX_INITIAL_OVERLAP`]
    /// of a radius (between particles or with a wall), a periodic axis shorter than twice
    /// the largest diameter times `1 + skin`, magnitudes the precision cannot hold (the GPU
    /// computes in `f32`, as the CPU with [`Precision::F32`]), position Verlet on the GPU,
    /// or any GPU failure. The checks are shared: both backends accept the same inputs.
    pub fn new(scene: Scene<L>, config: &Config, backend: Backend<'_>) -> Result<Self> {
        Self::build(scene, config, backend, None)
    }

    /// [`Dem::new`], at a checkpointed state when `saved` is given.
    fn build(
        scene: Scene<L>,
        config: &Config,
        backend: Backend<'_>,
        saved: Option<&Dynamics>,
    ) -> Result<Self> {
        let single = backend.is_gpu() || config.precision == Precision::F32;
        let prep = Prepared::new(&scene, config, single)?;
        diagnostics::check_initial_overlaps(&prep)?;
        #[cfg(feature = "gpu")]
        if backend.is_gpu() && config.integrator != Integrator::VelocityVerlet {
            return Err(Error::Unsupported(
                "the GPU backend integrates with velocity Verlet only; use \
                 Integrator::VelocityVerlet or the CPU backend"
                    .into(),
            ));
        }
        let engine = crate::build::engine_for(prep, config.precision, backend, saved)?;
        Ok(Self {
            engine,
            scene,
            config: *config,
        })
    }

    /// The time step in use.
    pub fn dt(&self) -> f64 {
        self.engine.prepared().dt
    }

    /// The scene the run started from.
    pub fn scene(&self) -> &Scene<L> {
        &self.scene
    }

    /// The settings of the run.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// Diagnostics of the current state (downloads it on the GPU).
    pub fn diagnostics(&mut self) -> Result<Diagnostics> {
        let s = self.engine.state()?;
        self.diagnostics_of(&s)
    }

    /// Diagnostics of a state of this simulation's scene.
    pub fn diagnostics_of(&self, state: &State) -> Result<Diagnostics> {
        let p = self.engine.prepared();
        if state.positions.len() != p.n || state.velocities.len() != p.n {
            return Err(Error::invalid(
                "state length",
                state.positions.len(),
                format!("must equal the particle count {}", p.n),
            ));
        }
        let w = &state.angular_velocities;
        if !w.is_empty() && w.len() != p.n {
            return Err(Error::invalid(
                "angular velocities",
                w.len(),
                format!("must be empty or one per particle ({})", p.n),
            ));
        }
        crate::diagnostics::compute(p, state.time, &state.positions, &state.velocities, w)
    }

    /// The force and torque on every particle (scene order; torques zero without rotation)
    /// at the current state, as the next step starts from them: before the first step they
    /// are evaluated now (exactly as the first step would, so the run does not change),
    /// after a step they are those of its end. For comparisons with other codes and for
    /// analysis (e.g. force chains). CPU backend, velocity Verlet.
    ///
    /// Errors: [`Error::Unsupported`] on the GPU, and before the first step of a position
    /// Verlet run.
    pub fn forces(&mut self) -> Result<Forces> {
        self.engine.forces()
    }

    /// Vertical displacement of the vibrating walls at time `t`.
    pub fn wall_displacement(&self, t: f64) -> f64 {
        self.engine.prepared().wall_motion(t).0
    }
}

impl<L: ContactLaw> Simulation for Dem<L> {
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

/// Checkpoints hold the scene, the settings and the complete dynamic state (CPU: positions,
/// velocities, accelerations, half-step velocities or last displacements, the particle
/// order and the positions of the last neighbour-list build, the step count and the
/// accumulated time; GPU: the device buffers and the step count, which keys the wall
/// phase). A checkpoint resumes on the backend kind that wrote it, bit for bit.
impl<L: ContactLaw> Restart for Dem<L> {
    fn checkpoint(&mut self) -> Result<Vec<u8>> {
        let engine = self.engine.save()?;
        encode(&self.scene, &self.config, &self.engine.model(), engine)
    }

    fn resume(bytes: &[u8], backend: Backend<'_>) -> Result<Self> {
        let saved = decode::<L>(bytes)?;
        let want = model_name::<L>(
            backend.is_gpu(),
            saved.config.precision,
            saved.scene.dim().axes(),
        );
        if saved.model != want {
            return Err(Error::checkpoint(format!(
                "holds a {} run, and {} on this backend would be a {want} run; resume it on \
                 the backend that wrote it (or start a new run there from Dem::state with \
                 Scene::set_kinematics)",
                saved.model,
                backend.name()
            )));
        }
        Self::build(saved.scene, &saved.config, backend, Some(&saved.engine))
    }
}

/// What a checkpoint holds, decoded: the model that wrote it, the scene and settings
/// (validated as builders would), and the engine's dynamic state (validated by the engine
/// that loads it).
pub(crate) struct Saved<L> {
    /// The model string of the engine that wrote it ([`model_name`]).
    pub model: String,
    pub scene: Scene<L>,
    pub config: Config,
    pub engine: Dynamics,
}

/// A checkpoint of `engine`'s state for `scene` and `config`, written by `model`.
pub(crate) fn encode<L: ContactLaw>(
    scene: &Scene<L>,
    config: &Config,
    model: &str,
    engine: Dynamics,
) -> Result<Vec<u8>> {
    let payload = Payload {
        scene: scene.to_record(),
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

/// The contents of a dem checkpoint of law `L` (any model).
///
/// Errors: a checkpoint of another law is refused before its payload is read.
pub(crate) fn decode<L: ContactLaw>(bytes: &[u8]) -> Result<Saved<L>> {
    checkpoint::require_law(bytes, L::NAME, Material::NAME)?;
    let (model, payload): (String, Payload<L>) =
        checkpoint::decode_any_model(bytes, env!("CARGO_PKG_NAME"), env!("CARGO_PKG_VERSION"))?;
    let scene = Scene::from_record(payload.scene)
        .map_err(|e| Error::checkpoint(format!("the stored scene is not valid: {e}")))?;
    Ok(Saved {
        model,
        scene,
        config: Config::from(payload.config),
        engine: payload.engine,
    })
}
