//! The three pair laws, each written once: the force weight `w(r^2)` (the pair field on a
//! target is `q_j w r`, `r` pointing from the source to the target) and the matching pair
//! potential per unit `q_i q_j`.
//!
//! Every CPU path calls these functions: the portable field kernel, the reference sum
//! [`crate::reference_accelerations`] and the potential energy of [`crate::Diagnostics`]. The
//! AVX-512 kernel evaluates the same formulas with `vrsqrt14` and Newton steps in place of the
//! square root and the division, and is tested against these functions. Each weight's WGSL twin
//! (`fn pair_weight(r2: REAL, p: REAL) -> REAL`, used by the GPU field kernel) is the constant
//! beside it; it needs [`wgsl_prelude`] first (the `REAL` type and `rsqrt_real`).

#[cfg(feature = "gpu")]
use simkit_backend::Precision;
use simkit_backend::Real;

/// Bare Coulomb weight `w = r^-3 = (1 / sqrt(r^2))^3`; the self pair (`r^2 = 0`) gives 0.
#[inline(always)]
pub fn exact_weight<T: Real>(r2: T) -> T {
    let inv = T::ONE / r2.sqrt();
    let w = inv * inv * inv;
    if r2 > T::ZERO { w } else { T::ZERO }
}

/// Bare Coulomb weight `r^-3` for `r^2 > radius2` (outside the exclusion radius), 0 inside
/// and at the radius.
#[inline(always)]
pub fn exclusion_weight<T: Real>(r2: T, radius2: T) -> T {
    let inv = T::ONE / r2.sqrt();
    let w = inv * inv * inv;
    if r2 > radius2 { w } else { T::ZERO }
}

/// Plummer-softened weight `(r^2 + eps^2)^(-3/2)` with `eps2 = eps^2`.
#[inline(always)]
pub fn plummer_weight<T: Real>(r2: T, eps2: T) -> T {
    let inv = T::ONE / (r2 + eps2).sqrt();
    inv * inv * inv
}

/// Bare Coulomb potential `1 / r` (the potential of [`exact_weight`]).
#[inline]
pub fn exact_potential<T: Real>(r: T) -> T {
    T::ONE / r
}

/// Bare Coulomb potential from the squared distance, `1 / sqrt(r^2)` (as
/// [`exact_potential`]); the self pair (`r^2 = 0`) gives 0, as in [`exact_weight`]. The exact
/// law's energy check sums it over all pairs on the CPU; its WGSL twin is
/// `pair_potential(r2)` in `EXACT_WGSL`, summed by the GPU's energy kernel.
#[inline(always)]
pub fn exact_pair_potential<T: Real>(r2: T) -> T {
    let p = T::ONE / r2.sqrt();
    if r2 > T::ZERO { p } else { T::ZERO }
}

/// Potential of [`exclusion_weight`]: `1 / r` for `r > radius`, 0 inside and at the radius.
#[inline]
pub fn exclusion_potential<T: Real>(r: T, radius: T) -> T {
    if r > radius { T::ONE / r } else { T::ZERO }
}

/// Plummer potential `1 / sqrt(r^2 + eps^2)` (the potential of [`plummer_weight`]), with
/// `eps2 = eps^2`.
#[inline]
pub fn plummer_potential<T: Real>(r: T, eps2: T) -> T {
    T::ONE / (r * r + eps2).sqrt()
}

/// WGSL twin of [`exact_weight`]: `pair_weight(r2, p)` (`p` unused), and of
/// [`exact_pair_potential`]: `pair_potential(r2)`.
#[cfg(feature = "gpu")]
pub const EXACT_WGSL: &str = simkit_backend::wgsl!("law_exact.wgsl");
/// WGSL twin of [`exclusion_weight`]: `pair_weight(r2, p)` with `p = radius^2`.
#[cfg(feature = "gpu")]
pub const EXCLUSION_WGSL: &str = simkit_backend::wgsl!("law_exclusion.wgsl");
/// WGSL twin of [`plummer_weight`]: `pair_weight(r2, p)` with `p = eps^2`.
#[cfg(feature = "gpu")]
pub const PLUMMER_WGSL: &str = simkit_backend::wgsl!("law_plummer.wgsl");

/// The WGSL that every law and kernel source expects first: `alias REAL` (`f32` or `f64`)
/// and `rsqrt_real(x)`, the reciprocal square root (`inverseSqrt` in f32, `1.0 / sqrt(x)` in
/// f64, where WGSL has no `inverseSqrt`).
#[cfg(feature = "gpu")]
pub fn wgsl_prelude(precision: Precision) -> &'static str {
    match precision {
        Precision::F32 => {
            "alias REAL = f32;\nfn rsqrt_real(x: REAL) -> REAL { return inverseSqrt(x); }\n"
        }
        Precision::F64 => {
            "alias REAL = f64;\nfn rsqrt_real(x: REAL) -> REAL { return 1.0 / sqrt(x); }\n"
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Relative difference, exact zeros required to match exactly.
    fn rel(a: f64, b: f64) -> f64 {
        if b == 0.0 {
            a.abs()
        } else {
            (a - b).abs() / b.abs()
        }
    }

    #[test]
    fn weights_are_the_closed_forms() {
        // Independent of the formulas above: powf.
        for r in [1e-3, 0.1, 0.5, 1.0, 1.5, 2.0, 37.0, 1e4] {
            let r2: f64 = r * r;
            assert!(rel(exact_weight(r2), r2.powf(-1.5)) < 4.0 * f64::EPSILON);
            assert!(rel(exact_weight(r2 as f32) as f64, r2.powf(-1.5)) < 4.0 * f32::EPSILON as f64);
            let inside = if r > 1.5 { r2.powf(-1.5) } else { 0.0 };
            assert!(rel(exclusion_weight(r2, 2.25), inside) < 4.0 * f64::EPSILON);
            let soft = (r2 + 0.16).powf(-1.5);
            assert!(rel(plummer_weight(r2, 0.16), soft) < 4.0 * f64::EPSILON);
        }
        assert_eq!(exact_weight(0.0f64), 0.0);
        assert_eq!(exact_weight(0.0f32), 0.0);
        assert_eq!(exclusion_weight(2.25f64, 2.25), 0.0);
        assert_eq!(plummer_weight(0.0f64, 0.25), 8.0);
        for r in [1e-3, 0.5, 3.0, 1e4f64] {
            assert_eq!(exact_pair_potential(r * r), exact_potential((r * r).sqrt()));
        }
        assert_eq!(exact_pair_potential(0.0f64), 0.0);
    }

    #[test]
    fn weights_are_minus_the_potential_slope_over_r() {
        // w r = -dphi/dr, by a central difference.
        let h = 1e-5;
        for r in [0.3, 1.0, 1.7, 4.0f64] {
            let slope = |phi: &dyn Fn(f64) -> f64| -(phi(r + h) - phi(r - h)) / (2.0 * h) / r;
            let r2 = r * r;
            assert!(rel(slope(&|x| exact_potential(x)), exact_weight(r2)) < 1e-8);
            assert!(
                rel(
                    slope(&|x| exclusion_potential(x, 1.5)),
                    exclusion_weight(r2, 2.25)
                ) < 1e-8
            );
            assert!(
                rel(
                    slope(&|x| plummer_potential(x, 0.16)),
                    plummer_weight(r2, 0.16)
                ) < 1e-8
            );
        }
    }
}
