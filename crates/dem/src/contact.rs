//! The linear spring–dashpot contact law derived from the requested `(e, t_c)`, written
//! once for both CPU precisions; its WGSL twin is `shaders/contact.wgsl`.

use std::f64::consts::PI;

use simkit_backend::{Real, Result};

use crate::{Contact, ContactForce, ContactLaw, Material};

/// Spring and dashpot coefficients per unit reduced mass, from a [`Material`], in the real
/// type `T` (`f64` unless stated; the CPU backend converts them to its precision with
/// [`ContactCoefficients::to_real`]).
///
/// The overlap `xi < 0` of a contact obeys the damped oscillator
/// `m_ij xi'' = -(k xi + 2 beta xi')` with the reduced mass `m_ij = m_i m_j / (m_i + m_j)`
/// (`m_ij = m_i` against a wall). With `b = beta / m_ij = -ln(e) / t_c` and
/// `k / m_ij = (pi / t_c)^2 + b^2` the contact lasts exactly `t_c` and the normal relative
/// velocity is reversed with factor `e`, for every mass pair. The normal force on `i` is
/// [`normal_force`]: `F_n = m_ij (kappa * delta - two_b * v_n)` along
/// `n = (r_i - r_j) / |r_i - r_j|`, with the overlap `delta = R_i + R_j - |r_i - r_j| > 0`
/// and `v_n = (v_i - v_j) . n`: both terms are multiplied by `m_ij` (multiplying only the
/// spring term gives a wrong restitution whenever `m_ij != 1`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactCoefficients<T = f64> {
    /// `k / m_ij = (pi / t_c)^2 + b^2`.
    pub kappa: T,
    /// `2 b = -2 ln(e) / t_c`.
    pub two_b: T,
    /// Coulomb coefficient.
    pub mu_s: T,
    /// Viscous tangential coefficient.
    pub mu_k: T,
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

    /// The coefficients rounded to the real type `T`.
    pub fn to_real<T: Real>(&self) -> ContactCoefficients<T> {
        ContactCoefficients {
            kappa: T::from_f64(self.kappa),
            two_b: T::from_f64(self.two_b),
            mu_s: T::from_f64(self.mu_s),
            mu_k: T::from_f64(self.mu_k),
        }
    }
}

/// Normal force magnitude (positive = repulsive) for overlap `delta`, normal relative
/// velocity `v_n` (negative when approaching) and reduced mass `m_ij`:
/// `F_n = m_ij (kappa delta - 2 b v_n)`.
///
/// WGSL twin: `dem_normal_force(c, m_ij, delta, v_n)` in `shaders/contact.wgsl`, with
/// `c = (kappa, 2b, mu_s, mu_k)`.
#[inline(always)]
pub fn normal_force<T: Real>(c: &ContactCoefficients<T>, m_ij: T, delta: T, v_n: T) -> T {
    m_ij * (c.kappa * delta - c.two_b * v_n)
}

/// Tangential (friction) force of a contact with unit normal `n`, relative velocity
/// `v_rel = v_i - v_j` (`v_n = v_rel . n`), normal force `f_n` and reduced mass `m_ij`:
/// `F_t = -min(mu_s |F_n|, mu_k m_ij |v_t|) v_t / |v_t|` with the tangential velocity
/// `v_t = v_rel - v_n n` (viscous, capped by Coulomb). `None` when `v_t = 0` (no force).
///
/// WGSL twin: `dem_friction_force(c, n, v_n, v_rel, f_n, m_ij)` in `shaders/contact.wgsl`
/// (zero where this returns `None`).
#[inline(always)]
pub fn friction_force<T: Real, const D: usize>(
    c: &ContactCoefficients<T>,
    n: &[T; D],
    v_n: T,
    v_rel: &[T; D],
    f_n: T,
    m_ij: T,
) -> Option<[T; D]> {
    let mut vt = [T::ZERO; D];
    let mut vt2 = T::ZERO;
    for d in 0..D {
        vt[d] = v_rel[d] - v_n * n[d];
        vt2 += vt[d] * vt[d];
    }
    if vt2 > T::ZERO {
        let vtn = vt2.sqrt();
        let fabs = if f_n > T::ZERO { f_n } else { -f_n };
        let ft = (c.mu_s * fabs).min(c.mu_k * m_ij * vtn);
        let s = ft / vtn;
        Some(vt.map(|v| -(s * v)))
    } else {
        None
    }
}

