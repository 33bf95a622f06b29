//! Ready-made inputs: the Lennard-Jones FCC melt of LAMMPS's `in.lj` benchmark and a
//! three-species (gas, liquid, solid) pair table.

use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use simkit_backend::{Error, Result};

use crate::{Dim, LennardJones, MAX_PARTICLES, PairLaw, PairTable, System};

/// Species index of the gas in [`three_phase_table`].
pub const GAS: u32 = 0;
/// Species index of the liquid in [`three_phase_table`].
pub const LIQUID: u32 = 1;
/// Species index of the solid in [`three_phase_table`].
pub const SOLID: u32 = 2;

/// Atoms of a face-centred cubic unit cell, in units of the lattice constant.
const FCC: [[f64; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [0.5, 0.5, 0.0],
    [0.5, 0.0, 0.5],
    [0.0, 0.5, 0.5],
];

/// An FCC lattice of `cells` unit cells at number density `density` (4 atoms per cell,
/// lattice constant `(4 / density)^(1/3)`), in a periodic box with its corner at the
/// origin; every atom has species `species[k]` for a species index `k` drawn uniformly
/// from the seeded generator (`species = [0]`: one species), random velocities with zero
/// total momentum scaled to the kinetic temperature `temperature = 2 K / (3 N - 3)` (the
/// convention of LAMMPS's `velocity create`), masses 1.
///
/// Errors: a zero cell count, more than [`MAX_PARTICLES`] atoms, a non-finite or
/// non-positive density, a negative temperature, an empty or unknown species list, and
/// whatever [`System::new`] refuses (e.g. a box shorter than twice the largest cutoff).
pub fn fcc_lattice<L: PairLaw>(
    cells: [usize; 3],
    density: f64,
    temperature: f64,
    table: PairTable<L>,
    species: &[u32],
    seed: u64,
) -> Result<System<L>> {
    let n = cells
        .iter()
        .try_fold(4usize, |acc, &c| acc.checked_mul(c))
        .filter(|&n| n > 0 && n <= MAX_PARTICLES)
        .ok_or_else(|| {
            Error::invalid(
                "FCC cells",
                format!("{cells:?}"),
                format!("need 1 to {MAX_PARTICLES} atoms (4 per cell)"),
            )
        })?;
    if !(density.is_finite() && density > 0.0) {
        return Err(Error::invalid("density", density, "must be finite and > 0"));
    }
    if !(temperature.is_finite() && temperature >= 0.0) {
        return Err(Error::invalid(
            "temperature",
            temperature,
            "must be finite and >= 0",
        ));
    }
    if species.is_empty() {
        return Err(Error::invalid(
            "species list",
            "[]",
            "needs at least one species",
        ));
    }
    let a = (4.0 / density).cbrt();
    let len = cells.map(|c| c as f64 * a);
    let masses = vec![1.0; table.n_species()];
    let mut sys = System::new(Dim::Three, [0.0; 3], len, [true; 3], masses, table)?;
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut pos = Vec::with_capacity(n);
    let mut kinds = Vec::with_capacity(n);
    let mut vel = Vec::with_capacity(n);
    for k in 0..cells[2] {
        for j in 0..cells[1] {
            for i in 0..cells[0] {
                for b in FCC {
                    pos.push([
                        (i as f64 + b[0]) * a,
                        (j as f64 + b[1]) * a,
                        (k as f64 + b[2]) * a,
                    ]);
                    let pick = rng.random_range(0..species.len());
                    kinds.push(species[pick]);
                    vel.push([0.0; 3].map(|_: f64| rng.random::<f64>() - 0.5));
                }
            }
        }
    }
    let mean: [f64; 3] = std::array::from_fn(|d| vel.iter().map(|v| v[d]).sum::<f64>() / n as f64);
    for v in &mut vel {
        for d in 0..3 {
            v[d] -= mean[d];
        }
    }
    let twice_k: f64 = vel.iter().flatten().map(|x| x * x).sum();
    let dof = (3 * n).saturating_sub(3).max(1) as f64;
    let scale = if twice_k > 0.0 {
        (temperature * dof / twice_k).sqrt()
    } else {
        0.0
    };
    for v in &mut vel {
        for x in v.iter_mut() {
            *x *= scale;
        }
    }
    sys.set_particles(&kinds, &pos, &vel)?;
    Ok(sys)
}

/// LAMMPS's `in.lj` melt: 32 000 Lennard-Jones atoms (`eps = sigma = m = 1`) on a
/// `20^3`-cell FCC lattice at density `0.8442`, temperature `1.44`, cutoff `2.5`; run it
/// with skin `0.3` (the default) and `dt = 0.005`.
pub fn lj_melt() -> Result<System> {
    let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5))?;
    fcc_lattice([20; 3], 0.8442, 1.44, table, &[0], 87287)
}

/// A three-species table, species [`GAS`], [`LIQUID`], [`SOLID`], all `eps = 1`:
///
/// | pair | `r_c` | `sigma` | `a` | `b` |
/// |---|---|---|---|---|
/// | gas–gas | 2 | 0.5 | 1 | 0 |
/// | liquid–liquid | 5 | 1 | 1 | 1 |
/// | solid–solid | 5 | 1 | 1 | 1 |
/// | gas–liquid, gas–solid | 3 | 1 | 1 | 0 |
/// | liquid–solid | 5 | 1 | 1 | 0 |
///
/// Gas particles only repel (a small core among themselves), the liquid and the solid
/// attract their own kind and repel each other.
pub fn three_phase_table() -> Result<PairTable> {
    let mut t = PairTable::uniform(3, LennardJones::new(1.0, 1.0, 5.0))?;
    let (g, l, s) = (GAS as usize, LIQUID as usize, SOLID as usize);
    t.set(g, g, LennardJones::repulsive(1.0, 0.5, 2.0))?;
    t.set(g, l, LennardJones::repulsive(1.0, 1.0, 3.0))?;
    t.set(g, s, LennardJones::repulsive(1.0, 1.0, 3.0))?;
    t.set(l, s, LennardJones::repulsive(1.0, 1.0, 5.0))?;
    Ok(t)
}

/// A mixture of the three species of [`three_phase_table`] on an FCC lattice of `cells`
/// unit cells at `density` and `temperature` (species drawn uniformly, see
/// [`fcc_lattice`]). The box must be at least 10 long (twice the largest cutoff), e.g.
/// `cells = [6; 3]` at density `0.4` (864 atoms, box 12.9).
pub fn three_phase_mix(
    cells: [usize; 3],
    density: f64,
    temperature: f64,
    seed: u64,
) -> Result<System> {
    fcc_lattice(
        cells,
        density,
        temperature,
        three_phase_table()?,
        &[GAS, LIQUID, SOLID],
        seed,
    )
}
