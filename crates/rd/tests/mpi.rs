//! `DistributedRd` under `mpirun -np P` (P = 2, 3, 4) against the single-process CPU run,
//! bit for bit, on a 37 x 23 grid (uneven splits) with every model, boundary kind and
//! integrator (the cases of `tests/common`). Built only with the `mpi` feature.
//!
//! The test launches its own test binary under `mpirun` with `SIMKIT_MPI_CHILD` set; in the
//! child the same test function runs the cases over `Comm::mpi()`. Without `mpirun` on the
//! `PATH` the test is skipped with a message, unless `SIMKIT_REQUIRE_MPI=1` (then it fails).
#![cfg(feature = "mpi")]

mod common;

use simkit_backend::testing::{is_mpi_child, mpirun_self};

use simkit_backend::comm::Comm;

#[test]
fn ranks_2_3_4_match_one_process_bit_for_bit() {
    if is_mpi_child() {
        let comm = Comm::mpi().expect("MPI initialises");
        // A failure on one rank must stop all (the others would wait for it forever).
        let run =
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| common::check_all(&comm)));
        let n = match run {
            Ok(Ok(n)) => n,
            Ok(Err(e)) => {
                eprintln!("rank {}: {e}", comm.rank());
                comm.abort(1)
            }
            Err(_) => comm.abort(2),
        };
        if comm.is_root() {
            println!("SIMKIT_MPI_OK {n} cases on {} ranks", comm.size());
        }
        return;
    }
    let Some(outputs) = mpirun_self("ranks_2_3_4_match_one_process_bit_for_bit", &[2, 3, 4]) else {
        return;
    };
    for (p, stdout) in [2, 3, 4].into_iter().zip(outputs) {
        let want = format!("SIMKIT_MPI_OK 26 cases on {p} ranks");
        assert!(
            stdout.contains(&want),
            "mpirun -np {p}: the cases did not run on rank 0 (no `{want}`):\n{stdout}"
        );
    }
}
