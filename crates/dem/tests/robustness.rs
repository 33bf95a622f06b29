//! Property tests: every public entry point driven with arbitrary values (NaN, ±inf, 0,
//! negative, huge, mismatched lengths) returns `Ok` with a finite result or a clear `Err`,
//! never a panic. About 12 000 cases, reproducible: each runner uses a fixed ChaCha seed
//! (`SEED`) and no failure persistence, so a failure shows the same case on every run.

use std::sync::atomic::{AtomicUsize, Ordering};

use proptest::prelude::*;
use simkit_backend::comm::Comm;
use simkit_backend::testing::robust::{self, LargestAllocation, awkward_f64, clear};
use simkit_backend::{Backend, Distributed, Error, Restart, Simulation};
use simkit_dem::{
    Config, Dem, Dim, DistributedDem, HertzMindlin, Material, Particle, Scene, Solid, Wall,
};

const SEED: [u8; 32] = *b"simkit-dem robustness seed 2024!";

/// Records the largest allocation (the checkpoint fuzzing checks it).
#[global_allocator]
static ALLOC: LargestAllocation = LargestAllocation::new();

/// Mostly sensible positive values, sometimes anything.
fn pos_num() -> impl Strategy<Value = f64> {
    prop_oneof![3 => 0.05..2.0f64, 1 => awkward_f64()]
}

/// Mostly moderate speeds, sometimes anything.
fn speed() -> impl Strategy<Value = f64> {
    prop_oneof![3 => -3.0..3.0f64, 1 => awkward_f64()]
}

fn dim() -> impl Strategy<Value = Dim> {
    prop_oneof![Just(Dim::Two), Just(Dim::Three)]
}

fn material() -> impl Strategy<Value = Material> {
    (
        prop_oneof![3 => 0.1..1.0f64, 1 => awkward_f64()],
        pos_num(),
        pos_num(),
        pos_num(),
        any::<bool>(),
    )
        .prop_map(|(e, tc, ms, mk, f)| {
            let m = Material::new(e, tc);
            if f { m.with_friction(ms, mk) } else { m }
        })
}

#[test]
fn scene_builders_never_panic() {
    let v3 = || [awkward_f64(), awkward_f64(), awkward_f64()];
    robust::run(
        &SEED,
        3000,
        (
            dim(),
            v3(),
            v3(),
            material(),
            any::<usize>(),
            0usize..80,
            material(),
            any::<u32>(),
            0u32..4,
        ),
        |(d, lo, hi, m, big, count, m2, a, b)| {
            match Scene::new(d, lo, hi, m) {
                Err(e) => clear(&e)?,
                Ok(mut s) => {
                    for n in [big, count] {
                        if let Err(e) = s.set_species(n, m2) {
                            clear(&e)?;
                        }
                    }
                    for (a, b) in [(a, b), (b, a), (b, b)] {
                        if let Err(e) = s.set_pair(a, b, m2) {
                            clear(&e)?;
                        }
                        let _ = s.pair(a, b);
                    }
                }
            }
            Ok(())
        },
    );
}

#[test]
fn scene_setters_never_panic() {
    let v3 = || [awkward_f64(), awkward_f64(), awkward_f64()];
    robust::run(
        &SEED,
        3000,
        (
            dim(),
            (
                v3(),
                v3(),
                awkward_f64(),
                awkward_f64(),
                awkward_f64(),
                material(),
            ),
            (v3(), v3(), pos_num(), pos_num(), 0u32..3),
            (
                awkward_f64(),
                awkward_f64(),
                awkward_f64(),
                [any::<bool>(), any::<bool>(), any::<bool>()],
            ),
            (0usize..4, 0usize..4),
        ),
        |(d, (normal, point, cx, cy, cr, wm), (x, v, r, mass, sp), (g, amp, om, per), (nx, nv))| {
            let mut s = Scene::new(d, [0.0; 3], [5.0; 3], Material::new(0.9, 0.05)).unwrap();
            s.set_periodic(per);
            for r in [
                s.add_wall(Wall::plane(normal, point, wm)).map(|_| ()),
                s.add_wall(Wall::cylinder([cx, cy], cr, wm).vibrating().spinning(cx))
                    .map(|_| ()),
                s.add_particle(Particle::new(x, r, mass).with_velocity(v).with_species(sp))
                    .map(|_| ()),
                s.set_gravity(g).map(|_| ()),
                s.set_vibration(amp, om).map(|_| ()),
                s.set_kinematics(&vec![x; nx], &vec![v; nv]),
            ] {
                if let Err(e) = r {
                    clear(&e)?;
                }
            }
            Ok(())
        },
    );
}

