//! Property tests: every public constructor, setter and stepping call of the crate, fed
//! arbitrary values (NaN, ±inf, 0, -0, negative, tiny, huge, mismatched lengths, empty
//! systems, garbled checkpoints), returns either `Ok` with a finite result or a clear `Err`,
//! and never panics. About 11,000 generated cases in all, on tiny systems (CPU; one small
//! GPU set), in a few seconds.
//!
//! Reproducible: every runner starts from the fixed seed `SEED` (ChaCha), and failure
//! persistence is off, so a failure shows the same minimal case on every run.

use proptest::prelude::*;
use simkit_backend::testing::robust::{self, awkward_f64};
use simkit_backend::{Backend, Error, Restart, Simulation, checkpoint};
use simkit_pp_coulomb::scenes::{Expansion, ExplosionSample, cold_sphere, crossing_time};
use simkit_pp_coulomb::units::{PhysicalInputs, normalise};
use simkit_pp_coulomb::{
    Config, ForceLaw, Integrator, MAX_PARTICLES, Particles, PpCoulomb, Precision, Region, Species,
    Velocities, scenes,
};

const SEED: [u8; 32] = *b"simkit-pp-coulomb-robustness-01!";

/// Records the largest allocation (the checkpoint fuzzing checks it).
#[global_allocator]
static ALLOC: simkit_backend::testing::robust::LargestAllocation =
    simkit_backend::testing::robust::LargestAllocation::new();

/// Counts: empty, small, and sizes past every limit.
fn count() -> impl Strategy<Value = usize> {
    prop_oneof![
        Just(0usize),
        1usize..40,
        Just(MAX_PARTICLES + 1),
        Just(usize::MAX),
        Just(usize::MAX / 2),
    ]
}

fn vec3() -> impl Strategy<Value = [f64; 3]> {
    [awkward_f64(), awkward_f64(), awkward_f64()]
}

fn region() -> impl Strategy<Value = Region> {
    prop_oneof![
        (vec3(), awkward_f64()).prop_map(|(min, length)| Region::Cube { min, length }),
        (vec3(), awkward_f64()).prop_map(|(center, radius)| Region::Sphere { center, radius }),
    ]
}

fn velocities() -> impl Strategy<Value = Velocities> {
    prop_oneof![
        Just(Velocities::Cold),
        awkward_f64().prop_map(|thermal_speed| Velocities::Maxwellian { thermal_speed }),
        awkward_f64().prop_map(|half_width| Velocities::Uniform { half_width }),
    ]
}

fn law() -> impl Strategy<Value = ForceLaw> {
    prop_oneof![
        Just(ForceLaw::Exact),
        awkward_f64().prop_map(|radius| ForceLaw::Exclusion { radius }),
        awkward_f64().prop_map(|epsilon| ForceLaw::Plummer { epsilon }),
    ]
}

fn config() -> impl Strategy<Value = Config> {
    (
        awkward_f64(),
        law(),
        any::<bool>(),
        any::<bool>(),
        any::<bool>(),
        any::<bool>(),
        prop_oneof![Just(0u32), 1u32..20, Just(u32::MAX)],
        prop_oneof![Just(None), awkward_f64().prop_map(Some)],
    )
        .prop_map(|(dt, law, leapfrog, f32, mixed, rsqrt, every, tol)| {
            Config::new(dt, law)
                .with_integrator(if leapfrog {
                    Integrator::Leapfrog
                } else {
                    Integrator::SymplecticEuler
                })
                .with_precision(if f32 { Precision::F32 } else { Precision::F64 })
                // Mixed with f64 pair terms too: an error naming the fix.
                .with_mixed(mixed)
                .with_rsqrt(rsqrt)
                .with_check_every(every)
                .with_energy_tolerance(tol)
        })
}

/// Valid configurations with ordinary or extreme steps (1e-4 .. 1e3, some far past any
/// stable step) and any law, integrator, precision and interval.
fn sane_config() -> impl Strategy<Value = Config> {
    (
        prop_oneof![1e-4..1.0f64, 1.0..1e3f64],
        prop_oneof![
            Just(ForceLaw::Exact),
            (0.01..2.0f64).prop_map(|radius| ForceLaw::Exclusion { radius }),
            (0.01..2.0f64).prop_map(|epsilon| ForceLaw::Plummer { epsilon }),
        ],
        config(),
    )
        .prop_map(|(dt, law, c)| Config {
            dt,
            force: law,
            energy_tolerance: c.energy_tolerance.filter(|t| *t > 0.0 && t.is_finite()),
            mixed: c.mixed && c.precision == Precision::F32,
            ..c
        })
}

