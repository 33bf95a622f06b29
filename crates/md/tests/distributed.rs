//! `DistributedMd` in one process: the cases of `tests/decomposed` (restarts, a blow-up),
//! agreement with `Md` on the CPU to rounding after 100 steps, the same statistics over a
//! long run, checkpoints moving between `Md` and `DistributedMd`, and what it refuses. The
//! same cases run on 2-4 MPI ranks in `tests/mpi.rs`.

#[path = "decomposed/mod.rs"]
mod decomposed;

use simkit_backend::Distributed;
use simkit_backend::comm::Comm;
use simkit_backend::{Backend, Error, Precision, Restart, Simulation};
use simkit_md::{Config, DistributedMd, Integrator, LennardJones, Md, PairTable, State, scenes};

use decomposed::{cases, state_bits};

#[test]
fn one_process_passes_the_decomposed_cases() {
    let n = decomposed::check_all(&Comm::serial()).expect("cases");
    assert_eq!(n, 29);
}

/// Largest difference of `a` from `b` over all particles and axes, relative to the
/// largest magnitude in `b` (`testing::max_rel_diff` on the flattened vectors).
fn max_rel(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    simkit_backend::testing::max_rel_diff(a.as_flattened(), b.as_flattened(), b.as_flattened())
}

/// Relative difference of two numbers.
fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn agrees_with_md_to_rounding_after_100_steps() {
    // From Md's state after the case's steps, both go on 100 steps. Each sums a particle's
    // pairs in another order than Md (by system index instead of the half list's cell
    // order), so the two differ by rounding only.
    for (name, system, config, steps) in cases() {
        let mut md = Md::new(system, &config, Backend::Cpu).expect("md");
        md.step(steps).expect("step");
        let bytes = md.checkpoint().expect("checkpoint");
        let mut dist =
            DistributedMd::<LennardJones>::resume(&bytes, Comm::serial()).expect("resume");
        let (d0, e0) = (
            md.diagnostics().expect("diagnostics"),
            dist.diagnostics().expect("diagnostics"),
        );
        md.step(100).expect("step");
        dist.step(100).expect("step");
        let (a, b) = (dist.state().expect("state"), md.state().expect("state"));
        let (dx, dv) = (
            max_rel(&a.positions, &b.positions),
            max_rel(&a.velocities, &b.velocities),
        );
        let (d1, e1) = (
            md.diagnostics().expect("diagnostics"),
            dist.diagnostics().expect("diagnostics"),
        );
        let de = [
            rel(e0.potential, d0.potential),
            rel(e1.potential, d1.potential),
            rel(e1.kinetic, d1.kinetic),
            rel(e1.virial, d1.virial),
        ];
        let df = max_rel(
            &dist.forces().expect("forces"),
            &md.forces().expect("forces"),
        );
        println!(
            "{name}: 100 steps after Md's step {steps}: positions differ by {dx:.2e}, \
             velocities by {dv:.2e}, forces by {df:.2e} (relative to the largest); potential \
             energy before {:.2e}, after {:.2e}, kinetic {:.2e}, virial {:.2e}",
            de[0], de[1], de[2], de[3]
        );
        assert!(
            d1.potential < 0.0 || name.contains("gas"),
            "{name}: no interactions?"
        );
        assert!(
            dx <= 1e-12 && dv <= 1e-12 && df <= 1e-12,
            "{name}: {dx:e} {dv:e} {df:e}"
        );
        assert!(de.iter().all(|&x| x <= 1e-12), "{name}: {de:?}");
        assert_eq!(a.time, b.time, "{name}");
        assert_eq!(a.species, b.species, "{name}");
    }
}

/// Mean potential energy per particle over the second half of an NVE run of the
/// Lennard-Jones liquid, sampled every `every` steps.
fn mean_potential(mut step: impl FnMut(u32) -> f64, steps: u32, every: u32) -> f64 {
    let samples: Vec<f64> = (0..steps / every).map(|_| step(every)).collect();
    let tail = &samples[samples.len() / 2..];
    tail.iter().sum::<f64>() / tail.len() as f64
}

