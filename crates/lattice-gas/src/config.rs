//! Run settings: the physics of the lattice (rules, random seed, boundaries, forcing) and the
//! backend choices (CPU method, GPU layout) as plain data, the same type with or without the
//! `gpu` feature.

use simkit_backend::{Error, Result};

use crate::{Lattice, RuleSet};

/// Which CPU backend [`crate::LatticeGas`] runs on `Backend::Cpu`. All give the same lattice
/// bit for bit; they differ in speed and in the widths they accept.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum CpuMethod {
    /// The lookup table where the CPU has AVX-512 VBMI (as fast per step as multi-spin, and
    /// its snapshot is a plain copy), else multi-spin when the width is a multiple of 64,
    /// else the lookup table.
    #[default]
    Auto,
    /// The lookup table: one byte per site, rayon over bands of rows, four steps per pass
    /// over the lattice (any width); 64 sites per `vpermi2b` where the CPU has AVX-512
    /// VBMI.
    Lut,
    /// The lookup table's portable loop, one site at a time, whatever the CPU has: the
    /// reference the SIMD paths are checked against (slower; any width).
    LutPortable,
    /// Multi-spin: 64-site bit-planes, boolean collisions (width a multiple of 64).
    MultiSpin,
}

/// How the GPU backend stores the lattice (ignored on the CPU).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum GpuLayout {
    /// One byte per site, four per `u32`, collision by table lookup (any width).
    Bytes,
    /// Six bit-planes of 32-site words, collision as boolean logic (width a multiple of 32).
    BitPlanes,
}

impl GpuLayout {
    /// The faster layout that fits a lattice of `width` sites per row: bit-planes when the
    /// width is a multiple of 32, else bytes.
    pub fn for_width(width: usize) -> Self {
        if width.is_multiple_of(32) {
            GpuLayout::BitPlanes
        } else {
            GpuLayout::Bytes
        }
    }
}

/// Every setting of a lattice-gas run: how the lattice evolves (collision rules, seed of the
/// random bits, boundaries, inflow/outflow columns, body force) and which backend variant
/// runs it. Every backend reads the physics fields; `cpu` is read only on the CPU and
/// `gpu_layout` only on the GPU.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Config {
    /// Collision rules.
    pub rules: RuleSet,
    /// Seed of the counter-based random bits (chirality and body force).
    pub seed: u32,
    /// Periodic in x (otherwise particles leaving at the left/right edge are lost).
    pub periodic_x: bool,
    /// Periodic in y (needs an even height; otherwise particles leaving are lost).
    pub periodic_y: bool,
    /// Column 0 is re-filled with one east-mover per non-wall site after every step.
    pub inflow: bool,
    /// The last column is emptied (non-wall sites) after every step.
    pub outflow: bool,
    /// Body-force probability `p` in `[0, 1]`: a site with a west-mover and no east-mover
    /// turns it into an east-mover with probability `p`. 0 disables the force.
    pub body_force: f64,
    /// The CPU backend (CPU only).
    pub cpu: CpuMethod,
    /// The GPU storage layout; `None` takes [`GpuLayout::for_width`] (GPU only).
    pub gpu_layout: Option<GpuLayout>,
}

impl Default for Config {
    /// FHP-I, seed 1, periodic in x and y, no inflow, outflow or force; automatic CPU method
    /// and GPU layout.
    fn default() -> Self {
        Self {
            rules: RuleSet::FhpI,
            seed: 1,
            periodic_x: true,
            periodic_y: true,
            inflow: false,
            outflow: false,
            body_force: 0.0,
            cpu: CpuMethod::Auto,
            gpu_layout: None,
        }
    }
}

impl Config {
    /// Checks the settings on their own: inflow/outflow columns need a non-periodic x axis,
    /// and the body force is a probability.
    pub fn validate(&self) -> Result<()> {
        if (self.inflow || self.outflow) && self.periodic_x {
            return Err(Error::invalid(
                "periodic_x",
                true,
                "inflow/outflow columns need a non-periodic x axis",
            ));
        }
        if !self.body_force.is_finite() || !(0.0..=1.0).contains(&self.body_force) {
            return Err(Error::invalid(
                "body_force",
                self.body_force,
                "must be a probability in [0, 1] (0 disables the force)",
            ));
        }
        Ok(())
    }

    /// [`Config::validate`], and checks the settings against a lattice (a periodic y axis
    /// needs an even height); every backend calls it.
    pub fn validate_for(&self, lattice: &Lattice) -> Result<()> {
        if self.periodic_y && !lattice.height().is_multiple_of(2) {
            return Err(Error::invalid(
                "height",
                lattice.height(),
                "a periodic y axis needs an even number of rows (odd rows are shifted)",
            ));
        }
        self.validate()
    }

    /// Bit flags of the GPU kernels (periodic x, periodic y, inflow, outflow, force).
    #[cfg(feature = "gpu")]
    pub(crate) fn flags(&self) -> u32 {
        u32::from(self.periodic_x)
            | u32::from(self.periodic_y) << 1
            | u32::from(self.inflow) << 2
            | u32::from(self.outflow) << 3
            | u32::from(self.body_force > 0.0) << 4
    }
}
