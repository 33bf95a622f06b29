//! The built-in pair laws, each a [`PairLaw`](crate::PairLaw) with its WGSL twin in
//! `shaders/laws/`, and the checks their parameters share.

mod buckingham;
mod lennard_jones;
mod mie;
mod morse;
mod wca;
mod yukawa;

pub use buckingham::{BuckCoeff, Buckingham};
pub use lennard_jones::{LennardJones, LjCoeff};
pub use mie::{Mie, MieCoeff};
pub use morse::{Morse, MorseCoeff};
pub use wca::Wca;
pub use yukawa::{Yukawa, YukawaCoeff};

use simkit_backend::{Error, Result};

/// Largest coefficient magnitude a built-in law accepts (e.g. `4 eps a sigma^12`): finite
/// in `f32` with room to spare.
pub const MAX_COEFFICIENT: f64 = 1e30;

/// The smallest cutoff a law accepts, in the law's length unit: inside a shorter cutoff the
/// inverse powers of `r` that the `f32` kernels form (`r^-12` is 6e37 at `0.7e-3`) overflow
/// `f32`, so a pair would give a NaN or infinite force at a distance the law admits.
pub const MIN_CUTOFF: f64 = 1e-3;

/// `v` finite and `>= 0`; `note` follows the requirement in the message.
pub(crate) fn non_negative(pair: &str, name: &str, v: f64, note: &str) -> Result<()> {
    if v.is_finite() && v >= 0.0 {
        return Ok(());
    }
    let sep = if note.is_empty() { "" } else { " " };
    Err(Error::invalid(
        format!("{pair} {name}"),
        v,
        format!("must be finite and >= 0{sep}{note}"),
    ))
}

/// `v` finite and `> 0`.
pub(crate) fn positive(pair: &str, name: &str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        return Ok(());
    }
    Err(Error::invalid(
        format!("{pair} {name}"),
        v,
        "must be finite and > 0",
    ))
}

/// `|v| <= MAX_COEFFICIENT` (finite in `f32`); `what` names the coefficient's formula.
pub(crate) fn bounded(pair: &str, name: &str, what: &str, v: f64) -> Result<()> {
    if v.abs() <= MAX_COEFFICIENT {
        return Ok(());
    }
    Err(Error::invalid(
        format!("{pair} {name}"),
        v,
        format!(
            "{what} must stay below {MAX_COEFFICIENT:e} in magnitude; rescale the energy or \
             length unit"
        ),
    ))
}

/// A cutoff `r_c` finite and `> 0` whose square is a normal `f64`.
pub(crate) fn check_cutoff(pair: &str, r_c: f64) -> Result<()> {
    positive(pair, "r_c", r_c)?;
    if !(r_c * r_c).is_normal() || r_c < MIN_CUTOFF {
        return Err(Error::invalid(
            format!("{pair} r_c"),
            r_c,
            format!(
                "r_c^2 must be a normal f64 and r_c at least {MIN_CUTOFF:e}; rescale the length \
                 unit (the laws take reduced units, sigma of order 1)"
            ),
        ));
    }
    Ok(())
}

