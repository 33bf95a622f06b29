//! `DistributedDem` in one process: the cases of `tests/decomposed` (restarts across the
//! two codes, a blow-up), agreement with `Dem` on the CPU to rounding after 100 steps,
//! the same statistics over a long run, checkpoints moving between `Dem` and
//! `DistributedDem`, and what it refuses. The same cases run on 2-4 MPI ranks in
//! `tests/mpi.rs`.

#[path = "decomposed/mod.rs"]
mod decomposed;

use simkit_backend::Distributed;
use simkit_backend::comm::Comm;
use simkit_backend::{Backend, Error, Restart, Simulation};
use simkit_dem::{
    Config, ContactLaw, Dem, Dim, DistributedDem, Integrator, Precision, Scene, State,
};

use decomposed::{cases, gas, history_cases, state_bits};

#[test]
fn one_process_passes_the_decomposed_cases() {
    let n = decomposed::check_all(&Comm::serial()).expect("cases");
    assert_eq!(n, 37);
}

/// Largest difference of `a` from `b` over all particles and axes, relative to the
/// largest magnitude in `b` (`testing::max_rel_diff` on the flattened vectors).
fn max_rel(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    simkit_backend::testing::max_rel_diff(a.as_flattened(), b.as_flattened(), b.as_flattened())
}

fn run_distributed(scene: &simkit_dem::Scene, config: &Config, steps: u32) -> State {
    let mut sim = DistributedDem::new(scene.clone(), config, Comm::serial()).expect("distributed");
    sim.step(steps).expect("step");
    sim.state().expect("state")
}

#[test]
fn agrees_with_dem_to_rounding_after_100_steps() {
    for (name, scene, config, steps) in cases() {
        agrees_with_dem(name, scene, config, steps);
    }
    let (rough, boxed) = history_cases();
    agrees_with_dem(rough.0, rough.1, rough.2, rough.3);
    agrees_with_dem(boxed.0, boxed.1, boxed.2, boxed.3);
}

/// From a state with contacts (Dem's, after the case's steps), both go on 100 steps. Each
/// sums a particle's contacts in another order than Dem (by scene index instead of the
/// half list's cell order), so the two differ by rounding only; with contact history,
/// DistributedDem starts from the mirror images of Dem's one copy per pair.
fn agrees_with_dem<L: ContactLaw>(name: &str, scene: Scene<L>, config: Config, steps: u32) {
    let mut dem = Dem::new(scene, &config, Backend::Cpu).expect("dem");
    dem.step(steps).expect("step");
    let contacts = dem.diagnostics().expect("diagnostics").contacts;
    let bytes = dem.checkpoint().expect("checkpoint");
    let mut dist = DistributedDem::<L>::resume(&bytes, Comm::serial()).expect("resume");
    assert_eq!(
        state_bits(&dist.state().expect("state")),
        state_bits(&dem.state().expect("state")),
        "{name}: resumed"
    );
    dem.step(100).expect("step");
    dist.step(100).expect("step");
    let (a, b) = (dist.state().expect("state"), dem.state().expect("state"));
    let (dx, dv, dw) = (
        max_rel(&a.positions, &b.positions),
        max_rel(&a.velocities, &b.velocities),
        max_rel(&a.angular_velocities, &b.angular_velocities),
    );
    println!(
        "{name}: {contacts} contacts; 100 steps later positions differ by {dx:.2e}, \
         velocities by {dv:.2e}, angular velocities by {dw:.2e} (relative to the largest)"
    );
    assert!(contacts > 0, "{name}: no contacts to compare");
    assert!(dx <= 1e-12 && dv <= 1e-12, "{name}: {dx:e} {dv:e}");
    assert!(dw <= 1e-12, "{name}: {dw:e}");
    assert_eq!(a.time, b.time, "{name}");
}

