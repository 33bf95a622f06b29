//! The law-level GPU test of a [`PairLaw`]: its WGSL twin against its Rust function.

use simkit_backend::testing::{check_struct_size, eval_wgsl2};
use simkit_backend::{Error, GpuContext, Result};

use crate::PairLaw;

/// What [`check_law_on_gpu`] compared.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LawCheck {
    /// Evaluations compared (laws x shifts x distances).
    pub cases: usize,
    /// The largest difference found, in `f32` machine epsilons of the term size
    /// ([`PairLaw::term_sizes`]).
    pub worst_ulps: f64,
}

/// Evaluates the WGSL twin of law `L` ([`PairLaw::WGSL`]) on the GPU for each of `laws`,
/// unshifted and shifted, at distances from `r_c / 20` to past the cutoff (`r_c (4 + k) /
/// 80`, `r_c (1 +- 1e-5)`, `2 r_c`), and compares it with the Rust function
/// [`PairLaw::force_energy`] in `f32` on the same coefficients and squared distances: the
/// same finiteness, and differences at most `ulps` `f32` machine epsilons of the term size
/// ([`PairLaw::term_sizes`], or the shift when larger). Both sides run the same operations
/// in `f32`; WGSL allows 2.5 ulps for a division, `3 + 2 |x|` ulps for `exp(x)` and lets
/// the compiler fuse a multiply and an add, so 8 suits rational laws and about 64 laws
/// with exponentials. It also checks that `struct MdCoeff` in the WGSL has the size of
/// [`PairLaw::Gpu`].
///
/// This is the test every built-in law passes (`tests/laws.rs`); run it on a law of your
/// own the same way (`examples/custom_law/`).
///
/// Errors: invalid laws, a size mismatch of `MdCoeff`, any GPU failure, and a
/// disagreement, naming the parameters, the distance and both results.
pub fn check_law_on_gpu<L: PairLaw>(ctx: &GpuContext, laws: &[L], ulps: f64) -> Result<LawCheck> {
    check_struct_size::<L::Gpu>(L::WGSL, "MdCoeff", &format!("law '{}'", L::NAME))?;
    let mut coeff = Vec::new();
    let mut r2s = Vec::new();
    let mut twins = Vec::new();
    for law in laws {
        law.validate("law under test")?;
        let rc = law.cutoff();
        for shift in [0.0, law.energy(rc)] {
            let c = law.coefficients::<f32>(shift);
            let mut rs: Vec<f64> = (4..=80).map(|k| rc * f64::from(k) / 80.0).collect();
            rs.extend([rc * (1.0 - 1e-5), rc * (1.0 + 1e-5), 2.0 * rc]);
            for r in rs {
                let r2 = (r as f32) * (r as f32);
                coeff.push(L::gpu(&c));
                r2s.push(r2);
                twins.push((*law, c, shift, r2));
            }
        }
    }
    let gpu: Vec<[f32; 2]> = eval_wgsl2(
        ctx,
        &[L::WGSL],
        ("MdCoeff", "f32"),
        "vec2<f32>",
        "md_pair_force_energy(x, y)",
        &coeff,
        &r2s,
    )?;
    let eps = f64::from(f32::EPSILON);
    let mut worst = 0.0f64;
    for (g, (law, c, shift, r2)) in gpu.iter().zip(&twins) {
        let (f, e) = L::force_energy(c, *r2);
        let (tf, te) = law.term_sizes(f64::from(*r2).sqrt());
        let te = te.max(shift.abs());
        for (got, want, scale) in [(g[0], f, tf), (g[1], e, te)] {
            let d = (f64::from(got) - f64::from(want)).abs();
            let ok = if !want.is_finite() || !got.is_finite() {
                got.is_finite() == want.is_finite()
            } else if scale > 0.0 && scale.is_finite() {
                worst = worst.max(d / (eps * scale));
                d <= ulps * eps * scale
            } else {
                got == want
            };
            if !ok {
                return Err(Error::invalid(
                    format!("WGSL twin of law '{}'", L::NAME),
                    format!("{got} (GPU) vs {want} (Rust) at r2 = {r2} for {law:?}, shift {shift}"),
                    format!(
                        "must agree within {ulps} f32 ulps of the term size {scale:e}; fix \
                         md_pair_force_energy or PairLaw::term_sizes"
                    ),
                ));
            }
        }
    }
    Ok(LawCheck {
        cases: twins.len(),
        worst_ulps: worst,
    })
}
