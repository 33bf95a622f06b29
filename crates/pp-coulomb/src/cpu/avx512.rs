//! AVX-512 fast path of the field kernel: `vrsqrt14` (14-bit reciprocal square root)
//! refined by Newton–Raphson steps instead of a square root and a division. The steps carry
//! the estimate scaled by a power of two (2 y after one step, 16 y after two), which saves a
//! multiply per step; the sums are scaled back once after the loop, exactly. With
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
    let (three, zero) = (_mm512_set1_ps(3.0), _mm512_setzero_ps());
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
        // One Newton step y1 = y0 (1.5 - 0.5 arg y0^2), carried as u = 2 y1 = y0 (3 - arg y0 y0)
        // (two multiplies and a fused step); w = q y1^3 = q u^3 / 8, the 1/8 applied to the
        // sums after the loop (a power of two: the same bits as scaling every term).
        let u = _mm512_mul_ps(y0, _mm512_fnmadd_ps(_mm512_mul_ps(arg, y0), y0, three));
        let keep = match kind {
            LawKind::Plummer => !0,
            LawKind::Exact => _mm512_cmp_ps_mask::<_CMP_GT_OQ>(r2, zero),
            LawKind::Exclusion => _mm512_cmp_ps_mask::<_CMP_GT_OQ>(r2, vp),
        };
        let w = _mm512_maskz_mul_ps(keep, _mm512_mul_ps(u, u), _mm512_mul_ps(u, sq));
        ax = _mm512_fmadd_ps(w, dx, ax);
        ay = _mm512_fmadd_ps(w, dy, ay);
        az = _mm512_fmadd_ps(w, dz, az);
    }
    [ax, ay, az].map(|a| _mm512_reduce_add_ps(a) * 0.125)
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
    let (three, twelve, zero) = (
        _mm512_set1_pd(3.0),
        _mm512_set1_pd(12.0),
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
        // Two Newton steps y' = y (1.5 - 0.5 arg y^2), carried as scaled estimates (two
        // multiplies and a fused step each): u1 = y0 (3 - arg y0 y0) = 2 y1 and
        // u2 = u1 (12 - arg u1 u1) = 16 y2. Then w = q y2^3 = q u2^3 / 4096, the 1/4096 applied
        // to the sums after the loop (a power of two: the same bits as scaling every term).
        let y0 = _mm512_rsqrt14_pd(arg);
        let u1 = _mm512_mul_pd(y0, _mm512_fnmadd_pd(_mm512_mul_pd(arg, y0), y0, three));
        let u2 = _mm512_mul_pd(u1, _mm512_fnmadd_pd(_mm512_mul_pd(arg, u1), u1, twelve));
        // The pair mask applied by the last multiply.
        let keep = match kind {
            LawKind::Plummer => !0,
            LawKind::Exact => _mm512_cmp_pd_mask::<_CMP_GT_OQ>(r2, zero),
            LawKind::Exclusion => _mm512_cmp_pd_mask::<_CMP_GT_OQ>(r2, vp),
        };
        let w = _mm512_maskz_mul_pd(keep, _mm512_mul_pd(u2, u2), _mm512_mul_pd(u2, sq));
        ax = _mm512_fmadd_pd(w, dx, ax);
        ay = _mm512_fmadd_pd(w, dy, ay);
        az = _mm512_fmadd_pd(w, dz, az);
    }
    [ax, ay, az].map(|a| _mm512_reduce_add_pd(a) * (1.0 / 4096.0))
}
