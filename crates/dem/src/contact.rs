//! The linear spring–dashpot contact law derived from the requested `(e, t_c)`.

use std::f64::consts::PI;

use crate::Material;

/// Spring and dashpot coefficients per unit reduced mass, from a [`Material`].
///
/// The overlap `xi < 0` of a contact obeys the damped oscillator
/// `m_ij xi'' = -(k xi + 2 beta xi')` with the reduced mass `m_ij = m_i m_j / (m_i + m_j)`
/// (`m_ij = m_i` against a wall). With `b = beta / m_ij = -ln(e) / t_c` and
/// `k / m_ij = (pi / t_c)^2 + b^2` the contact lasts exactly `t_c` and the normal relative
/// velocity is reversed with factor `e`, for every mass pair. The normal force on `i` is
/// `F_n = m_ij (kappa * delta - two_b * v_n)` along `n = (r_i - r_j) / |r_i - r_j|`, with the
/// overlap `delta = R_i + R_j - |r_i - r_j| > 0` and `v_n = (v_i - v_j) . n`: both terms are
/// multiplied by `m_ij` (the source multiplies only the spring term, which gives a wrong
/// restitution whenever `m_ij != 1`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactCoefficients {
    /// `k / m_ij = (pi / t_c)^2 + b^2`.
    pub kappa: f64,
    /// `2 b = -2 ln(e) / t_c`.
    pub two_b: f64,
    /// Coulomb coefficient.
    pub mu_s: f64,
    /// Viscous tangential coefficient.
    pub mu_k: f64,
}

impl ContactCoefficients {
    /// Coefficients for `material`.
    pub fn new(material: &Material) -> Self {
        let tc = material.contact_time;
        let b = -material.restitution.ln() / tc;
        Self {
            kappa: (PI / tc).powi(2) + b * b,
            two_b: 2.0 * b,
            mu_s: material.mu_s,
            mu_k: material.mu_k,
        }
    }

    /// Natural frequency `omega_0 = sqrt(kappa)` of the undamped contact.
    pub fn omega0(&self) -> f64 {
        self.kappa.sqrt()
    }

    /// The safe time-step bound used by the guard: `min(t_c / 5, 1 / omega_0)`.
    ///
    /// Verlet integration of one contact is stable for `omega_0 dt < 2`; the bound keeps a
    /// factor 2 for particles in several contacts at once and at least 5 steps per contact.
    pub fn safe_dt(&self, material: &Material) -> f64 {
        (material.contact_time / 5.0).min(1.0 / self.omega0())
    }
}

/// Analytic normal force magnitude (positive = repulsive) for overlap `delta`, normal
/// relative velocity `v_n` and reduced mass `m_ij`.
pub fn normal_force(c: &ContactCoefficients, m_ij: f64, delta: f64, v_n: f64) -> f64 {
    m_ij * (c.kappa * delta - c.two_b * v_n)
}

/// Reduced mass `m_i m_j / (m_i + m_j)`.
pub fn reduced_mass(m_i: f64, m_j: f64) -> f64 {
    m_i * m_j / (m_i + m_j)
}
