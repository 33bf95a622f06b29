//! `DistributedLatticeGas` under `mpirun -np P` (P = 2, 3, 4) against the single-process
//! run, bit for bit: lattices that split unevenly along x, y and both, every boundary
//! setting, obstacles, body force, and checkpoints moved between rank counts (the cases of
//! `tests/common`), and with a GPU per rank on 2 ranks. Built only with the `mpi` feature.
//!
//! The test launches its own test binary under `mpirun` with `SIMKIT_MPI_CHILD` set; in the
//! child the same test function runs the cases over `Comm::mpi()`. Without `mpirun` on the
//! `PATH` the test is skipped with a message, unless `SIMKIT_REQUIRE_MPI=1` (then it fails).
#![cfg(feature = "mpi")]

mod common;

use simkit_backend::comm::Comm;
use simkit_backend::testing::{check_on_ranks, check_one_rank_faults};
#[cfg(feature = "gpu")]
use simkit_backend::testing::{is_mpi_child, shared_gpu};
use simkit_lattice_gas::{Config, DistributedLatticeGas, Lattice};

/// The cases of `tests/common`, then faults on one rank.
fn cases(comm: &Comm) -> Result<usize, String> {
    let n = common::check_all(comm)?;
    let mut lattice = Lattice::new(64, 32).map_err(|e| e.to_string())?;
    lattice.fill_random(0.3, 1).map_err(|e| e.to_string())?;
    let run = DistributedLatticeGas::new(lattice, &Config::default(), comm.clone())
        .map_err(|e| e.to_string())?;
    Ok(n + check_one_rank_faults(comm, run)?)
}

#[test]
fn ranks_2_3_4_match_one_process_bit_for_bit() {
    check_on_ranks(
        "ranks_2_3_4_match_one_process_bit_for_bit",
        &[2, 3, 4],
        12,
        cases,
    );
}

/// Two ranks, each stepping its block on its own GPU (lavapipe in CI), the halo through the
/// host: bit for bit the single-process CPU run. Without an adapter: a printed skip, or a
/// failure under `SIMKIT_REQUIRE_GPU=1`.
#[cfg(feature = "gpu")]
#[test]
fn gpu_per_rank_on_2_ranks_matches_one_process() {
    const NAME: &str = "gpu_per_rank_on_2_ranks_matches_one_process";
    if !is_mpi_child() && shared_gpu(NAME).is_none() {
        return;
    }
    check_on_ranks(NAME, &[2], 3, common::check_gpu);
}
