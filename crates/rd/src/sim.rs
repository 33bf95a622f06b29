//! [`Rd`]: the reaction–diffusion simulation on either backend, chosen by a
//! [`simkit_backend::Backend`] value, with its checkpoints.

use serde::{Deserialize, Serialize};
use simkit_backend::{Backend, Error, Precision, Restart, Result, Simulation, checkpoint};

use crate::cpu::CpuRd;
use crate::engine::Engine;
#[cfg(feature = "gpu")]
use crate::gpu::GpuRd;
use crate::{Boundaries, Config, Grid, Model, Real, Stepping};

/// Reaction–diffusion of the fields of a [`Grid`] under a [`Model`], on the backend chosen at
/// construction.
///
/// # Stability and blow-up checks
///
/// The stability bound `dt <= h^2 / (4 D_max)` is checked at construction, at
/// [`Rd::set_stepping`] and, for models whose diffusivity depends on the fields (the colony
/// model), again at the start of each `step` call from the current fields (on the GPU, a
/// reduction kernel finds `D_max` on the device, in f32, and only that number is read back):
/// a `dt` over it is refused with [`Error::Unstable`] and nothing is stepped.
///
/// Inside `step(n)` the run is checked every [`Config::check_every`] steps (counted from
/// step 0, so the same steps are checked however a run is split into calls) and at the end of
/// the call:
///
/// - every value of every field must be finite. A failed check puts the run back to the last
///   state that passed a check (`state()` returns it, `steps_done()` is its step) and
///   returns [`Error::BlowUp`] naming the step, the first bad cell `(x, y)`, its species and
///   value, and the likely cause (`dt` too large);
/// - for field-dependent diffusivities with the guard enforced, `dt` must still be within
///   the bound of the current fields at each check inside the call: a colony whose `d n b`
///   grows during one long call stops at the first check where the bound fell below `dt`,
///   holding that (finite) state, and `step` returns [`Error::BlowUp`] naming `D_max` and
///   the bound (fix: a smaller `dt` through [`Rd::set_stepping`]). At the end of a call the
///   bound is left to the start of the next call, so a run split into calls stops at the same
///   step with the same state.
///
/// The checks only read the fields (and keep one copy of them per check): results are
/// bit-identical for every `check_every`.
///
/// # Checkpoints
///
/// [`Rd`] implements [`Restart`]: the checkpoint holds the grid (size, `h`, edges, fields),
/// the model, the [`Config`], the step counter and the simulated time, and a resumed run
/// continues bit for bit on the same backend. [`crate::DistributedRd`] writes and reads the
/// same bytes, so a run moves between one process and any number of ranks.
pub struct Rd<T: Real, M: Model> {
    engine: Box<dyn Engine<T, M>>,
    config: Config,
    /// Simulated time at step `epoch_step` (the last change of `dt`).
    epoch_time: f64,
    /// Step of the last change of `dt`.
    epoch_step: u64,
}

impl<T: Real, M: Model> std::fmt::Debug for Rd<T, M> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Rd")
            .field("backend", &self.engine.name())
            .field("model", self.engine.model())
            .field("config", &self.config)
            .field("steps", &self.engine.steps_done())
            .field("time", &self.time())
            .finish()
    }
}

impl<T: Real, M: Model> Rd<T, M> {
    /// Validates `config`, checks the model against the grid and `dt` against the stability
    /// bound (unless overridden), and builds the backend `backend` names (the grid is
    /// uploaded once on the GPU).
    ///
    /// Errors: an invalid [`Config`], a model that does not fit the grid, non-finite field
    /// values, an unstable `dt`; on the GPU also `f64` fields without `SHADER_F64`, a tile
    /// over the device's workgroup limits, a grid over the buffer or dispatch limits.
    pub fn new(grid: Grid<T>, model: M, config: &Config, backend: Backend<'_>) -> Result<Self> {
        Self::build(grid, model, config, backend, 0, 0.0)
    }

