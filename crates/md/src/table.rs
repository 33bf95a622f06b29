//! The species-pair table: one [`PairLaw`] value per unordered species pair.

use serde::{Deserialize, Serialize};
use simkit_backend::{Error, Real, Result};

use crate::{LennardJones, MAX_COEFFICIENT, PairLaw};

/// Most species a [`PairTable`] holds (the table has `n^2` entries).
pub const MAX_SPECIES: usize = 256;

/// The parameters of law `L` for every unordered species pair, stored as a flat symmetric
/// table indexed by `si * n_species + sj` (no branch on the species at run time).
///
/// ```
/// use simkit_md::{LennardJones, PairTable};
/// # fn main() -> simkit_backend::Result<()> {
/// let mut t = PairTable::uniform(2, LennardJones::new(1.0, 1.0, 2.5))?;
/// t.set(0, 1, LennardJones::repulsive(1.0, 1.0, 1.5))?;
/// assert_eq!(t.get(1, 0), t.get(0, 1));
/// assert_eq!(t.max_cutoff(), 2.5);
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PairTable<L = LennardJones> {
    n: usize,
    params: Vec<L>,
}

impl<L: PairLaw> PairTable<L> {
    /// A table of `n_species` species (1 to [`MAX_SPECIES`]) with every pair set to `law`.
    ///
    /// Errors: a species count out of range, or parameters the law refuses
    /// ([`PairLaw::validate`]).
    pub fn uniform(n_species: usize, law: L) -> Result<Self> {
        if !(1..=MAX_SPECIES).contains(&n_species) {
            return Err(Error::invalid(
                "species count",
                n_species,
                format!("must be between 1 and {MAX_SPECIES}"),
            ));
        }
        check_entry(&law, 0, 0)?;
        Ok(Self {
            n: n_species,
            params: vec![law; n_species * n_species],
        })
    }

    /// Sets the pair `(si, sj)` and its mirror `(sj, si)`.
    ///
    /// Errors: a species index `>= n_species`, or parameters the law refuses (NaN, a
    /// negative energy scale, a non-positive length or cutoff, magnitudes that overflow
    /// `f32`, ...).
    pub fn set(&mut self, si: usize, sj: usize, law: L) -> Result<()> {
        for s in [si, sj] {
            if s >= self.n {
                return Err(Error::invalid(
                    "species index",
                    s,
                    format!("must be below the species count {}", self.n),
                ));
            }
        }
        check_entry(&law, si, sj)?;
        self.params[si * self.n + sj] = law;
        self.params[sj * self.n + si] = law;
        Ok(())
    }

    /// The parameters of pair `(si, sj)`, or `None` for an index out of range.
    pub fn get(&self, si: usize, sj: usize) -> Option<L> {
        (si < self.n && sj < self.n).then(|| self.params[si * self.n + sj])
    }

    /// Number of species.
    pub fn n_species(&self) -> usize {
        self.n
    }

    /// The flat table, `n_species^2` entries, entry `si * n_species + sj`.
    pub fn as_slice(&self) -> &[L] {
        &self.params
    }

    /// The largest cutoff of the table.
    pub fn max_cutoff(&self) -> f64 {
        self.params.iter().fold(0.0, |m, p| m.max(p.cutoff()))
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
                check_entry(&p, si, sj)?;
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
    /// the cutoff, `phi(r_c)`, when `shift` is set.
    pub fn coefficients<T: Real>(&self, shift: bool) -> Vec<L::Coeff<T>> {
        self.params
            .iter()
            .map(|p| p.coefficients(if shift { p.energy(p.cutoff()) } else { 0.0 }))
            .collect()
    }
}

/// The law's own checks, then what every backend needs of any law: a cutoff whose square is
/// a normal `f64` and an energy at the cutoff (the shift, a coefficient of the `f32` kernels)
/// within [`MAX_COEFFICIENT`].
fn check_entry<L: PairLaw>(law: &L, si: usize, sj: usize) -> Result<()> {
    let is_default = std::any::TypeId::of::<L>() == std::any::TypeId::of::<LennardJones>();
    simkit_backend::checkpoint::check_law_name(L::NAME, LennardJones::NAME, is_default)?;
    let pair = format!("pair ({si}, {sj})");
    law.validate(&pair)?;
    let rc = law.cutoff();
    if !(rc.is_finite() && rc > 0.0 && (rc * rc).is_normal()) {
        return Err(Error::invalid(
            format!("{pair} cutoff"),
            rc,
            "must be finite and > 0, its square a normal f64; rescale the length unit",
        ));
    }
    let shift = law.energy(rc);
    if !shift.is_finite() || shift.abs() > MAX_COEFFICIENT {
        return Err(Error::invalid(
            format!("{pair} energy at the cutoff"),
            shift,
            format!(
                "must be finite and at most {MAX_COEFFICIENT:e} in magnitude (it is the energy \
                 shift); move the cutoff out of the law's core"
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_entries_are_refused_and_the_table_stays_symmetric() {
        let mut t = PairTable::uniform(3, LennardJones::new(1.0, 1.0, 2.5)).unwrap();
        for bad in [
            LennardJones::new(f64::NAN, 1.0, 2.5),
            LennardJones::new(-1.0, 1.0, 2.5),
            LennardJones::new(1.0, 0.0, 2.5),
            LennardJones::new(1.0, 1.0, 0.0),
            LennardJones::weighted(1.0, 1.0, -1.0, 1.0, 2.5),
            LennardJones::new(1.0, 1e30, 2.5),
        ] {
            assert!(t.set(0, 1, bad).is_err(), "{bad:?}");
        }
        assert!(t.set(0, 3, LennardJones::new(1.0, 1.0, 2.5)).is_err());
        t.set(2, 0, LennardJones::repulsive(2.0, 0.5, 1.0)).unwrap();
        assert_eq!(t.get(0, 2), t.get(2, 0));
        assert_eq!(t.get(3, 0), None);
        t.validate().unwrap();
        t.params[1] = LennardJones::new(2.0, 1.0, 2.5);
        assert!(t.validate().is_err());
        assert!(PairTable::uniform(0, LennardJones::new(1.0, 1.0, 1.0)).is_err());
    }
}