/// Particles with arbitrary fields set directly: lengths 0..5 each (often mismatched), any
/// values, species indices that may not exist.
fn raw_particles() -> impl Strategy<Value = Particles> {
    let n = 0usize..5;
    (n.clone(), n.clone(), n.clone(), n.clone(), n, any::<bool>())
        .prop_flat_map(|(np, nv, nq, nm, ns, same)| {
            let (nv, nq, nm, ns) = if same {
                (np, np, np, np)
            } else {
                (nv, nq, nm, ns)
            };
            (
                prop::collection::vec(vec3(), np),
                prop::collection::vec(vec3(), nv),
                prop::collection::vec(awkward_f64(), nq),
                prop::collection::vec(awkward_f64(), nm),
                prop::collection::vec(0u32..3, ns),
            )
        })
        .prop_map(|(position, velocity, charge, mass, species)| Particles {
            position,
            velocity,
            charge,
            mass,
            species,
            species_table: vec![Species::new("a", -1.0, 1.0), Species::new("b", 1.0, 2.0)],
        })
}

/// Valid particles with ordinary values, for the stepping properties.
fn sane_particles() -> impl Strategy<Value = Particles> {
    (
        0usize..12,
        -2.0..2.0f64,
        0.1..5.0f64,
        0.0..2.0f64,
        any::<u64>(),
    )
        .prop_map(|(n, q, m, v, seed)| {
            let mut p = Particles::new();
            let a = p.add_species(Species::new("a", q, m)).unwrap();
            let b = p.add_species(Species::new("b", -q, 2.0 * m)).unwrap();
            let cube = Region::Cube {
                min: [-2.0; 3],
                length: 4.0,
            };
            let vel = Velocities::Uniform { half_width: v };
            p.fill(a, n / 2, cube, vel, seed).unwrap();
            p.fill(b, n - n / 2, cube, vel, seed ^ 1).unwrap();
            p
        })
}

fn all_finite(p: &Particles) -> bool {
    p.position
        .iter()
        .chain(&p.velocity)
        .flatten()
        .all(|c| c.is_finite())
        && p.charge.iter().chain(&p.mass).all(|c| c.is_finite())
}

/// `Ok`: the particles validate and are finite; `Err`: a message naming something.
fn particles_ok_or_clear(r: simkit_backend::Result<()>, p: &Particles) {
    match r {
        Ok(()) => {
            p.validate().unwrap();
            assert!(all_finite(p));
        }
        Err(e) => assert!(e.to_string().len() > 10, "{e}"),
    }
}

/// Species, push and fill with arbitrary arguments, several in a row on one `Particles`.
#[test]
fn particles_constructors_and_setters() {
    let op = prop_oneof![
        (awkward_f64(), awkward_f64())
            .prop_map(|(q, m)| (0u8, q, m, [0.0; 3], [0.0; 3], 0usize, 0u32)),
        (0u32..4, vec3(), vec3()).prop_map(|(s, x, v)| (1u8, 0.0, 0.0, x, v, 0, s)),
        (0u32..4, count(), awkward_f64(), awkward_f64())
            .prop_map(|(s, n, a, b)| (2u8, a, b, [a; 3], [b; 3], n, s)),
    ];
    let ops = (
        prop::collection::vec(op, 1..6),
        region(),
        velocities(),
        any::<u64>(),
    );
    robust::runner(&SEED, 4000)
        .run(&ops, |(ops, region, vel, seed)| {
            let mut p = Particles::new();
            for (kind, a, b, x, v, n, s) in ops {
                let r = match kind {
                    0 => p.add_species(Species::new("s", a, b)).map(|_| ()),
                    1 => p.push(s, x, v),
                    _ => p.fill(s, n, region, vel, seed),
                };
                let before = p.len();
                particles_ok_or_clear(r, &p);
                assert!(p.len() <= 1000 && p.len() >= before.min(p.len()));
            }
            Ok(())
        })
        .unwrap();
}

