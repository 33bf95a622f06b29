//! The user-facing simulation object, [`LatticeGas`].

use serde::{Deserialize, Serialize};
use simkit_backend::{Backend, Restart, Result, Simulation, checkpoint};

use crate::cpu::lut::LutCpu;
use crate::cpu::multispin::MultiSpinCpu;
use crate::engine::Engine;
use crate::field::BlockField;
use crate::{Config, CpuMethod, Lattice};

/// An FHP lattice-gas simulation of a [`Lattice`] on a chosen backend. Every backend and
/// every [`CpuMethod`] / [`crate::GpuLayout`] gives the same lattice bit for bit.
///
/// ```
/// use simkit_backend::{Backend, Simulation};
/// use simkit_lattice_gas::{Config, Lattice, LatticeGas};
/// # fn main() -> simkit_backend::Result<()> {
/// let mut lattice = Lattice::new(64, 32)?;
/// lattice.fill_random(0.2, 7)?;
/// let n0 = lattice.particle_count();
/// let mut sim = LatticeGas::new(lattice, &Config::default(), Backend::Cpu)?;
/// sim.step(100)?;
/// assert_eq!(sim.state()?.particle_count(), n0); // periodic box: particles are conserved
/// # Ok(())
/// # }
/// ```
pub struct LatticeGas {
    engine: Box<dyn Engine>,
    config: Config,
    steps: u64,
}

impl std::fmt::Debug for LatticeGas {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LatticeGas")
            .field("backend", &self.engine.name())
            .field("config", &self.config)
            .field("steps", &self.steps)
            .finish()
    }
}

/// What a lattice-gas checkpoint holds: the settings, the site bytes (directions and walls)
/// and the step counter, which keys the random bits of every later step.
#[derive(Serialize, Deserialize)]
struct Saved {
    config: Config,
    width: u64,
    height: u64,
    cells: Vec<u8>,
    steps: u64,
}

/// The model name in lattice-gas checkpoint headers.
const MODEL: &str = "LatticeGas";

impl LatticeGas {
    /// Validates `config` against `lattice` ([`Config::validate_for`]) and builds the backend:
    /// on the CPU the method `config.cpu` names, on the GPU the layout `config.gpu_layout`
    /// names.
    ///
    /// Errors: invalid settings, a multi-spin width that is not a multiple of 64, a GPU
    /// bit-plane width that is not a multiple of 32, or any GPU failure.
    pub fn new(lattice: Lattice, config: &Config, backend: Backend<'_>) -> Result<Self> {
        config.validate_for(&lattice)?;
        let engine: Box<dyn Engine> = match backend {
            Backend::Cpu if runs_multispin(config.cpu, lattice.width()) => {
                Box::new(MultiSpinCpu::new(lattice, config)?)
            }
            Backend::Cpu if config.cpu == CpuMethod::LutPortable => {
                Box::new(LutCpu::new(lattice, config)?.force_scalar())
            }
            Backend::Cpu => Box::new(LutCpu::new(lattice, config)?),
            #[cfg(feature = "gpu")]
            Backend::Gpu(ctx) => Box::new(crate::gpu::GpuLattice::new(lattice, config, ctx)?),
        };
        Ok(Self {
            engine,
            config: config.clone(),
            steps: 0,
        })
    }

    /// The settings the run was built with.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// Block sums of density and momentum over `block x block` sites of the current lattice
    /// (the same field as [`BlockField::from_lattice`] on [`Simulation::state`]; the
    /// multi-spin backend counts its bit-planes without building the site bytes).
    pub fn block_field(&mut self, block: usize) -> Result<BlockField> {
        self.engine.block_field(block)
    }
}

/// Whether `method` runs the multi-spin backend on a lattice `width` sites wide (the choice
/// [`CpuMethod::Auto`] documents).
fn runs_multispin(method: CpuMethod, width: usize) -> bool {
    match method {
        CpuMethod::Auto => !crate::cpu::lut::has_vbmi() && width.is_multiple_of(64),
        CpuMethod::Lut | CpuMethod::LutPortable => false,
        CpuMethod::MultiSpin => true,
    }
}

