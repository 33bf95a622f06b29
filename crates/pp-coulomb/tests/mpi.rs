//! `DistributedCoulomb` under `mpirun -np P` (P = 2, 3, 4) against the single-process CPU
//! run, bit for bit (the cases of `tests/replicated`: 203 particles, which no P divides,
//! three laws, both integrators, f64, f32 and mixed, a single-process checkpoint resumed on P
//! ranks, a blow-up stopping every rank), ranks that pass different particles refused on
//! every rank, and a bad input on one rank an error on all. Built only with the `mpi`
//! feature.
//!
//! The test launches its own test binary under `mpirun` (`check_on_ranks`); without
//! `mpirun` on the `PATH` it is skipped with a message, unless `SIMKIT_REQUIRE_MPI=1` (then
//! it fails).
#![cfg(feature = "mpi")]

mod replicated;

use simkit_backend::comm::Comm;
use simkit_backend::testing::check_on_ranks;
use simkit_pp_coulomb::{Config, DistributedCoulomb, ForceLaw};

/// The replicated cases, then inputs that differ between ranks.
fn cases(comm: &Comm) -> Result<usize, String> {
    let mut n = replicated::check_all(comm)?;
    let c = Config::new(0.01, ForceLaw::Plummer { epsilon: 0.5 });
    let run = DistributedCoulomb::new(replicated::plasma(1), &c, comm.clone())
        .map_err(|e| e.to_string())?;
    n += simkit_backend::testing::check_one_rank_faults(comm, run)?;
    // Rank 0 and the others fill the box with different seeds.
    let seed = if comm.is_root() { 1 } else { 2 };
    match DistributedCoulomb::new(replicated::plasma(seed), &c, comm.clone()) {
        Err(e) if e.to_string().contains("differs from rank 0") => {}
        other => {
            return Err(format!(
                "different particles on the ranks: expected an error, got {:?}",
                other.map(|_| ())
            ));
        }
    }
    // The last rank alone passes a bad time step: every rank returns an error (none waits
    // for the others), the last its own, the others one naming it.
    let last = comm.size() - 1;
    let dt = if comm.rank() == last { -1.0 } else { 0.01 };
    let c = Config::new(dt, ForceLaw::Plummer { epsilon: 0.5 });
    match DistributedCoulomb::new(replicated::plasma(1), &c, comm.clone()) {
        Err(e) if comm.rank() == last && e.to_string().contains("dt") => Ok(n + 2),
        Err(e) if e.to_string().contains(&format!("inputs of rank {last}")) => Ok(n + 2),
        other => Err(format!(
            "a bad dt on rank {last}: expected an error on rank {}, got {:?}",
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
        17,
        cases,
    );
}
