//! The Hertz–Mindlin contact law with Cundall–Strack tangential history and an optional
//! rolling spring, from material properties.

use std::f64::consts::PI;

use serde::{Deserialize, Serialize};
use simkit_backend::{Error, Real, Result};

use crate::spin::Springs;
use crate::{Contact, ContactForce, ContactLaw};

/// An elastic solid: Young's modulus `E` and Poisson ratio `nu`, from which
/// [`HertzMindlin::new`] derives the effective moduli of a pair.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Solid {
    /// Young's modulus `E > 0` (units of pressure: force per length^2 in 3D).
    pub youngs_modulus: f64,
    /// Poisson ratio `nu` in `(-1, 0.5]`.
    pub poisson_ratio: f64,
}

impl Solid {
    /// A solid with Young's modulus `e` and Poisson ratio `nu`.
    pub fn new(youngs_modulus: f64, poisson_ratio: f64) -> Self {
        Self {
            youngs_modulus,
            poisson_ratio,
        }
    }

    fn check(&self, what: &str) -> Result<()> {
        let e = self.youngs_modulus;
        if !(e.is_finite() && e > 0.0) {
            return Err(Error::invalid(
                format!("{what}: youngs_modulus"),
                e,
                "must be finite and > 0",
            ));
        }
        let nu = self.poisson_ratio;
        if !(nu > -1.0 && nu <= 0.5) {
            return Err(Error::invalid(
                format!("{what}: poisson_ratio"),
                nu,
                "must be in (-1, 0.5] (0.5: incompressible)",
            ));
        }
        Ok(())
    }
}

/// The Hertz–Mindlin law of a pair of solids (or a solid and a wall):
///
/// - normal: Hertz, `F_n = (4/3) E* sqrt(R*) delta^(3/2) - gamma_n v_n` with
///   `1/E* = (1 - nu_i^2)/E_i + (1 - nu_j^2)/E_j`, `R* = R_i R_j / (R_i + R_j)`, and the
///   damping `gamma_n = 2 sqrt(5/6) beta sqrt(S_n m*)`, `S_n = 2 E* sqrt(R* delta)`,
///   `beta = -ln e / sqrt(ln^2 e + pi^2)` (Tsuji, Tanaka & Ishida 1992 in the form of
///   Antypov & Elliott 2011), which gives a restitution close to `e` at every impact speed;
/// - tangential: Mindlin's stiffness `k_t = 8 G* sqrt(R* delta)` with
///   `1/G* = 2 (2 - nu_i)(1 + nu_i)/E_i + 2 (2 - nu_j)(1 + nu_j)/E_j` on the tangential
///   displacement `xi` kept per contact (Cundall–Strack, [`crate::coulomb_spring`]), the
///   damping `gamma_t = 2 sqrt(5/6) beta sqrt(k_t m*)`, and the Coulomb cap `mu |F_n|`
///   (LAMMPS `pair granular` `hertz/material` with `tangential mindlin`);
/// - rolling (opt-in, [`with_rolling`](Self::with_rolling)): a spring–dashpot of stiffness
///   `k_roll` and damping `gamma_roll` on the rolling displacement `R* (w_i - w_j) x n`,
///   capped at `mu_r |F_n|`, whose force `F_r` acts as the couple `R* n x F_r` (the
///   elastic–plastic "type C" model; LAMMPS `rolling sds k_roll gamma_roll mu_roll`).
///
/// The history holds 6 values per contact: `xi` and the rolling displacement, both in the
/// contact plane; the rolling part needs a scene with [`crate::Scene::set_rotation`]. In
/// 2D the same formulas are applied to discs (Hertz's law is a 3D result; 2D scenes use it as a model).
///
/// ```
/// use simkit_dem::{HertzMindlin, Solid};
/// # fn main() -> simkit_backend::Result<()> {
/// let glass = Solid::new(6.3e10, 0.24);
/// let law = HertzMindlin::new(glass, glass, 0.9, 0.3)?.with_rolling(0.01, 1e6, 0.0);
/// assert!((law.e_star - 6.3e10 / (2.0 * (1.0 - 0.24 * 0.24))).abs() < 1.0);
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HertzMindlin {
    /// Effective Young's modulus `E*`.
    pub e_star: f64,
    /// Effective shear modulus `G*`.
    pub g_star: f64,
    /// Normal coefficient of restitution `e` in (0, 1].
    pub restitution: f64,
    /// Coulomb friction coefficient `mu` (0: no tangential force).
    pub friction: f64,
    /// Rolling friction coefficient `mu_r` (0: no rolling resistance).
    pub rolling_friction: f64,
    /// Stiffness `k_roll` of the rolling spring (force per length).
    pub rolling_stiffness: f64,
    /// Damping `gamma_roll` of the rolling spring (force per speed).
    pub rolling_damping: f64,
}

