//! The blow-up checks inside `step(n)` on every backend: a diverging run is stopped and put
//! back to the last state that passed a check, a colony whose diffusivity outgrows `dt`
//! during one long call is stopped at the first check over the bound, and the checks never
//! change the results (any `check_every`, any split of the run into calls).

use simkit_backend::rng::rng_uniform;
use simkit_backend::testing::backends;
use simkit_backend::{Backend, Error, Restart, Simulation};
use simkit_rd::scenes::{colony_scene, gray_scott_square};
use simkit_rd::{
    Colony, Config, GpuOptions, GrayScott, Grid, Model, Rd, Real, Stepping, stable_dt,
};

/// Every value of every field is finite.
fn finite<T: Real>(g: &Grid<T>) -> bool {
    g.fields()
        .iter()
        .all(|f| f.iter().all(|v| v.to_f64().is_finite()))
}

/// Bit patterns of every field (for exact comparisons that also tell -0 from 0).
fn bits<T: Real>(g: &Grid<T>) -> Vec<u64> {
    g.fields()
        .iter()
        .flatten()
        .map(|v| v.to_f64().to_bits())
        .collect()
}

/// A run with `dt` far over the bound (guard overridden) returns `BlowUp` naming the step, a
/// cell and the cause; it holds the state of step `rolled_back_to`, finite and bit-identical
/// to an identical run stepped exactly that far, and `steps_done()` is that step.
fn diverging_run_is_rolled_back<T: Real, M: Model>(
    backend: Backend<'_>,
    grid: &Grid<T>,
    model: &M,
    dt: f64,
    check_every: u32,
) {
    let config = Config::new(Stepping::euler(dt).unguarded()).with_check_every(check_every);
    let mut sim = Rd::new(grid.clone(), model.clone(), &config, backend).unwrap();
    // A first call that passes, so the rollback goes to a step inside the second call.
    sim.step(3).unwrap();
    let e = sim.step(2000).unwrap_err();
    let name = sim.backend_name();
    let Error::BlowUp {
        step,
        rolled_back_to,
        ref what,
        ref cause,
    } = e
    else {
        panic!("{name}: expected BlowUp, got {e}");
    };
    println!("{} {name}: {e}", model.name());
    assert!(
        rolled_back_to >= 3 && rolled_back_to < step && step <= 2003,
        "{name}: {e}"
    );
    assert!(
        step % u64::from(check_every) == 0 || step == 2003,
        "{name}: checked at {step}, not on a multiple of {check_every}"
    );
    assert!(
        rolled_back_to == 3 || rolled_back_to % u64::from(check_every) == 0,
        "{name}: {e}"
    );
    assert!(
        step - rolled_back_to <= u64::from(check_every),
        "{name}: {e}"
    );
    assert!(
        what.contains("species ") && what.contains("at cell ("),
        "{what}"
    );
    assert!(
        cause.contains("dt") && cause.contains("overridden"),
        "{cause}"
    );
    assert_eq!(sim.steps_done(), rolled_back_to);
    let got = sim.state().unwrap();
    assert!(finite(&got), "{name}: the rolled-back state is not finite");
    let mut again = Rd::new(grid.clone(), model.clone(), &config, backend).unwrap();
    again.step(rolled_back_to as u32).unwrap();
    assert_eq!(
        bits(&got),
        bits(&again.state().unwrap()),
        "{name}: the rolled-back state differs from a run stepped to {rolled_back_to}"
    );
    assert_eq!(
        sim.checkpoint().unwrap(),
        again.checkpoint().unwrap(),
        "{name}: checkpoints differ"
    );
}

