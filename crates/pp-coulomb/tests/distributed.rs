//! `DistributedCoulomb` on one process (`Comm::serial`): bit for bit the single-process CPU
//! run in every case of `tests/replicated` (three laws, both integrators, f64, f32 and mixed,
//! checkpoints both ways, a blow-up), plus its errors and accessors. The splitting of the
//! targets into blocks is checked without MPI by the crate's unit tests (`cpu::tests`: 2, 3
//! and 7 blocks on threads against one engine) and over MPI by `tests/mpi.rs`.

#[path = "replicated/mod.rs"]
mod replicated;

use simkit_backend::Distributed;
use simkit_backend::comm::Comm;
use simkit_backend::{Backend, Error, Restart, Simulation};
use simkit_pp_coulomb::{Config, DistributedCoulomb, ForceLaw, Particles, PpCoulomb};

#[test]
fn one_process_matches_the_cpu_run_bit_for_bit() {
    assert_eq!(replicated::check_all(&Comm::serial()), Ok(12));
}

#[test]
fn accessors_describe_the_run() {
    let c = Config::new(0.01, ForceLaw::Plummer { epsilon: 0.5 });
    let mut d = DistributedCoulomb::new(replicated::plasma(1), &c, Comm::serial()).unwrap();
    assert_eq!(d.own(), 0..replicated::N);
    assert_eq!((d.len(), d.is_empty()), (replicated::N, false));
    assert_eq!(d.config(), &c);
    assert_eq!(d.comm().size(), 1);
    let n = replicated::N as f64;
    assert_eq!(d.interactions_per_step(), n * (n - 1.0));
    let one = PpCoulomb::new(replicated::plasma(1), &c, Backend::Cpu).unwrap();
    assert_eq!(
        d.backend_name(),
        format!("{}, 1 ranks (serial)", one.backend_name())
    );
    d.step(3).unwrap();
    assert_eq!((d.steps_done(), d.time()), (3, 0.03));
}

#[test]
fn bad_inputs_are_the_errors_of_one_process() {
    let c = Config::new(0.01, ForceLaw::Exact);
    let mut p = replicated::plasma(2);
    p.position[7] = p.position[3];
    // Coincident particles under the exact law: the first step stops, naming the pair.
    let mut d = DistributedCoulomb::new(p.clone(), &c, Comm::serial()).unwrap();
    let mut one = PpCoulomb::new(p, &c, Backend::Cpu).unwrap();
    let (d, one) = (d.step(1), one.step(1));
    assert!(matches!(d, Err(Error::BlowUp { .. })), "{d:?}");
    assert_eq!(format!("{d:?}"), format!("{one:?}"));
    let bad = Config::new(-1.0, ForceLaw::Exact);
    let d = DistributedCoulomb::new(replicated::plasma(2), &bad, Comm::serial());
    assert!(matches!(d, Err(Error::InvalidParameter { .. })), "{d:?}");
    let mut d = DistributedCoulomb::new(replicated::plasma(2), &c, Comm::serial()).unwrap();
    assert!(d.set_dt(f64::NAN).is_err());
    let garbage = DistributedCoulomb::resume(b"not a checkpoint", Comm::serial());
    assert!(
        matches!(garbage, Err(Error::Checkpoint { .. })),
        "{garbage:?}"
    );
}

#[test]
fn zero_and_one_particle_step() {
    let c = Config::new(0.1, ForceLaw::Exact);
    let mut empty = DistributedCoulomb::new(Particles::new(), &c, Comm::serial()).unwrap();
    empty.step(5).unwrap();
    assert_eq!(empty.steps_done(), 5);
    assert!(empty.accelerations().unwrap().is_empty());
    let bytes = empty.checkpoint().unwrap();
    assert_eq!(
        DistributedCoulomb::resume(&bytes, Comm::serial())
            .unwrap()
            .steps_done(),
        5
    );
    let mut p = replicated::plasma(3);
    p.position.truncate(1);
    p.velocity.truncate(1);
    p.charge.truncate(1);
    p.mass.truncate(1);
    p.species.truncate(1);
    let mut d = DistributedCoulomb::new(p.clone(), &c, Comm::serial()).unwrap();
    let mut one = PpCoulomb::new(p, &c, Backend::Cpu).unwrap();
    d.step(4).unwrap();
    one.step(4).unwrap();
    assert_eq!(d.state().unwrap(), one.state().unwrap());
    assert_eq!(d.checkpoint().unwrap(), one.checkpoint().unwrap());
}
