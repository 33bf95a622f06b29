//! The species-pair table and the pair law `phi(r) = 4 eps (a (sigma/r)^12 - b (sigma/r)^6)`.

use serde::{Deserialize, Serialize};
use simkit_backend::{Error, Real, Result};

/// Most species a [`PairTable`] holds (the table has `n^2` entries).
pub const MAX_SPECIES: usize = 256;

/// Largest `4 eps a sigma^12` and `4 eps b sigma^6` a table accepts (finite in `f32`
/// with room to spare).
pub const MAX_COEFFICIENT: f64 = 1e30;

/// Parameters of one species pair: `phi(r) = 4 eps (a (sigma/r)^12 - b (sigma/r)^6)` for
/// `r < r_c`, zero beyond.
///
/// `a = b = 1` is the Lennard-Jones potential; `b = 0` a purely repulsive `r^-12` wall.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PairParams {
    /// Energy scale `eps >= 0`.
    pub eps: f64,
    /// Length scale `sigma > 0`.
    pub sigma: f64,
    /// Weight of the repulsive `r^-12` term (`a >= 0`).
    pub a: f64,
    /// Weight of the attractive `r^-6` term (`b >= 0`).
    pub b: f64,
    /// Cutoff `r_c > 0`: the pair does not interact at `r >= r_c`.
    pub r_c: f64,
}

impl PairParams {
    /// Lennard-Jones (`a = b = 1`).
    pub fn lj(eps: f64, sigma: f64, r_c: f64) -> Self {
        Self::new(eps, sigma, 1.0, 1.0, r_c)
    }

    /// Purely repulsive `4 eps (sigma/r)^12` (`a = 1`, `b = 0`).
    pub fn repulsive(eps: f64, sigma: f64, r_c: f64) -> Self {
        Self::new(eps, sigma, 1.0, 0.0, r_c)
    }

    /// Any parameters (checked by [`PairTable::set`] and [`PairTable::uniform`]).
    pub fn new(eps: f64, sigma: f64, a: f64, b: f64, r_c: f64) -> Self {
        Self {
            eps,
            sigma,
            a,
            b,
            r_c,
        }
    }

    /// `phi(r)` without the cutoff or shift, in `f64` (for tests and time-step guidance).
    pub fn phi(&self, r: f64) -> f64 {
        let x6 = (self.sigma / r).powi(6);
        4.0 * self.eps * (self.a * x6 * x6 - self.b * x6)
    }

    /// `phi''(r) = 4 eps (156 a sigma^12 / r^14 - 42 b sigma^6 / r^8)`.
    pub fn curvature(&self, r: f64) -> f64 {
        let x6 = (self.sigma / r).powi(6);
        4.0 * self.eps * (156.0 * self.a * x6 * x6 - 42.0 * self.b * x6) / (r * r)
    }

    /// The distance at which the time-step guidance measures the pair's stiffness: the
    /// minimum of `phi`, `sigma (2 a / b)^(1/6)`, when `a, b > 0`, else the distance where
    /// the repulsive term alone equals `4 eps`, `sigma a^(1/12)`.
    pub fn stiffness_distance(&self) -> f64 {
        if self.a > 0.0 && self.b > 0.0 {
            self.sigma * (2.0 * self.a / self.b).powf(1.0 / 6.0)
        } else {
            self.sigma * self.a.powf(1.0 / 12.0)
        }
    }

    fn validate(&self, si: usize, sj: usize) -> Result<()> {
        let name = |f: &str| format!("pair ({si}, {sj}) {f}");
        let p = *self;
        if !(p.eps.is_finite() && p.eps >= 0.0) {
            return Err(Error::invalid(
                name("eps"),
                p.eps,
                "must be finite and >= 0 (0 switches the pair off)",
            ));
        }
        if !(p.sigma.is_finite() && p.sigma > 0.0) {
            return Err(Error::invalid(
                name("sigma"),
                p.sigma,
                "must be finite and > 0",
            ));
        }
        for (f, v) in [("a", p.a), ("b", p.b)] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::invalid(name(f), v, "must be finite and >= 0"));
            }
        }
        if !(p.r_c.is_finite() && p.r_c > 0.0) {
            return Err(Error::invalid(name("r_c"), p.r_c, "must be finite and > 0"));
        }
        // The coefficients 4 eps a sigma^12 and 4 eps b sigma^6 must be finite in f32 too.
        let c12 = 4.0 * p.eps * p.a * p.sigma.powi(12);
        let c6 = 4.0 * p.eps * p.b * p.sigma.powi(6);
        if !(c12 <= MAX_COEFFICIENT && c6 <= MAX_COEFFICIENT) {
            return Err(Error::invalid(
                name("eps, sigma, a, b"),
                format!("{p:?}"),
                format!(
                    "4 eps a sigma^12 = {c12:e} and 4 eps b sigma^6 = {c6:e} must stay below \
                     {MAX_COEFFICIENT:e}; rescale the energy or length unit"
                ),
            ));
        }
        if !(p.r_c * p.r_c).is_normal() {
            return Err(Error::invalid(
                name("r_c"),
                p.r_c,
                "r_c^2 must be a normal f64; rescale the length unit",
            ));
        }
        Ok(())
    }
}