/// A tiny scene: 1 to 4 particles, sometimes walls, gravity, vibration, periodic axes.
fn tiny_scene() -> impl Strategy<Value = Scene> {
    (
        dim(),
        prop_oneof![3 => 2.0..20.0f64, 1 => awkward_f64()],
        material(),
        prop::collection::vec(
            (
                [0.0..1.0f64, 0.0..1.0f64, 0.0..1.0f64],
                pos_num(),
                pos_num(),
                [speed(), speed(), speed()],
            ),
            1..5,
        ),
        (
            any::<bool>(),
            any::<bool>(),
            prop_oneof![Just(0.0), awkward_f64()],
            any::<bool>(),
            [any::<bool>(), any::<bool>(), any::<bool>()],
        ),
        (0.0..1.0f64, 0.1..20.0f64),
    )
        .prop_filter_map(
            "the box must build",
            |(d, size, m, ps, (walls, vib_walls, g, vib, per), (a, w))| {
                let mut s = Scene::new(d, [0.0; 3], [size; 3], m).ok()?;
                s.set_periodic(per);
                if walls {
                    s.add_box_walls(m, vib_walls).ok()?;
                }
                let _ = s.set_gravity(g);
                if vib {
                    let _ = s.set_vibration(a, w);
                }
                for (f, r, mass, v) in ps {
                    let z = if d == Dim::Two { 0.0 } else { 1.0 };
                    let x = [f[0] * size, f[1] * size, f[2] * size * z];
                    let v = [v[0], v[1], v[2] * z];
                    let _ = s.add_particle(Particle::new(x, r, mass).with_velocity(v));
                }
                Some(s)
            },
        )
}

fn config() -> impl Strategy<Value = Config> {
    (
        prop_oneof![2 => Just(None), 1 => awkward_f64().prop_map(Some), 1 => (1e-4..1e-1f64).prop_map(Some)],
        any::<bool>(),
        any::<bool>(),
        prop_oneof![3 => Just(0.1), 1 => awkward_f64()],
        prop_oneof![Just(0u32), Just(1), Just(7), Just(100), any::<u32>()],
        prop_oneof![3 => Just(0.5), 1 => awkward_f64()],
        any::<bool>(),
    )
        .prop_map(|(dt, unstable, pv, skin, every, overlap, single)| {
            let mut c = Config {
                dt,
                allow_unstable_dt: unstable,
                skin,
                check_every: every,
                max_overlap: overlap,
                ..Config::default()
            };
            if pv {
                c = c.with_integrator(simkit_dem::Integrator::PositionVerlet);
            }
            if single {
                c = c.with_precision(simkit_dem::Precision::F32);
            }
            c
        })
}

#[test]
fn dem_new_and_step_never_panic() {
    static BUILT: AtomicUsize = AtomicUsize::new(0);
    robust::run(
        &SEED,
        3000,
        (tiny_scene(), config(), 0u32..60, 0u32..40),
        |(scene, cfg, n1, n2)| {
            let mut sim = match Dem::new(scene, &cfg, Backend::Cpu) {
                Ok(sim) => {
                    BUILT.fetch_add(1, Ordering::Relaxed);
                    sim
                }
                Err(e) => return clear(&e),
            };
            for n in [n1, n2] {
                match sim.step(n) {
                    Ok(()) => {
                        let s = sim.state().unwrap();
                        prop_assert!(
                            s.positions
                                .iter()
                                .chain(&s.velocities)
                                .flatten()
                                .all(|c| c.is_finite()),
                            "Ok with a non-finite state"
                        );
                        let d = sim.diagnostics().unwrap();
                        prop_assert!(d.finite && d.kinetic.is_finite());
                    }
                    Err(e) => {
                        clear(&e)?;
                        if let Error::BlowUp { rolled_back_to, .. } = e {
                            prop_assert_eq!(sim.steps_done(), rolled_back_to);
                            let s = sim.state().unwrap();
                            prop_assert!(s.positions.iter().flatten().all(|c| c.is_finite()));
                        }
                        break;
                    }
                }
            }
            Ok(())
        },
    );
    // The generator must reach the stepping often enough to mean something.
    let built = BUILT.load(Ordering::Relaxed);
    assert!(
        built >= 300,
        "only {built} of 3000 cases built a simulation"
    );
}

