//! The check every distributed run passes against itself in one process: the same bits on
//! any communicator, and checkpoints that move between rank counts.

use crate::comm::Comm;
use crate::{Distributed, Result};

/// A distributed run on `comm` against the same run in one process (`Comm::serial`, on
/// every rank), bit for bit: the states after `steps / 2` steps (compared by `same_state`,
/// which returns `Err` describing the first difference), the checkpoint bytes, and after
/// `steps` steps the states of both runs and of each checkpoint resumed on the other side
/// (the one-process checkpoint on `comm`, `comm`'s on one process). `make` builds the run on
/// a communicator. Returns the one-process run and the run on `comm`, at the end, for the
/// model's own checks (diagnostics, forces, ownership).
///
/// Errors: the first check that failed, naming `name`, or a failed call.
pub fn check_decomposed<S: Distributed>(
    comm: &Comm,
    name: &str,
    steps: u32,
    make: impl Fn(Comm) -> Result<S>,
    same_state: impl Fn(&S::State, &S::State, &str) -> std::result::Result<(), String>,
) -> std::result::Result<(S, S), String> {
    let err = |e: crate::Error| format!("{name}: {e}");
    let serial = Comm::serial();
    let mut one = make(serial.clone()).map_err(err)?;
    let mut many = make(comm.clone()).map_err(err)?;
    let half = steps / 2;
    one.step(half).map_err(err)?;
    many.step(half).map_err(err)?;
    same_state(
        &one.state().map_err(err)?,
        &many.state().map_err(err)?,
        &format!("{name}: state after {half} steps"),
    )?;
    let (c1, cm) = (
        one.checkpoint().map_err(err)?,
        many.checkpoint().map_err(err)?,
    );
    if c1 != cm {
        return Err(format!(
            "{name}: checkpoint differs from the one-process run"
        ));
    }
    let mut many_resumed = S::resume(&c1, comm.clone()).map_err(err)?;
    let mut one_resumed = S::resume(&cm, serial).map_err(err)?;
    for sim in [&mut one, &mut many, &mut many_resumed, &mut one_resumed] {
        sim.step(steps - half).map_err(err)?;
    }
    let want = one.state().map_err(err)?;
    for (sim, what) in [
        (&mut many, format!("state after {steps} steps")),
        (
            &mut many_resumed,
            format!("state after a resume on {} ranks", comm.size()),
        ),
        (
            &mut one_resumed,
            "state after a resume on one process".into(),
        ),
    ] {
        same_state(
            &want,
            &sim.state().map_err(err)?,
            &format!("{name}: {what}"),
        )?;
    }
    Ok((one, many))
}
