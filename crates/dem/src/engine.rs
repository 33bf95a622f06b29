//! The backend-neutral engine interface behind [`crate::Dem`], and the engine part of a
//! checkpoint.

use serde::{Deserialize, Serialize};
use simkit_backend::Result;

use crate::State;
use crate::prepared::Prepared;

/// One backend instance (CPU at some dimension and precision, or GPU).
pub(crate) trait Engine: Send {
    /// Advances `steps` time steps with the blow-up check (see [`simkit_backend::guard`]);
    /// on a failed check the engine is back at the last state that passed and returns
    /// [`simkit_backend::Error::BlowUp`].
    fn step(&mut self, steps: u32) -> Result<()>;
    /// Time, positions and velocities (scene order, `[x, y, 0]` in 2D).
    fn state(&mut self) -> Result<State>;
    /// The validated scene and run settings the engine was built from.
    fn prepared(&self) -> &Prepared;
    /// Backend description (device, precision, threads).
    fn name(&self) -> String;
    /// Steps done since the start of the run (checkpoints included).
    fn steps_done(&self) -> u64;
    /// The checkpoint model string (backend kind, precision, dimension).
    fn model(&self) -> String;
    /// The complete dynamic state (downloaded on the GPU).
    fn save(&mut self) -> Result<EngineState>;
}

/// The dynamic state of an engine, as a checkpoint stores it: everything beyond the scene
/// and the settings that the next steps read. Vectors are flat, `width` values per slot,
/// and hold the engine's numbers exactly (`f32` widens to `f64` without rounding).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub(crate) struct EngineState {
    /// Steps done.
    pub steps: u64,
    /// Simulated time (the CPU accumulates `t += dt`; the GPU derives it from `steps`).
    pub time: f64,
    /// Whether the first force evaluation has happened (CPU).
    pub started: bool,
    /// Values per slot in the vectors below.
    pub width: u32,
    /// Scene index of every slot (CPU: the cell-sorted order of the last list build).
    pub id: Vec<u32>,
    /// Positions (CPU: not wrapped since the last list build; GPU: `(x, y, z, radius)`).
    pub pos: Vec<f64>,
    /// Velocities (GPU: `(vx, vy, vz, mass)`).
    pub vel: Vec<f64>,
    /// Accelerations of the last force evaluation (GPU: `w` the deepest overlap ratio).
    pub acc: Vec<f64>,
    /// CPU: predicted velocities (velocity Verlet) or last displacements (position
    /// Verlet); empty on the GPU.
    pub aux: Vec<f64>,
    /// CPU: positions at the last list build (the list is rebuilt from them on resume, so
    /// it is the same list); empty on the GPU.
    pub reference: Vec<f64>,
}

impl EngineState {
    /// Checks that the state fits a scene of `n` particles in `width` dimensions: the
    /// width, a permutation of the particles as the slot order, and `n * width` values in
    /// every per-particle vector.
    ///
    /// Errors: [`simkit_backend::Error::Checkpoint`] naming the first mismatch.
    pub fn check(&self, n: usize, width: usize) -> simkit_backend::Result<()> {
        let bad = |what: String| {
            simkit_backend::Error::checkpoint(format!(
                "{what}; the file does not belong to this scene"
            ))
        };
        if self.width as usize != width {
            return Err(bad(format!(
                "{} values per particle, expected {width}",
                self.width
            )));
        }
        if self.id.len() != n {
            return Err(bad(format!(
                "{} particle slots for {n} particles",
                self.id.len()
            )));
        }
        let mut seen = vec![false; n];
        for &i in &self.id {
            match seen.get_mut(i as usize) {
                Some(f) if !*f => *f = true,
                _ => {
                    return Err(bad(format!(
                        "particle order lists {i} twice or out of range"
                    )));
                }
            }
        }
        for (v, name) in [
            (&self.pos, "positions"),
            (&self.vel, "velocities"),
            (&self.acc, "accelerations"),
            (&self.aux, "half-step velocities"),
            (&self.reference, "list-build positions"),
        ] {
            if v.len() != n * width {
                return Err(bad(format!(
                    "{name} holds {} values, expected {}",
                    v.len(),
                    n * width
                )));
            }
        }
        Ok(())
    }
}
