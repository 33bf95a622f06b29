//! The vectorisable all-pairs field kernel (structure of arrays, j-blocking, runtime
//! CPU-feature dispatch).
//!
//! Sources are padded to a multiple of [`LANES`] with zero-charge particles far away, so the
//! inner loop has no remainder. Each target accumulates `LANES` independent partial sums
//! (one per vector lane), which lets the compiler keep them in SIMD registers without
//! reassociating floating-point sums.

use multiversion::multiversion;
use rayon::prelude::*;

#[cfg(target_arch = "x86_64")]
use super::avx512;
use crate::config::ForceLaw;

/// Partial sums per target (16 f32 = one AVX-512 register; 16 f64 = two).
pub(crate) const LANES: usize = 16;
/// Sources per cache block (4 arrays x 1024 x 8 bytes = 32 KiB in f64).
const J_BLOCK: usize = 1024;
/// Targets per rayon task.
const TARGET_CHUNK: usize = 32;

/// A float type the kernel runs in.
pub(crate) trait Real:
    Copy
    + Send
    + Sync
    + PartialOrd
    + std::ops::Add<Output = Self>
    + std::ops::Sub<Output = Self>
    + std::ops::Mul<Output = Self>
    + std::ops::Div<Output = Self>
    + std::ops::AddAssign
    + 'static
{
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// Coordinate of padding sources (far from everything, finite when squared).
    const PAD: Self;
    /// Square root.
    fn sqrt(self) -> Self;
    /// `self * a + b` with one rounding (an FMA instruction in the AVX2/AVX-512 clones).
    fn mul_add(self, a: Self, b: Self) -> Self;
    /// Conversion from f64 (rounding).
    fn from_f64(x: f64) -> Self;
    /// Conversion to f64 (exact).
    fn to_f64(self) -> f64;
    /// Field of one target from a block of sources: the AVX-512 rsqrt path when `fast`
    /// (the caller checked [`avx512::available`]), else the portable multiversioned kernel.
    fn block<L: Law>(
        xi: Self,
        yi: Self,
        zi: Self,
        s: &Sources<'_, Self>,
        p: Self,
        fast: bool,
    ) -> [Self; 3];
}

/// Implements [`Real`] for a float type: its padding value and its AVX-512 block kernel.
macro_rules! impl_real {
    ($t:ty, $pad:expr, $simd:ident) => {
        impl Real for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const PAD: Self = $pad;
            #[inline(always)]
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            #[inline(always)]
            fn mul_add(self, a: Self, b: Self) -> Self {
                <$t>::mul_add(self, a, b)
            }
            #[inline(always)]
            fn from_f64(x: f64) -> Self {
                x as $t
            }
            #[inline(always)]
            fn to_f64(self) -> f64 {
                f64::from(self)
            }
            #[inline(always)]
            fn block<L: Law>(
                xi: Self,
                yi: Self,
                zi: Self,
                s: &Sources<'_, Self>,
                p: Self,
                fast: bool,
            ) -> [Self; 3] {
                #[cfg(target_arch = "x86_64")]
                if fast {
                    // SAFETY: `fast` is only set when avx512::available() returned true.
                    return unsafe { avx512::$simd(L::KIND, xi, yi, zi, s, p) };
                }
                let _ = fast;
                block_field::<Self, L>(xi, yi, zi, s, p)
            }
        }
    };
}

impl_real!(f32, 1.0e12, block_f32);
impl_real!(f64, 1.0e50, block_f64);

/// Which law a [`Law`] type is (a compile-time constant in the SIMD path).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum LawKind {
    Exact,
    Exclusion,
    Plummer,
}

/// A pair law: the factor `w(r^2)` with force `q_j w r`; `p` is the squared parameter.
pub(crate) trait Law: Send + Sync {
    const KIND: LawKind;
    fn weight<T: Real>(r2: T, p: T) -> T;
}

/// Bare Coulomb; the self pair (r = 0) contributes nothing.
pub(crate) struct ExactLaw;
/// Bare Coulomb outside the exclusion radius, nothing inside.
pub(crate) struct ExclusionLaw;
/// Plummer-softened Coulomb.
pub(crate) struct PlummerLaw;

impl Law for ExactLaw {
    const KIND: LawKind = LawKind::Exact;
    #[inline(always)]
    fn weight<T: Real>(r2: T, _p: T) -> T {
        let inv = T::ONE / r2.sqrt();
        let w = inv * inv * inv;
        if r2 > T::ZERO { w } else { T::ZERO }
    }
}

impl Law for ExclusionLaw {
    const KIND: LawKind = LawKind::Exclusion;
    #[inline(always)]
    fn weight<T: Real>(r2: T, p: T) -> T {
        let inv = T::ONE / r2.sqrt();
        let w = inv * inv * inv;
        if r2 > p { w } else { T::ZERO }
    }
}