/// `PpCoulomb::new` with arbitrary particles (mismatched lengths, NaN, zero masses, unknown
/// species) and configurations, then `step`: a clear error, or a run whose state stays
/// finite (a blow-up leaves it at the finite state of `rolled_back_to`).
#[test]
fn new_and_step_with_arbitrary_inputs() {
    let input = (
        prop_oneof![1 => raw_particles(), 3 => sane_particles()],
        prop_oneof![1 => config(), 3 => sane_config()],
        prop::collection::vec(prop_oneof![0u32..30, Just(u32::MAX)], 0..3),
        prop_oneof![Just(None), awkward_f64().prop_map(Some)],
    );
    // Outcomes: [refused by new, built, steps Ok, blow-ups, refused step counts].
    let seen = std::cell::Cell::new([0u32; 5]);
    let count = |k: usize| {
        let mut s = seen.get();
        s[k] += 1;
        seen.set(s);
    };
    robust::runner(&SEED, 2500)
        .run(&input, |(p, config, calls, new_dt)| {
            let mut sim = match PpCoulomb::new(p, &config, Backend::Cpu) {
                Ok(sim) => {
                    count(1);
                    sim
                }
                Err(e) => {
                    count(0);
                    assert!(e.to_string().len() > 10);
                    return Ok(());
                }
            };
            if let Some(dt) = new_dt {
                let ok = sim.set_dt(dt).is_ok();
                assert_eq!(ok, dt.is_finite() && dt > 0.0);
            }
            for steps in calls {
                // u32::MAX steps would take hours: only small calls on systems with
                // particles; the empty system takes any count.
                let steps = if sim.is_empty() { steps } else { steps.min(30) };
                let before = sim.steps_done();
                match sim.step(steps) {
                    Ok(()) => {
                        count(2);
                        assert_eq!(sim.steps_done(), before + u64::from(steps));
                    }
                    Err(Error::BlowUp { rolled_back_to, .. }) => {
                        count(3);
                        assert_eq!(sim.steps_done(), rolled_back_to);
                        assert!(rolled_back_to >= before);
                    }
                    Err(e) => {
                        count(4);
                        assert!(matches!(e, Error::InvalidParameter { .. }), "{e}");
                        assert_eq!(sim.steps_done(), before);
                    }
                }
                assert!(all_finite(&sim.state().unwrap()));
                assert!(sim.time().is_finite());
            }
            // The checkpoint of whatever state it reached resumes.
            let bytes = sim.checkpoint().unwrap();
            let back = PpCoulomb::resume(&bytes, Backend::Cpu).unwrap();
            assert_eq!(back.steps_done(), sim.steps_done());
            Ok(())
        })
        .unwrap();
    let [refused, built, ok, blow_ups, bad_counts] = seen.get();
    println!(
        "new: {refused} refused, {built} built; step calls: {ok} Ok, {blow_ups} blow-ups, \
         {bad_counts} refused counts"
    );
    assert!(built > 100 && blow_ups > 10 && ok > 100, "{:?}", seen.get());
}

/// Unit conversions and the plasma scene with arbitrary physical inputs.
#[test]
fn units_and_scenes_with_arbitrary_inputs() {
    let inputs = (
        [
            awkward_f64(),
            awkward_f64(),
            awkward_f64(),
            awkward_f64(),
            awkward_f64(),
            awkward_f64(),
        ],
        prop_oneof![
            Just(0usize),
            1usize..50,
            Just(usize::MAX),
            Just(MAX_PARTICLES + 1)
        ],
        any::<u64>(),
    );
    robust::runner(&SEED, 2000)
        .run(
            &inputs,
            |([dt, density, box_length, te, q, m], particles, seed)| {
                let inputs = PhysicalInputs {
                    dt,
                    density,
                    box_length,
                    particles,
                    temperature_ev: te,
                    charge_number: q,
                    mass_ratio: m,
                };
                match normalise(&inputs) {
                    Ok(u) => {
                        for v in [
                            u.weight,
                            u.length,
                            u.time,
                            u.velocity,
                            u.box_length,
                            u.thermal_speed,
                            u.debye_length,
                            u.omega_pe_dt,
                            u.mass,
                        ] {
                            assert!(v.is_finite() && v > 0.0, "{u:?}");
                        }
                        assert!(u.charge.is_finite() && u.charge != 0.0);
                    }
                    Err(e) => assert!(e.to_string().len() > 10),
                }
                match scenes::plasma_box(&inputs, seed) {
                    Ok((p, law, _)) => {
                        p.validate().unwrap();
                        law.validate().unwrap();
                        assert_eq!(p.len(), particles);
                    }
                    Err(e) => assert!(e.to_string().len() > 10),
                }
                Ok(())
            },
        )
        .unwrap();
}

