//! Property tests: every public entry point driven with arbitrary values (NaN, ±inf, 0,
//! negative, huge, mismatched lengths) returns `Ok` with a finite result or a clear `Err`,
//! never a panic. About 13 000 cases (60 of them on the GPU, 1500 on `DistributedMd`),
//! reproducible: each runner uses a fixed ChaCha seed (`SEED`) and no failure persistence,
//! so a failure shows the same case on every run.

use simkit_backend::Distributed;
use std::sync::atomic::{AtomicUsize, Ordering};

use proptest::prelude::*;
use proptest::test_runner::TestCaseError;
use simkit_backend::comm::Comm;
use simkit_backend::testing::robust::{self, awkward_f64, clear};
use simkit_backend::{Backend, Error, Precision, Restart, Simulation};
use simkit_md::{
    Config, Dim, DistributedMd, GpuKernel, Integrator, Langevin, LennardJones, Md, PairTable,
    System, scenes,
};

const SEED: [u8; 32] = *b"simkit-md robustness seed 2026!!";

/// Records the largest allocation (the checkpoint fuzzing checks it).
#[global_allocator]
static ALLOC: simkit_backend::testing::robust::LargestAllocation =
    simkit_backend::testing::robust::LargestAllocation::new();

/// Mostly sensible positive values, sometimes anything.
fn pos_num(lo: f64, hi: f64) -> impl Strategy<Value = f64> {
    prop_oneof![3 => lo..hi, 1 => awkward_f64()]
}

fn params() -> impl Strategy<Value = LennardJones> {
    (
        pos_num(0.1, 2.0),
        pos_num(0.3, 1.5),
        pos_num(0.0, 2.0),
        pos_num(0.0, 2.0),
        pos_num(0.5, 3.0),
    )
        .prop_map(|(eps, sigma, a, b, r_c)| LennardJones::weighted(eps, sigma, a, b, r_c))
}

fn finite_state(md: &mut Md) -> Result<(), TestCaseError> {
    let s = md.state().map_err(|e| TestCaseError::fail(e.to_string()))?;
    prop_assert!(
        s.positions
            .iter()
            .chain(&s.velocities)
            .flatten()
            .all(|x| x.is_finite()),
        "non-finite state returned as Ok"
    );
    Ok(())
}

#[test]
fn pair_tables_accept_valid_entries_and_refuse_the_rest() {
    robust::run(
        &SEED,
        3000,
        (0usize..5, 0usize..5, 0usize..5, params(), params()),
        |(n, i, j, p, q)| {
            match PairTable::uniform(n, p) {
                Ok(mut t) => {
                    match t.set(i, j, q) {
                        Ok(()) => {
                            prop_assert_eq!(t.get(i, j), Some(q));
                            prop_assert_eq!(t.get(j, i), Some(q));
                        }
                        Err(e) => clear(&e)?,
                    }
                    prop_assert!(t.validate().is_ok());
                    let c = t.coefficients::<f32>(true);
                    for (k, c) in c.iter().enumerate() {
                        let r2 = c.rc2 * 0.5;
                        let (f, e) = <LennardJones as simkit_md::PairLaw>::force_energy(c, r2);
                        prop_assert!(f.is_finite() && e.is_finite(), "entry {k}: {c:?}");
                    }
                }
                Err(e) => clear(&e)?,
            }
            Ok(())
        },
    );
}

fn dim() -> impl Strategy<Value = Dim> {
    prop_oneof![Just(Dim::Two), Just(Dim::Three)]
}

fn vec3() -> impl Strategy<Value = [f64; 3]> {
    [pos_num(0.0, 8.0), pos_num(0.0, 8.0), pos_num(0.0, 8.0)]
}

