//! Property tests: arbitrary inputs through the public API (grid and model constructors and
//! accessors, stepping and config values, `Rd::new`, `step`, `set_stepping`, checkpoint
//! decoding) give `Ok` with finite results or a clear `Err`, never a panic.
//!
//! Reproducible: every runner starts from the fixed seed `SEED` (ChaCha), so each run draws
//! the same cases; no failure persistence files are used. 10 560 cases in all, a few seconds
//! in release mode (tiny grids, few steps, the CPU backend; one small GPU set).

use proptest::prelude::*;
use simkit_backend::testing::robust::{self, awkward_f64};
use simkit_backend::{Backend, Error, Restart, Simulation, checkpoint};
use simkit_rd::{
    Boundaries, Boundary, Colony, Config, Diffusion, GpuKernel, GpuOptions, GrayScott, Grid, Guard,
    Integrator, Model, Rd, Real, Stepping,
};

const SEED: [u8; 32] = *b"simkit-rd robustness, fixed seed";

/// Records the largest allocation (the checkpoint fuzzing checks it).
#[global_allocator]
static ALLOC: simkit_backend::testing::robust::LargestAllocation =
    simkit_backend::testing::robust::LargestAllocation::new();

/// Mostly a valid value from `valid`, sometimes a wild one.
fn mostly(valid: impl Strategy<Value = f64> + 'static) -> BoxedStrategy<f64> {
    prop_oneof![4 => valid, 1 => awkward_f64()].boxed()
}

/// Mostly a valid count from `valid`, sometimes an edge case.
fn mostly_count(valid: impl Strategy<Value = u32> + 'static) -> BoxedStrategy<u32> {
    prop_oneof![4 => valid, 1 => counts()].boxed()
}

/// Sizes: 0, small, and huge ones (each huge one alone exceeds the grid limit).
fn size() -> impl Strategy<Value = usize> {
    prop_oneof![
        Just(0usize),
        1..7usize,
        Just(1usize << 30),
        Just(1usize << 40),
        Just(usize::MAX),
    ]
}

fn counts() -> impl Strategy<Value = u32> {
    prop_oneof![
        Just(0u32),
        Just(1),
        Just(3),
        Just(16),
        Just(17),
        Just(100),
        Just(u32::MAX)
    ]
}

fn boundaries() -> impl Strategy<Value = Boundaries> {
    let edge = prop_oneof![
        Just(Boundary::NoFlux),
        Just(Boundary::Periodic),
        prop::collection::vec(awkward_f64(), 0..4).prop_map(Boundary::Dirichlet),
    ];
    (edge.clone(), edge.clone(), edge.clone(), edge).prop_map(|(west, east, south, north)| {
        Boundaries {
            west,
            east,
            south,
            north,
        }
    })
}

/// A bad input must be refused with one of the input errors, never anything else.
fn is_input_error(e: &Error) -> bool {
    matches!(
        e,
        Error::InvalidParameter { .. } | Error::Unstable { .. } | Error::Unsupported(_)
    )
}

fn all_finite<T: Real>(g: &Grid<T>) -> bool {
    g.fields()
        .iter()
        .all(|f| f.iter().all(|v| v.to_f64().is_finite()))
}

