//! The blow-up check inside `step(n)` and the input checks both backends share: a run that
//! turns non-finite, lets a particle escape or presses contacts too deep stops with
//! `Error::BlowUp`, rolled back to the last state that passed; the check does not perturb
//! a stable run; diagnostics of a non-finite state are NaN; inputs are accepted and refused
//! alike on every backend.

use approx::{abs_diff_eq, assert_abs_diff_eq};
use simkit_backend::testing::backends;
use simkit_backend::{Backend, Error, Simulation};
use simkit_dem::{Config, Dem, Dim, Material, Particle, Scene, State, safe_dt};

/// 24 discs of radius 0.5 stacked 1.02 apart on the floor of a walled 2D box, under gravity.
fn pile() -> Scene {
    let m = Material::new(0.8, 0.05);
    let mut s = Scene::new(Dim::Two, [0.0; 3], [8.0, 10.0, 0.0], m).unwrap();
    s.set_gravity(1.0).unwrap();
    s.add_box_walls(m, false).unwrap();
    for k in 0..24 {
        let (x, y) = ((k % 6) as f64, (k / 6) as f64);
        s.add_particle(Particle::new(
            [1.0 + 1.02 * x, 0.6 + 1.02 * y, 0.0],
            0.5,
            1.0,
        ))
        .unwrap();
    }
    s
}

fn finite(s: &State) -> bool {
    s.positions
        .iter()
        .chain(&s.velocities)
        .all(|v| v.iter().all(|c| c.is_finite()))
}

/// Steps `sim` until `step` fails (at most `calls` calls of `n`), returning the error.
fn run_to_failure(sim: &mut Dem, calls: u32, n: u32) -> Error {
    for _ in 0..calls {
        if let Err(e) = sim.step(n) {
            return e;
        }
    }
    panic!("no blow-up after {} steps", calls * n);
}

#[test]
fn unstable_step_returns_blow_up_with_the_last_good_state() {
    let scene = pile();
    // Three times the safe bound: omega_0 dt ~ 3 > 2, every contact diverges.
    let dt = 3.0 * safe_dt(&scene);
    let cfg = Config::default().with_dt(dt).allow_unstable_dt();
    for backend in backends("unstable_step_returns_blow_up_with_the_last_good_state") {
        let name = backend.name();
        let mut sim = Dem::new(scene.clone(), &cfg, backend).unwrap();
        let err = run_to_failure(&mut sim, 20, 250);
        let Error::BlowUp {
            step,
            rolled_back_to,
            ref what,
            ref cause,
        } = err
        else {
            panic!("{name}: expected BlowUp, got {err:?}");
        };
        assert!(
            cause.contains("time step too large") && cause.contains("dt <="),
            "{err}"
        );
        assert!(what.contains("particle"), "{err}");
        assert_eq!(sim.steps_done(), rolled_back_to, "{name}");
        assert_eq!(
            rolled_back_to % 100,
            0,
            "{name}: checks fall on multiples of 100"
        );
        assert!(
            step > rolled_back_to && step <= rolled_back_to + 100,
            "{err}"
        );
        let state = sim.state().unwrap();
        assert!(
            finite(&state),
            "{name}: the rolled-back state is not finite"
        );
        assert_abs_diff_eq!(
            state.time,
            rolled_back_to as f64 * dt,
            epsilon = 1e-9 * state.time.max(1.0)
        );
        if matches!(backend, Backend::Cpu) {
            // Bit-identical to the same run stepped exactly to that step.
            let mut again = Dem::new(scene.clone(), &cfg, backend).unwrap();
            let mut left = rolled_back_to;
            while left > 0 {
                let n = left.min(250) as u32;
                again.step(n).unwrap();
                left -= u64::from(n);
            }
            assert_eq!(
                again.state().unwrap(),
                state,
                "{name}: rolled-back state differs"
            );
            // Stepping on from the rolled-back state fails at the same check.
            match sim.step(250) {
                Err(Error::BlowUp { step: s2, .. }) => assert_eq!(s2, step, "{name}"),
                other => panic!("{name}: expected the same blow-up, got {other:?}"),
            }
        }
        // The diagnostics of the rolled-back state are finite.
        let d = sim.diagnostics().unwrap();
        assert!(
            d.finite && d.kinetic.is_finite() && d.elastic.is_finite(),
            "{d:?}"
        );
    }
}

#[test]
fn the_check_does_not_perturb_a_stable_run() {
    let scene = pile();
    for backend in backends("the_check_does_not_perturb_a_stable_run") {
        let run = |every: u32| {
            let cfg = Config::default().with_check_every(every);
            let mut sim = Dem::new(scene.clone(), &cfg, backend).unwrap();
            sim.step(130).unwrap();
            sim.step(270).unwrap();
            sim.state().unwrap()
        };
        let (checked, unchecked, often) = (run(100), run(0), run(1));
        assert_eq!(checked, unchecked, "{}", backend.name());
        assert_eq!(checked, often, "{}", backend.name());
    }
}

