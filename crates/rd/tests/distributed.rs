//! `DistributedRd` over the serial communicator: bit-identical to `Rd` on the CPU for every
//! model, boundary kind and integrator, with the same blow-up error (the MPI runs of the
//! same cases are in `tests/mpi.rs`).

#[path = "common/mod.rs"]
mod common;

use simkit_backend::comm::Comm;
use simkit_rd::{Boundaries, Config, Diffusion, DistributedRd, Grid, Simulation, Stepping};

#[test]
fn one_rank_matches_the_cpu_backend_bit_for_bit() {
    let n = common::check_all(&Comm::serial()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(n, 27, "cases compared");
}

#[test]
fn bad_input_is_refused_with_the_single_process_errors() {
    let g = Grid::new(4, 3, 1.0, Boundaries::no_flux(), vec![vec![0.0f64; 12]]).unwrap();
    let d = Diffusion::new(&[1.0]).unwrap();
    let unstable = Config::new(Stepping::euler(0.3));
    let e = DistributedRd::new(g.clone(), d.clone(), &unstable, Comm::serial()).unwrap_err();
    assert!(e.to_string().contains("dt"), "{e}");
    let two = Diffusion::new(&[1.0, 1.0]).unwrap();
    let ok = Config::new(Stepping::euler(0.2));
    assert!(DistributedRd::new(g.clone(), two, &ok, Comm::serial()).is_err());
    let mut run = DistributedRd::new(g.clone(), d, &ok, Comm::serial()).unwrap();
    assert_eq!(run.decomposition().dims(), [1, 1]);
    assert_eq!(run.block().len, [4, 3]);
    run.step(0).unwrap();
    assert_eq!(run.steps_done(), 0);
    assert_eq!(run.state().unwrap(), g);
    assert_eq!(run.backend_name(), "cpu (1 ranks, serial)");
}
