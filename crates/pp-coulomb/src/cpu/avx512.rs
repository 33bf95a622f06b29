//! AVX-512 fast path of the field kernel: `vrsqrt14` (14-bit reciprocal square root)
//! refined by Newton–Raphson steps instead of a square root and a division. With
//! `SPLIT`, the separations come from coordinates split into high and low parts, as
//! `kernel::Split` forms them (the mixed mode).
//!
//! One Newton step takes the estimate to about 2e-8 relative (below f32 rounding, ~6e-8);
//! two steps take it to a few f64 ulps. The tests compare both against a plain f64 reference.
//! Pairs are masked (self pair, exclusion radius) after the arithmetic, so `rsqrt(0) = inf`
//! never reaches a sum. The formulas are those of [`crate::laws`] (the same argument of the
//! reciprocal square root, the same masks); the tests compare this path with them.

use std::arch::x86_64::*;

use super::pairs::{LawKind, Sources};

/// Whether this CPU runs the AVX-512 path (checked once per force evaluation).
pub(crate) fn available() -> bool {
    is_x86_feature_detected!("avx512f")
}

/// f32 field of one target from a block of sources (length a multiple of 16).
///
/// # Safety
/// The CPU must support AVX-512F ([`available`]).
#[target_feature(enable = "avx512f")]
pub(crate) unsafe fn block_f32<const SPLIT: bool>(
    kind: LawKind,
    [xi, yi, zi]: [f32; 3],
    li: [f32; 3],
    s: &Sources<'_, f32>,
    p: f32,
) -> [f32; 3] {
    let n = s.x.len() / 16 * 16;
    let (x, y, z, q) = (&s.x[..n], &s.y[..n], &s.z[..n], &s.q[..n]);
    // Plain coordinates: the low parts are never read (any slices of the right length).
    let [lx, ly, lz] = s.lo.unwrap_or([s.x, s.y, s.z]).map(|l| &l[..n]);
    let (vx, vy, vz, vp) = (
        _mm512_set1_ps(xi),
        _mm512_set1_ps(yi),
        _mm512_set1_ps(zi),
        _mm512_set1_ps(p),
    );
    let vl = li.map(|l| _mm512_set1_ps(l));
    let (half, three_halves, zero) = (
        _mm512_set1_ps(0.5),
        _mm512_set1_ps(1.5),
        _mm512_setzero_ps(),
    );
    let (mut ax, mut ay, mut az) = (zero, zero, zero);
    for c in (0..n).step_by(16) {
        // SAFETY: c + 16 <= n, the length of every slice.
        let (sx, sy, sz, sq) = unsafe {
            (
                _mm512_loadu_ps(x.as_ptr().add(c)),
                _mm512_loadu_ps(y.as_ptr().add(c)),
                _mm512_loadu_ps(z.as_ptr().add(c)),
                _mm512_loadu_ps(q.as_ptr().add(c)),
            )
        };
        let (mut dx, mut dy, mut dz) = (
            _mm512_sub_ps(vx, sx),
            _mm512_sub_ps(vy, sy),
            _mm512_sub_ps(vz, sz),
        );
        if SPLIT {
            // (xi - xj) + (li - lj), as `Split::of` in the portable kernel.
            // SAFETY: c + 16 <= n, the length of every slice.
            let (sl0, sl1, sl2) = unsafe {
                (
                    _mm512_loadu_ps(lx.as_ptr().add(c)),
                    _mm512_loadu_ps(ly.as_ptr().add(c)),
                    _mm512_loadu_ps(lz.as_ptr().add(c)),
                )
            };
            dx = _mm512_add_ps(dx, _mm512_sub_ps(vl[0], sl0));
            dy = _mm512_add_ps(dy, _mm512_sub_ps(vl[1], sl1));
            dz = _mm512_add_ps(dz, _mm512_sub_ps(vl[2], sl2));
        }
        let r2 = _mm512_fmadd_ps(dx, dx, _mm512_fmadd_ps(dy, dy, _mm512_mul_ps(dz, dz)));
        let arg = if kind == LawKind::Plummer {
            _mm512_add_ps(r2, vp)
        } else {
            r2
        };
        let y0 = _mm512_rsqrt14_ps(arg);
        // y1 = y0 (1.5 - 0.5 arg y0^2)
        let h = _mm512_mul_ps(_mm512_mul_ps(half, arg), _mm512_mul_ps(y0, y0));
        let y1 = _mm512_mul_ps(y0, _mm512_sub_ps(three_halves, h));
        let w = _mm512_mul_ps(_mm512_mul_ps(y1, y1), _mm512_mul_ps(y1, sq));
        let w = match kind {
            LawKind::Plummer => w,
            LawKind::Exact => _mm512_maskz_mov_ps(_mm512_cmp_ps_mask::<_CMP_GT_OQ>(r2, zero), w),
            LawKind::Exclusion => _mm512_maskz_mov_ps(_mm512_cmp_ps_mask::<_CMP_GT_OQ>(r2, vp), w),
        };
        ax = _mm512_fmadd_ps(w, dx, ax);
        ay = _mm512_fmadd_ps(w, dy, ay);
        az = _mm512_fmadd_ps(w, dz, az);
    }
    [
        _mm512_reduce_add_ps(ax),
        _mm512_reduce_add_ps(ay),
        _mm512_reduce_add_ps(az),
    ]
}