    /// [`Rd::new`] for a run `steps` steps in, at simulated time `time`.
    fn build(
        grid: Grid<T>,
        model: M,
        config: &Config,
        backend: Backend<'_>,
        steps: u64,
        time: f64,
    ) -> Result<Self> {
        config.validate()?;
        let engine: Box<dyn Engine<T, M>> = match backend {
            Backend::Cpu => Box::new(CpuRd::new(grid, model, config, steps)?),
            #[cfg(feature = "gpu")]
            Backend::Gpu(ctx) => Box::new(GpuRd::new(ctx, grid, model, config, steps)?),
        };
        Ok(Self {
            engine,
            config: *config,
            epoch_time: time,
            epoch_step: steps,
        })
    }

    /// The model.
    pub fn model(&self) -> &M {
        self.engine.model()
    }

    /// The run settings (with the current stepping).
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// Changes the time-stepping settings (checked against the stability bound from the
    /// current fields). The simulated time goes on from its current value.
    pub fn set_stepping(&mut self, stepping: Stepping) -> Result<()> {
        let now = self.time();
        self.engine.set_stepping(stepping)?;
        self.epoch_time = now;
        self.epoch_step = self.engine.steps_done();
        self.config.stepping = stepping;
        Ok(())
    }

    /// Current time-stepping settings.
    pub fn stepping(&self) -> Stepping {
        self.engine.stepping()
    }

    /// Simulated time: the time at the last [`Rd::set_stepping`] (0 at the start) plus the
    /// steps since then times `dt`. It depends only on the steps done, not on how they were
    /// split into calls, and a checkpoint restores it exactly.
    pub fn time(&self) -> f64 {
        self.time_at(self.engine.steps_done())
    }

    fn time_at(&self, steps: u64) -> f64 {
        self.epoch_time + steps.saturating_sub(self.epoch_step) as f64 * self.engine.stepping().dt
    }

    /// Largest stable `dt`, `h^2 / (4 D_max)`, for the current fields (on the GPU, for
    /// models whose diffusivity depends on the fields, `D_max` is reduced on the device in
    /// f32 and read back: hence the `Result`).
    pub fn stable_dt(&self) -> Result<f64> {
        self.engine.stable_dt()
    }
}

impl<T: Real, M: Model> Simulation for Rd<T, M> {
    type State = Grid<T>;

    /// Advances `steps` steps with the checks described on [`Rd`]: `Error::Unstable` when
    /// the bound of the current fields is already below `dt` (nothing stepped),
    /// `Error::BlowUp` when a check inside the call fails (the run is then at the step the
    /// error names as `rolled_back_to`), `Error::InvalidParameter` when the step counter or
    /// the simulated time would overflow.
    fn step(&mut self, steps: u32) -> Result<()> {
        let end = self.engine.steps_done().saturating_add(u64::from(steps));
        let t = self.time_at(end);
        if !t.is_finite() {
            return Err(Error::invalid(
                "steps",
                steps,
                format!(
                    "the simulated time would reach {t} (dt = {:e}); use a smaller dt or fewer \
                     steps",
                    self.engine.stepping().dt
                ),
            ));
        }
        self.engine.step(steps)
    }

    fn state(&mut self) -> Result<Grid<T>> {
        self.engine.state()
    }

    fn steps_done(&self) -> u64 {
        self.engine.steps_done()
    }

    fn backend_name(&self) -> String {
        self.engine.name()
    }
}

/// The fields of a checkpoint in their own precision (bit-exact).
#[derive(Serialize, Deserialize)]
enum SavedFields {
    F32(Vec<Vec<f32>>),
    F64(Vec<Vec<f64>>),
}

/// The checkpoint payload: everything [`Rd`] needs to go on bit for bit.
#[derive(Serialize, Deserialize)]
struct Saved<M> {
    nx: u64,
    ny: u64,
    h: f64,
    boundaries: Boundaries,
    fields: SavedFields,
    model: M,
    config: Config,
    steps: u64,
    epoch_time: f64,
    epoch_step: u64,
}

/// The model string of a checkpoint header: the precision and the model type.
fn model_string<T: Real, M>() -> String {
    format!("Rd<{}, {}>", T::WGSL, std::any::type_name::<M>())
}

/// What a checkpoint of `rd` holds besides its format header: the run of [`Rd`] or of
/// [`crate::DistributedRd`] (which writes and reads the same bytes).
pub(crate) struct RunState<T: Real, M> {
    /// The whole grid.
    pub grid: Grid<T>,
    /// The model.
    pub model: M,
    /// The settings, with the current stepping.
    pub config: Config,
    /// Steps done.
    pub steps: u64,
    /// Simulated time at step `epoch_step` (the last change of `dt`).
    pub epoch_time: f64,
    /// Step of the last change of `dt`.
    pub epoch_step: u64,
}

