//! The common trait of every distributed simulation: [`Distributed`].

use std::path::Path;

use crate::comm::Comm;
use crate::{Error, Result, Simulation, checkpoint};

/// A simulation spread over the ranks of a [`Comm`]: every simkit crate's distributed twin
/// (`DistributedRd`, `DistributedLatticeGas`, `DistributedCoulomb`, `DistributedDem`,
/// `DistributedMd`) implements it, so code written for one runs any of them.
///
/// The conventions are those of the single-process run, made collective: every method that
/// takes `&mut self`, and [`Distributed::resume`], is called by all ranks in the same order;
/// an error on one rank is an error on every rank (no rank is left waiting in a
/// collective); [`Simulation::state`] and [`Distributed::checkpoint`] return the whole run
/// on every rank (gathered on rank 0 and broadcast, so each rank holds one copy while the
/// call lasts); a checkpoint is in the format of the single-process run (`Restart`), so a
/// run moves between one process and any rank count.
///
/// ```
/// use simkit_backend::comm::Comm;
/// use simkit_backend::{Distributed, Result};
///
/// /// Runs `steps` steps on any distributed simulation and checkpoints it from rank 0.
/// fn run_and_save<S: Distributed>(sim: &mut S, steps: u32, path: &std::path::Path) -> Result<()> {
///     sim.step(steps)?;
///     sim.write_checkpoint(path)
/// }
/// # let _ = run_and_save::<Never>;
/// # struct Never;
/// # impl simkit_backend::Simulation for Never {
/// #     type State = ();
/// #     fn step(&mut self, _: u32) -> Result<()> { Ok(()) }
/// #     fn state(&mut self) -> Result<()> { Ok(()) }
/// #     fn steps_done(&self) -> u64 { 0 }
/// #     fn backend_name(&self) -> String { String::new() }
/// # }
/// # impl Distributed for Never {
/// #     fn comm(&self) -> &Comm { unreachable!() }
/// #     fn checkpoint(&mut self) -> Result<Vec<u8>> { Ok(Vec::new()) }
/// #     fn resume(_: &[u8], _: Comm) -> Result<Self> { Ok(Never) }
/// # }
/// ```
pub trait Distributed: Simulation + Sized {
    /// The communicator of the run.
    fn comm(&self) -> &Comm;

    /// The complete state in the single-process checkpoint format, the same bytes on every
    /// rank and on any rank count. Collective.
    ///
    /// Errors: a failed exchange or encoding (on every rank).
    fn checkpoint(&mut self) -> Result<Vec<u8>>;

    /// Rebuilds a run from checkpoint bytes (of this type on any rank count, or of the
    /// crate's single-process run where its docs say so), continuing bit for bit.
    /// Collective: every rank passes the same bytes (checked), e.g. from
    /// [`Distributed::resume_file`].
    ///
    /// Errors: another crate's or model's checkpoint, corrupt bytes, ranks whose bytes
    /// differ, and the constructor's errors; on every rank.
    fn resume(bytes: &[u8], comm: Comm) -> Result<Self>;

    /// Writes [`Distributed::checkpoint`] to `path` from rank 0, atomically (parent
    /// directories are created). Collective: every rank returns once the file is complete;
    /// if rank 0 fails, it returns its error and the other ranks an [`Error::Io`] naming
    /// the path.
    fn write_checkpoint(&mut self, path: impl AsRef<Path>) -> Result<()> {
        let bytes = self.checkpoint()?;
        let comm = self.comm();
        comm.write_from_root(path.as_ref(), comm.is_root().then_some(&bytes[..]))
    }

    /// Reads a checkpoint file on rank 0, sends it to every rank and resumes from it
    /// ([`Distributed::resume`]). Collective; only rank 0 needs to see the file.
    ///
    /// Errors: an unreadable file (on every rank, naming it), those of `resume` (checkpoint
    /// errors name the file).
    fn resume_file(path: impl AsRef<Path>, comm: Comm) -> Result<Self> {
        let path = path.as_ref();
        let read = comm
            .is_root()
            .then(|| checkpoint::read_file(path))
            .transpose();
        let bytes = comm.agree(read)?;
        let bytes = comm.broadcast_from_root(bytes)?;
        Self::resume(&bytes, comm).map_err(|e| match e {
            Error::Checkpoint { reason, .. } => Error::Checkpoint {
                source_name: path.display().to_string(),
                reason,
            },
            other => other,
        })
    }
}
