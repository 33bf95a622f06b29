//! What the blow-up check costs: each crate's benchmark scene stepped with the default check
//! (`check_every` = 100: finite state, the model's guards and a copy of the state every 100
//! steps) and with the interval checks off (`check_every` = 0: only the end-of-call check),
//! alternating A, B, A, B, ... on the same machine in the same run, so drift hits both
//! alike. Prints the median time of each and the cost of the check in percent.
//!
//! Run: `cargo bench --bench guard_cost` (`-- --rounds N` for more rounds; CPU backends on
//! the current rayon pool). On a busy machine, count instructions instead of time:
//! `-- --case K --every E --steps S` builds case `K` (0-based, in the order printed) once
//! and steps it `S` steps, for `valgrind --tool=callgrind` with `RAYON_NUM_THREADS=1`
//! (instructions of the step = total minus the total of the same command with `--steps 0`).

use std::time::Instant;

use simkit::backend::{Backend, Result, Simulation};
use simkit::dem::Dem;
use simkit::dem::scenes::granular_box;
use simkit::pp_coulomb::scenes::cold_sphere;
use simkit::pp_coulomb::{Config as PpConfig, ForceLaw, PpCoulomb};
use simkit::rd::scenes::{colony_scene, gray_scott_square};
use simkit::rd::{Config as RdConfig, GrayScott, Rd, Stepping};

/// A built simulation's `step`.
type Stepper = Box<dyn FnMut(u32) -> Result<()>>;

/// One scene: builds a simulation with the given `check_every` (not timed), then the
/// timed part steps it.
struct Case {
    name: &'static str,
    steps: u32,
    build: Box<dyn Fn(u32) -> Result<Stepper>>,
}

fn stepper<S: Simulation + 'static>(mut sim: S) -> Stepper {
    Box::new(move |n| sim.step(n))
}

fn cases() -> Vec<Case> {
    vec![
        Case {
            name: "dem 3D box, 20,000 spheres, f64",
            steps: 500,
            build: Box::new(|every| {
                let scene = granular_box(25, 25, 32, 4_928_459)?;
                let config = simkit::dem::Config::default().with_check_every(every);
                Ok(stepper(Dem::new(scene, &config, Backend::Cpu)?))
            }),
        },
        Case {
            name: "rd Gray-Scott 512^2, f64",
            steps: 400,
            build: Box::new(|every| {
                let grid = gray_scott_square::<f64>(512, 1.0, 64, 1)?;
                let model = GrayScott::new(1.0, 0.5, 0.04, 0.06)?;
                let config = RdConfig::new(Stepping::euler(0.1)).with_check_every(every);
                Ok(stepper(Rd::new(grid, model, &config, Backend::Cpu)?))
            }),
        },
        Case {
            name: "rd colony 512^2, f32 (bound re-checked)",
            steps: 400,
            build: Box::new(|every| {
                let (grid, model) = colony_scene::<f32>(512, 512, 1)?;
                let config = RdConfig::new(Stepping::euler(0.005)).with_check_every(every);
                Ok(stepper(Rd::new(grid, model, &config, Backend::Cpu)?))
            }),
        },
        Case {
            name: "pp-coulomb exact law, N = 4096, f64 (energy guard)",
            steps: 200,
            build: Box::new(|every| {
                let particles = cold_sphere(4096, 1.0, 7)?;
                let config = PpConfig::new(1e-4, ForceLaw::Exact).with_check_every(every);
                Ok(stepper(PpCoulomb::new(particles, &config, Backend::Cpu)?))
            }),
        },
    ]
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn time(case: &Case, every: u32) -> Result<f64> {
    let mut run = (case.build)(every)?;
    let t = Instant::now();
    run(case.steps)?;
    Ok(t.elapsed().as_secs_f64())
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let value = |name: &str| -> Option<u32> {
        let i = args.iter().position(|a| a == name)?;
        args.get(i + 1)?.parse().ok()
    };
    if let Some(k) = value("--case") {
        let cases = cases();
        let case = cases.get(k as usize).ok_or_else(|| {
            simkit::backend::Error::invalid("--case", k, format!("use 0..{}", cases.len()))
        })?;
        let every = value("--every").unwrap_or(simkit::backend::guard::DEFAULT_CHECK_EVERY);
        let mut run = (case.build)(every)?;
        return run(value("--steps").unwrap_or(case.steps));
    }
    let rounds = value("--rounds").unwrap_or(5) as usize;
    println!(
        "blow-up check cost, {rounds} alternating rounds, {} rayon threads",
        rayon::current_num_threads()
    );
    println!(
        "{:<52} {:>12} {:>12} {:>8}",
        "scene", "every 100 s", "off s", "cost"
    );
    for case in cases() {
        let (mut on, mut off) = (Vec::new(), Vec::new());
        for _ in 0..rounds {
            on.push(time(&case, simkit::backend::guard::DEFAULT_CHECK_EVERY)?);
            off.push(time(&case, 0)?);
        }
        let (a, b) = (median(&mut on), median(&mut off));
        println!(
            "{:<52} {a:>12.4} {b:>12.4} {:>7.2}%",
            case.name,
            100.0 * (a - b) / b
        );
    }
    Ok(())
}
