//! The user-facing simulation object, [`LatticeGas`].

use simkit_backend::{Backend, Result, Simulation};

use crate::engine::Engine;
use crate::field::BlockField;
use crate::{Config, CpuMethod, Lattice, LutCpu, MultiSpinCpu};

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
    steps: u64,
}

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
            Backend::Cpu => Box::new(LutCpu::new(lattice, config)?),
            #[cfg(feature = "gpu")]
            Backend::Gpu(ctx) => Box::new(crate::GpuLattice::new(lattice, config, ctx)?),
        };
        Ok(Self { engine, steps: 0 })
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
        CpuMethod::Lut => false,
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