#[test]
fn long_run_statistics_agree_with_md() {
    // Two codes that round differently part like trajectories of a chaotic system; what
    // must agree is the statistics. The yardstick is how far Md itself moves when one
    // position moves by 1e-12: the scatter of rounding-level perturbations.
    let (steps, every) = (3000, 50);
    let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5)).expect("table");
    let system = scenes::fcc_lattice([4; 3], 0.8442, 1.44, table, &[0], 3).expect("system");
    let config = Config::default().with_dt(0.005);
    let n = system.particle_count() as f64;
    let md_run = |system: &simkit_md::System| {
        let mut sim = Md::new(system.clone(), &config, Backend::Cpu).expect("md");
        mean_potential(
            |k| {
                sim.step(k).expect("step");
                sim.diagnostics().expect("diagnostics").potential / n
            },
            steps,
            every,
        )
    };
    let reference = md_run(&system);
    let mut dist =
        DistributedMd::new(system.clone(), &config, Comm::serial()).expect("distributed");
    let distributed = mean_potential(
        |k| {
            dist.step(k).expect("step");
            dist.diagnostics().expect("diagnostics").potential / n
        },
        steps,
        every,
    );
    let mut perturbed = Vec::new();
    for k in 0..4 {
        let mut s = system.clone();
        let mut x = s.positions().to_vec();
        // 1e-12 along x: a rounding-level change.
        x[37 * k + 5][0] += 1e-12;
        let (species, v) = (s.species().to_vec(), s.velocities().to_vec());
        s.set_particles(&species, &x, &v).expect("particles");
        perturbed.push(md_run(&s) - reference);
    }
    let sigma = (perturbed.iter().map(|d| d * d).sum::<f64>() / perturbed.len() as f64).sqrt();
    let diff = distributed - reference;
    println!(
        "mean potential energy per atom over the second half: Md {reference:.8}, \
         DistributedMd {distributed:.8} (difference {diff:.3e}); Md with one position moved \
         by 1e-12: {perturbed:?} (rms {sigma:.3e})"
    );
    // The liquid melted (the statistic is not the lattice's) and the runs did part.
    assert!(reference > -6.5 && reference < -4.0, "{reference}");
    assert!(sigma > 0.0 && diff != 0.0);
    assert!(diff.abs() <= 4.0 * sigma, "{diff:e} against 4 x {sigma:e}");
}

/// The state after a checkpoint moved between the codes: the positions and stored
/// velocities are the checkpoint's bits; leapfrog reports `v(t + dt/2) - a(t) dt/2` with
/// the acceleration each code recomputes (in its own summation order), so there the
/// velocities agree to rounding.
fn same_state(a: &State, b: &State, config: &Config, name: &str) {
    let bits = |v: &[[f64; 3]]| -> Vec<u64> { v.iter().flatten().map(|x| x.to_bits()).collect() };
    assert_eq!(bits(&a.positions), bits(&b.positions), "{name}");
    assert_eq!(a.time, b.time, "{name}");
    if config.integrator == Integrator::Leapfrog {
        let d = max_rel(&a.velocities, &b.velocities);
        assert!(d > 0.0 && d < 1e-14, "{name}: {d:e}");
    } else {
        assert_eq!(state_bits(a), state_bits(b), "{name}");
    }
}