/// f64 field of one target from a block of sources (length a multiple of 8).
///
/// # Safety
/// The CPU must support AVX-512F ([`available`]).
#[target_feature(enable = "avx512f")]
pub(crate) unsafe fn block_f64<const SPLIT: bool>(
    kind: LawKind,
    [xi, yi, zi]: [f64; 3],
    li: [f64; 3],
    s: &Sources<'_, f64>,
    p: f64,
) -> [f64; 3] {
    let n = s.x.len() / 8 * 8;
    let (x, y, z, q) = (&s.x[..n], &s.y[..n], &s.z[..n], &s.q[..n]);
    // Plain coordinates: the low parts are never read (any slices of the right length).
    let [lx, ly, lz] = s.lo.unwrap_or([s.x, s.y, s.z]).map(|l| &l[..n]);
    let (vx, vy, vz, vp) = (
        _mm512_set1_pd(xi),
        _mm512_set1_pd(yi),
        _mm512_set1_pd(zi),
        _mm512_set1_pd(p),
    );
    let vl = li.map(|l| _mm512_set1_pd(l));
    let (half, three_halves, zero) = (
        _mm512_set1_pd(0.5),
        _mm512_set1_pd(1.5),
        _mm512_setzero_pd(),
    );
    let (mut ax, mut ay, mut az) = (zero, zero, zero);
    for c in (0..n).step_by(8) {
        // SAFETY: c + 8 <= n, the length of every slice.
        let (sx, sy, sz, sq) = unsafe {
            (
                _mm512_loadu_pd(x.as_ptr().add(c)),
                _mm512_loadu_pd(y.as_ptr().add(c)),
                _mm512_loadu_pd(z.as_ptr().add(c)),
                _mm512_loadu_pd(q.as_ptr().add(c)),
            )
        };
        let (mut dx, mut dy, mut dz) = (
            _mm512_sub_pd(vx, sx),
            _mm512_sub_pd(vy, sy),
            _mm512_sub_pd(vz, sz),
        );
        if SPLIT {
            // (xi - xj) + (li - lj), as `Split::of` in the portable kernel.
            // SAFETY: c + 8 <= n, the length of every slice.
            let (sl0, sl1, sl2) = unsafe {
                (
                    _mm512_loadu_pd(lx.as_ptr().add(c)),
                    _mm512_loadu_pd(ly.as_ptr().add(c)),
                    _mm512_loadu_pd(lz.as_ptr().add(c)),
                )
            };
            dx = _mm512_add_pd(dx, _mm512_sub_pd(vl[0], sl0));
            dy = _mm512_add_pd(dy, _mm512_sub_pd(vl[1], sl1));
            dz = _mm512_add_pd(dz, _mm512_sub_pd(vl[2], sl2));
        }
        let r2 = _mm512_fmadd_pd(dx, dx, _mm512_fmadd_pd(dy, dy, _mm512_mul_pd(dz, dz)));
        let arg = if kind == LawKind::Plummer {
            _mm512_add_pd(r2, vp)
        } else {
            r2
        };
        let ha = _mm512_mul_pd(half, arg);
        let mut yk = _mm512_rsqrt14_pd(arg);
        for _ in 0..2 {
            // y = y (1.5 - (0.5 arg y) y), the bracket in one fused step.
            let hy = _mm512_mul_pd(ha, yk);
            yk = _mm512_mul_pd(yk, _mm512_fnmadd_pd(hy, yk, three_halves));
        }
        // w = y^3 q, the pair mask applied by the last multiply.
        let keep = match kind {
            LawKind::Plummer => !0,
            LawKind::Exact => _mm512_cmp_pd_mask::<_CMP_GT_OQ>(r2, zero),
            LawKind::Exclusion => _mm512_cmp_pd_mask::<_CMP_GT_OQ>(r2, vp),
        };
        let w = _mm512_maskz_mul_pd(keep, _mm512_mul_pd(yk, yk), _mm512_mul_pd(yk, sq));
        ax = _mm512_fmadd_pd(w, dx, ax);
        ay = _mm512_fmadd_pd(w, dy, ay);
        az = _mm512_fmadd_pd(w, dz, az);
    }
    [
        _mm512_reduce_add_pd(ax),
        _mm512_reduce_add_pd(ay),
        _mm512_reduce_add_pd(az),
    ]
}