/// Grid constructors and accessors: sizes 0, huge and overflowing `nx * ny * species`, NaN
/// and huge values, mismatched field lengths, bad edges, out-of-range cells and species.
#[test]
fn grid_constructors_and_accessors() {
    robust::runner(&SEED, 3000)
        .run(
            &(
                size(),
                size(),
                awkward_f64(),
                prop_oneof![
                    Just(0usize),
                    1..4usize,
                    Just(1usize << 40),
                    Just(usize::MAX)
                ],
                awkward_f64(),
                boundaries(),
                0..3usize,
                (0..8usize, 0..8usize, 0..4usize),
            ),
            |(nx, ny, h, species, value, bc, mismatch, (i, j, s))| {
                let uniform = Grid::uniform(nx, ny, h, bc.clone(), species, value);
                match &uniform {
                    Ok(g) => {
                        prop_assert!(value.is_finite() && h.is_finite() && h > 0.0);
                        prop_assert_eq!((g.nx(), g.ny(), g.species()), (nx, ny, species));
                        prop_assert!(all_finite(g));
                        prop_assert_eq!(g.get(s, i, j).is_some(), s < species && i < nx && j < ny);
                        prop_assert_eq!(g.try_field(s).is_some(), s < species);
                        prop_assert_eq!(g.field(s).is_empty(), s >= species);
                        prop_assert_eq!(g.max_abs(s).is_nan(), s >= species);
                        prop_assert!(s < species || g.total(s).is_nan());
                        let c = g.convert::<f32>();
                        prop_assert_eq!(c.species(), species);
                    }
                    Err(e) => prop_assert!(matches!(e, Error::InvalidParameter { .. }), "{e}"),
                }
                // Grid::new with fields of the right (or a wrong) length, when small.
                if nx <= 8 && ny <= 8 && species <= 3 {
                    let len = (nx * ny + mismatch).saturating_sub(usize::from(mismatch == 2) * 2);
                    let fields = vec![vec![value; len]; species];
                    match Grid::new(nx, ny, h, bc, fields) {
                        Ok(g) => {
                            prop_assert_eq!(g.field(0).len(), nx * ny);
                            prop_assert!(all_finite(&g));
                        }
                        Err(e) => prop_assert!(matches!(e, Error::InvalidParameter { .. }), "{e}"),
                    }
                }
                Ok(())
            },
        )
        .unwrap();
}

/// Model constructors with NaN, negative, infinite and huge parameters, wrong species
/// counts and coefficient fields of the wrong size.
#[test]
fn model_constructors() {
    robust::runner(&SEED, 2500)
        .run(
            &(
                prop::collection::vec(awkward_f64(), 0..6),
                (awkward_f64(), awkward_f64(), awkward_f64(), awkward_f64()),
                (
                    awkward_f64(),
                    size(),
                    size(),
                    prop::collection::vec(awkward_f64(), 0..40),
                ),
            ),
            |(ds, (du, dv, f, k), (gamma, nx, ny, d))| {
                match Diffusion::new(&ds) {
                    Ok(m) => {
                        prop_assert!((1..=4).contains(&ds.len()));
                        prop_assert!(ds.iter().all(|v| v.is_finite() && *v >= 0.0));
                        prop_assert_eq!(m.species(), ds.len());
                    }
                    Err(e) => prop_assert!(matches!(e, Error::InvalidParameter { .. }), "{e}"),
                }
                match GrayScott::new(du, dv, f, k) {
                    Ok(_) => {
                        prop_assert!([du, dv, f, k].iter().all(|v| v.is_finite() && *v >= 0.0))
                    }
                    Err(e) => prop_assert!(matches!(e, Error::InvalidParameter { .. }), "{e}"),
                }
                match Colony::new(gamma, nx, ny, d.clone()) {
                    Ok(m) => {
                        prop_assert!(gamma.is_finite() && gamma >= 0.0);
                        prop_assert_eq!(Some(d.len()), nx.checked_mul(ny));
                        prop_assert!(m.reaction(1.0, 1.0).is_finite() || gamma.is_nan());
                    }
                    Err(e) => prop_assert!(matches!(e, Error::InvalidParameter { .. }), "{e}"),
                }
                match Colony::random_d(nx, ny, 0.75, 0.4, 1) {
                    Ok(d) => prop_assert_eq!(d.len(), nx * ny),
                    Err(e) => prop_assert!(matches!(e, Error::InvalidParameter { .. }), "{e}"),
                }
                Ok(())
            },
        )
        .unwrap();
}

/// The models a run is built with.
#[derive(Clone, Debug)]
enum AnyModel {
    Diffusion(Vec<f64>),
    GrayScott(f64, f64, f64, f64),
    Colony(f64, f64),
}

fn any_model() -> impl Strategy<Value = AnyModel> {
    let rate = || mostly(0.0..1.0f64);
    prop_oneof![
        prop::collection::vec(rate(), 1..3).prop_map(AnyModel::Diffusion),
        (rate(), rate(), rate(), rate()).prop_map(|(a, b, c, d)| AnyModel::GrayScott(a, b, c, d)),
        (rate(), rate()).prop_map(|(g, d)| AnyModel::Colony(g, d)),
    ]
}