#[test]
fn systems_refuse_bad_boxes_masses_and_particles() {
    robust::run(
        &SEED,
        3000,
        (
            dim(),
            vec3(),
            [pos_num(5.0, 12.0), pos_num(5.0, 12.0), pos_num(5.0, 12.0)],
            any::<[bool; 3]>(),
            prop::collection::vec(pos_num(0.5, 2.0), 0..3),
            prop::collection::vec((0u32..3, vec3(), vec3()), 0..4),
            0usize..3,
        ),
        |(dim, lo, len, periodic, masses, particles, cut)| {
            let table = PairTable::uniform(2, LennardJones::new(1.0, 1.0, 2.5)).unwrap();
            let mut sys = match System::new(dim, lo, len, periodic, masses, table) {
                Ok(s) => s,
                Err(e) => return clear(&e),
            };
            for &(s, x, v) in &particles {
                if let Err(e) = sys.add_particle(s, x, v) {
                    clear(&e)?;
                }
            }
            // Mismatched lengths.
            let kinds: Vec<u32> = particles.iter().map(|p| p.0).collect();
            let xs: Vec<[f64; 3]> = particles.iter().map(|p| p.1).collect();
            let vs: Vec<[f64; 3]> = particles.iter().map(|p| p.2).skip(cut).collect();
            if let Err(e) = sys.set_particles(&kinds, &xs, &vs) {
                clear(&e)?;
            }
            Ok(())
        },
    );
}

fn integrator() -> impl Strategy<Value = Integrator> {
    prop_oneof![Just(Integrator::VelocityVerlet), Just(Integrator::Leapfrog)]
}

fn precision() -> impl Strategy<Value = Precision> {
    prop_oneof![Just(Precision::F64), Just(Precision::F32)]
}

/// The two-species system of the run property tests: an 8^3 box (`dim`), the pair
/// parameters `p` for every pair, the `particles` (species, position, velocity; z dropped in
/// 2D), species 1 frozen or not. `None` when a builder refused the input with a clear error.
fn system(
    dim: Dim,
    p: LennardJones,
    particles: &[(u32, [f64; 3], [f64; 3])],
    periodic: [bool; 3],
    frozen: bool,
) -> Result<Option<System>, TestCaseError> {
    let table = match PairTable::uniform(2, p) {
        Ok(t) => t,
        Err(e) => return clear(&e).map(|()| None),
    };
    let mut sys = match System::new(dim, [0.0; 3], [8.0; 3], periodic, vec![1.0, 2.0], table) {
        Ok(s) => s,
        Err(e) => return clear(&e).map(|()| None),
    };
    for &(s, mut x, mut v) in particles {
        if dim == Dim::Two {
            x[2] = 0.0;
            v[2] = 0.0;
        }
        if let Err(e) = sys.add_particle(s, x, v) {
            clear(&e)?;
        }
    }
    if let Err(e) = sys.set_frozen(1, frozen) {
        clear(&e)?;
    }
    Ok(Some(sys))
}