/// The checkpoint bytes of `run`.
pub(crate) fn encode_checkpoint<T: Real, M: Model>(run: &RunState<T, M>) -> Result<Vec<u8>> {
    let grid = &run.grid;
    let fields = match T::PRECISION {
        // `to_f64` is exact and f32 values convert back exactly.
        Precision::F32 => SavedFields::F32(
            grid.fields()
                .iter()
                .map(|f| f.iter().map(|v| v.to_f64() as f32).collect())
                .collect(),
        ),
        Precision::F64 => SavedFields::F64(
            grid.fields()
                .iter()
                .map(|f| f.iter().map(|v| v.to_f64()).collect())
                .collect(),
        ),
    };
    let saved = Saved {
        nx: grid.nx() as u64,
        ny: grid.ny() as u64,
        h: grid.h(),
        boundaries: grid.boundaries().clone(),
        fields,
        model: run.model.clone(),
        config: run.config,
        steps: run.steps,
        epoch_time: run.epoch_time,
        epoch_step: run.epoch_step,
    };
    checkpoint::encode(
        env!("CARGO_PKG_NAME"),
        env!("CARGO_PKG_VERSION"),
        &model_string::<T, M>(),
        &saved,
    )
}

/// The run a checkpoint holds, its grid and clock validated (the model, config and `dt`
/// are validated by the constructor that takes it).
pub(crate) fn decode_checkpoint<T: Real, M: Model>(bytes: &[u8]) -> Result<RunState<T, M>> {
    let s: Saved<M> = checkpoint::decode(
        bytes,
        env!("CARGO_PKG_NAME"),
        env!("CARGO_PKG_VERSION"),
        &model_string::<T, M>(),
    )?;
    let fields: Vec<Vec<T>> = match (s.fields, T::PRECISION) {
        (SavedFields::F32(f), Precision::F32) => f
            .into_iter()
            .map(|f| f.into_iter().map(|v| T::from_f64(f64::from(v))).collect())
            .collect(),
        (SavedFields::F64(f), Precision::F64) => f
            .into_iter()
            .map(|f| f.into_iter().map(T::from_f64).collect())
            .collect(),
        _ => {
            return Err(Error::checkpoint(format!(
                "the fields are not in {}; resume it with the precision that wrote it",
                T::WGSL
            )));
        }
    };
    let size = |v: u64| {
        usize::try_from(v)
            .map_err(|_| Error::checkpoint(format!("grid size {v} does not fit this machine")))
    };
    let grid = Grid::new(size(s.nx)?, size(s.ny)?, s.h, s.boundaries, fields)?;
    if !s.epoch_time.is_finite() || s.epoch_step > s.steps {
        return Err(Error::checkpoint(format!(
            "simulated time {} at step {} of {} steps is not a valid clock",
            s.epoch_time, s.epoch_step, s.steps
        )));
    }
    Ok(RunState {
        grid,
        model: s.model,
        config: s.config,
        steps: s.steps,
        epoch_time: s.epoch_time,
        epoch_step: s.epoch_step,
    })
}

impl<T: Real, M: Model> Restart for Rd<T, M> {
    /// The complete state: grid, model, config, step counter and simulated time (a GPU run
    /// downloads its fields).
    fn checkpoint(&mut self) -> Result<Vec<u8>> {
        let mut config = self.config;
        config.stepping = self.engine.stepping();
        encode_checkpoint(&RunState {
            grid: self.engine.state()?,
            model: self.engine.model().clone(),
            config,
            steps: self.engine.steps_done(),
            epoch_time: self.epoch_time,
            epoch_step: self.epoch_step,
        })
    }

    /// Rebuilds the run on `backend`, validating the grid, model, config and `dt` as
    /// [`Rd::new`] does.
    fn resume(bytes: &[u8], backend: Backend<'_>) -> Result<Self> {
        let s = decode_checkpoint::<T, M>(bytes)?;
        Self::build(s.grid, s.model, &s.config, backend, s.steps, s.epoch_time).map(|mut r| {
            r.epoch_step = s.epoch_step;
            r
        })
    }
}
