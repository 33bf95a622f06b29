//! Energies, virial pressure and per-species temperatures.

/// Observables of one state (reduced units: `k_B = 1`).
///
/// - `kinetic = sum_i m_i |v_i|^2 / 2` (velocities at the step; leapfrog: synchronised as
///   `v(t + dt/2) - a(t) dt/2`);
/// - `potential = sum_{i<j} phi_{s_i s_j}(r_ij)` (shifted when [`crate::Config::shift`]);
/// - `virial = sum_{i<j} r_ij . F_ij`;
/// - `pressure = (2 kinetic + virial) / (D V)`, the virial pressure (the same convention
///   as LAMMPS's `compute pressure`);
/// - `species_temperature[s] = 2 kinetic_s / (D N_s)` (no degree of freedom removed; NaN
///   for a species without particles).
///
/// A non-finite state gives NaN (never 0) in the sums.
#[derive(Clone, Debug, PartialEq)]
pub struct Diagnostics {
    /// Simulation time.
    pub time: f64,
    /// Kinetic energy.
    pub kinetic: f64,
    /// Potential energy.
    pub potential: f64,
    /// `kinetic + potential`.
    pub total: f64,
    /// Pair virial `sum r_ij . F_ij`.
    pub virial: f64,
    /// Virial pressure `(2 kinetic + virial) / (D V)`.
    pub pressure: f64,
    /// Kinetic temperature of each species.
    pub species_temperature: Vec<f64>,
}

/// Per-species kinetic energies and counts into [`Diagnostics`].
pub(crate) fn assemble(
    time: f64,
    axes: usize,
    volume: f64,
    kinetic_by_species: &[f64],
    count_by_species: &[usize],
    potential: f64,
    virial: f64,
) -> Diagnostics {
    let kinetic: f64 = kinetic_by_species.iter().sum();
    let d = axes as f64;
    Diagnostics {
        time,
        kinetic,
        potential,
        total: kinetic + potential,
        virial,
        pressure: (2.0 * kinetic + virial) / (d * volume),
        species_temperature: kinetic_by_species
            .iter()
            .zip(count_by_species)
            .map(|(&k, &n)| {
                if n == 0 {
                    f64::NAN
                } else {
                    2.0 * k / (d * n as f64)
                }
            })
            .collect(),
    }
}
