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

/// The linear spring–dashpot of [`Material`] with a tangential spring per contact and an
/// optional rolling spring: the normal force is [`normal_force`] (from the requested `e`
/// and `t_c` with the reduced mass), the tangential force the Cundall–Strack spring
/// [`crate::coulomb_spring`] with stiffness `k_t = stiffness_ratio * k_n`
/// (`k_n = m_ij kappa`) and damping `m_ij b` (half the normal damping `2 m_ij b`), capped at
/// `mu |F_n|`; the rolling spring (with `mu_r > 0`) has the tangential stiffness and
/// damping, is capped at `mu_r |F_n|` and acts as the couple `R* n x F_r`. The
/// history-keeping counterpart of LAMMPS `pair gran/hooke/history` (which takes `k_t` and
/// the dampings directly): static friction holds, unlike the viscous friction of
/// [`Material`], whose tangential force vanishes with the sliding speed.
///
/// ```
/// use simkit_dem::LinearHistory;
/// let law = LinearHistory::new(0.8, 0.01, 0.5).with_rolling_friction(0.02);
/// assert_eq!(law.stiffness_ratio, 2.0 / 7.0);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LinearHistory {
    /// Normal coefficient of restitution `e` in (0, 1].
    pub restitution: f64,
    /// Duration `t_c > 0` of a binary normal contact.
    pub contact_time: f64,
    /// Coulomb coefficient `mu` (0: no tangential force).
    pub friction: f64,
    /// `k_t / k_n`, in (0, 1]; default 2/7, for which the tangential and normal
    /// oscillations of two spheres have the same period.
    pub stiffness_ratio: f64,
    /// Rolling friction coefficient `mu_r` (0: no rolling resistance).
    pub rolling_friction: f64,
}

impl LinearHistory {
    /// Restitution `e`, contact time `t_c` and Coulomb friction `mu`, with
    /// `k_t / k_n = 2/7` and no rolling resistance.
    pub fn new(restitution: f64, contact_time: f64, friction: f64) -> Self {
        Self {
            restitution,
            contact_time,
            friction,
            stiffness_ratio: 2.0 / 7.0,
            rolling_friction: 0.0,
        }
    }

    /// The same law with rolling resistance `mu_r`.
    pub fn with_rolling_friction(mut self, mu_r: f64) -> Self {
        self.rolling_friction = mu_r;
        self
    }

    /// The same law with another `k_t / k_n`.
    pub fn with_stiffness_ratio(mut self, ratio: f64) -> Self {
        self.stiffness_ratio = ratio;
        self
    }

    /// The normal part as a [`Material`] (no friction of its own).
    fn normal(&self) -> Material {
        Material::new(self.restitution, self.contact_time)
    }
}

/// The coefficients of [`LinearHistory`] as the force loop reads them: the normal
/// [`ContactCoefficients`] (without friction), `k_t / k_n`, `mu` and `mu_r`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinearHistoryCoefficients<T> {
    /// Normal spring and dashpot.
    pub normal: ContactCoefficients<T>,
    /// `k_t / k_n`.
    pub ratio: T,
    /// `mu`.
    pub mu: T,
    /// `mu_r`.
    pub mu_r: T,
}

impl ContactLaw for LinearHistory {
    type Coeff<T: Real> = LinearHistoryCoefficients<T>;
    type Gpu = [f32; 8];
    const NAME: &'static str = "linear-history";
    const WGSL: &'static str = simkit_backend::wgsl!("linear_history.wgsl");
    const BUILT_IN: bool = true;
    const HISTORY: usize = crate::spin::Springs::<f64>::HISTORY;

    fn swap_history<T: Real>(h: &mut [T]) {
        crate::spin::Springs::<T>::swap(h);
    }

    fn validate(&self, what: &str) -> Result<()> {
        self.normal().check(what)?;
        let r = self.stiffness_ratio;
        if !(r > 0.0 && r <= 1.0) {
            return Err(simkit_backend::Error::invalid(
                format!("{what}: stiffness_ratio"),
                r,
                "must be in (0, 1] (k_t / k_n; 2/7 is usual)",
            ));
        }
        for (name, v) in [
            ("friction", self.friction),
            ("rolling_friction", self.rolling_friction),
        ] {
            simkit_backend::require_non_negative(&format!("{what}: {name}"), v)?;
        }
        Ok(())
    }

    fn coefficients<T: Real>(&self) -> LinearHistoryCoefficients<T> {
        LinearHistoryCoefficients {
            normal: ContactCoefficients::new(&self.normal()).to_real(),
            ratio: T::from_f64(self.stiffness_ratio),
            mu: T::from_f64(self.friction),
            mu_r: T::from_f64(self.rolling_friction),
        }
    }

    fn gpu(c: &LinearHistoryCoefficients<f32>) -> [f32; 8] {
        let n = &c.normal;
        [n.kappa, n.two_b, c.ratio, c.mu, c.mu_r, 0.0, 0.0, 0.0]
    }

    fn scales(&self) -> Vec<(&'static str, f64, bool)> {
        let mut s = self.normal().scales();
        s.retain(|x| !x.0.starts_with("friction"));
        s.push(("friction mu", self.friction, false));
        s.push(("rolling friction mu_r", self.rolling_friction, false));
        s
    }

    fn has_friction(&self) -> bool {
        self.friction > 0.0 || self.rolling_friction > 0.0
    }

    fn contact_time(&self, _m_ij: f64, _r_eff: f64) -> f64 {
        self.contact_time
    }

    /// The normal law's bound: with `k_t <= k_n` the tangential oscillation is no faster.
    fn safe_dt(&self, _m_ij: f64, _r_eff: f64) -> f64 {
        let m = self.normal();
        ContactCoefficients::new(&m).safe_dt(&m)
    }

    #[inline(always)]
    fn force<T: Real, const D: usize, const FRICTION: bool>(
        c: &LinearHistoryCoefficients<T>,
        k: &Contact<T, D>,
        history: &mut [T],
    ) -> ContactForce<T, D> {
        let f_n = normal_force(&c.normal, k.m_ij, k.delta, k.v_n);
        let mut out = ContactForce::force(k.n.map(|x| f_n * x));
        if FRICTION {
            let (k_t, g_t) = (
                c.ratio * c.normal.kappa * k.m_ij,
                T::from_f64(0.5) * c.normal.two_b * k.m_ij,
            );
            let springs = crate::spin::Springs {
                k: k_t,
                gamma: g_t,
                mu: c.mu,
                k_r: k_t,
                gamma_r: g_t,
                mu_r: c.mu_r,
            };
            springs.add(k, f_n, history, &mut out);
        }
        out
    }

    fn elastic_energy<T: Real>(c: &LinearHistoryCoefficients<T>, m_ij: T, _r: T, delta: T) -> T {
        spring_energy(&c.normal, m_ij, delta)
    }
}
