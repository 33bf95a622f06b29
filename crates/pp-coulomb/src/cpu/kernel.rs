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
    /// Field of one target at `xi` (low parts `li` when `S` splits the coordinates, else
    /// unused) from a block of sources: the AVX-512 rsqrt path when `fast` (the caller
    /// checked [`avx512::available`]), else the portable multiversioned kernel.
    fn block<L: Law, S: Separation>(
        xi: [Self; 3],
        li: [Self; 3],
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
            fn block<L: Law, S: Separation>(
                xi: [Self; 3],
                li: [Self; 3],
                s: &Sources<'_, Self>,
                p: Self,
                fast: bool,
            ) -> [Self; 3] {
                #[cfg(target_arch = "x86_64")]
                if fast {
                    // SAFETY: `fast` is only set when avx512::available() returned true.
                    return unsafe {
                        if S::SPLIT {
                            avx512::$simd::<true>(L::KIND, xi, li, s, p)
                        } else {
                            avx512::$simd::<false>(L::KIND, xi, li, s, p)
                        }
                    };
                }
                let _ = fast;
                block_field::<Self, L, S>(xi, li, s, p)
            }
        }
    };
}

impl_cpu_real!(f32, block_f32);
impl_cpu_real!(f64, block_f64);

/// How a kernel forms the separation `r_i - r_j`, one coordinate at a time (a type, so
/// that each choice is its own compiled kernel, like the laws).
pub(crate) trait Separation: Send + Sync {
    /// Whether the coordinates come split into high and low parts ([`Sources::lo`]).
    const SPLIT: bool;
    /// `x_i - x_j` from the high parts `xi`, `xj` and the low parts `li`, `lj`.
    fn of<T: Real>(xi: T, li: T, xj: T, lj: T) -> T;
}

/// Plain coordinates: `xi - xj` (the low parts are not read).
pub(crate) struct Plain;
/// Coordinates split into `x + l` (the mixed mode): `(xi - xj) + (li - lj)`. For the f64
/// coordinates of the mixed mode, `x` rounded to f32 and `l` the f32 rounding of the rest,
/// this is the f64 separation rounded to f32 within about two f32 ulps, whatever the
/// size of the coordinates: `xi - xj` is exact for close pairs (Sterbenz), and the low
/// parts carry the 24 bits the f32 coordinates lost.
pub(crate) struct Split;

impl Separation for Plain {
    const SPLIT: bool = false;
    #[inline(always)]
    fn of<T: Real>(xi: T, _li: T, xj: T, _lj: T) -> T {
        xi - xj
    }
}

impl Separation for Split {
    const SPLIT: bool = true;
    #[inline(always)]
    fn of<T: Real>(xi: T, li: T, xj: T, lj: T) -> T {
        (xi - xj) + (li - lj)
    }
}

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
fn block_field<T: CpuReal, L: Law, S: Separation>(
    xi: [T; 3],
    li: [T; 3],
    s: &Sources<'_, T>,
    p: T,
) -> [T; 3] {
    let mut ax = [T::ZERO; LANES];
    let mut ay = [T::ZERO; LANES];
    let mut az = [T::ZERO; LANES];
    // Plain coordinates: the low parts are never read (any slices of the right length).
    let [lx, ly, lz] = s.lo.unwrap_or([s.x, s.y, s.z]);
    let chunks =
        s.x.chunks_exact(LANES)
            .zip(s.y.chunks_exact(LANES))
            .zip(s.z.chunks_exact(LANES).zip(s.q.chunks_exact(LANES)))
            .zip(
                lx.chunks_exact(LANES)
                    .zip(ly.chunks_exact(LANES).zip(lz.chunks_exact(LANES))),
            );
    for (((cx, cy), (cz, cq)), (clx, (cly, clz))) in chunks {
        for l in 0..LANES {
            let dx = S::of(xi[0], li[0], cx[l], clx[l]);
            let dy = S::of(xi[1], li[1], cy[l], cly[l]);
            let dz = S::of(xi[2], li[2], cz[l], clz[l]);
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

/// Fields at sources `first..first + ex.len()` (the targets), written to `ex, ey, ez` in
/// the output type `O` (the kernel's type, or f64 in the mixed mode: the f64 block sums
/// are then kept unrounded); `fast` selects the AVX-512 rsqrt path (only pass `true` when
/// [`avx512::available`]). Sources with low parts ([`Sources::lo`]) run the [`Split`]
/// kernel, others the [`Plain`] one.
///
/// Each target's field is summed in an order that depends only on the sources (lanes,
/// then j-blocks), never on which other targets are computed with it: the field of a
/// range of targets has the bits of the same targets in a pass over all of them.
pub(crate) fn field<T: CpuReal, O: Real>(
    law: ForceLaw,
    fast: bool,
    s: &Sources<'_, T>,
    first: usize,
    ex: &mut [O],
    ey: &mut [O],
    ez: &mut [O],
) {
    let p = T::from_f64(law.squared_parameter());
    let out = (first, ex, ey, ez);
    match (law, s.lo.is_some()) {
        (ForceLaw::Exact, false) => field_with::<T, O, ExactLaw, Plain>(s, p, fast, out),
        (ForceLaw::Exact, true) => field_with::<T, O, ExactLaw, Split>(s, p, fast, out),
        (ForceLaw::Exclusion { .. }, false) => {
            field_with::<T, O, ExclusionLaw, Plain>(s, p, fast, out)
        }
        (ForceLaw::Exclusion { .. }, true) => {
            field_with::<T, O, ExclusionLaw, Split>(s, p, fast, out)
        }
        (ForceLaw::Plummer { .. }, false) => field_with::<T, O, PlummerLaw, Plain>(s, p, fast, out),
        (ForceLaw::Plummer { .. }, true) => field_with::<T, O, PlummerLaw, Split>(s, p, fast, out),
    }
}

/// The targets and outputs of [`field_with`]: the first target and the three components.
type Out<'a, O> = (usize, &'a mut [O], &'a mut [O], &'a mut [O]);

fn field_with<T: CpuReal, O: Real, L: Law, S: Separation>(
    s: &Sources<'_, T>,
    p: T,
    fast: bool,
    (first, ex, ey, ez): Out<'_, O>,
) {
    let npad = s.x.len();
    debug_assert!(npad.is_multiple_of(LANES) && first + ex.len() <= npad);
    debug_assert!(s.lo.is_none_or(|lo| lo.iter().all(|l| l.len() == npad)));
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
                    lo: s.lo.map(|lo| lo.map(|l| &l[j0..j1])),
                };
                for (t, acc) in sum.iter_mut().take(ex.len()).enumerate() {
                    let i = i0 + t;
                    let li = s.lo.map_or([T::ZERO; 3], |lo| lo.map(|l| l[i]));
                    let f = T::block::<L, S>([s.x[i], s.y[i], s.z[i]], li, &block, p, fast);
                    for k in 0..3 {
                        acc[k] += f[k].to_f64();
                    }
                }
            }
            for (t, acc) in sum.iter().take(ex.len()).enumerate() {
                ex[t] = O::from_f64(acc[0]);
                ey[t] = O::from_f64(acc[1]);
                ez[t] = O::from_f64(acc[2]);
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