#[test]
fn runs_step_to_a_finite_state_or_a_clear_error() {
    let stepped = AtomicUsize::new(0);
    let blown = AtomicUsize::new(0);
    robust::run(
        &SEED,
        2500,
        (
            dim(),
            params(),
            prop::collection::vec(
                (
                    0u32..2,
                    vec3(),
                    [pos_num(-2.0, 2.0), pos_num(-2.0, 2.0), pos_num(-2.0, 2.0)],
                ),
                1..5,
            ),
            (
                prop::option::of(pos_num(0.0005, 0.05)),
                pos_num(0.0, 0.5),
                0u32..20,
                integrator(),
                precision(),
                any::<bool>(),
                any::<bool>(),
            ),
            any::<[bool; 3]>(),
            0u32..40,
            (
                prop::option::of((pos_num(0.0, 3.0), pos_num(0.0, 10.0), any::<u32>())),
                prop::option::of((pos_num(0.0, 3.0), pos_num(0.0, 10.0))),
                any::<bool>(),
            ),
        ),
        |(
            dim,
            p,
            particles,
            (dt, skin, check_every, integrator, precision, shift, allow),
            periodic,
            steps,
            (thermostat, species_target, frozen),
        )| {
            let Some(mut sys) = system(dim, p, &particles, periodic, frozen)? else {
                return Ok(());
            };
            if let Err(e) = sys.set_species_langevin(0, species_target.map(|(t, g)| [t, g])) {
                clear(&e)?;
            }
            let config = Config {
                dt,
                integrator,
                gpu_kernel: GpuKernel::default(),
                precision,
                skin,
                check_every,
                shift,
                allow_unstable_dt: allow,
                thermostat: thermostat.map(|(t, g, seed)| Langevin::new(t, g, seed)),
            };
            let mut md = match Md::new(sys, &config, Backend::Cpu) {
                Ok(m) => m,
                Err(e) => return clear(&e),
            };
            stepped.fetch_add(1, Ordering::Relaxed);
            match md.step(steps) {
                Ok(()) => {
                    prop_assert_eq!(md.steps_done(), u64::from(steps));
                }
                Err(e) => {
                    blown.fetch_add(1, Ordering::Relaxed);
                    prop_assert!(matches!(e, Error::BlowUp { .. }), "{e}");
                    clear(&e)?;
                }
            }
            finite_state(&mut md)?;
            let d = md
                .diagnostics()
                .map_err(|e| TestCaseError::fail(e.to_string()))?;
            prop_assert!(d.kinetic.is_finite());
            let f = md
                .forces()
                .map_err(|e| TestCaseError::fail(e.to_string()))?;
            prop_assert!(f.iter().flatten().all(|x| x.is_finite()));
            Ok(())
        },
    );
    let (stepped, blown) = (stepped.into_inner(), blown.into_inner());
    eprintln!("{stepped} of 2500 cases built and stepped, {blown} of them blew up");
    // The generator must reach the stepping code often, not only the constructors.
    assert!(stepped >= 500, "{stepped}");
}

/// `DistributedMd` (one process) on the same arbitrary runs: it accepts exactly what `Md`
/// accepts in `f64` (and refuses `f32` clearly), and steps to a finite state or a clear
/// error.
#[test]
fn distributed_runs_step_to_a_finite_state_or_a_clear_error() {
    let stepped = AtomicUsize::new(0);
    robust::run(
        &SEED,
        1500,
        (
            dim(),
            params(),
            prop::collection::vec(
                (
                    0u32..2,
                    vec3(),
                    [pos_num(-2.0, 2.0), pos_num(-2.0, 2.0), pos_num(-2.0, 2.0)],
                ),
                0..6,
            ),
            (
                prop::option::of(pos_num(0.0005, 0.05)),
                pos_num(0.0, 0.5),
                0u32..20,
                integrator(),
                prop_oneof![3 => Just(Precision::F64), 1 => Just(Precision::F32)],
                any::<bool>(),
                any::<bool>(),
            ),
            any::<[bool; 3]>(),
            0u32..40,
            (
                prop::option::of((pos_num(0.0, 3.0), pos_num(0.0, 10.0), any::<u32>())),
                any::<bool>(),
            ),
        ),
        |(
            dim,
            p,
            particles,
            (dt, skin, check_every, integrator, precision, shift, allow),
            periodic,
            steps,
            (thermostat, frozen),
        )| {
            let Some(sys) = system(dim, p, &particles, periodic, frozen)? else {
                return Ok(());
            };
            let config = Config {
                dt,
                integrator,
                gpu_kernel: GpuKernel::default(),
                precision,
                skin,
                check_every,
                shift,
                allow_unstable_dt: allow,
                thermostat: thermostat.map(|(t, g, seed)| Langevin::new(t, g, seed)),
            };
            let made = DistributedMd::new(sys.clone(), &config, Comm::serial());
            if precision == Precision::F64 {
                let md = Md::new(sys, &config, Backend::Cpu);
                prop_assert_eq!(
                    md.is_ok(),
                    made.is_ok(),
                    "Md: {:?}, DistributedMd: {:?}",
                    md.err(),
                    made.as_ref().err()
                );
            }
            let mut sim = match made {
                Ok(m) => m,
                Err(e) => return clear(&e),
            };
            stepped.fetch_add(1, Ordering::Relaxed);
            match sim.step(steps) {
                Ok(()) => prop_assert_eq!(sim.steps_done(), u64::from(steps)),
                Err(e) => {
                    prop_assert!(matches!(e, Error::BlowUp { .. }), "{e}");
                    clear(&e)?;
                }
            }
            let s = sim
                .state()
                .map_err(|e| TestCaseError::fail(e.to_string()))?;
            prop_assert!(
                s.positions
                    .iter()
                    .chain(&s.velocities)
                    .flatten()
                    .all(|x| x.is_finite()),
                "non-finite state returned as Ok"
            );
            let d = sim
                .diagnostics()
                .map_err(|e| TestCaseError::fail(e.to_string()))?;
            prop_assert!(d.kinetic.is_finite());
            let f = sim
                .forces()
                .map_err(|e| TestCaseError::fail(e.to_string()))?;
            prop_assert!(f.iter().flatten().all(|x| x.is_finite()));
            let bytes = sim
                .checkpoint()
                .map_err(|e| TestCaseError::fail(e.to_string()))?;
            let again = DistributedMd::<LennardJones>::resume(&bytes, Comm::serial())
                .map_err(|e| TestCaseError::fail(e.to_string()))?;
            prop_assert_eq!(again.steps_done(), sim.steps_done());
            Ok(())
        },
    );
    let stepped = stepped.into_inner();
    eprintln!("{stepped} of 1500 cases built and stepped");
    assert!(stepped >= 150, "{stepped}");
}