impl Law for PlummerLaw {
    const KIND: LawKind = LawKind::Plummer;
    #[inline(always)]
    fn weight<T: Real>(r2: T, p: T) -> T {
        let inv = T::ONE / (r2 + p).sqrt();
        inv * inv * inv
    }
}

/// Sources in structure-of-arrays form, padded to a multiple of [`LANES`].
pub(crate) struct Sources<'a, T> {
    pub x: &'a [T],
    pub y: &'a [T],
    pub z: &'a [T],
    pub q: &'a [T],
}

/// Field `E_i = sum_j q_j w(r_ij) r_ij` of one target from a block of sources.
#[multiversion(targets("x86_64+avx512f+avx512vl+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn block_field<T: Real, L: Law>(xi: T, yi: T, zi: T, s: &Sources<'_, T>, p: T) -> [T; 3] {
    let mut ax = [T::ZERO; LANES];
    let mut ay = [T::ZERO; LANES];
    let mut az = [T::ZERO; LANES];
    let chunks =
        s.x.chunks_exact(LANES)
            .zip(s.y.chunks_exact(LANES))
            .zip(s.z.chunks_exact(LANES).zip(s.q.chunks_exact(LANES)));
    for ((cx, cy), (cz, cq)) in chunks {
        for l in 0..LANES {
            let dx = xi - cx[l];
            let dy = yi - cy[l];
            let dz = zi - cz[l];
            let r2 = dx.mul_add(dx, dy.mul_add(dy, dz * dz));
            let w = L::weight(r2, p) * cq[l];
            ax[l] = w.mul_add(dx, ax[l]);
            ay[l] = w.mul_add(dy, ay[l]);
            az[l] = w.mul_add(dz, az[l]);
        }
    }
    let mut out = [T::ZERO; 3];
    for l in 0..LANES {
        out[0] += ax[l];
        out[1] += ay[l];
        out[2] += az[l];
    }
    out
}

/// Fields at the first `ex.len()` sources (the targets), written to `ex, ey, ez`; `fast`
/// selects the AVX-512 rsqrt path (only pass `true` when [`avx512::available`]).
pub(crate) fn field<T: Real>(
    law: ForceLaw,
    fast: bool,
    s: &Sources<'_, T>,
    ex: &mut [T],
    ey: &mut [T],
    ez: &mut [T],
) {
    let p = T::from_f64(law.squared_parameter());
    match law {
        ForceLaw::Exact => field_with::<T, ExactLaw>(s, p, fast, ex, ey, ez),
        ForceLaw::Exclusion { .. } => field_with::<T, ExclusionLaw>(s, p, fast, ex, ey, ez),
        ForceLaw::Plummer { .. } => field_with::<T, PlummerLaw>(s, p, fast, ex, ey, ez),
    }
}

fn field_with<T: Real, L: Law>(
    s: &Sources<'_, T>,
    p: T,
    fast: bool,
    ex: &mut [T],
    ey: &mut [T],
    ez: &mut [T],
) {
    let npad = s.x.len();
    debug_assert!(npad.is_multiple_of(LANES) && ex.len() <= npad);
    ex.par_chunks_mut(TARGET_CHUNK)
        .zip(ey.par_chunks_mut(TARGET_CHUNK))
        .zip(ez.par_chunks_mut(TARGET_CHUNK))
        .enumerate()
        .for_each(|(c, ((ex, ey), ez))| {
            let i0 = c * TARGET_CHUNK;
            // Block sums are added in f64 (free: once per target and block), so that f32
            // rounding grows with the block length, not with N.
            let mut sum = [[0.0f64; 3]; TARGET_CHUNK];
            for j0 in (0..npad).step_by(J_BLOCK) {
                let j1 = (j0 + J_BLOCK).min(npad);
                let block = Sources {
                    x: &s.x[j0..j1],
                    y: &s.y[j0..j1],
                    z: &s.z[j0..j1],
                    q: &s.q[j0..j1],
                };
                for (t, acc) in sum.iter_mut().take(ex.len()).enumerate() {
                    let i = i0 + t;
                    let f = T::block::<L>(s.x[i], s.y[i], s.z[i], &block, p, fast);
                    for k in 0..3 {
                        acc[k] += f[k].to_f64();
                    }
                }
            }
            for (t, acc) in sum.iter().take(ex.len()).enumerate() {
                ex[t] = T::from_f64(acc[0]);
                ey[t] = T::from_f64(acc[1]);
                ez[t] = T::from_f64(acc[2]);
            }
        });
}
