//! Normalised units: charge in e, mass in m_e, time in dt, length chosen so that k_e' = 1.
//!
//! A macro-particle stands for `w = n0 V / N` physical particles. With the charge unit
//! `C = e`, the mass unit `M = m_e` and the time unit `T = dt`, the length unit
//! `L = (w C^2 T^2 / (4 pi eps0 M))^(1/3)` makes the Coulomb constant of macro-particles 1,
//! so that the acceleration is `a_i = (q_i/m_i) sum_j q_j r_ij / |r_ij|^3` and the time step
//! is 1.

use simkit_backend::{Error, Result, require_positive};

/// Elementary charge in C (CODATA 2018, exact).
pub const ELEMENTARY_CHARGE: f64 = 1.602_176_634e-19;
/// Electron mass in kg (CODATA 2018).
pub const ELECTRON_MASS: f64 = 9.109_383_701_5e-31;
/// Vacuum permittivity in F/m (CODATA 2018).
pub const VACUUM_PERMITTIVITY: f64 = 8.854_187_812_8e-12;

/// Physical inputs of a periodic-box plasma (SI units, temperature in eV).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhysicalInputs {
    /// Time step in s (the time unit).
    pub dt: f64,
    /// Number density of the physical particles in m^-3.
    pub density: f64,
    /// Edge of the cubic box in m.
    pub box_length: f64,
    /// Number of macro-particles.
    pub particles: usize,
    /// Temperature in eV.
    pub temperature_ev: f64,
    /// Species charge in units of e (e.g. -1 for electrons).
    pub charge_number: f64,
    /// Species mass in units of m_e (1 for electrons, 1836.15 for protons).
    pub mass_ratio: f64,
}

impl PhysicalInputs {
    /// The source's configuration: dt = 1.5e-11 s, n0 = 5e16 m^-3, box 64 x 1e-4 m,
    /// N = 50,000 electrons at 10 eV.
    pub fn source_plasma() -> Self {
        Self {
            dt: 1.5e-11,
            density: 5e16,
            box_length: 64.0 * 1e-4,
            particles: 50_000,
            temperature_ev: 10.0,
            charge_number: -1.0,
            mass_ratio: 1.0,
        }
    }
}

/// Units and normalised quantities derived from [`PhysicalInputs`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Normalised {
    /// Macro-particle weight `w = n0 V / N` (physical particles per macro-particle).
    pub weight: f64,
    /// Length unit L in m.
    pub length: f64,
    /// Time unit T in s (the time step).
    pub time: f64,
    /// Velocity unit V = L/T in m/s.
    pub velocity: f64,
    /// Normalised box edge `box_length / L`.
    pub box_length: f64,
    /// Normalised thermal speed `sqrt(Te e / m) / V` of the species.
    pub thermal_speed: f64,
    /// Normalised Debye length `sqrt(eps0 Te / (n0 e)) / L`.
    pub debye_length: f64,
    /// Plasma frequency times the time step, `omega_pe dt` (dimensionless).
    pub omega_pe_dt: f64,
    /// Normalised macro-particle charge (the species charge number).
    pub charge: f64,
    /// Normalised macro-particle mass (the species mass ratio).
    pub mass: f64,
}

/// Converts physical inputs to normalised units (k_e' = 1, dt' = 1).
///
/// Errors name the offending input (zero or negative density, NaN temperature, ...), or the
/// derived quantity that overflows or underflows for extreme inputs.
pub fn normalise(p: &PhysicalInputs) -> Result<Normalised> {
    let dt = require_positive("dt", p.dt)?;
    let n0 = require_positive("density", p.density)?;
    let ll = require_positive("box_length", p.box_length)?;
    let te = require_positive("temperature_ev", p.temperature_ev)?;
    let mass = require_positive("mass_ratio", p.mass_ratio)?;
    if !p.charge_number.is_finite() || p.charge_number == 0.0 {
        return Err(Error::invalid(
            "charge_number",
            p.charge_number,
            "must be finite and non-zero (e.g. -1 for electrons)",
        ));
    }
    if p.particles == 0 {
        return Err(Error::invalid(
            "particles",
            0,
            "need at least one macro-particle",
        ));
    }
    let e = ELEMENTARY_CHARGE;
    let weight = n0 * ll.powi(3) / p.particles as f64;
    let length = (weight * e * e * dt * dt
        / (4.0 * std::f64::consts::PI * VACUUM_PERMITTIVITY * ELECTRON_MASS))
        .cbrt();
    let velocity = length / dt;
    let thermal = (te * e / (mass * ELECTRON_MASS)).sqrt();
    let debye = (VACUUM_PERMITTIVITY * te / (n0 * e)).sqrt();
    let omega_pe = (n0 * e * e / (VACUUM_PERMITTIVITY * ELECTRON_MASS)).sqrt();
    let out = Normalised {
        weight,
        length,
        time: dt,
        velocity,
        box_length: ll / length,
        thermal_speed: thermal / velocity,
        debye_length: debye / length,
        omega_pe_dt: omega_pe * dt,
        charge: p.charge_number,
        mass,
    };
    let derived = [
        ("weight", out.weight),
        ("length unit", out.length),
        ("velocity unit", out.velocity),
        ("normalised box", out.box_length),
        ("normalised thermal speed", out.thermal_speed),
        ("normalised Debye length", out.debye_length),
        ("omega_pe dt", out.omega_pe_dt),
    ];
    if let Some((name, value)) = derived.iter().find(|(_, v)| !(v.is_finite() && *v > 0.0)) {
        return Err(Error::invalid(
            format!("physical inputs ({name})"),
            value,
            format!(
                "the inputs {p:?} give a {name} that is not finite and > 0 (overflow or \
                 underflow); use inputs of physical magnitude"
            ),
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rel(a: f64, b: f64) -> f64 {
        ((a - b) / b).abs()
    }

    #[test]
    fn source_test_vector() {
        let n = normalise(&PhysicalInputs::source_plasma()).unwrap();
        assert!(rel(n.weight, 262_144.0) < 1e-12, "w = {}", n.weight);
        assert!(rel(n.length, 2.4628155e-5) < 1e-7, "L = {}", n.length);
        assert!(
            rel(n.box_length, 259.8651820816571) < 1e-7,
            "l = {}",
            n.box_length
        );
        assert!(
            rel(n.thermal_speed, 0.8077371891833447) < 1e-7,
            "vt = {}",
            n.thermal_speed
        );
        assert!(
            rel(n.debye_length, 4.26876539) < 1e-7,
            "lD = {}",
            n.debye_length
        );
        assert!((n.omega_pe_dt - 0.1892).abs() < 5e-5, "{}", n.omega_pe_dt);
        // In normalised units omega_pe^2 = 4 pi n' q^2 / m with n' = N / l^3.
        let wp = (4.0 * std::f64::consts::PI * 50_000.0 / n.box_length.powi(3)).sqrt();
        assert!(rel(wp, n.omega_pe_dt) < 1e-10);
    }

    #[test]
    fn bad_inputs_are_named() {
        let mut p = PhysicalInputs::source_plasma();
        p.density = f64::NAN;
        assert!(normalise(&p).unwrap_err().to_string().contains("density"));
        let mut p = PhysicalInputs::source_plasma();
        p.particles = 0;
        assert!(normalise(&p).unwrap_err().to_string().contains("particles"));
        let mut p = PhysicalInputs::source_plasma();
        p.charge_number = 0.0;
        assert!(normalise(&p).is_err());
    }
}
