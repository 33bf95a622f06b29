//! `DistributedRd` under `mpirun -np P` (P = 2, 3, 4) against the single-process CPU run,
//! bit for bit, on a 37 x 23 grid (uneven splits) with every model, boundary kind and
//! integrator (the cases of `tests/common`). Built only with the `mpi` feature.
//!
//! The test launches its own test binary under `mpirun` with `SIMKIT_MPI_CHILD` set; in the
//! child the same test function runs the cases over `Comm::mpi()`. Without `mpirun` on the
//! `PATH` the test is skipped with a message, unless `SIMKIT_REQUIRE_MPI=1` (then it fails).
#![cfg(feature = "mpi")]

mod common;

use simkit_backend::comm::Comm;
use simkit_backend::testing::{check_on_ranks, check_one_rank_faults};
use simkit_rd::{Config, DistributedRd, GrayScott, Stepping};

/// The cases of `tests/common`, then faults on one rank.
fn cases(comm: &Comm) -> Result<usize, String> {
    let n = common::check_all(comm)?;
    let grid =
        simkit_rd::scenes::gray_scott_square::<f64>(24, 1.0, 4, 1).map_err(|e| e.to_string())?;
    let model = GrayScott::new(1.0, 0.5, 0.04, 0.06).map_err(|e| e.to_string())?;
    let config = Config::new(Stepping::euler(0.2));
    let run = DistributedRd::new(grid, model, &config, comm.clone()).map_err(|e| e.to_string())?;
    Ok(n + check_one_rank_faults(comm, run)?)
}

#[test]
fn ranks_2_3_4_match_one_process_bit_for_bit() {
    check_on_ranks(
        "ranks_2_3_4_match_one_process_bit_for_bit",
        &[2, 3, 4],
        30,
        cases,
    );
}
