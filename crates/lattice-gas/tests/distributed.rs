//! `DistributedLatticeGas` over the serial communicator: bit-identical to `LatticeGas` for
//! every boundary setting, obstacles and body force, checkpoints in both directions (the
//! MPI runs of the same cases are in `tests/mpi.rs`; the P-block stepping in one process is
//! a unit test of the `distributed` module).

#[path = "common/mod.rs"]
mod common;

use simkit_backend::comm::Comm;
use simkit_backend::{Backend, Distributed, Restart, Simulation, checkpoint};
use simkit_lattice_gas::{Config, DistributedLatticeGas, Lattice, LatticeGas};

#[test]
fn one_rank_matches_the_single_process_run_bit_for_bit() {
    let n = common::check_all(&Comm::serial()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(n, 9, "cases compared");
}

#[test]
fn bad_input_is_refused_with_the_single_process_errors() {
    let odd = Lattice::new(8, 5).unwrap();
    let e = DistributedLatticeGas::new(odd, &Config::default(), Comm::serial()).unwrap_err();
    assert!(e.to_string().contains("even number of rows"), "{e}");
    let l = Lattice::new(8, 6).unwrap();
    let open = Config {
        inflow: true,
        ..Config::default()
    };
    let e = DistributedLatticeGas::new(l.clone(), &open, Comm::serial()).unwrap_err();
    assert!(e.to_string().contains("periodic_x"), "{e}");
    let e = DistributedLatticeGas::resume(b"not a checkpoint", Comm::serial()).unwrap_err();
    assert!(e.to_string().contains("checkpoint"), "{e}");
    let mut run =
        DistributedLatticeGas::new(l.clone(), &Config::default(), Comm::serial()).unwrap();
    assert_eq!(run.decomposition().dims(), [1, 1]);
    assert_eq!(run.block().len, [8, 6]);
    run.step(0).unwrap();
    assert_eq!(run.steps_done(), 0);
    assert_eq!(run.state().unwrap(), l);
    assert_eq!(run.backend_name(), "cpu lookup table (1 ranks)");
    assert_eq!(run.config(), &Config::default());
}

#[test]
fn a_checkpoint_file_resumes_on_one_process_and_on_the_distributed_run() {
    let mut lattice = Lattice::new(40, 16).unwrap();
    lattice.fill_random(0.3, 3).unwrap();
    let config = Config {
        body_force: 0.05,
        ..Config::default()
    };
    let mut whole = LatticeGas::new(lattice.clone(), &config, Backend::Cpu).unwrap();
    whole.step(20).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sub").join("run.ckpt");
    let mut dist = DistributedLatticeGas::new(lattice, &config, Comm::serial()).unwrap();
    dist.step(12).unwrap();
    dist.write_checkpoint(&path).unwrap();
    let mut one = LatticeGas::resume_file(&path, Backend::Cpu).unwrap();
    one.step(8).unwrap();
    assert_eq!(one.state().unwrap(), whole.state().unwrap());
    let bytes = checkpoint::read_file(&path).unwrap();
    let mut again = DistributedLatticeGas::resume(&bytes, Comm::serial()).unwrap();
    assert_eq!(again.steps_done(), 12);
    again.step(8).unwrap();
    assert_eq!(again.state().unwrap(), whole.state().unwrap());
    let mut from_file = DistributedLatticeGas::resume_file(&path, Comm::serial()).unwrap();
    from_file.step(8).unwrap();
    assert_eq!(from_file.checkpoint().unwrap(), again.checkpoint().unwrap());
    let e =
        DistributedLatticeGas::resume_file(dir.path().join("none"), Comm::serial()).unwrap_err();
    assert!(e.to_string().contains("none"), "{e}");
    // A directory is not a file: rank 0's error comes back.
    let e = dist.write_checkpoint(dir.path()).unwrap_err();
    assert!(
        e.to_string().contains(&dir.path().display().to_string()),
        "{e}"
    );
}

/// One process stepping its (only) block on the GPU with the halo through the host: the
/// bits of the single-process CPU run.
#[cfg(feature = "gpu")]
#[test]
fn gpu_stepper_on_one_rank_matches_one_process() {
    if simkit_backend::testing::shared_gpu("gpu_stepper_on_one_rank_matches_one_process").is_none()
    {
        return;
    }
    assert_eq!(common::check_gpu(&Comm::serial()), Ok(3));
}