#[cfg(feature = "gpu")]
#[test]
fn gpu_runs_step_to_a_finite_state_or_a_clear_error() {
    let Some(ctx) =
        simkit_backend::testing::shared_gpu("gpu_runs_step_to_a_finite_state_or_a_clear_error")
    else {
        return;
    };
    // A small set: every case builds GPU kernels.
    robust::run(
        &SEED,
        60,
        (
            params(),
            prop::collection::vec((0u32..2, vec3(), vec3()), 0..4),
            prop::option::of(pos_num(0.0005, 0.05)),
            integrator(),
            any::<[bool; 3]>(),
            0u32..30,
            prop::option::of(prop::option::of(0u32..6)),
        ),
        |(p, particles, dt, integrator, periodic, steps, block)| {
            let table = match PairTable::uniform(2, p) {
                Ok(t) => t,
                Err(e) => return clear(&e),
            };
            let mut sys = match System::new(
                Dim::Three,
                [0.0; 3],
                [8.0; 3],
                periodic,
                vec![1.0, 2.0],
                table,
            ) {
                Ok(s) => s,
                Err(e) => return clear(&e),
            };
            for &(s, x, v) in &particles {
                if let Err(e) = sys.add_particle(s, x, v) {
                    clear(&e)?;
                }
            }
            // Either kernel; the cell block with an automatic or a (too) small capacity.
            let gpu_kernel = block.map_or(GpuKernel::PerParticle, |slots| GpuKernel::CellBlock {
                slots,
            });
            let config = Config {
                dt,
                integrator,
                gpu_kernel,
                allow_unstable_dt: true,
                check_every: 7,
                ..Config::default()
            };
            let mut md = match Md::new(sys, &config, Backend::Gpu(ctx)) {
                Ok(m) => m,
                Err(e) => return clear(&e),
            };
            if let Err(e) = md.step(steps) {
                // A cell block over its capacity is refused by name, not a blow-up.
                let full =
                    matches!(&e, Error::InvalidParameter { name, .. } if name.contains("slots"));
                prop_assert!(matches!(e, Error::BlowUp { .. }) || full, "{e}");
            }
            finite_state(&mut md)?;
            Ok(())
        },
    );
}