/// Mean kinetic energy per particle over the second half of a cooling 2D gas (900 grains,
/// e = 0.8, friction), sampled every 100 steps.
fn cooling(run: impl FnOnce(u32, &mut dyn FnMut(f64))) -> f64 {
    let mut samples = Vec::new();
    run(100, &mut |k| samples.push(k));
    let tail = &samples[samples.len() / 2..];
    tail.iter().sum::<f64>() / tail.len() as f64
}

#[test]
fn long_run_statistics_agree_with_dem() {
    // Two codes that round differently part like trajectories of a chaotic system; what
    // must agree is the statistics. The yardstick is how far Dem itself moves when one
    // position moves by 1e-12: the scatter of rounding-level perturbations.
    let steps = 6000;
    let scene = gas(Dim::Two, 30, 1.3, 2.0);
    let config = Config::default();
    let dem_run = |scene: &simkit_dem::Scene| {
        cooling(|every, push| {
            let mut sim = Dem::new(scene.clone(), &config, Backend::Cpu).expect("dem");
            sim.step_observed(u64::from(steps), every, |s| {
                push(s.diagnostics()?.kinetic);
                Ok(std::ops::ControlFlow::Continue(()))
            })
            .expect("run");
        })
    };
    let reference = dem_run(&scene);
    let distributed = cooling(|every, push| {
        let mut sim =
            DistributedDem::new(scene.clone(), &config, Comm::serial()).expect("distributed");
        for _ in 0..steps / every {
            sim.step(every).expect("step");
            push(sim.diagnostics().expect("diagnostics").kinetic);
        }
    });
    let mut perturbed = Vec::new();
    for k in 0..4 {
        let mut s = scene.clone();
        let v: Vec<[f64; 3]> = s.particles().iter().map(|p| p.velocity).collect();
        let mut x: Vec<[f64; 3]> = s.particles().iter().map(|p| p.position).collect();
        // 1e-12 along x: a rounding-level change (a last-bit change of a velocity is
        // lost in the position update).
        x[17 * k + 3][0] += 1e-12;
        s.set_kinematics(&x, &v).expect("kinematics");
        perturbed.push(dem_run(&s) - reference);
    }
    let sigma = (perturbed.iter().map(|d| d * d).sum::<f64>() / perturbed.len() as f64).sqrt();
    let diff = distributed - reference;
    println!(
        "mean kinetic energy over the second half: Dem {reference:.6e}, DistributedDem \
         {distributed:.6e} (difference {diff:.3e}); Dem with one position moved by 1e-12: {perturbed:?} \
         (rms {sigma:.3e})"
    );
    // The gas cooled (the statistic is not its initial value) and the runs did part.
    assert!(sigma > 0.0 && diff != 0.0);
    assert!(diff.abs() <= 4.0 * sigma, "{diff:e} against 4 x {sigma:e}");
}

#[test]
fn checkpoints_move_between_dem_and_distributed_dem() {
    let (_, scene, config, _) = cases().remove(0);
    // DistributedDem -> Dem: the same state, and Dem goes on.
    let mut dist =
        DistributedDem::new(scene.clone(), &config, Comm::serial()).expect("distributed");
    dist.step(300).expect("step");
    let bytes = dist.checkpoint().expect("checkpoint");
    let mut dem =
        Dem::<simkit_dem::Material>::resume(&bytes, Backend::Cpu).expect("Dem resumes it");
    assert_eq!(dem.steps_done(), 300);
    assert_eq!(
        state_bits(&dem.state().expect("state")),
        state_bits(&dist.state().expect("state"))
    );
    dem.step(10).expect("Dem goes on");
    // Dem -> DistributedDem: the same state, and both go on to rounding of each other.
    let mut dem = Dem::new(scene, &config, Backend::Cpu).expect("dem");
    dem.step(300).expect("step");
    let bytes = dem.checkpoint().expect("checkpoint");
    let mut dist = DistributedDem::<simkit_dem::Material>::resume(&bytes, Comm::serial())
        .expect("resumes Dem's");
    assert_eq!(
        state_bits(&dist.state().expect("state")),
        state_bits(&dem.state().expect("state"))
    );
    dem.step(50).expect("step");
    dist.step(50).expect("step");
    let (a, b) = (dist.state().expect("state"), dem.state().expect("state"));
    assert!(max_rel(&a.positions, &b.positions) < 1e-12);
    // The file path: written atomically, read back the same.
    let dir = tempfile::tempdir().expect("dir");
    let path = dir.path().join("run.ckpt");
    dist.write_checkpoint(&path).expect("write");
    let again = DistributedDem::<simkit_dem::Material>::resume(
        &std::fs::read(&path).expect("read"),
        Comm::serial(),
    )
    .expect("resume");
    assert_eq!(again.steps_done(), 350);
}