#[test]
fn checkpoint_decode_of_garbage_never_panics() {
    let mut m = Scene::new(
        Dim::Two,
        [0.0; 3],
        [6.0, 6.0, 0.0],
        Material::new(0.9, 0.05),
    )
    .unwrap();
    m.set_gravity(1.0).unwrap();
    m.add_box_walls(Material::new(0.9, 0.05), false).unwrap();
    for k in 0..3 {
        m.add_particle(Particle::new([1.0 + 1.5 * k as f64, 1.0, 0.0], 0.5, 1.0))
            .unwrap();
    }
    let mut sim = Dem::new(m, &Config::default(), Backend::Cpu).unwrap();
    sim.step(20).unwrap();
    let good = sim.checkpoint().unwrap();
    let len = good.len();
    robust::run(
        &SEED,
        3000,
        (
            prop::collection::vec(any::<u8>(), 0..300),
            0..len,
            0..len,
            any::<u8>(),
            0u8..3,
        ),
        |(noise, cut, at, byte, how)| {
            let bytes = match how {
                0 => noise,
                1 => good[..cut].to_vec(),
                _ => {
                    let mut b = good.clone();
                    b[at] ^= byte.max(1);
                    b
                }
            };
            match Dem::<Material>::resume(&bytes, Backend::Cpu) {
                Ok(_) => prop_assert!(false, "garbage resumed"),
                Err(e) => {
                    prop_assert!(matches!(e, Error::Checkpoint { .. }), "{e}");
                    clear(&e)?;
                }
            }
            Ok(())
        },
    );
}

#[test]
fn resealed_checkpoints_never_panic_nor_allocate_past_their_size() {
    // A rotating scene with a history law, walls and contacts, so that every part of the
    // payload (spins, contact keys, history) is there to be changed; 10^4 variants past the
    // checksum, each resumed by Dem (and stepped) and by DistributedDem.
    let law = HertzMindlin::new(Solid::new(1e5, 0.3), Solid::new(1e5, 0.3), 0.6, 0.4)
        .unwrap()
        .with_rolling(0.05, 2000.0, 20.0);
    let mut scene = Scene::new(Dim::Three, [0.0; 3], [3.0, 3.0, 4.0], law).unwrap();
    scene
        .set_gravity(1.0)
        .unwrap()
        .set_rotation(true)
        .add_box_walls(law, false)
        .unwrap();
    for k in 0..8 {
        let p = [
            0.8 + (k % 2) as f64 * 1.05,
            0.8 + (k / 2 % 2) as f64 * 1.05,
            0.6 + (k / 4) as f64 * 1.02,
        ];
        scene.add_particle(Particle::new(p, 0.5, 1.0)).unwrap();
    }
    let mut sim = Dem::new(scene, &Config::default(), Backend::Cpu).unwrap();
    sim.step(4000).unwrap();
    let bytes = sim.checkpoint().unwrap();
    assert!(sim.diagnostics().unwrap().contacts > 0);
    // What the file justifies: its own size many times over, and the fixed cost of an
    // engine (cell grid, rayon) of a few MiB.
    let limit = |len: usize| (64 * len).max(8 << 20);
    let resumed = robust::fuzz_checkpoints(&SEED, 10_000, &bytes, &ALLOC, limit, |b| {
        if let Ok(mut d) = DistributedDem::<HertzMindlin>::resume(b, Comm::serial()) {
            let _ = d.step(2);
            d.checkpoint()?;
        }
        let mut dem = Dem::<HertzMindlin>::resume(b, Backend::Cpu)?;
        let _ = dem.step(2);
        Ok(())
    });
    println!(
        "{resumed} of 10000 resealed checkpoints ({} bytes) resumed",
        bytes.len()
    );
}

#[cfg(feature = "gpu")]
#[test]
fn gpu_new_and_step_never_panic() {
    let Some(ctx) = simkit_backend::testing::gpu_or_skip("gpu_new_and_step_never_panic") else {
        return;
    };
    // A small set: each case builds GPU kernels. Both backends must agree on acceptance.
    robust::run(&SEED, 40, (tiny_scene(), config()), |(scene, cfg)| {
        let mut cfg = cfg;
        cfg.integrator = simkit_dem::Integrator::VelocityVerlet;
        cfg.precision = simkit_dem::Precision::F32;
        let cpu = Dem::new(scene.clone(), &cfg, Backend::Cpu);
        let gpu = Dem::new(scene, &cfg, Backend::Gpu(&ctx));
        prop_assert_eq!(
            cpu.is_ok(),
            gpu.is_ok(),
            "cpu {:?} gpu {:?}",
            cpu.as_ref().err(),
            gpu.as_ref().err()
        );
        if let Ok(mut sim) = gpu {
            match sim.step(30) {
                Ok(()) => {
                    let s = sim.state().unwrap();
                    prop_assert!(
                        s.positions
                            .iter()
                            .chain(&s.velocities)
                            .flatten()
                            .all(|c| c.is_finite())
                    );
                }
                Err(e) => clear(&e)?,
            }
        }
        Ok(())
    });
}