impl HertzMindlin {
    /// The law between solids `a` and `b` (for a wall, `b` is the wall's solid) with
    /// restitution `e` and friction `mu`, without rolling resistance.
    ///
    /// Errors: a Young's modulus that is not finite and `> 0`, a Poisson ratio outside
    /// `(-1, 0.5]`, or a restitution or friction the law refuses
    /// ([`ContactLaw::validate`]), each naming the value.
    pub fn new(a: Solid, b: Solid, restitution: f64, friction: f64) -> Result<Self> {
        a.check("first solid")?;
        b.check("second solid")?;
        let e = |s: Solid| (1.0 - s.poisson_ratio * s.poisson_ratio) / s.youngs_modulus;
        let g =
            |s: Solid| 2.0 * (2.0 - s.poisson_ratio) * (1.0 + s.poisson_ratio) / s.youngs_modulus;
        let law = Self {
            e_star: 1.0 / (e(a) + e(b)),
            g_star: 1.0 / (g(a) + g(b)),
            restitution,
            friction,
            rolling_friction: 0.0,
            rolling_stiffness: 0.0,
            rolling_damping: 0.0,
        };
        law.validate("Hertz–Mindlin law")?;
        Ok(law)
    }

    /// The same law with rolling resistance: coefficient `mu_r` (the couple is capped at
    /// `mu_r R* |F_n|`), spring stiffness `k_roll > 0` and damping `gamma_roll >= 0` (the
    /// spring sets how far a ball turns back and forth before it stops; `k_roll` of the
    /// order of the tangential stiffness `8 G* sqrt(R* delta)` at a typical overlap is
    /// usual).
    pub fn with_rolling(mut self, mu_r: f64, k_roll: f64, gamma_roll: f64) -> Self {
        self.rolling_friction = mu_r;
        self.rolling_stiffness = k_roll;
        self.rolling_damping = gamma_roll;
        self
    }

    /// `beta = -ln e / sqrt(ln^2 e + pi^2)` times `2 sqrt(5/6)`: the damping factor.
    fn damping_factor(&self) -> f64 {
        let l = self.restitution.ln();
        2.0 * (5.0f64 / 6.0).sqrt() * (-l / (l * l + PI * PI).sqrt())
    }

    /// The impact speed whose head-on contact reaches an overlap of 1 % of `r_eff` (the
    /// reference impact of the time-step guidance).
    fn reference_speed(&self, m_ij: f64, r_eff: f64) -> f64 {
        let delta = 0.01 * r_eff;
        (16.0 * self.e_star * r_eff.sqrt() * delta.powf(2.5) / (15.0 * m_ij)).sqrt()
    }
}

/// The coefficients of [`HertzMindlin`] as the force loop reads them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HertzCoefficients<T> {
    /// `E*`.
    pub e_star: T,
    /// `G*`.
    pub g_star: T,
    /// `2 sqrt(5/6) beta`.
    pub damping: T,
    /// `mu`.
    pub mu: T,
    /// `mu_r`.
    pub mu_r: T,
    /// `k_roll`.
    pub k_r: T,
    /// `gamma_roll`.
    pub gamma_r: T,
}

/// Hertz's head-on contact time of an elastic impact at relative speed `v`:
/// `t_c = 2.8683 (m*^2 / (R* E*^2 v))^(1/5)` (Johnson, *Contact Mechanics*, 1985, §11.1:
/// `t_c = 2 I delta_max / v` with the deepest overlap
/// `delta_max = (15 m* v^2 / (16 E* sqrt(R*)))^(2/5)` and
/// `I = int_0^1 dx / sqrt(1 - x^(5/2)) = 1.47164`).
pub fn hertz_contact_time(m_ij: f64, r_eff: f64, e_star: f64, v: f64) -> f64 {
    const FACTOR: f64 = 2.868_266; // 2 * 1.4716376 * (15 / 16)^(2/5)
    FACTOR * (m_ij * m_ij / (r_eff * e_star * e_star * v)).powf(0.2)
}

impl ContactLaw for HertzMindlin {
    type Coeff<T: Real> = HertzCoefficients<T>;
    type Gpu = [f32; 8];
    const NAME: &'static str = "hertz-mindlin";
    const WGSL: &'static str = simkit_backend::wgsl!("hertz_mindlin.wgsl");
    const BUILT_IN: bool = true;
    const HISTORY: usize = Springs::<f64>::HISTORY;

    fn swap_history<T: Real>(h: &mut [T]) {
        Springs::<T>::swap(h);
    }