#[test]
fn a_particle_leaving_a_closed_box_is_a_blow_up() {
    // No walls: nothing holds the disc in, and the box is closed along x and y.
    let m = Material::new(0.9, 0.05);
    let mut s = Scene::new(Dim::Two, [0.0; 3], [6.0, 6.0, 0.0], m).unwrap();
    s.add_particle(Particle::new([3.05, 3.0, 0.0], 0.5, 1.0).with_velocity([2.0, 0.0, 0.0]))
        .unwrap();
    s.add_particle(Particle::new([1.0, 1.0, 0.0], 0.5, 1.0))
        .unwrap();
    for backend in backends("a_particle_leaving_a_closed_box_is_a_blow_up") {
        let mut sim =
            Dem::new(s.clone(), &Config::default().with_check_every(10), backend).unwrap();
        // x = 3.05 + 2 t leaves [0, 6] by a radius at t = 1.725, step 1035 (dt = t_c / 30):
        // the check at step 1030 passes, the one at 1040 fails.
        let err = sim.step(2000).unwrap_err();
        let Error::BlowUp {
            step,
            rolled_back_to,
            ref what,
            ref cause,
        } = err
        else {
            panic!("expected BlowUp, got {err:?}");
        };
        assert!(
            what.contains("particle 0") && what.contains("position x"),
            "{err}"
        );
        assert!(
            cause.contains("escaped") && cause.contains("no walls"),
            "{err}"
        );
        assert_eq!((rolled_back_to, step), (1030, 1040), "{err}");
        assert_eq!(sim.steps_done(), 1030);
        let x = sim.state().unwrap().positions[0][0];
        assert!(x > 6.45 && x <= 6.5, "x = {x}");
    }
}

#[test]
fn a_contact_deeper_than_max_overlap_is_a_blow_up() {
    // Head-on at relative speed 8 with t_c = 0.5: the overlap would reach about
    // v t_c / pi = 1.3, far over half the radius 0.5 (dt = t_c / 30 is stable).
    let m = Material::new(0.9, 0.5);
    let mut s = Scene::new(Dim::Three, [0.0; 3], [10.0; 3], m).unwrap();
    s.add_particle(Particle::new([4.0, 5.0, 5.0], 0.5, 1.0).with_velocity([4.0, 0.0, 0.0]))
        .unwrap();
    s.add_particle(Particle::new([6.0, 5.0, 5.0], 0.5, 1.0).with_velocity([-4.0, 0.0, 0.0]))
        .unwrap();
    for backend in backends("a_contact_deeper_than_max_overlap_is_a_blow_up") {
        let mut sim = Dem::new(s.clone(), &Config::default().with_check_every(1), backend).unwrap();
        let err = sim.step(200).unwrap_err();
        let Error::BlowUp {
            ref what,
            ref cause,
            rolled_back_to,
            ..
        } = err
        else {
            panic!("expected BlowUp, got {err:?}");
        };
        assert!(
            what.contains("particle 0") || what.contains("particle 1"),
            "{err}"
        );
        assert!(what.contains("max_overlap = 0.5"), "{err}");
        assert!(cause.contains("impact too fast"), "{err}");
        let d = sim.diagnostics().unwrap();
        assert!(
            d.max_overlap_ratio <= 0.5 + 1e-3,
            "{d:?} at {rolled_back_to}"
        );
        // With the guard off the same run goes on.
        let off = Config::default().with_max_overlap(f64::INFINITY);
        let mut sim = Dem::new(s.clone(), &off, backend).unwrap();
        sim.step(40).unwrap();
    }
}

#[test]
fn diagnostics_of_a_non_finite_state_are_nan() {
    let scene = pile();
    let sim = Dem::new(scene.clone(), &Config::default(), Backend::Cpu).unwrap();
    let mut state = State {
        time: 0.0,
        positions: scene.particles().iter().map(|p| p.position).collect(),
        velocities: vec![[0.0; 3]; scene.particles().len()],
        angular_velocities: Vec::new(),
        species: vec![0; scene.particles().len()],
    };
    state.velocities[3][1] = f64::INFINITY;
    let d = sim.diagnostics_of(&state).unwrap();
    assert!(!d.finite);
    for (name, v) in [
        ("kinetic", d.kinetic),
        ("elastic", d.elastic),
        ("potential", d.potential),
        ("temperature", d.granular_temperature),
        ("com", d.com_height),
        ("overlap", d.max_overlap_ratio),
    ] {
        assert!(v.is_nan(), "{name} = {v}");
    }
}

