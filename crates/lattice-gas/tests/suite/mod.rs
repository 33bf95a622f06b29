//! The conformance suite every simkit simulation crate runs (`conformance_tests!` of
//! `simkit-backend`, compiled into `tests/restart.rs`): the backends agree bit for bit,
//! split calls equal one call, restart bit for bit, damaged checkpoints refused; on a
//! body-forced channel with an obstacle (the scene of the restart tests). No blow-up
//! check: the state is bits, and every step keeps it valid.

use simkit_backend::{Backend, Result};
use simkit_lattice_gas::{Config, Lattice, LatticeGas, RuleSet};

/// The obstacle scene of the restart tests, body-forced, with the full collision rules.
fn channel(backend: Backend<'_>) -> Result<LatticeGas> {
    let config = Config {
        rules: RuleSet::Full,
        body_force: 0.02,
        ..Config::default()
    };
    super::scene(&config, backend)
}

/// Every backend gives the same lattice bit for bit.
fn same_bits(cpu: &Lattice, gpu: &Lattice) -> std::result::Result<(), String> {
    match cpu
        .cells()
        .iter()
        .zip(gpu.cells())
        .position(|(a, b)| a != b)
    {
        None if cpu.width() == gpu.width() && cpu.height() == gpu.height() => Ok(()),
        None => Err("the lattices differ in size".into()),
        Some(k) => Err(format!(
            "site {k} differs: {:#04x} against {:#04x}",
            cpu.cells()[k],
            gpu.cells()[k]
        )),
    }
}

simkit_backend::conformance_tests! {
    sim: LatticeGas,
    make: channel,
    steps: 50,
    compare: same_bits,
}