fn stepping() -> impl Strategy<Value = Stepping> {
    (mostly(0.001..0.3f64), any::<bool>(), any::<bool>()).prop_map(|(dt, heun, over)| Stepping {
        dt,
        integrator: if heun {
            Integrator::Heun
        } else {
            Integrator::Euler
        },
        guard: if over {
            Guard::Override
        } else {
            Guard::Enforce
        },
    })
}

fn config() -> impl Strategy<Value = Config> {
    (
        stepping(),
        mostly_count(1..=16u32),
        counts(),
        (
            mostly_count(1..=16u32),
            mostly_count(1..=16u32),
            mostly_count(1..=50u32),
            any::<bool>(),
        ),
    )
        .prop_map(|(stepping, sweep, every, (tx, ty, submit, global))| {
            Config::new(stepping)
                .with_steps_per_sweep(sweep)
                .with_check_every(every)
                .with_gpu(GpuOptions {
                    kernel: if global {
                        GpuKernel::Global
                    } else {
                        GpuKernel::Tiled
                    },
                    tile: (tx, ty),
                    steps_per_submit: submit,
                })
        })
}

/// A tiny run: a grid of 1..6 x 1..6 cells with values drawn from `values`.
#[derive(Clone, Debug)]
struct Case {
    nx: usize,
    ny: usize,
    h: f64,
    /// The grid's species count when not the model's.
    species: Option<usize>,
    values: Vec<f64>,
    model: AnyModel,
    config: Config,
    steps: Vec<u32>,
    later: Stepping,
}

fn case() -> impl Strategy<Value = Case> {
    (
        (
            1..6usize,
            1..6usize,
            mostly(prop_oneof![Just(1.0), Just(0.5)]),
        ),
        prop::collection::vec(prop_oneof![9 => 0.0..1.5f64, 1 => awkward_f64()], 72),
        any_model(),
        config(),
        prop::collection::vec(prop_oneof![0..40u32, Just(250u32)], 1..4),
        stepping(),
        prop_oneof![6 => Just(None), 1 => (0..4usize).prop_map(Some)],
    )
        .prop_map(
            |((nx, ny, h), values, model, config, steps, later, species)| Case {
                nx,
                ny,
                h,
                species,
                values,
                model,
                config,
                steps,
                later,
            },
        )
}

fn build<T: Real, M: Model>(
    c: &Case,
    model: M,
    backend: Backend<'_>,
) -> Option<simkit_backend::Result<Rd<T, M>>> {
    let n = c.nx * c.ny;
    let fields = (0..c.species.unwrap_or(model.species()))
        .map(|s| {
            (0..n)
                .map(|k| T::from_f64(c.values[(s * 36 + k) % 72]))
                .collect()
        })
        .collect();
    let grid = match Grid::new(c.nx, c.ny, c.h, Boundaries::no_flux(), fields) {
        Ok(g) => g,
        Err(e) => {
            assert!(matches!(e, Error::InvalidParameter { .. }), "{e}");
            return None;
        }
    };
    Some(Rd::new(grid, model, &c.config, backend))
}

/// Steps a built run through the case's calls and a later `set_stepping`: each call is
/// `Ok` with finite fields, `BlowUp` holding the finite state of `rolled_back_to`, or an
/// input error; then a checkpoint round trip.
fn drive<T: Real, M: Model>(c: &Case, mut sim: Rd<T, M>) -> Result<(), TestCaseError> {
    for &n in &c.steps {
        let before = sim.steps_done();
        match sim.step(n) {
            Ok(()) => prop_assert_eq!(sim.steps_done(), before + u64::from(n)),
            Err(Error::BlowUp {
                rolled_back_to,
                step,
                ..
            }) => {
                prop_assert_eq!(sim.steps_done(), rolled_back_to);
                prop_assert!(before <= rolled_back_to && rolled_back_to <= step);
            }
            Err(e) => {
                prop_assert!(is_input_error(&e), "{e}");
                prop_assert_eq!(sim.steps_done(), before);
            }
        }
        let g = sim.state().unwrap();
        prop_assert!(
            all_finite(&g),
            "non-finite state after {} steps",
            sim.steps_done()
        );
        prop_assert!(sim.time().is_finite());
    }
    let old = sim.stepping();
    match sim.set_stepping(c.later) {
        Ok(()) => prop_assert_eq!(sim.stepping(), c.later),
        Err(e) => {
            prop_assert!(is_input_error(&e), "{e}");
            prop_assert_eq!(sim.stepping(), old);
        }
    }
    if let Ok(s) = sim.stable_dt() {
        prop_assert!(!s.is_nan());
    }
    let bytes = sim.checkpoint().unwrap();
    let mut back = Rd::<T, M>::resume(&bytes, Backend::Cpu);
    // The stored state is valid, except that its bound may be below an enforced dt.
    match &mut back {
        Ok(b) => prop_assert_eq!(b.checkpoint().unwrap(), bytes),
        Err(e) => prop_assert!(matches!(e, Error::Unstable { .. }), "{e}"),
    }
    Ok(())
}