#[test]
fn checkpoints_move_between_md_and_distributed_md() {
    for (name, system, config, _) in cases() {
        // DistributedMd -> Md: the same state, and Md goes on.
        let mut dist = DistributedMd::new(system.clone(), &config, Comm::serial()).expect("new");
        dist.step(60).expect("step");
        let bytes = dist.checkpoint().expect("checkpoint");
        let mut md = Md::<LennardJones>::resume(&bytes, Backend::Cpu).expect("Md resumes it");
        assert_eq!(md.steps_done(), 60, "{name}");
        same_state(
            &md.state().expect("state"),
            &dist.state().expect("state"),
            &config,
            name,
        );
        md.step(10).expect("Md goes on");
        // Md -> DistributedMd: the same state, and both go on to rounding of each other.
        let mut md = Md::new(system, &config, Backend::Cpu).expect("md");
        md.step(60).expect("step");
        let bytes = md.checkpoint().expect("checkpoint");
        let mut dist =
            DistributedMd::<LennardJones>::resume(&bytes, Comm::serial()).expect("resumes Md's");
        same_state(
            &dist.state().expect("state"),
            &md.state().expect("state"),
            &config,
            name,
        );
        md.step(20).expect("step");
        dist.step(20).expect("step");
        let (a, b): (State, State) = (dist.state().expect("state"), md.state().expect("state"));
        let d = max_rel(&a.positions, &b.positions);
        assert!(d < 1e-12, "{name}: {d:e}");
    }
    // The file path: written atomically, read back the same.
    let (system, config) = decomposed::lj_liquid();
    let mut dist = DistributedMd::new(system, &config, Comm::serial()).expect("new");
    dist.step(30).expect("step");
    let dir = tempfile::tempdir().expect("dir");
    let path = dir.path().join("run.ckpt");
    dist.write_checkpoint(&path).expect("write");
    let again =
        DistributedMd::<LennardJones>::resume(&std::fs::read(&path).expect("read"), Comm::serial())
            .expect("resume");
    assert_eq!(again.steps_done(), 30);
}

#[test]
fn the_check_interval_and_step_splitting_do_not_change_results() {
    let (system, config) = decomposed::walled_2d();
    let run = |check_every: u32, calls: &[u32]| {
        let c = Config {
            check_every,
            ..config
        };
        let mut sim = DistributedMd::new(system.clone(), &c, Comm::serial()).expect("new");
        for &k in calls {
            sim.step(k).expect("step");
        }
        state_bits(&sim.state().expect("state"))
    };
    let a = run(100, &[250]);
    assert_eq!(a, run(0, &[250]));
    assert_eq!(a, run(7, &[100, 1, 149]));
}

#[test]
fn refuses_what_it_does_not_offer_and_bad_inputs() {
    let (system, config) = decomposed::lj_liquid();
    let f32 = Config {
        precision: Precision::F32,
        ..config
    };
    match DistributedMd::new(system.clone(), &f32, Comm::serial()) {
        Err(Error::Unsupported(m)) => assert!(m.contains("Md for f32"), "{m}"),
        other => panic!("expected Unsupported, got {other:?}"),
    }
    // Md's own refusals come through unchanged.
    let bad = Config {
        dt: Some(1.0),
        ..config
    };
    let e =
        DistributedMd::new(system.clone(), &bad, Comm::serial()).expect_err("dt over the bound");
    assert!(matches!(e, Error::Unstable { .. }), "{e}");
    let bad = Config {
        skin: f64::NAN,
        ..config
    };
    let e = DistributedMd::new(system.clone(), &bad, Comm::serial()).expect_err("NaN skin");
    assert!(e.to_string().contains("skin"), "{e}");
    // Two atoms on top of each other: the initial check, as Md's.
    let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5)).expect("table");
    let mut s = simkit_md::System::new(
        simkit_md::Dim::Three,
        [0.0; 3],
        [6.0; 3],
        [true; 3],
        vec![1.0],
        table,
    )
    .expect("system");
    s.add_particle(0, [1.0, 1.0, 1.0], [0.0; 3]).expect("add");
    s.add_particle(0, [1.0, 1.0, 1.0], [0.0; 3]).expect("add");
    let e = DistributedMd::new(s, &config, Comm::serial()).expect_err("coincident atoms");
    assert!(e.to_string().contains("initial state"), "{e}");
    // An f32 or GPU Md checkpoint is another model; garbage is no checkpoint.
    let mut md = Md::new(system, &f32, Backend::Cpu).expect("md");
    let bytes = md.checkpoint().expect("checkpoint");
    let e = DistributedMd::<LennardJones>::resume(&bytes, Comm::serial()).expect_err("f32 model");
    assert!(e.to_string().contains("f64"), "{e}");
    assert!(DistributedMd::<LennardJones>::resume(b"not a checkpoint", Comm::serial()).is_err());
}