impl Simulation for LatticeGas {
    type State = Lattice;

    fn step(&mut self, steps: u32) -> Result<()> {
        self.engine.step(steps)?;
        self.steps += u64::from(steps);
        Ok(())
    }

    fn state(&mut self) -> Result<Lattice> {
        self.engine.state()
    }

    fn steps_done(&self) -> u64 {
        self.steps
    }

    fn backend_name(&self) -> String {
        self.engine.name()
    }
}

/// Checkpoints hold the [`Config`], the lattice and the step counter; a resumed run gives
/// the lattice of the uninterrupted run bit for bit, on every backend (they all agree bit for
/// bit, so a checkpoint from one backend resumes exactly on any other).
///
/// ```
/// use simkit_backend::{Backend, Restart, Simulation};
/// use simkit_lattice_gas::{Config, Lattice, LatticeGas};
/// # fn main() -> simkit_backend::Result<()> {
/// let mut lattice = Lattice::new(64, 32)?;
/// lattice.fill_random(0.3, 5)?;
/// let config = Config { body_force: 0.01, ..Config::default() };
/// let mut whole = LatticeGas::new(lattice.clone(), &config, Backend::Cpu)?;
/// whole.step(40)?;
/// let mut half = LatticeGas::new(lattice, &config, Backend::Cpu)?;
/// half.step(20)?;
/// let saved = half.checkpoint()?; // or half.write_checkpoint("run.ckpt")
/// let mut resumed = LatticeGas::resume(&saved, Backend::Cpu)?;
/// resumed.step(20)?;
/// assert_eq!(resumed.steps_done(), 40);
/// assert_eq!(resumed.state()?, whole.state()?);
/// # Ok(())
/// # }
/// ```
impl Restart for LatticeGas {
    fn checkpoint(&mut self) -> Result<Vec<u8>> {
        encode_checkpoint(&self.config, &self.engine.state()?, self.steps)
    }

    fn resume(bytes: &[u8], backend: Backend<'_>) -> Result<Self> {
        let (config, lattice, steps) = decode_checkpoint(bytes)?;
        let mut sim = Self::new(lattice, &config, backend)?;
        sim.engine.set_steps(steps)?;
        sim.steps = steps;
        Ok(sim)
    }
}

/// The checkpoint bytes of a run of `config` at `lattice` after `steps` steps (the format
/// of [`LatticeGas`]'s [`Restart`], also written by [`crate::DistributedLatticeGas`]).
pub(crate) fn encode_checkpoint(config: &Config, lattice: &Lattice, steps: u64) -> Result<Vec<u8>> {
    let saved = Saved {
        config: config.clone(),
        width: lattice.width() as u64,
        height: lattice.height() as u64,
        cells: lattice.cells().to_vec(),
        steps,
    };
    checkpoint::encode(
        env!("CARGO_PKG_NAME"),
        env!("CARGO_PKG_VERSION"),
        MODEL,
        &saved,
    )
}

/// The settings, lattice and step counter of [`encode_checkpoint`] bytes (the lattice
/// validated by [`Lattice::from_cells`], the settings not yet against it).
pub(crate) fn decode_checkpoint(bytes: &[u8]) -> Result<(Config, Lattice, u64)> {
    let saved: Saved = checkpoint::decode(
        bytes,
        env!("CARGO_PKG_NAME"),
        env!("CARGO_PKG_VERSION"),
        MODEL,
    )?;
    let size = |name: &str, v: u64| {
        usize::try_from(v).map_err(|_| {
            simkit_backend::Error::invalid(name, v, "does not fit this machine's usize")
        })
    };
    let lattice = Lattice::from_cells(
        size("width", saved.width)?,
        size("height", saved.height)?,
        saved.cells,
    )?;
    Ok((saved.config, lattice, saved.steps))
}