fn run_case<T: Real>(c: &Case, backend: Backend<'_>) -> Result<bool, TestCaseError> {
    macro_rules! go {
        ($model:expr) => {
            match $model {
                Ok(m) => match build::<T, _>(c, m, backend) {
                    Some(Ok(sim)) => {
                        drive(c, sim)?;
                        Ok(true)
                    }
                    Some(Err(e)) => {
                        prop_assert!(is_input_error(&e), "{e}");
                        Ok(false)
                    }
                    None => Ok(false),
                },
                Err(e) => {
                    prop_assert!(matches!(e, Error::InvalidParameter { .. }), "{e}");
                    Ok(false)
                }
            }
        };
    }
    match &c.model {
        AnyModel::Diffusion(d) => go!(Diffusion::new(d)),
        AnyModel::GrayScott(a, b, f, k) => go!(GrayScott::new(*a, *b, *f, *k)),
        AnyModel::Colony(g, d) => go!(Colony::new(*g, c.nx, c.ny, vec![*d; c.nx * c.ny])),
    }
}

/// `Rd::new`, `step`, `set_stepping` and the checkpoint round trip on tiny grids with
/// arbitrary stepping (dt NaN/0/negative/huge, guard overridden or not, Euler or Heun) and
/// config (`steps_per_sweep` 0/17/huge, `check_every` 0/1/huge, tiles and submissions of any
/// size): f64 and f32 on the CPU.
#[test]
fn runs_on_tiny_grids() {
    let built = std::cell::Cell::new(0);
    robust::runner(&SEED, 2500)
        .run(&case(), |c| {
            let n = usize::from(run_case::<f64>(&c, Backend::Cpu)?)
                + usize::from(run_case::<f32>(&c, Backend::Cpu)?);
            built.set(built.get() + n);
            Ok(())
        })
        .unwrap();
    let built = built.get();
    println!("{built} runs built and stepped");
    assert!(
        built > 500,
        "only {built} runs were built: the strategy is too wild"
    );
}

/// The GPU accepts and refuses what the CPU does (except tiles over the device limits),
/// and its runs end finite or rolled back.
#[cfg(feature = "gpu")]
#[test]
fn gpu_runs_on_tiny_grids() {
    let Some(ctx) = simkit_backend::testing::gpu_or_skip("gpu_runs_on_tiny_grids") else {
        return;
    };
    let backend = Backend::Gpu(&ctx);
    robust::runner(&SEED, 60)
        .run(&case(), |mut c| {
            // Keep the GPU set small and inside the device's tile limits.
            c.config.gpu.tile = (
                c.config.gpu.tile.0.clamp(1, 16),
                c.config.gpu.tile.1.clamp(1, 16),
            );
            c.steps.truncate(2);
            let cpu = run_case::<f32>(&c, Backend::Cpu)?;
            let gpu = run_case::<f32>(&c, backend)?;
            prop_assert_eq!(cpu, gpu, "CPU built: {}, GPU built: {}", cpu, gpu);
            Ok(())
        })
        .unwrap();
}