/// Pair parameters for every unordered species pair, stored as a flat symmetric table
/// indexed by `si * n_species + sj` (no branch on the species at run time).
///
/// ```
/// use simkit_md::{PairParams, PairTable};
/// # fn main() -> simkit_backend::Result<()> {
/// let mut t = PairTable::uniform(2, PairParams::lj(1.0, 1.0, 2.5))?;
/// t.set(0, 1, PairParams::repulsive(1.0, 1.0, 1.5))?;
/// assert_eq!(t.get(1, 0), t.get(0, 1));
/// assert_eq!(t.max_cutoff(), 2.5);
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PairTable {
    n: usize,
    params: Vec<PairParams>,
}

impl PairTable {
    /// A table of `n_species` species (1 to [`MAX_SPECIES`]) with every pair set to `p`.
    pub fn uniform(n_species: usize, p: PairParams) -> Result<Self> {
        if !(1..=MAX_SPECIES).contains(&n_species) {
            return Err(Error::invalid(
                "species count",
                n_species,
                format!("must be between 1 and {MAX_SPECIES}"),
            ));
        }
        p.validate(0, 0)?;
        Ok(Self {
            n: n_species,
            params: vec![p; n_species * n_species],
        })
    }

    /// Sets the pair `(si, sj)` and its mirror `(sj, si)`.
    ///
    /// Errors: a species index `>= n_species`, or invalid parameters (NaN, `eps < 0`,
    /// `sigma <= 0`, `r_c <= 0`, `a < 0`, `b < 0`, magnitudes that overflow).
    pub fn set(&mut self, si: usize, sj: usize, p: PairParams) -> Result<()> {
        for s in [si, sj] {
            if s >= self.n {
                return Err(Error::invalid(
                    "species index",
                    s,
                    format!("must be below the species count {}", self.n),
                ));
            }
        }
        p.validate(si, sj)?;
        self.params[si * self.n + sj] = p;
        self.params[sj * self.n + si] = p;
        Ok(())
    }

    /// The parameters of pair `(si, sj)`, or `None` for an index out of range.
    pub fn get(&self, si: usize, sj: usize) -> Option<PairParams> {
        (si < self.n && sj < self.n).then(|| self.params[si * self.n + sj])
    }

    /// Number of species.
    pub fn n_species(&self) -> usize {
        self.n
    }

    /// The flat table, `n_species^2` entries, entry `si * n_species + sj`.
    pub fn as_slice(&self) -> &[PairParams] {
        &self.params
    }

    /// The largest cutoff of the table.
    pub fn max_cutoff(&self) -> f64 {
        self.params.iter().fold(0.0, |m, p| m.max(p.r_c))
    }

    /// Checks every entry and the symmetry (used for tables read from a checkpoint).
    pub fn validate(&self) -> Result<()> {
        let n = self.n;
        let count = n.checked_mul(n);
        if !(1..=MAX_SPECIES).contains(&n) || count != Some(self.params.len()) {
            return Err(Error::invalid(
                "pair table",
                format!("{n} species, {} entries", self.params.len()),
                format!("needs 1 to {MAX_SPECIES} species and n^2 entries"),
            ));
        }
        for si in 0..n {
            for sj in 0..n {
                let p = self.params[si * n + sj];
                p.validate(si, sj)?;
                if p != self.params[sj * n + si] {
                    return Err(Error::invalid(
                        format!("pair table entry ({si}, {sj})"),
                        format!("{p:?}"),
                        "differs from its mirror entry; set pairs with PairTable::set",
                    ));
                }
            }
        }
        Ok(())
    }

    /// The coefficients the force loops read, in precision `T`, with the energy shift at
    /// the cutoff when `shift` is set.
    pub fn coefficients<T: Real>(&self, shift: bool) -> Vec<PairCoeff<T>> {
        self.params
            .iter()
            .map(|p| {
                let s6 = p.sigma.powi(6);
                let c12 = 4.0 * p.eps * p.a * s6 * s6;
                let c6 = 4.0 * p.eps * p.b * s6;
                let cut = if shift { p.phi(p.r_c) } else { 0.0 };
                PairCoeff {
                    c12: T::from_f64(c12),
                    c6: T::from_f64(c6),
                    rc2: T::from_f64(p.r_c * p.r_c),
                    shift: T::from_f64(cut),
                }
            })
            .collect()
    }
}