#[test]
fn diverging_runs_are_rolled_back_to_the_last_good_check() {
    for backend in backends("diverging_runs_are_rolled_back_to_the_last_good_check") {
        // Colony (bound 0.0625): 16 x the bound; checks every 10 steps.
        let (grid, model) = colony_scene::<f32>(40, 36, 3).unwrap();
        diverging_run_is_rolled_back(backend, &grid, &model, 1.0, 10);
        // Gray–Scott with a constant diffusivity: 1.5 x the bound, checks every 7 steps.
        let gs = GrayScott::new(1.0, 0.5, 0.04, 0.06).unwrap();
        let grid = gray_scott_square::<f32>(24, 1.0, 6, 2).unwrap();
        diverging_run_is_rolled_back(backend, &grid, &gs, 0.375, 7);
        if matches!(backend, Backend::Cpu) {
            let (grid, model) = colony_scene::<f64>(40, 36, 3).unwrap();
            diverging_run_is_rolled_back(backend, &grid, &model, 1.0, 10);
            let grid = gray_scott_square::<f64>(24, 1.0, 6, 2).unwrap();
            diverging_run_is_rolled_back(backend, &grid, &gs, 0.375, 25);
        }
    }
}

/// The colony of the user's report: `d n b` grows through the reaction until `dt` (just
/// under the starting bound) is over the bound of the current fields. Uniform `b = 0.5`,
/// `n = 3` with 1 % noise, so that the unstable modes have something to grow from.
fn growing_colony<T: Real>() -> (Grid<T>, Colony, f64) {
    let (mut grid, model) = colony_scene::<T>(24, 20, 4).unwrap();
    for (s, base) in [(0, 0.5), (1, 3.0)] {
        for (k, v) in grid.field_mut(s).iter_mut().enumerate() {
            let u = f64::from(rng_uniform(40 + s as u32, 0, k as u32));
            *v = T::from_f64(base * (1.0 + 0.01 * (2.0 * u - 1.0)));
        }
    }
    let dt = 0.98 * stable_dt(&model, &grid);
    (grid, model, dt)
}

/// One long call used to run straight through the bound and return `Ok` holding NaN (the
/// fields overflow at step 47 on the CPU, the bound falls below `dt` within 10 steps). Now
/// every check inside the call re-evaluates `h^2 / (4 D_max)` from the current fields: the
/// call stops at the first check where it fell below `dt`, with `BlowUp` naming `D_max` and
/// the bound, holding that finite state (`rolled_back_to` = the failed check's step). The
/// same run split into calls of `check_every` steps stops at the same step with the same
/// state (the next call refuses with `Unstable`).
#[test]
fn colony_bound_is_rechecked_inside_one_long_call() {
    for backend in backends("colony_bound_is_rechecked_inside_one_long_call") {
        let (grid, model, dt) = growing_colony::<f32>();
        let config = Config::new(Stepping::euler(dt)).with_check_every(10);
        let mut long = Rd::new(grid.clone(), model.clone(), &config, backend).unwrap();
        let e = long.step(3000).unwrap_err();
        let name = long.backend_name();
        println!("{name}: {e}");
        let Error::BlowUp {
            step,
            rolled_back_to,
            ref what,
            ref cause,
        } = e
        else {
            panic!("{name}: expected BlowUp, got {e}");
        };
        assert_eq!(step, rolled_back_to);
        assert!(step > 0 && step % 10 == 0, "{e}");
        assert_eq!(long.steps_done(), step);
        assert!(
            what.contains("D_max") && what.contains("now below dt"),
            "{what}"
        );
        assert!(cause.contains("smaller dt"), "{cause}");
        let state = long.state().unwrap();
        assert!(finite(&state));
        let bound = stable_dt(&model, &state);
        assert!(
            bound < dt,
            "stopped at a state whose bound {bound} is not below dt {dt}"
        );

        let mut split = Rd::new(grid.clone(), model.clone(), &config, backend).unwrap();
        let refused = loop {
            match split.step(10) {
                Ok(()) => assert!(split.steps_done() <= step, "{name}: the split run went on"),
                Err(Error::Unstable { bound: b, .. }) => break b,
                Err(e) => panic!("{name}: {e}"),
            }
        };
        assert_eq!(split.steps_done(), step);
        assert!(refused < dt);
        assert_eq!(bits(&split.state().unwrap()), bits(&state), "{name}");
    }
}