/// The checkpoint of a 108-atom Lennard-Jones crystal after 5 steps.
fn small_checkpoint() -> Vec<u8> {
    let sys = scenes::fcc_lattice(
        [3; 3],
        0.3,
        1.0,
        PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5)).unwrap(),
        &[0],
        1,
    )
    .unwrap();
    let mut md = Md::new(sys, &Config::default(), Backend::Cpu).unwrap();
    md.step(5).unwrap();
    md.checkpoint().unwrap()
}

#[test]
fn garbled_and_truncated_checkpoints_are_refused() {
    let bytes = small_checkpoint();
    let n = bytes.len();
    robust::run(
        &SEED,
        2000,
        (0..n, 0..n, any::<u8>(), any::<bool>()),
        |(cut, at, x, truncate)| {
            let mut b = bytes.clone();
            if truncate {
                b.truncate(cut);
            } else if b[at] != x {
                b[at] = x;
            } else {
                return Ok(());
            }
            match Md::<LennardJones>::resume(&b, Backend::Cpu) {
                Ok(mut m) => {
                    // Only an unchanged payload passes the checksum.
                    prop_assert!(false, "accepted a damaged checkpoint");
                    finite_state(&mut m)?;
                }
                Err(e) => {
                    prop_assert!(matches!(e, Error::Checkpoint { .. }), "{e}");
                    clear(&e)?;
                }
            }
            // The same bytes are Md's format for DistributedMd too.
            match DistributedMd::<LennardJones>::resume(&b, Comm::serial()) {
                Ok(_) => prop_assert!(false, "DistributedMd accepted a damaged checkpoint"),
                Err(e) => {
                    prop_assert!(matches!(e, Error::Checkpoint { .. }), "{e}");
                    clear(&e)?;
                }
            }
            Ok(())
        },
    );
}

fn cells() -> impl Strategy<Value = usize> {
    prop_oneof![3 => 0usize..4, 1 => Just(usize::MAX), 1 => Just(1usize << 30)]
}

#[test]
fn lattices_refuse_bad_sizes_before_allocating() {
    robust::run(
        &SEED,
        1000,
        (
            [cells(), cells(), cells()],
            pos_num(0.05, 1.0),
            pos_num(0.0, 2.0),
            prop::collection::vec(0u32..3, 0..3),
        ),
        |(cells, density, temperature, species)| {
            let table = PairTable::uniform(2, LennardJones::new(1.0, 1.0, 1.0)).unwrap();
            match scenes::fcc_lattice(cells, density, temperature, table, &species, 3) {
                Ok(s) => {
                    prop_assert!(s.particle_count() <= 4 * 27);
                    prop_assert!(s.velocities().iter().flatten().all(|v| v.is_finite()));
                }
                Err(e) => clear(&e)?,
            }
            Ok(())
        },
    );
}

#[test]
fn resealed_checkpoints_never_panic_nor_allocate_past_their_size() {
    // 10^4 variants of a checkpoint past the checksum, each resumed by Md (and stepped) and
    // by DistributedMd.
    let bytes = small_checkpoint();
    let limit = |len: usize| (64 * len).max(8 << 20);
    let resumed = robust::fuzz_checkpoints(&SEED, 10_000, &bytes, &ALLOC, limit, |b| {
        if let Ok(mut d) = DistributedMd::<LennardJones>::resume(b, Comm::serial()) {
            let _ = d.step(2);
            d.checkpoint()?;
        }
        let mut md = Md::<LennardJones>::resume(b, Backend::Cpu)?;
        let _ = md.step(2);
        Ok(())
    });
    println!(
        "{resumed} of 10000 resealed checkpoints ({} bytes) resumed",
        bytes.len()
    );
}