    fn validate(&self, what: &str) -> Result<()> {
        for (name, v) in [("e_star", self.e_star), ("g_star", self.g_star)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::invalid(
                    format!("{what}: {name}"),
                    v,
                    "must be finite and > 0 (build the law with HertzMindlin::new from two \
                     Solids)",
                ));
            }
        }
        let e = self.restitution;
        if !(e.is_finite() && e > 0.0 && e <= 1.0) {
            return Err(Error::invalid(
                format!("{what}: restitution"),
                e,
                "must be in (0, 1]",
            ));
        }
        for (name, v) in [
            ("friction", self.friction),
            ("rolling_friction", self.rolling_friction),
            ("rolling_stiffness", self.rolling_stiffness),
            ("rolling_damping", self.rolling_damping),
        ] {
            simkit_backend::require_non_negative(&format!("{what}: {name}"), v)?;
        }
        if self.rolling_friction > 0.0 && self.rolling_stiffness <= 0.0 {
            return Err(Error::invalid(
                format!("{what}: rolling_stiffness"),
                self.rolling_stiffness,
                "must be > 0 when rolling_friction > 0 (HertzMindlin::with_rolling)",
            ));
        }
        Ok(())
    }

    fn coefficients<T: Real>(&self) -> HertzCoefficients<T> {
        HertzCoefficients {
            e_star: T::from_f64(self.e_star),
            g_star: T::from_f64(self.g_star),
            damping: T::from_f64(self.damping_factor()),
            mu: T::from_f64(self.friction),
            mu_r: T::from_f64(self.rolling_friction),
            k_r: T::from_f64(self.rolling_stiffness),
            gamma_r: T::from_f64(self.rolling_damping),
        }
    }

    fn gpu(c: &HertzCoefficients<f32>) -> [f32; 8] {
        [
            c.e_star, c.g_star, c.damping, c.mu, c.mu_r, c.k_r, c.gamma_r, 0.0,
        ]
    }

    fn scales(&self) -> Vec<(&'static str, f64, bool)> {
        vec![
            ("effective Young's modulus E*", self.e_star, true),
            ("effective shear modulus G*", self.g_star, true),
            ("friction mu", self.friction, false),
            ("rolling friction mu_r", self.rolling_friction, false),
            ("rolling stiffness k_roll", self.rolling_stiffness, false),
            ("rolling damping gamma_roll", self.rolling_damping, false),
        ]
    }

    fn has_friction(&self) -> bool {
        self.friction > 0.0 || self.rolling_friction > 0.0
    }

    /// Hertz's contact time ([`hertz_contact_time`]) of the head-on impact whose deepest
    /// overlap is 1 % of `r_eff` (the overlap granular scenes are usually designed for;
    /// faster impacts have shorter contacts, slower ones longer).
    fn contact_time(&self, m_ij: f64, r_eff: f64) -> f64 {
        hertz_contact_time(m_ij, r_eff, self.e_star, self.reference_speed(m_ij, r_eff))
    }

    /// `min(t_c / 5, 1 / omega)` with the contact time above and `omega^2 = k_n / m*` the
    /// normal stiffness `2 E* sqrt(R* delta)` at an overlap of 1 % of `r_eff`, as for the
    /// linear law. Deeper overlaps are stiffer: the blow-up guard's overlap limit catches
    /// a scene whose impacts are far faster than that.
    fn safe_dt(&self, m_ij: f64, r_eff: f64) -> f64 {
        let k = 2.0 * self.e_star * (r_eff * 0.01 * r_eff).sqrt();
        (self.contact_time(m_ij, r_eff) / 5.0).min((m_ij / k).sqrt())
    }

    #[inline(always)]
    fn force<T: Real, const D: usize, const FRICTION: bool>(
        c: &HertzCoefficients<T>,
        k: &Contact<T, D>,
        history: &mut [T],
    ) -> ContactForce<T, D> {
        let two = T::from_f64(2.0);
        let a = (k.r_eff * k.delta).sqrt();
        let s_n = two * c.e_star * a;
        let f_n =
            T::from_f64(2.0 / 3.0) * s_n * k.delta - c.damping * (s_n * k.m_ij).sqrt() * k.v_n;
        let mut out = ContactForce::force(k.n.map(|x| f_n * x));
        if FRICTION {
            let k_t = T::from_f64(8.0) * c.g_star * a;
            let g_t = c.damping * (k_t * k.m_ij).sqrt();
            let springs = Springs {
                k: k_t,
                gamma: g_t,
                mu: c.mu,
                k_r: c.k_r,
                gamma_r: c.gamma_r,
                mu_r: c.mu_r,
            };
            springs.add(k, f_n, history, &mut out);
        }
        out
    }

    /// `(8/15) E* sqrt(R*) delta^(5/2)`.
    fn elastic_energy<T: Real>(c: &HertzCoefficients<T>, _m_ij: T, r_eff: T, delta: T) -> T {
        T::from_f64(8.0 / 15.0) * c.e_star * (r_eff * delta).sqrt() * delta * delta
    }
}