/// One table entry as the force loop reads it: `phi(r) = c12 / r^12 - c6 / r^6 - shift`
/// for `r^2 < rc2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairCoeff<T> {
    /// `4 eps a sigma^12`.
    pub c12: T,
    /// `4 eps b sigma^6`.
    pub c6: T,
    /// `r_c^2`.
    pub rc2: T,
    /// `phi(r_c)` when the energy is shifted, else 0.
    pub shift: T,
}

/// The pair law, used by every CPU path: for squared distance `r2`, returns
/// `(f / r, phi)` with `f / r = (12 c12 / r^12 - 6 c6 / r^6) / r^2` (the force on `i` is
/// `(f / r) (x_i - x_j)`) and `phi = c12 / r^12 - c6 / r^6 - shift`; `(0, 0)` at
/// `r2 >= rc2`.
#[inline(always)]
pub fn pair_force_energy<T: Real>(c: &PairCoeff<T>, r2: T) -> (T, T) {
    if r2 < c.rc2 {
        let ir2 = T::ONE / r2;
        let ir6 = ir2 * ir2 * ir2;
        let rep = c.c12 * ir6 * ir6;
        let att = c.c6 * ir6;
        let twelve = T::from_f64(12.0);
        let six = T::from_f64(6.0);
        ((twelve * rep - six * att) * ir2, rep - att - c.shift)
    } else {
        (T::ZERO, T::ZERO)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn law_matches_the_closed_form_and_its_derivative() {
        let p = PairParams::new(1.3, 0.9, 0.7, 1.1, 2.7);
        let c = PairTable::uniform(1, p).unwrap().coefficients::<f64>(false)[0];
        for &r in &[0.8, 1.0, 1.2, 2.0, 2.69] {
            let (fr, e) = pair_force_energy(&c, r * r);
            assert!((e - p.phi(r)).abs() < 1e-12 * p.phi(r).abs().max(1.0));
            let h = 1e-6;
            let deriv = (p.phi(r + h) - p.phi(r - h)) / (2.0 * h);
            assert!(
                (fr * r + deriv).abs() < 1e-6 * deriv.abs().max(1.0),
                "r = {r}"
            );
        }
        assert_eq!(pair_force_energy(&c, 2.7 * 2.7), (0.0, 0.0));
        let cs = PairTable::uniform(1, p).unwrap().coefficients::<f64>(true)[0];
        let r = 2.7 - 1e-9;
        assert!(pair_force_energy(&cs, r * r).1.abs() < 1e-8);
    }

    #[test]
    fn minimum_and_curvature_of_lennard_jones() {
        let p = PairParams::lj(1.0, 1.0, 2.5);
        let rm = p.stiffness_distance();
        assert!((rm - 2f64.powf(1.0 / 6.0)).abs() < 1e-15);
        assert!((p.phi(rm) + 1.0).abs() < 1e-14);
        // 72 eps / (2^(1/3) sigma^2).
        assert!((p.curvature(rm) - 72.0 / 2f64.powf(1.0 / 3.0)).abs() < 1e-11);
    }

    #[test]
    fn bad_entries_are_refused_and_the_table_stays_symmetric() {
        let mut t = PairTable::uniform(3, PairParams::lj(1.0, 1.0, 2.5)).unwrap();
        for bad in [
            PairParams::lj(f64::NAN, 1.0, 2.5),
            PairParams::lj(-1.0, 1.0, 2.5),
            PairParams::lj(1.0, 0.0, 2.5),
            PairParams::lj(1.0, 1.0, 0.0),
            PairParams::new(1.0, 1.0, -1.0, 1.0, 2.5),
            PairParams::lj(1.0, 1e30, 2.5),
        ] {
            assert!(t.set(0, 1, bad).is_err(), "{bad:?}");
        }
        assert!(t.set(0, 3, PairParams::lj(1.0, 1.0, 2.5)).is_err());
        t.set(2, 0, PairParams::repulsive(2.0, 0.5, 1.0)).unwrap();
        assert_eq!(t.get(0, 2), t.get(2, 0));
        assert_eq!(t.get(3, 0), None);
        t.validate().unwrap();
        t.params[1] = PairParams::lj(2.0, 1.0, 2.5);
        assert!(t.validate().is_err());
        assert!(PairTable::uniform(0, PairParams::lj(1.0, 1.0, 1.0)).is_err());
    }
}
