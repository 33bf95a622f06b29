//! A published reference state point of the truncated Lennard-Jones fluid, reproduced by a
//! thermostatted run.
//!
//! NIST, "Lennard-Jones Fluid Properties" (<https://www.nist.gov/mml/csd/chemical-informatics-group/lennard-jones-fluid-properties>),
//! page "MC: NVT Monte Carlo results" (<https://mmlapps.nist.gov/srs/LJ_PURE/mc.htm>):
//! 500 atoms, Lennard-Jones potential truncated (not shifted) at `r_c = 3 sigma`, analytic
//! long-range corrections included in the reported energy; at `T* = 0.85`,
//! `rho* = 0.776`: mean potential energy per atom `U/N = -5.5121`, standard deviation
//! `4.55e-4`.

use simkit_backend::{Backend, Error, Result, Simulation};

use crate::{Config, Langevin, LennardJones, Md, PairTable, scenes};

/// Reference temperature `T*`.
pub const NIST_TEMPERATURE: f64 = 0.85;
/// Reference density `rho*`.
pub const NIST_DENSITY: f64 = 0.776;
/// Reference cutoff (truncated, not shifted).
pub const NIST_CUTOFF: f64 = 3.0;
/// Reference mean potential energy per atom, long-range correction included.
pub const NIST_ENERGY: f64 = -5.5121;
/// Its stated standard deviation.
pub const NIST_ENERGY_SIGMA: f64 = 4.55e-4;

/// The outcome of [`nist_lj_state_point`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NistComparison {
    /// Atoms simulated.
    pub atoms: usize,
    /// Mean potential energy per atom of the truncated potential, as sampled.
    pub truncated: f64,
    /// Long-range correction per atom `(8/3) pi rho (r_c^-9 / 3 - r_c^-3)`.
    pub correction: f64,
    /// `truncated + correction`, to compare with [`NIST_ENERGY`].
    pub energy: f64,
    /// Standard error of the mean from 10 block averages.
    pub standard_error: f64,
    /// `(energy - NIST_ENERGY) / sqrt(standard_error^2 + NIST_ENERGY_SIGMA^2)`.
    pub z: f64,
}

/// Runs the NIST state point (`T* = 0.85`, `rho* = 0.776`, `r_c = 3`, unshifted) with
/// `4 cells^3` atoms on an FCC lattice (5 cells: NIST's 500 atoms) started at `T = 1.5`
/// so that it melts at once, the Langevin thermostat at `T*` (`gamma = 1`, seed `seed`),
/// `dt = 0.005`: `equilibrate` steps, then `samples` samples of the potential energy
/// every `every` steps, and compares the mean with [`NIST_ENERGY`].
///
/// The fast test (`tests/nist.rs`) runs 500 atoms for 3000 + 500 x 20 steps; a run
/// reaching NIST's own uncertainty needs about 100 times more samples, e.g.
/// `nist_lj_state_point(5, 5000, 50_000, 20, Backend::Cpu, 1)`.
///
/// Errors: fewer than 4 cells (the box must be at least `2 r_c` long) or more than 40,
/// fewer than 10 samples (10 blocks), `every = 0`, or a failed run.
pub fn nist_lj_state_point(
    cells: usize,
    equilibrate: u32,
    samples: u32,
    every: u32,
    backend: Backend<'_>,
    seed: u32,
) -> Result<NistComparison> {
    if !(4..=40).contains(&cells) {
        return Err(Error::invalid(
            "cells",
            cells,
            "must be 4 to 40 (the periodic box must be at least 2 r_c = 6 long)",
        ));
    }
    if samples < 10 || every == 0 {
        return Err(Error::invalid(
            "samples, every",
            format!("{samples}, {every}"),
            "need at least 10 samples (10 blocks) and every >= 1",
        ));
    }
    let (rho, rc) = (NIST_DENSITY, NIST_CUTOFF);
    let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, rc))?;
    let sys = scenes::fcc_lattice([cells; 3], rho, 1.5, table, &[0], u64::from(seed))?;
    let atoms = sys.particle_count();
    let config = Config {
        thermostat: Some(Langevin::new(NIST_TEMPERATURE, 1.0, seed)),
        ..Config::default().with_dt(0.005)
    };
    let mut md = Md::new(sys, &config, backend)?;
    md.step(equilibrate)?;
    let mut u = Vec::with_capacity(samples as usize);
    for _ in 0..samples {
        md.step(every)?;
        u.push(md.diagnostics()?.potential / atoms as f64);
    }
    let blocks = 10;
    let per = u.len() / blocks;
    let means: Vec<f64> = (0..blocks)
        .map(|b| u[b * per..(b + 1) * per].iter().sum::<f64>() / per as f64)
        .collect();
    let truncated = means.iter().sum::<f64>() / blocks as f64;
    let var = means.iter().map(|x| (x - truncated).powi(2)).sum::<f64>() / (blocks - 1) as f64;
    let standard_error = (var / blocks as f64).sqrt();
    let correction = 8.0 / 3.0 * std::f64::consts::PI * rho * (rc.powi(-9) / 3.0 - rc.powi(-3));
    let energy = truncated + correction;
    let combined = standard_error.hypot(NIST_ENERGY_SIGMA);
    Ok(NistComparison {
        atoms,
        truncated,
        correction,
        energy,
        standard_error,
        z: (energy - NIST_ENERGY) / combined,
    })
}
