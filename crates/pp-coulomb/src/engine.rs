//! What every backend implements ([`Engine`]) and the types the backends share; the CPU and
//! GPU backends import this module, and [`crate::PpCoulomb`] builds them.

use simkit_backend::{Precision, Real, Result};

use crate::guard::{Checks, Energy};
use crate::particles::PositionsVelocities;

/// What a backend implements.
pub(crate) trait Engine: Send {
    /// Advances `steps` steps with the blow-up checks of `checks`; on a failed check the
    /// engine puts itself back to the last state that passed and returns
    /// `Error::BlowUp` (whose `rolled_back_to` the caller adopts).
    fn step(&mut self, steps: u32, checks: &mut Checks<'_>) -> Result<()>;
    /// Kinetic and potential energy of the current state under the exact law (the energy
    /// check's measure; f64 sums).
    fn energy(&mut self) -> Result<Energy>;
    /// The accelerations kept for the next step (leapfrog keeps those at the current
    /// positions between calls), if any.
    fn kept_accelerations(&mut self) -> Result<Option<Vec<[f64; 3]>>>;
    /// Current positions and velocities (f64).
    fn state(&mut self) -> Result<PositionsVelocities>;
    /// Accelerations at the current positions.
    fn accelerations(&mut self) -> Result<Vec<[f64; 3]>>;
    /// Changes the time step for the following steps.
    fn set_dt(&mut self, dt: f64) -> Result<()>;
    /// Backend name.
    fn name(&self) -> String;
}

/// Coordinate of the zero-charge padding sources that fill the CPU's SIMD blocks and the
/// GPU's tiles: far from every particle, and finite when squared (1e12 in f32, 1e50 in f64).
#[inline]
pub(crate) fn pad_coordinate<T: Real>() -> T {
    match T::PRECISION {
        Precision::F32 => T::from_f64(1.0e12),
        Precision::F64 => T::from_f64(1.0e50),
    }
}