#[test]
fn contact_history_moves_between_dem_and_distributed_dem() {
    // DistributedDem -> Dem with rotation and history (both copies of every pair in the
    // file; Dem takes the one in its orientation): the same state, and the two go on to
    // rounding of each other. (Dem -> DistributedDem: `agrees_with_dem`.)
    let ((name, scene, config, steps), _) = history_cases();
    let mut dist =
        DistributedDem::new(scene.clone(), &config, Comm::serial()).expect("distributed");
    dist.step(steps).expect("step");
    let bytes = dist.checkpoint().expect("checkpoint");
    let mut dem =
        Dem::<simkit_dem::HertzMindlin>::resume(&bytes, Backend::Cpu).expect("Dem resumes it");
    assert_eq!(
        state_bits(&dem.state().expect("state")),
        state_bits(&dist.state().expect("state")),
        "{name}"
    );
    // The contacts' history came along: Dem's next steps follow DistributedDem's.
    dem.step(100).expect("step");
    dist.step(100).expect("step");
    let (a, b) = (dist.state().expect("state"), dem.state().expect("state"));
    let dw = max_rel(&a.angular_velocities, &b.angular_velocities);
    println!("{name}: angular velocities 100 steps after the move differ by {dw:.2e}");
    // (A lost history would restart the springs from zero: far more than rounding.)
    assert!(dw <= 1e-12, "{name}: {dw:e}");
}

#[test]
fn the_blow_up_check_does_not_change_results() {
    let (_, scene, config, _) = cases().remove(1);
    let off = Config {
        check_every: 0,
        ..config
    };
    let (a, b) = (
        run_distributed(&scene, &config, 500),
        run_distributed(&scene, &off, 500),
    );
    assert_eq!(state_bits(&a), state_bits(&b));
}

#[test]
fn refuses_what_it_does_not_offer_and_bad_checkpoints() {
    let scene = gas(Dim::Two, 4, 1.1, 1.0);
    let unsupported = [
        Config {
            precision: Precision::F32,
            ..Config::default()
        },
        Config {
            integrator: Integrator::PositionVerlet,
            ..Config::default()
        },
    ];
    for c in unsupported {
        match DistributedDem::new(scene.clone(), &c, Comm::serial()) {
            Err(Error::Unsupported(m)) => assert!(m.contains("Dem for"), "{m}"),
            other => panic!("expected Unsupported, got {other:?}"),
        }
    }
    // Dem's own refusals come through unchanged.
    let bad = Config {
        dt: Some(1.0),
        ..Config::default()
    };
    let e =
        DistributedDem::new(scene.clone(), &bad, Comm::serial()).expect_err("dt over the bound");
    assert!(e.to_string().contains("dt"), "{e}");
    // An f32 Dem checkpoint is another model; garbage is no checkpoint.
    let f32 = Config {
        precision: Precision::F32,
        ..Config::default()
    };
    let mut dem = Dem::new(scene, &f32, Backend::Cpu).expect("dem");
    let bytes = dem.checkpoint().expect("checkpoint");
    let e = DistributedDem::<simkit_dem::Material>::resume(&bytes, Comm::serial())
        .expect_err("f32 model");
    assert!(e.to_string().contains("f64"), "{e}");
    assert!(
        DistributedDem::<simkit_dem::Material>::resume(b"not a checkpoint", Comm::serial())
            .is_err()
    );
}