/// Builds `scene` with `config` on every backend: all must agree on accepting it.
fn same_verdict(test: &str, scene: &Scene, config: &Config) -> Result<(), String> {
    let results: Vec<Result<(), String>> = backends(test)
        .into_iter()
        .map(|b| {
            Dem::new(scene.clone(), config, b)
                .map(|_| ())
                .map_err(|e| e.to_string())
        })
        .collect();
    for r in &results[1..] {
        assert_eq!(
            r.is_ok(),
            results[0].is_ok(),
            "{test}: backends disagree: {results:?}"
        );
    }
    results[0].clone()
}

#[test]
fn inputs_are_accepted_and_refused_alike_by_every_backend() {
    let test = "inputs_are_accepted_and_refused_alike_by_every_backend";
    let m = Material::new(0.9, 0.05);
    // A particle outside a closed box: refused (it used to fly off with v = 1183).
    let mut s = Scene::new(Dim::Two, [0.0; 3], [10.0, 10.0, 0.0], m).unwrap();
    s.add_box_walls(m, false).unwrap();
    s.add_particle(Particle::new([-2.0, 5.0, 0.0], 0.5, 1.0))
        .unwrap();
    let e = same_verdict(test, &s, &Config::default()).unwrap_err();
    assert!(
        e.contains("particle[0].position.x") && e.contains("outside the box"),
        "{e}"
    );
    // Half inside a wall: refused.
    let mut s = Scene::new(Dim::Two, [0.0; 3], [10.0, 10.0, 0.0], m).unwrap();
    s.add_box_walls(m, false).unwrap();
    s.add_particle(Particle::new([0.2, 5.0, 0.0], 0.5, 1.0))
        .unwrap();
    let e = same_verdict(test, &s, &Config::default()).unwrap_err();
    assert!(e.contains("particle 0 against wall 0"), "{e}");
    // A periodic axis shorter than twice the diameter times (1 + skin): refused by both
    // (the GPU used to take it).
    let mut s = Scene::new(Dim::Three, [0.0; 3], [2.1, 8.0, 8.0], m).unwrap();
    s.set_periodic([true, false, false]);
    s.add_particle(Particle::new([1.0, 4.0, 4.0], 0.5, 1.0))
        .unwrap();
    let e = same_verdict(test, &s, &Config::default()).unwrap_err();
    assert!(e.contains("periodic box length along x"), "{e}");
    // ... and accepted from 2 x 1.1 on.
    let mut s = Scene::new(Dim::Three, [0.0; 3], [2.2, 8.0, 8.0], m).unwrap();
    s.set_periodic([true, false, false]);
    s.add_particle(Particle::new([1.0, 4.0, 4.0], 0.5, 1.0))
        .unwrap();
    same_verdict(test, &s, &Config::default()).unwrap();
    // Magnitudes f32 cannot hold: refused by the GPU and by the CPU in f32 alike.
    let mut s = Scene::new(Dim::Two, [0.0; 3], [1e35, 1e35, 0.0], m).unwrap();
    s.add_particle(Particle::new([5.0, 5.0, 0.0], 0.5, 1.0))
        .unwrap();
    let single = Config::default().with_precision(simkit_dem::Precision::F32);
    let e = Dem::new(s.clone(), &single, Backend::Cpu)
        .err()
        .expect("f32 took 1e35");
    assert!(e.to_string().contains("rescale"), "{e}");
    Dem::new(s, &Config::default(), Backend::Cpu).unwrap();
}

#[test]
fn a_sparse_box_is_accepted_and_runs() {
    // 1000^3 with 8 spheres: the initial-overlap check used to build a grid over the whole
    // box and refuse it, asking for a larger "cutoff".
    let m = Material::new(0.9, 0.05);
    let mut s = Scene::new(Dim::Three, [0.0; 3], [1000.0; 3], m).unwrap();
    s.add_box_walls(m, false).unwrap();
    for k in 0..8 {
        let c = |b: usize| if k >> b & 1 == 1 { 700.0 } else { 300.0 };
        s.add_particle(Particle::new([c(0), c(1), c(2)], 0.5, 1.0).with_velocity([1.0, 0.0, 0.0]))
            .unwrap();
    }
    // Two touching spheres far from the others: the overlap check still finds them.
    let mut deep = s.clone();
    deep.add_particle(Particle::new([300.5, 300.0, 300.0], 0.5, 1.0))
        .unwrap();
    for backend in backends("a_sparse_box_is_accepted_and_runs") {
        let mut sim = Dem::new(s.clone(), &Config::default(), backend).unwrap();
        sim.step(100).unwrap();
        let x = sim.state().unwrap().positions[0][0];
        // Free flight at speed 1; the GPU adds 100 roundings of x ~ 300 in f32 (ulp 3e-5).
        assert!(
            abs_diff_eq!(x, 300.0 + 100.0 * sim.dt(), epsilon = 5e-3),
            "{x}"
        );
        let e = Dem::new(deep.clone(), &Config::default(), backend)
            .err()
            .expect("deep overlap");
        let e = e.to_string();
        assert!(
            e.contains("particles 0 and 8") && !e.contains("cutoff"),
            "{e}"
        );
    }
}