/// Elastic energy `m_ij kappa delta^2 / 2` stored in the spring of a contact with overlap
/// `delta` (the potential of the spring term of [`normal_force`]).
#[inline(always)]
pub fn spring_energy<T: Real>(c: &ContactCoefficients<T>, m_ij: T, delta: T) -> T {
    T::from_f64(0.5) * m_ij * c.kappa * delta * delta
}

/// Reduced mass `m_i m_j / (m_i + m_j)`.
///
/// WGSL twin: `dem_reduced_mass(m_i, m_j)` in `shaders/mass.wgsl`.
#[inline(always)]
pub fn reduced_mass<T: Real>(m_i: T, m_j: T) -> T {
    m_i * m_j / (m_i + m_j)
}

/// The built-in contact law: the linear spring–dashpot of [`ContactCoefficients`] with the
/// Coulomb-capped viscous friction of [`friction_force`].
impl ContactLaw for Material {
    type Coeff<T: Real> = ContactCoefficients<T>;
    type Gpu = [f32; 4];
    const NAME: &'static str = "linear";
    const WGSL: &'static str = simkit_backend::wgsl!("contact.wgsl");
    const BUILT_IN: bool = true;

    fn validate(&self, what: &str) -> Result<()> {
        self.check(what)
    }

    fn coefficients<T: Real>(&self) -> ContactCoefficients<T> {
        ContactCoefficients::new(self).to_real()
    }

    fn gpu(c: &ContactCoefficients<f32>) -> [f32; 4] {
        [c.kappa, c.two_b, c.mu_s, c.mu_k]
    }

    fn scales(&self) -> Vec<(&'static str, f64, bool)> {
        let c = ContactCoefficients::new(self);
        vec![
            ("contact stiffness (pi / t_c)^2", c.kappa, true),
            ("contact damping 2 ln(1/e) / t_c", c.two_b, false),
            ("friction mu_s", c.mu_s, false),
            ("friction mu_k", c.mu_k, false),
        ]
    }

    fn has_friction(&self) -> bool {
        self.mu_s > 0.0 && self.mu_k > 0.0
    }

    /// The requested `t_c`, whatever the masses (the coefficients scale with `m_ij`).
    fn contact_time(&self, _m_ij: f64, _r_eff: f64) -> f64 {
        self.contact_time
    }

    fn safe_dt(&self, _m_ij: f64, _r_eff: f64) -> f64 {
        ContactCoefficients::new(self).safe_dt(self)
    }

    /// [`normal_force`] along `n`, plus [`friction_force`] when `FRICTION` (at the contact
    /// point's relative velocity, so a rotating scene gets the friction's torque); no
    /// history, no couple.
    #[inline(always)]
    fn force<T: Real, const D: usize, const FRICTION: bool>(
        c: &ContactCoefficients<T>,
        k: &Contact<T, D>,
        _history: &mut [T],
    ) -> ContactForce<T, D> {
        let fnorm = normal_force(c, k.m_ij, k.delta, k.v_n);
        let mut fp = k.n.map(|x| fnorm * x);
        if FRICTION && let Some(ft) = friction_force(c, &k.n, k.v_n, &k.v_rel, fnorm, k.m_ij) {
            for (f, t) in fp.iter_mut().zip(ft) {
                *f += t;
            }
        }
        ContactForce::force(fp)
    }

    fn elastic_energy<T: Real>(c: &ContactCoefficients<T>, m_ij: T, _r_eff: T, delta: T) -> T {
        spring_energy(c, m_ij, delta)
    }
}
