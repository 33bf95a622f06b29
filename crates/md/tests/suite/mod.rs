//! The conformance suite every simkit simulation crate runs (`conformance_tests!` of
//! `simkit-backend`, compiled into `tests/restart.rs`): the backends agree, split calls
//! equal one call, restart bit for bit, rollback after a blow-up, damaged checkpoints
//! refused; on the Lennard-Jones liquid of 108 atoms (the CPU in `f32`, as the GPU
//! computes).

use simkit_backend::testing::{max_abs_diff, within};
use simkit_backend::{Backend, Precision, Result};
use simkit_md::{Config, LennardJones, Md, PairTable, State, System, scenes};

fn liquid() -> Result<System> {
    let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5))?;
    scenes::fcc_lattice([3; 3], 0.8442, 1.44, table, &[0], 7)
}

fn run(backend: Backend<'_>, dt: f64) -> Result<Md> {
    let config = Config {
        precision: Precision::F32,
        allow_unstable_dt: true,
        check_every: 10,
        ..Config::default().with_dt(dt)
    };
    Md::new(liquid()?, &config, backend)
}

fn stable(backend: Backend<'_>) -> Result<Md> {
    run(backend, 0.005)
}

/// Just above the stability bound (0.0294): the liquid blows up after a few hundred steps.
fn unstable(backend: Backend<'_>) -> Result<Md> {
    run(backend, 0.03)
}

/// Positions within 1e-5 (the bound of the 40-step comparisons in `tests/conformance.rs`).
fn within_f32(cpu: &State, gpu: &State) -> std::result::Result<(), String> {
    let flat = |s: &State| -> Vec<f64> { s.positions.iter().flatten().copied().collect() };
    within("positions", max_abs_diff(&flat(cpu), &flat(gpu)), 1e-5)
}

simkit_backend::conformance_tests! {
    sim: Md,
    make: stable,
    steps: 40,
    compare: within_f32,
    blow_up: unstable,
    blow_up_steps: 2000,
}
