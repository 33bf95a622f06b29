//! The vectorisable all-pairs field kernel (structure of arrays, j-blocking, runtime
//! CPU-feature dispatch).
//!
//! Sources are padded to a multiple of [`LANES`] with zero-charge particles far away, so the
//! inner loop has no remainder. Each target accumulates `LANES` independent partial sums
//! (one per vector lane), which lets the compiler keep them in SIMD registers without
//! reassociating floating-point sums.

use std::ops::Range;

use multiversion::multiversion;
use rayon::prelude::*;

use simkit_backend::Real;

#[cfg(target_arch = "x86_64")]
use super::avx512;
use super::pairs::{LawKind, Sources};
use crate::config::ForceLaw;
use crate::laws;

/// Partial sums per target (16 f32 = one AVX-512 register; 16 f64 = two).
pub(crate) const LANES: usize = 16;
/// Sources per cache block (4 arrays x 1024 x 8 bytes = 32 KiB in f64).
const J_BLOCK: usize = 1024;
/// Targets per rayon task.
const TARGET_CHUNK: usize = 32;

/// A float type the CPU kernel runs in: the shared [`Real`] plus its block kernel.
pub(crate) trait CpuReal: Real {
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

/// Implements [`CpuReal`] for a float type: its AVX-512 block kernel.
macro_rules! impl_cpu_real {
    ($t:ty, $simd:ident) => {
        impl CpuReal for $t {
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

impl_cpu_real!(f32, block_f32);
impl_cpu_real!(f64, block_f64);

/// A pair law as a type (one compiled kernel per law): the weight `w(r^2)` of
/// [`crate::laws`], with force `q_j w r`; `p` is the squared parameter.
pub(crate) trait Law: Send + Sync {
    const KIND: LawKind;
    fn weight<T: Real>(r2: T, p: T) -> T;
}

/// [`laws::exact_weight`].
pub(crate) struct ExactLaw;
/// [`laws::exclusion_weight`].
pub(crate) struct ExclusionLaw;
/// [`laws::plummer_weight`].
pub(crate) struct PlummerLaw;

impl Law for ExactLaw {
    const KIND: LawKind = LawKind::Exact;
    #[inline(always)]
    fn weight<T: Real>(r2: T, _p: T) -> T {
        laws::exact_weight(r2)
    }
}

impl Law for ExclusionLaw {
    const KIND: LawKind = LawKind::Exclusion;
    #[inline(always)]
    fn weight<T: Real>(r2: T, p: T) -> T {
        laws::exclusion_weight(r2, p)
    }
}

impl Law for PlummerLaw {
    const KIND: LawKind = LawKind::Plummer;
    #[inline(always)]
    fn weight<T: Real>(r2: T, p: T) -> T {
        laws::plummer_weight(r2, p)
    }
}

/// Field `E_i = sum_j q_j w(r_ij) r_ij` of one target from a block of sources.
#[multiversion(targets("x86_64+avx512f+avx512vl+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn block_field<T: CpuReal, L: Law>(xi: T, yi: T, zi: T, s: &Sources<'_, T>, p: T) -> [T; 3] {
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

/// Fields at sources `first..first + ex.len()` (the targets), written to `ex, ey, ez`;
/// `fast` selects the AVX-512 rsqrt path (only pass `true` when [`avx512::available`]).
///
/// Each target's field is summed in an order that depends only on the sources (lanes,
/// then j-blocks), never on which other targets are computed with it: the field of a
/// range of targets has the bits of the same targets in a pass over all of them.
pub(crate) fn field<T: CpuReal>(
    law: ForceLaw,
    fast: bool,
    s: &Sources<'_, T>,
    first: usize,
    ex: &mut [T],
    ey: &mut [T],
    ez: &mut [T],
) {
    let p = T::from_f64(law.squared_parameter());
    match law {
        ForceLaw::Exact => field_with::<T, ExactLaw>(s, p, fast, first, ex, ey, ez),
        ForceLaw::Exclusion { .. } => field_with::<T, ExclusionLaw>(s, p, fast, first, ex, ey, ez),
        ForceLaw::Plummer { .. } => field_with::<T, PlummerLaw>(s, p, fast, first, ex, ey, ez),
    }
}

fn field_with<T: CpuReal, L: Law>(
    s: &Sources<'_, T>,
    p: T,
    fast: bool,
    first: usize,
    ex: &mut [T],
    ey: &mut [T],
    ez: &mut [T],
) {
    let npad = s.x.len();
    debug_assert!(npad.is_multiple_of(LANES) && first + ex.len() <= npad);
    ex.par_chunks_mut(TARGET_CHUNK)
        .zip(ey.par_chunks_mut(TARGET_CHUNK))
        .zip(ez.par_chunks_mut(TARGET_CHUNK))
        .enumerate()
        .for_each(|(c, ((ex, ey), ez))| {
            let i0 = first + c * TARGET_CHUNK;
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

/// `phi_i = sum_j q_j / r_ij` ([`laws::exact_pair_potential`], the self pair and the
/// zero-charge padding give 0) at the sources `targets`, in f64 (the differences are formed
/// in `T`, as the field kernel does), written to `phi[targets]`. Each target's sum has a
/// fixed order, so the result depends neither on the thread count nor on the range.
pub(crate) fn exact_potentials<T: CpuReal>(
    s: &Sources<'_, T>,
    targets: Range<usize>,
    phi: &mut [f64],
) {
    let first = targets.start;
    phi[targets]
        .par_iter_mut()
        .with_min_len(TARGET_CHUNK)
        .enumerate()
        .for_each(|(t, phi)| {
            let i = first + t;
            *phi = block_potential(s.x[i], s.y[i], s.z[i], s);
        });
}

/// `sum_j q_j / r_ij` of one target over all sources (16 partial sums, like the field).
#[multiversion(targets("x86_64+avx512f+avx512vl+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn block_potential<T: CpuReal>(xi: T, yi: T, zi: T, s: &Sources<'_, T>) -> f64 {
    let mut phi = [0.0f64; LANES];
    let chunks =
        s.x.chunks_exact(LANES)
            .zip(s.y.chunks_exact(LANES))
            .zip(s.z.chunks_exact(LANES).zip(s.q.chunks_exact(LANES)));
    for ((cx, cy), (cz, cq)) in chunks {
        for l in 0..LANES {
            let dx = (xi - cx[l]).to_f64();
            let dy = (yi - cy[l]).to_f64();
            let dz = (zi - cz[l]).to_f64();
            let r2 = dx.mul_add(dx, dy.mul_add(dy, dz * dz));
            phi[l] = cq[l]
                .to_f64()
                .mul_add(laws::exact_pair_potential(r2), phi[l]);
        }
    }
    phi.iter().sum()
}
