//! Scenes and vector error metrics shared by the force and conformance tests.

use simkit_pp_coulomb::{ForceLaw, Particles, Region, Species, Velocities};

/// Electrons and heavier ions in a cube (several species, per-particle charge and mass).
pub fn plasma(n: usize, seed: u64) -> Particles {
    let mut p = Particles::new();
    let e = p.add_species(Species::new("electron", -1.0, 1.0)).unwrap();
    let ion = p.add_species(Species::new("ion", 2.0, 100.0)).unwrap();
    let cube = Region::Cube {
        min: [-10.0; 3],
        length: 20.0,
    };
    let v = Velocities::Maxwellian { thermal_speed: 0.3 };
    p.fill(e, n - n / 3, cube, v, seed).unwrap();
    p.fill(ion, n / 3, cube, v, seed + 1).unwrap();
    p
}

/// The three force laws, with parameters that matter at the scenes' spacing.
pub const LAWS: [ForceLaw; 3] = [
    ForceLaw::Exact,
    ForceLaw::Exclusion { radius: 1.5 },
    ForceLaw::Plummer { epsilon: 0.4 },
];

/// Euclidean norm of a 3-vector.
pub fn norm(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

/// max_i |a_i - b_i| / rms_i |b_i|: the worst particle's vector error against the typical
/// magnitude (a per-component metric would under-weight particles whose vectors are small).
pub fn max_error_over_rms(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let rms = (b.iter().map(|x| norm(*x).powi(2)).sum::<f64>() / b.len() as f64).sqrt();
    a.iter()
        .zip(b)
        .map(|(x, y)| norm([x[0] - y[0], x[1] - y[1], x[2] - y[2]]))
        // A NaN anywhere must fail every tolerance (`f64::max` would skip it).
        .fold(0.0, simkit_backend::max_or_nan)
        / rms
}

/// sqrt(sum_i |a_i - b_i|^2 / sum_i |b_i|^2): the L2 relative error over all particles.
pub fn l2_relative(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let num: f64 = a
        .iter()
        .zip(b)
        .map(|(x, y)| norm([x[0] - y[0], x[1] - y[1], x[2] - y[2]]).powi(2))
        .sum();
    let den: f64 = b.iter().map(|y| norm(*y).powi(2)).sum();
    (num / den).sqrt()
}
