//! Block splitting without MPI: `P` engines on `P` threads, each owning one block of
//! targets and exchanging through an in-process all-gather, step in lockstep and must hold
//! the bits of the single engine ([`Alone`]) — positions, velocities, accelerations and the
//! energy guard's reference — for block counts that divide neither `N` nor the SIMD width.

use std::any::Any;
use std::ops::Range;
use std::sync::{Arc, Barrier, Mutex};

use simkit_backend::comm::split;
use simkit_backend::{Precision, Real, Result};

use super::{Alone, CpuEngine, CpuReal, Share};
use crate::config::{Config, ForceLaw, Integrator};
use crate::guard::{Checks, Energy};
use crate::particles::{Particles, Region, Species, Velocities};

/// Where the threads of one simulated run leave their blocks.
struct Hub {
    slots: Mutex<Vec<Option<Box<dyn Any + Send>>>>,
    barrier: Barrier,
}

/// One simulated rank: block `rank` of `size` (the blocks of [`super::Ranks`]).
struct Thread {
    rank: usize,
    size: usize,
    hub: Arc<Hub>,
}

impl Share for Thread {
    fn own(&self, n: usize) -> Range<usize> {
        let (start, len) = split(n, self.size, self.rank);
        start..start + len
    }

    fn gather<U: Real>(&self, arrays: &mut [&mut [U]], n: usize) -> Result<()> {
        let own = self.own(n);
        let mine: Vec<Vec<U>> = arrays.iter().map(|a| a[own.clone()].to_vec()).collect();
        self.hub.slots.lock().expect("hub")[self.rank] = Some(Box::new(mine));
        self.hub.barrier.wait();
        {
            let slots = self.hub.slots.lock().expect("hub");
            for (r, slot) in slots.iter().enumerate() {
                let theirs = slot
                    .as_ref()
                    .and_then(|b| b.downcast_ref::<Vec<Vec<U>>>())
                    .expect("every thread left its block");
                let (start, len) = split(n, self.size, r);
                for (a, block) in arrays.iter_mut().zip(theirs) {
                    a[start..start + len].copy_from_slice(block);
                }
            }
        }
        // Nobody overwrites a slot before all have read it.
        self.hub.barrier.wait();
        Ok(())
    }
}

/// 101 particles of two species in a cube (101 = 6 x 16 + 5).
fn plasma() -> Particles {
    let mut p = Particles::new();
    let e = p.add_species(Species::new("electron", -1.0, 1.0)).unwrap();
    let ion = p.add_species(Species::new("ion", 2.0, 40.0)).unwrap();
    let cube = Region::Cube {
        min: [-5.0; 3],
        length: 10.0,
    };
    let v = Velocities::Maxwellian { thermal_speed: 0.2 };
    p.fill(e, 70, cube, v, 3).unwrap();
    p.fill(ion, 31, cube, v, 4).unwrap();
    p
}

/// What a run ends with: positions and velocities, accelerations, energy reference, and
/// the run's result (`Ok` or the blow-up, as text).
type Outcome = (
    crate::particles::PositionsVelocities,
    Vec<[f64; 3]>,
    Option<Energy>,
    String,
);

/// The bits of an outcome (so -0.0 and 0.0 differ, and NaN equals itself).
fn bits(o: &Outcome) -> Vec<u64> {
    let ((x, v), a, e, _) = o;
    let e = e.map(|e| [e.kinetic, e.potential]);
    x.iter()
        .chain(v)
        .chain(a)
        .flatten()
        .chain(e.iter().flatten())
        .map(|c| c.to_bits())
        .collect()
}

/// Runs `steps` steps of `engine` with the checks of `c` through `share`.
fn advance<T: CpuReal>(
    mut engine: CpuEngine<T>,
    p: &Particles,
    c: &Config,
    steps: u32,
    share: &impl Share,
) -> Outcome {
    let mut energy_ref = Some(engine.energy_now(share).unwrap());
    let mut checks = Checks {
        done: 0,
        every: c.check_every,
        // As `Run::energy_tolerance`: the energy guard runs under the exact law only.
        energy_tolerance: c.energy_tolerance.filter(|_| c.force == ForceLaw::Exact),
        energy_ref: &mut energy_ref,
        charge: &p.charge,
        mass: &p.mass,
        dt: c.dt,
        integrator: c.integrator,
    };
    let result = format!("{:?}", engine.run(steps, &mut checks, share));
    let acc = engine.accelerations_with(share).unwrap();
    (engine.state_now(), acc, energy_ref, result)
}

/// The outcome of every one of `size` threads.
fn split_run<T: CpuReal>(p: &Particles, c: &Config, steps: u32, size: usize) -> Vec<Outcome> {
    let hub = Arc::new(Hub {
        slots: Mutex::new((0..size).map(|_| None).collect()),
        barrier: Barrier::new(size),
    });
    std::thread::scope(|s| {
        let runs: Vec<_> = (0..size)
            .map(|rank| {
                let share = Thread {
                    rank,
                    size,
                    hub: hub.clone(),
                };
                s.spawn(move || advance(CpuEngine::<T>::new(p, c, None), p, c, steps, &share))
            })
            .collect();
        runs.into_iter()
            .map(|r| r.join().expect("thread"))
            .collect()
    })
}

fn blocks_match_one_engine<T: CpuReal>(precision: Precision, mixed: bool) {
    let p = plasma();
    // The exact law at dt = 0.02 blows up at the check of step 21 (a close ion-electron
    // pair) and rolls back to step 14: the blocks must agree on that too.
    let cases = [
        (ForceLaw::Exact, Integrator::Leapfrog, 0.002, "Ok(())"),
        (
            ForceLaw::Exact,
            Integrator::Leapfrog,
            0.02,
            "Err(BlowUp { step: 21,",
        ),
        (
            ForceLaw::Plummer { epsilon: 0.3 },
            Integrator::SymplecticEuler,
            0.02,
            "Ok(())",
        ),
        (
            ForceLaw::Exclusion { radius: 0.8 },
            Integrator::Leapfrog,
            0.02,
            "Ok(())",
        ),
    ];
    for (law, integrator, dt, result) in cases {
        let c = Config::new(dt, law)
            .with_integrator(integrator)
            .with_precision(precision)
            .with_mixed(mixed)
            .with_check_every(7);
        let one = advance(CpuEngine::<T>::new(&p, &c, None), &p, &c, 23, &Alone);
        assert!(one.0.0.iter().flatten().all(|x| x.is_finite()));
        assert!(one.3.starts_with(result), "{law:?} dt {dt}: {}", one.3);
        let (one, one_result) = (bits(&one), one.3);
        for size in [2, 3, 7] {
            for (rank, got) in split_run::<T>(&p, &c, 23, size).iter().enumerate() {
                assert_eq!(got.3, one_result, "{law:?} block {rank} of {size}");
                assert!(
                    bits(got) == one,
                    "{law:?} {integrator:?} {precision:?} (mixed: {mixed}): block {rank} of \
                     {size} differs from the single engine"
                );
            }
        }
    }
}

#[test]
fn blocks_on_threads_match_one_engine_f64() {
    blocks_match_one_engine::<f64>(Precision::F64, false);
}

#[test]
fn blocks_on_threads_match_one_engine_f32() {
    blocks_match_one_engine::<f32>(Precision::F32, false);
}

/// The mixed mode (an f64 engine running the f32 kernel on split coordinates).
#[test]
fn blocks_on_threads_match_one_engine_mixed() {
    blocks_match_one_engine::<f64>(Precision::F32, true);
}
