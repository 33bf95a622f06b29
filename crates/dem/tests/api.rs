//! The public API takes `glam` vectors as well as arrays and gives states back as both.

use glam::{DVec3, Vec2};
use simkit_backend::{Backend, Simulation};
use simkit_dem::{Config, Dem, Dim, Material, Particle, Scene};

fn run(scene: &Scene) -> simkit_dem::State {
    let mut sim = Dem::new(scene.clone(), &Config::default(), Backend::Cpu).unwrap();
    sim.step(50).unwrap();
    sim.state().unwrap()
}

#[test]
fn glam_vectors_and_arrays_build_the_same_scene() {
    let m = Material::new(0.9, 0.05);
    let mut arrays = Scene::new(Dim::Two, [0.0; 3], [4.0, 4.0, 0.0], m).unwrap();
    arrays
        .add_particle(Particle::new([1.0, 2.0, 0.0], 0.5, 1.0).with_velocity([1.0, 0.25, 0.0]))
        .unwrap();
    arrays
        .add_particle(Particle::new([2.5, 2.0, 0.0], 0.5, 1.0))
        .unwrap();

    let mut vectors = Scene::new(Dim::Two, Vec2::ZERO, Vec2::new(4.0, 4.0), m).unwrap();
    vectors
        .add_particle(
            Particle::new(Vec2::new(1.0, 2.0), 0.5, 1.0).with_velocity(Vec2::new(1.0, 0.25)),
        )
        .unwrap();
    vectors
        .add_particle(Particle::new(DVec3::new(2.5, 2.0, 0.0), 0.5, 1.0))
        .unwrap();

    assert_eq!(arrays.particles(), vectors.particles());
    let (a, b) = (run(&arrays), run(&vectors));
    assert_eq!(a, b);
    // The DVec3 view is the same memory read as vectors.
    let v = b.positions_dvec3();
    assert_eq!(v.len(), 2);
    for (p, q) in v.iter().zip(&b.positions) {
        assert_eq!(p.to_array(), *q);
    }
    assert_eq!(b.velocities_dvec3()[0].x, b.velocities[0][0]);
    // The particles moved, so the comparison above compares a real run.
    assert_ne!(b.positions[0], [1.0, 2.0, 0.0]);
}

#[test]
fn observed_runs_equal_plain_runs_and_can_stop_early() {
    use std::ops::ControlFlow;
    let m = Material::new(0.9, 0.05);
    let mut scene = Scene::new(Dim::Two, Vec2::ZERO, Vec2::new(4.0, 4.0), m).unwrap();
    scene
        .add_particle(Particle::new(Vec2::new(1.0, 2.0), 0.5, 1.0).with_velocity(Vec2::X))
        .unwrap();
    scene
        .add_particle(Particle::new(Vec2::new(2.5, 2.0), 0.5, 1.0))
        .unwrap();
    let new = || Dem::new(scene.clone(), &Config::default(), Backend::Cpu).unwrap();

    let mut plain = new();
    plain.step(400).unwrap();
    let mut observed = new();
    let mut seen = Vec::new();
    observed
        .step_observed(400, 130, |s| {
            seen.push(s.steps_done());
            Ok(ControlFlow::Continue(()))
        })
        .unwrap();
    assert_eq!(seen, [130, 260, 390, 400]);
    assert_eq!(observed.state().unwrap(), plain.state().unwrap());

    // Break stops after the chunk that asked; an observer's error is passed on.
    let mut early = new();
    early
        .step_observed(400, 100, |s| {
            Ok(if s.steps_done() >= 200 {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            })
        })
        .unwrap();
    assert_eq!(early.steps_done(), 200);
    let err = new()
        .step_observed(400, 100, |_| {
            Err(simkit_backend::Error::invalid("probe", 1, "test"))
        })
        .unwrap_err();
    assert!(err.to_string().contains("probe"), "{err}");
    assert!(
        new()
            .step_observed(10, 0, |_| Ok(ControlFlow::Continue(())))
            .is_err()
    );
}
