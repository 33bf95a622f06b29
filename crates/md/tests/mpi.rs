//! `DistributedMd` under `mpirun -np P` (P = 2, 3, 4) against the one-process run, bit for
//! bit (the cases of `tests/decomposed`: a 3D Lennard-Jones liquid, 2D walls with a frozen
//! column and leapfrog, a 3D three-species mixture under the Langevin thermostat, a hot
//! periodic 2D gas; checkpoints moved between rank counts; a blow-up stopping every rank
//! with the same error), and a bad input on one rank an error on all. Built only with the
//! `mpi` feature.
//!
//! The test launches its own test binary under `mpirun` (`check_on_ranks`); without
//! `mpirun` on the `PATH` it is skipped with a message, unless `SIMKIT_REQUIRE_MPI=1` (then
//! it fails).
#![cfg(feature = "mpi")]

mod decomposed;

use simkit_backend::comm::Comm;
use simkit_backend::testing::check_on_ranks;
use simkit_md::{Config, DistributedMd};

/// The decomposed cases, then a bad input on the last rank only.
fn cases(comm: &Comm) -> Result<usize, String> {
    let mut n = decomposed::check_all(comm)?;
    let (_, system, config, _) = decomposed::cases().remove(0);
    let run =
        DistributedMd::new(system.clone(), &config, comm.clone()).map_err(|e| e.to_string())?;
    n += simkit_backend::testing::check_one_rank_faults(comm, run)?;
    let last = comm.size() - 1;
    let config = Config {
        skin: if comm.rank() == last { -1.0 } else { 0.3 },
        ..Config::default()
    };
    match DistributedMd::new(system, &config, comm.clone()) {
        Err(e) if comm.rank() == last && e.to_string().contains("skin") => Ok(n + 1),
        Err(e) if e.to_string().contains(&format!("inputs of rank {last}")) => Ok(n + 1),
        other => Err(format!(
            "a bad skin on rank {last}: expected an error on rank {}, got {:?}",
            comm.rank(),
            other.map(|_| ())
        )),
    }
}

#[test]
fn ranks_2_3_4_match_one_process_bit_for_bit() {
    check_on_ranks(
        "ranks_2_3_4_match_one_process_bit_for_bit",
        &[2, 3, 4],
        33,
        cases,
    );
}