/// The outermost minimum of `phi` in `(0, r_c)`, found from the sign of `phi'` (`dphi`):
/// scanning inwards from `r_c` on a geometric grid (down to `1e-4 r_c`) for the first step
/// where the derivative turns from positive (attraction outside) to negative (repulsion
/// inside), then bisecting. `None` when `phi` is not attractive at `r_c` or has no such
/// turn inside the cutoff.
pub(crate) fn well_inside(r_c: f64, dphi: impl Fn(f64) -> f64) -> Option<f64> {
    let steps = 4000;
    let ratio = 1e-4f64.powf(1.0 / steps as f64);
    let mut outer = r_c;
    if dphi(outer).partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    for _ in 0..steps {
        let inner = outer * ratio;
        let d = dphi(inner);
        if !d.is_finite() {
            return None;
        }
        if d < 0.0 {
            let (mut lo, mut hi) = (inner, outer);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if dphi(mid) < 0.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            return Some(0.5 * (lo + hi));
        }
        outer = inner;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::PairLaw;

    /// Every built-in law: `f / r` is `-phi'(r) / r` (central differences of
    /// [`PairLaw::energy`]), the energy is `phi - shift`, both are exactly 0 at and beyond
    /// the cutoff, and the stiffness, where given, is a minimum with the curvature of
    /// `phi`.
    fn check_law<L: PairLaw>(law: L, rs: &[f64]) {
        law.validate("pair (0, 0)").unwrap();
        let rc = law.cutoff();
        let shift = law.energy(rc);
        let c = law.coefficients::<f64>(shift);
        for &r in rs {
            assert!(r < rc);
            let (fr, e) = L::force_energy(&c, r * r);
            let want = law.energy(r) - shift;
            let (_, te) = law.term_sizes(r);
            assert!(
                (e - want).abs() <= 1e-13 * te.max(shift.abs()),
                "{}: r = {r}: {e} vs {want}",
                L::NAME
            );
            let h = 1e-6 * r;
            let deriv = (law.energy(r + h) - law.energy(r - h)) / (2.0 * h);
            let (tf, _) = law.term_sizes(r);
            assert!(
                (fr * r + deriv).abs() <= 1e-7 * (tf * r).max(deriv.abs()),
                "{}: r = {r}: f/r = {fr}, -phi'/r = {}",
                L::NAME,
                -deriv / r
            );
        }
        for r2 in [rc * rc, rc * rc * 1.000_001, 4.0 * rc * rc] {
            assert_eq!(L::force_energy(&c, r2), (0.0, 0.0), "{}", L::NAME);
        }
        if let Some((r, k)) = law.stiffness() {
            assert!(r > 0.0 && r <= rc && k > 0.0, "{}: {r} {k}", L::NAME);
            let h = 1e-4 * r;
            let d2 = (law.energy(r + h) - 2.0 * law.energy(r) + law.energy(r - h)) / (h * h);
            assert!((d2 - k).abs() < 1e-5 * k, "{}: {d2} vs {k}", L::NAME);
        }
    }

    #[test]
    fn every_built_in_law_is_its_energy_and_derivative() {
        let rs = [0.85, 0.95, 1.0, 1.1, 1.3, 1.7, 2.2, 2.49];
        check_law(LennardJones::new(1.0, 1.0, 2.5), &rs);
        check_law(LennardJones::weighted(1.3, 0.9, 0.7, 1.1, 2.7), &rs);
        check_law(Morse::new(1.0, 4.0, 1.1, 2.5), &rs);
        check_law(Yukawa::new(12.0, 2.0, 2.5), &rs);
        check_law(Mie::new(1.0, 1.0, 14.0, 7.0, 2.5), &rs);
        check_law(Mie::new(0.8, 1.1, 12.5, 5.5, 2.5), &rs);
        check_law(Wca::new(1.0, 1.0), &[0.85, 0.95, 1.0, 1.05, 1.12]);
        check_law(Buckingham::new(2000.0, 0.2, 1.5, 2.5), &rs);
        check_law(Buckingham::new(1.0e5, 0.1, 2.0, 2.5), &rs);
        assert!(Buckingham::new(1.0e5, 0.1, 2.0, 2.5).stiffness().is_some());
        assert!(Buckingham::new(2000.0, 0.2, 1.5, 2.5).stiffness().is_none());
    }

    #[test]
    fn the_well_search_finds_minima_and_their_absence() {
        // Lennard-Jones: 2^(1/6).
        let lj = LennardJones::new(1.0, 1.0, 2.5);
        let dphi = |r: f64| -lj.coefficients::<f64>(0.0).c12 * 12.0 / r.powi(13) + 24.0 / r.powi(7);
        let r = well_inside(2.5, dphi).unwrap();
        assert!((r - 2f64.powf(1.0 / 6.0)).abs() < 1e-12, "{r}");
        // A purely repulsive law has none; neither has one whose well is beyond r_c.
        assert_eq!(well_inside(2.5, |r| -1.0 / r), None);
        assert_eq!(well_inside(1.0, dphi), None);
    }

    #[test]
    fn bad_parameters_name_the_pair_and_the_value() {
        let e = Morse::new(1.0, -4.0, 1.1, 2.5)
            .validate("pair (0, 1)")
            .unwrap_err();
        assert!(e.to_string().contains("pair (0, 1) alpha"), "{e}");
        assert!(Mie::new(1.0, 1.0, 6.0, 12.0, 2.5).validate("p").is_err());
        assert!(Mie::new(1.0, 1.0, 6.0, 6.0, 2.5).validate("p").is_err());
        assert!(Yukawa::new(f64::NAN, 1.0, 2.5).validate("p").is_err());
        assert!(Yukawa::new(1.0, -1.0, 2.5).validate("p").is_err());
        assert!(Buckingham::new(1.0, 0.0, 1.0, 2.5).validate("p").is_err());
        assert!(Buckingham::new(1e40, 0.2, 1.0, 2.5).validate("p").is_err());
        assert!(Wca::new(1.0, -1.0).validate("p").is_err());
        assert!(LennardJones::new(1.0, 1e30, 2.5).validate("p").is_err());
        assert!(
            Morse::new(1.0, 4.0, 1.1, f64::INFINITY)
                .validate("p")
                .is_err()
        );
        // Morse: the core energy D0 e^(2 alpha r0) must be finite in f32.
        assert!(Morse::new(1.0, 40.0, 2.0, 2.5).validate("p").is_err());
    }
}