/// The sphere scene, the expansion measurement (also on too few positions), the crossing
/// time and a short explosion run, with arbitrary arguments.
#[test]
fn explosion_helpers_with_arbitrary_inputs() {
    let inputs = (
        prop_oneof![
            Just(0usize),
            1usize..30,
            Just(usize::MAX),
            Just(MAX_PARTICLES + 1)
        ],
        awkward_f64(),
        prop::collection::vec(vec3(), 0..20),
        prop::collection::vec((awkward_f64(), awkward_f64()), 0..5),
        [awkward_f64(), awkward_f64(), awkward_f64(), awkward_f64()],
    );
    robust::runner(&SEED, 1500)
        .run(
            &inputs,
            |(n, radius, positions, samples, [omega, courant, xi_max, t_max])| {
                match cold_sphere(n, radius, 3) {
                    Ok(p) => {
                        p.validate().unwrap();
                        let e = Expansion::new(&p.position, radius);
                        let f = e.factor(&p.position);
                        assert!(f.is_nan() || (f - 1.0).abs() < 1e-12);
                        // Fewer positions than particles: NaN, not a panic.
                        let _ = e.factor(&positions);
                        let config = Config::new(0.05, ForceLaw::Exact);
                        let mut sim = PpCoulomb::new(p, &config, Backend::Cpu).unwrap();
                        // Bounded runs only: the loop runs until xi_max or t_max, here
                        // at most about 10^4 steps (t_max omega / courant at xi = 1).
                        let (xi_max, t_max) = (xi_max.min(1.5), t_max.min(0.5));
                        let t_max = t_max.min(1e4 * courant / omega);
                        match scenes::run_explosion(
                            &mut sim,
                            &e,
                            omega,
                            courant,
                            xi_max,
                            t_max,
                            |_, _| Ok(()),
                        ) {
                            Ok(s) => assert!(s.iter().all(|s| s.time.is_finite())),
                            Err(e) => assert!(e.to_string().len() > 10),
                        }
                    }
                    Err(e) => assert!(e.to_string().len() > 10),
                }
                let samples: Vec<ExplosionSample> = samples
                    .into_iter()
                    .map(|(time, xi)| ExplosionSample { time, xi })
                    .collect();
                let _ = crossing_time(&samples, xi_max);
                Ok(())
            },
        )
        .unwrap();
}

/// Resuming garbage: random bytes, truncations and bit flips of a real checkpoint, and real
/// checkpoints whose payload bytes were changed with the checksum recomputed (so the payload
/// decoder and the validation of the decoded state see them): a clear error, or a run whose
/// state is finite and steps.
/// A step far too small for `t_max` (here 5e153 steps) is refused before the first step,
/// not run as a loop without end (found by the shared awkward inputs: omega = 1e154).
#[test]
fn an_explosion_run_of_too_many_steps_is_refused() {
    let p = cold_sphere(20, 1.0, 3).unwrap();
    let e = Expansion::new(&p.position, 1.0);
    let config = Config::new(0.05, ForceLaw::Exact);
    let mut sim = PpCoulomb::new(p, &config, Backend::Cpu).unwrap();
    let err = scenes::run_explosion(&mut sim, &e, 1e154, 1.0, 1.5, 0.5, |_, _| Ok(()))
        .unwrap_err()
        .to_string();
    assert!(err.contains("steps") && err.contains("courant"), "{err}");
    assert_eq!(sim.steps_done(), 0);
}