/// Checkpoint decoding: random bytes, random bytes behind the magic, a valid checkpoint
/// truncated, extended or with bytes changed, and a well-formed file (valid checksum) whose
/// payload is random: `Error::Checkpoint` or, for a payload that happens to decode, the
/// validation errors of `Rd::new`; never a panic.
#[test]
fn checkpoint_decode_of_garbage() {
    let grid = simkit_rd::scenes::gray_scott_square::<f32>(6, 1.0, 2, 1).unwrap();
    let mut sim = Rd::new(
        grid,
        GrayScott::new(1.0, 0.5, 0.04, 0.06).unwrap(),
        &Config::new(Stepping::euler(0.2)),
        Backend::Cpu,
    )
    .unwrap();
    sim.step(5).unwrap();
    let good = sim.checkpoint().unwrap();
    let h = checkpoint::header(&good).unwrap();
    let head_len = 8 + 4 + 3 * 2 + h.package.len() + h.version.len() + h.model.len();
    let with_payload = |payload: &[u8]| {
        let mut b = good[..head_len].to_vec();
        b.extend_from_slice(&(payload.len() as u64).to_le_bytes());
        b.extend_from_slice(payload);
        let crc = crc32fast::hash(&b);
        b.extend_from_slice(&crc.to_le_bytes());
        b
    };
    // The real payload passes through the hand-made framing unchanged.
    assert_eq!(with_payload(&good[head_len + 8..good.len() - 4]), good);
    let real_payload = good[head_len + 8..good.len() - 4].to_vec();
    robust::runner(&SEED, 2500)
        .run(
            &(
                0..5u8,
                prop::collection::vec(any::<u8>(), 0..300),
                prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..4),
                any::<prop::sample::Index>(),
            ),
            |(kind, random, edits, cut)| {
                let bytes = match kind {
                    0 => random,
                    1 => [b"SIMKITCK".as_slice(), &random].concat(),
                    2 => good[..cut.index(good.len())].to_vec(),
                    3 => {
                        let mut b = good.clone();
                        for (at, v) in &edits {
                            let at = at.index(b.len());
                            b[at] = b[at].wrapping_add(v.max(&1).to_owned());
                        }
                        b
                    }
                    _ => {
                        let mut p = real_payload.clone();
                        for (at, v) in &edits {
                            let at = at.index(p.len());
                            p[at] ^= v.max(&1);
                        }
                        p.truncate(p.len() - cut.index(4));
                        with_payload(&p)
                    }
                };
                match Rd::<f32, GrayScott>::resume(&bytes, Backend::Cpu) {
                    Err(Error::Checkpoint { .. }) => {}
                    Err(e) => prop_assert!(kind == 4 && is_input_error(&e), "kind {kind}: {e}"),
                    Ok(mut r) => {
                        prop_assert_eq!(kind, 4);
                        prop_assert!(all_finite(&r.state().unwrap()));
                        let _ = r.step(3);
                        prop_assert!(all_finite(&r.state().unwrap()));
                    }
                }
                Ok(())
            },
        )
        .unwrap();
}

#[test]
fn resealed_checkpoints_never_panic_nor_allocate_past_their_size() {
    // 10^4 variants of a checkpoint past the checksum, each resumed by Rd (and stepped) and
    // by DistributedRd.
    let grid = simkit_rd::scenes::gray_scott_square::<f32>(6, 1.0, 2, 1).unwrap();
    let model = GrayScott::new(1.0, 0.5, 0.04, 0.06).unwrap();
    let mut sim = Rd::new(
        grid,
        model,
        &Config::new(Stepping::euler(0.2)),
        Backend::Cpu,
    )
    .unwrap();
    sim.step(5).unwrap();
    let bytes = sim.checkpoint().unwrap();
    let limit = |len: usize| (64 * len).max(8 << 20);
    let resumed = robust::fuzz_checkpoints(&SEED, 10_000, &bytes, &ALLOC, limit, |b| {
        use simkit_backend::Distributed;
        let comm = simkit_backend::comm::Comm::serial();
        if let Ok(mut d) = simkit_rd::DistributedRd::<f32, GrayScott>::resume(b, comm) {
            let _ = d.step(2);
            d.checkpoint()?;
        }
        let mut rd = Rd::<f32, GrayScott>::resume(b, Backend::Cpu)?;
        let _ = rd.step(2);
        Ok(())
    });
    println!(
        "{resumed} of 10000 resealed checkpoints ({} bytes) resumed",
        bytes.len()
    );
}
