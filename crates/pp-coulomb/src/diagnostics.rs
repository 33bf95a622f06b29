//! Conserved quantities and reference sums (plain f64, independent of the fast kernels; the
//! pair laws are those of [`crate::laws`]).

use std::ops::Range;

use rayon::prelude::*;

use crate::config::ForceLaw;
use crate::particles::Particles;
use crate::{Error, Result};

/// Energies, momenta and the force balance of one state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Diagnostics {
    /// Kinetic energy `sum m v^2 / 2`.
    pub kinetic: f64,
    /// Potential energy `sum_{i<j} q_i q_j phi(r_ij)` with the force law's potential.
    pub potential: f64,
    /// `kinetic + potential`.
    pub total: f64,
    /// Total momentum `sum m v`.
    pub momentum: [f64; 3],
    /// Total angular momentum about the origin `sum m r x v`.
    pub angular_momentum: [f64; 3],
    /// Sum of all forces `sum m a` (zero by Newton's third law, up to round-off).
    pub force_sum: [f64; 3],
    /// `sum |m a|`, the scale against which `force_sum` is small.
    pub force_magnitude_sum: f64,
}

/// Potential energy `sum_{i<j} q_i q_j phi(r_ij)`, summed in f64 (O(N^2), rayon): the rows
/// `q_i sum_{j>i} q_j phi(r_ij)` in parallel, then their sum in particle order, so the
/// result does not depend on the thread count.
///
/// Errors: particles that [`Particles::validate`] refuses (e.g. columns of different
/// lengths: the fields are public, so nothing else keeps them consistent).
pub fn potential_energy(p: &Particles, law: ForceLaw) -> Result<f64> {
    p.validate()?;
    Ok(potential_sum(p, law))
}

/// [`potential_energy`] of particles known to be valid.
fn potential_sum(p: &Particles, law: ForceLaw) -> f64 {
    let mut rows = vec![0.0; p.len()];
    potential_rows(p, law, 0..p.len(), &mut rows);
    rows.iter().sum()
}

/// The rows `rows[i] = q_i sum_{j>i} q_j phi(r_ij)` of [`potential_energy`] for `i` in
/// `range` (a distributed run computes each rank's range and gathers them).
pub(crate) fn potential_rows(p: &Particles, law: ForceLaw, range: Range<usize>, rows: &mut [f64]) {
    let x = &p.position;
    let q = &p.charge;
    let first = range.start;
    rows[range].par_iter_mut().enumerate().for_each(|(t, row)| {
        let i = first + t;
        let mut s = 0.0;
        for j in i + 1..p.len() {
            let r = dist(x[i], x[j]);
            s += q[j] * law.potential(r);
        }
        *row = q[i] * s;
    });
}

/// Accelerations by a plain scalar f64 double loop (a reference for tests): the pair
/// weights of [`crate::laws`], without SIMD, blocking or reciprocal square-root estimates.
/// Under the exact law a coincident pair contributes nothing (as the kernels' self pair).
///
/// Errors: particles that [`Particles::validate`] refuses.
pub fn reference_accelerations(p: &Particles, law: ForceLaw) -> Result<Vec<[f64; 3]>> {
    p.validate()?;
    let all: Vec<usize> = (0..p.len()).collect();
    Ok(accelerations_of(p, law, &all))
}

/// [`reference_accelerations`] of the particles `targets` only (each against every
/// particle): a check of a large run on a subset, `O(targets.len() N)`. Errors if a target
/// is not below `p.len()`, or for particles that [`Particles::validate`] refuses.
pub fn reference_accelerations_of(
    p: &Particles,
    law: ForceLaw,
    targets: &[usize],
) -> Result<Vec<[f64; 3]>> {
    p.validate()?;
    if let Some(&bad) = targets.iter().find(|&&i| i >= p.len()) {
        return Err(Error::invalid(
            "target",
            bad,
            format!("must be below the particle count {}", p.len()),
        ));
    }
    Ok(accelerations_of(p, law, targets))
}

fn accelerations_of(p: &Particles, law: ForceLaw, targets: &[usize]) -> Vec<[f64; 3]> {
    let x = &p.position;
    targets
        .par_iter()
        .map(|&i| {
            let mut e = [0.0; 3];
            for j in 0..p.len() {
                if j == i {
                    continue;
                }
                let d = [0, 1, 2].map(|k| x[i][k] - x[j][k]);
                let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                let w = law.weight(r2);
                for k in 0..3 {
                    e[k] += p.charge[j] * w * d[k];
                }
            }
            e.map(|c| c * p.charge[i] / p.mass[i])
        })
        .collect()
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Diagnostics of `p` with accelerations `acc` (from the backend, one per particle) under
/// `law`.
///
/// Errors: particles that [`Particles::validate`] refuses, or `acc` of another length
/// than the particles.
pub fn diagnostics(p: &Particles, acc: &[[f64; 3]], law: ForceLaw) -> Result<Diagnostics> {
    p.validate()?;
    if acc.len() != p.len() {
        return Err(Error::invalid(
            "number of accelerations",
            acc.len(),
            format!("must equal the number of particles, {}", p.len()),
        ));
    }
    Ok(state_diagnostics(p, acc, law))
}

/// [`diagnostics`] of a simulation's own state (valid by construction).
pub(crate) fn state_diagnostics(p: &Particles, acc: &[[f64; 3]], law: ForceLaw) -> Diagnostics {
    with_potential(p, acc, potential_sum(p, law))
}

/// [`diagnostics`] with the potential energy given.
pub(crate) fn with_potential(p: &Particles, acc: &[[f64; 3]], potential: f64) -> Diagnostics {
    let mut kinetic = 0.0;
    let mut momentum = [0.0; 3];
    let mut angular_momentum = [0.0; 3];
    let mut force_sum = [0.0; 3];
    let mut force_magnitude_sum = 0.0;
    for i in 0..p.len() {
        let (m, x, v) = (p.mass[i], p.position[i], p.velocity[i]);
        kinetic += 0.5 * m * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        for k in 0..3 {
            momentum[k] += m * v[k];
        }
        angular_momentum[0] += m * (x[1] * v[2] - x[2] * v[1]);
        angular_momentum[1] += m * (x[2] * v[0] - x[0] * v[2]);
        angular_momentum[2] += m * (x[0] * v[1] - x[1] * v[0]);
        if let Some(a) = acc.get(i) {
            let f = a.map(|c| c * m);
            for k in 0..3 {
                force_sum[k] += f[k];
            }
            force_magnitude_sum += (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt();
        }
    }
    Diagnostics {
        kinetic,
        potential,
        total: kinetic + potential,
        momentum,
        angular_momentum,
        force_sum,
        force_magnitude_sum,
    }
}