#[test]
fn resume_of_garbage_is_a_clear_error() {
    let mut p = Particles::new();
    let e = p.add_species(Species::new("e", -1.0, 1.0)).unwrap();
    let cube = Region::Cube {
        min: [0.0; 3],
        length: 3.0,
    };
    p.fill(e, 4, cube, Velocities::Uniform { half_width: 0.1 }, 1)
        .unwrap();
    let mut sim = PpCoulomb::new(p, &Config::new(0.01, ForceLaw::Exact), Backend::Cpu).unwrap();
    sim.step(3).unwrap();
    let good = sim.checkpoint().unwrap();
    let header_len = good.len() - 4 - {
        // The payload length sits in the 8 bytes before the payload; find it by scanning.
        (0..good.len() - 12)
            .find_map(|at| {
                let len = u64::from_le_bytes(good[at..at + 8].try_into().unwrap()) as usize;
                (at + 8 + len + 4 == good.len()).then_some(len)
            })
            .unwrap()
    };
    let garbage = prop_oneof![
        prop::collection::vec(any::<u8>(), 0..200),
        (0..good.len()).prop_map({
            let good = good.clone();
            move |n| good[..n].to_vec()
        }),
        (0..good.len(), 0u8..8).prop_map({
            let good = good.clone();
            move |(at, bit)| {
                let mut b = good.clone();
                b[at] ^= 1 << bit;
                b
            }
        }),
        prop::collection::vec((0..good.len() - header_len - 4, any::<u8>()), 1..4).prop_map({
            let good = good.clone();
            move |edits| {
                let mut b = good.clone();
                for (at, byte) in edits {
                    b[header_len + at] = byte;
                }
                simkit_backend::testing::reseal(&mut b);
                b
            }
        }),
    ];
    let resumed = std::cell::Cell::new(0u32);
    robust::runner(&SEED, 2000)
        .run(&garbage, |bytes| {
            match PpCoulomb::resume(&bytes, Backend::Cpu) {
                Ok(mut sim) => {
                    assert!(all_finite(&sim.state().unwrap()));
                    assert!(sim.time().is_finite());
                    let _ = sim.step(2);
                    assert!(all_finite(&sim.state().unwrap()));
                    resumed.set(resumed.get() + 1);
                }
                Err(e) => assert!(e.to_string().len() > 10, "{e}"),
            }
            Ok(())
        })
        .unwrap();
    let resumed = resumed.get();
    println!("{resumed} of 2000 garbled checkpoints still decoded to a valid run");
    // A sanity check of the forgery: the unmodified payload with a fresh checksum resumes.
    assert!(checkpoint::header(&good).is_ok());
}

/// A small set on the GPU (when present): arbitrary configurations on tiny valid systems
/// are refused exactly as on the CPU, and runs stay finite.
#[cfg(feature = "gpu")]
#[test]
fn gpu_accepts_and_refuses_like_the_cpu() {
    use proptest::strategy::ValueTree;
    let Some(ctx) = simkit_backend::testing::gpu_or_skip("gpu_accepts_and_refuses_like_the_cpu")
    else {
        return;
    };
    let input = (sane_particles(), config(), 0u32..25);
    let mut runner = robust::runner(&SEED, 40);
    for _ in 0..40 {
        let (p, config, steps) = input.new_tree(&mut runner).unwrap().current();
        let f64_missing = config.precision == Precision::F64 && !ctx.has_f64();
        let cpu = PpCoulomb::new(p.clone(), &config, Backend::Cpu);
        let gpu = PpCoulomb::new(p, &config, Backend::Gpu(&ctx));
        match (cpu, gpu) {
            (Ok(_), Err(Error::Unsupported(_))) if f64_missing || config.mixed => {}
            (Ok(mut cpu), Ok(mut sim)) => {
                match sim.step(steps) {
                    Ok(()) | Err(Error::BlowUp { .. }) => {}
                    // A step count the clock cannot take (e.g. dt near f64::MAX): refused
                    // as on the CPU, with nothing changed.
                    Err(e @ Error::InvalidParameter { .. }) => {
                        let on_cpu = cpu.step(steps).map_err(|e| e.to_string());
                        assert_eq!(on_cpu, Err(e.to_string()));
                        assert_eq!(sim.steps_done(), 0);
                    }
                    Err(e) => panic!("{e}"),
                }
                assert!(all_finite(&sim.state().unwrap()));
            }
            (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string()),
            (a, b) => panic!("CPU {:?} vs GPU {:?}", a.err(), b.err()),
        }
    }
}

#[test]
fn resealed_checkpoints_never_panic_nor_allocate_past_their_size() {
    // 10^4 variants of a checkpoint past the checksum, each resumed by PpCoulomb (and
    // stepped) and by DistributedCoulomb.
    let p = cold_sphere(40, 1.0, 3).unwrap();
    let mut sim = PpCoulomb::new(p, &Config::new(0.05, ForceLaw::Exact), Backend::Cpu).unwrap();
    sim.step(3).unwrap();
    let bytes = sim.checkpoint().unwrap();
    let limit = |len: usize| (64 * len).max(8 << 20);
    let resumed = robust::fuzz_checkpoints(&SEED, 10_000, &bytes, &ALLOC, limit, |b| {
        use simkit_backend::Distributed;
        let comm = simkit_backend::comm::Comm::serial();
        if let Ok(mut d) = simkit_pp_coulomb::DistributedCoulomb::resume(b, comm) {
            let _ = d.step(2);
            d.checkpoint()?;
        }
        let mut pp = PpCoulomb::resume(b, Backend::Cpu)?;
        let _ = pp.step(2);
        Ok(())
    });
    println!(
        "{resumed} of 10000 resealed checkpoints ({} bytes) resumed",
        bytes.len()
    );
}