/// Without interval checks (`check_every = 0`) the same long call runs through the bound
/// and diverges (the bound falls below `dt` after one or two steps), and the end-of-call
/// check puts it back to the start of the call.
#[test]
fn colony_without_interval_checks_is_rolled_back_at_the_end_of_the_call() {
    for backend in backends("colony_without_interval_checks_is_rolled_back_at_the_end_of_the_call")
    {
        let (grid, model, dt) = growing_colony::<f32>();
        let config = Config::new(Stepping::euler(dt)).with_check_every(0);
        let mut sim = Rd::new(grid.clone(), model.clone(), &config, backend).unwrap();
        let e = sim.step(3000).unwrap_err();
        println!("{}: {e}", sim.backend_name());
        assert!(
            matches!(
                e,
                Error::BlowUp {
                    step: 3000,
                    rolled_back_to: 0,
                    ..
                }
            ),
            "{e}"
        );
        assert_eq!(sim.steps_done(), 0);
        assert_eq!(bits(&sim.state().unwrap()), bits(&grid));
    }
}

/// What a run's results are: the field bits, the step counter and the simulated time.
type Outcome = (Vec<u64>, u64, u64);

/// Runs `calls` on a fresh run; returns its outcome and its checkpoint (which also holds
/// the config, so it is compared only between runs of the same config).
fn run_calls<T: Real, M: Model>(make: &dyn Fn() -> Rd<T, M>, calls: &[u32]) -> (Outcome, Vec<u8>) {
    let mut sim = make();
    for &n in calls {
        sim.step(n).unwrap();
    }
    let outcome = (
        bits(&sim.state().unwrap()),
        sim.steps_done(),
        sim.time().to_bits(),
    );
    (outcome, sim.checkpoint().unwrap())
}

/// The checks never change the results: `check_every` = 100, 7 or 0 give bit-identical
/// fields, step counters and times, and `step(2N)` against `step(N) + step(N)` (and an
/// uneven split) give byte-identical checkpoints (fields, step counter, time, config), on
/// the CPU (fused sweeps of 4 steps, stretches that split them) and the
/// GPU (submissions of 16 steps).
#[test]
fn checks_and_splits_do_not_change_results() {
    for backend in backends("checks_and_splits_do_not_change_results") {
        let gpu = GpuOptions {
            steps_per_submit: 16,
            ..GpuOptions::default()
        };
        let (cgrid, colony) = colony_scene::<f32>(30, 26, 5).unwrap();
        let gs = GrayScott::new(1.0, 0.5, 0.04, 0.06).unwrap();
        let sgrid = gray_scott_square::<f32>(20, 1.0, 6, 3).unwrap();
        let check = |label: &str, make: &dyn Fn(u32) -> Outcome| {
            let reference = make(0);
            for every in [100, 7] {
                assert!(make(every) == reference, "{label}: check_every {every}");
            }
        };
        check("colony f32", &|every| {
            let config = Config::new(Stepping::euler(0.005))
                .with_gpu(gpu)
                .with_check_every(every);
            let make = || Rd::new(cgrid.clone(), colony.clone(), &config, backend).unwrap();
            let whole = run_calls(&make, &[300]);
            assert!(
                whole == run_calls(&make, &[150, 150]),
                "step(2N) vs 2 x step(N)"
            );
            assert!(whole == run_calls(&make, &[1, 98, 3, 198]), "uneven split");
            whole.0
        });
        check("gray-scott f32", &|every| {
            let config = Config::new(Stepping::euler(0.2))
                .with_gpu(gpu)
                .with_check_every(every);
            let make = || Rd::new(sgrid.clone(), gs.clone(), &config, backend).unwrap();
            let whole = run_calls(&make, &[300]);
            assert!(
                whole == run_calls(&make, &[150, 150]),
                "step(2N) vs 2 x step(N)"
            );
            whole.0
        });
        if matches!(backend, Backend::Cpu) {
            let (cgrid, colony) = colony_scene::<f64>(30, 26, 5).unwrap();
            check("colony f64 heun", &|every| {
                let config = Config::new(Stepping::heun(0.005)).with_check_every(every);
                let make = || Rd::new(cgrid.clone(), colony.clone(), &config, backend).unwrap();
                let whole = run_calls(&make, &[250]);
                assert!(whole == run_calls(&make, &[125, 125]), "heun step(2N)");
                whole.0
            });
        }
    }
}
