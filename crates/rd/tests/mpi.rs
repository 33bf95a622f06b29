//! `DistributedRd` under `mpirun -np P` (P = 2, 3, 4) against the single-process CPU run,
//! bit for bit, on a 37 x 23 grid (uneven splits) with every model, boundary kind and
//! integrator (the cases of `tests/common`). Built only with the `mpi` feature.
//!
//! The test launches its own test binary under `mpirun` with `SIMKIT_MPI_CHILD` set; in the
//! child the same test function runs the cases over `Comm::mpi()`. Without `mpirun` on the
//! `PATH` the test is skipped with a message, unless `SIMKIT_REQUIRE_MPI=1` (then it fails).
#![cfg(feature = "mpi")]

mod common;

use simkit_backend::testing::check_on_ranks;

#[test]
fn ranks_2_3_4_match_one_process_bit_for_bit() {
    check_on_ranks(
        "ranks_2_3_4_match_one_process_bit_for_bit",
        &[2, 3, 4],
        27,
        common::check_all,
    );
}
