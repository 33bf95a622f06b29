//! AVX-512 VBMI path of the lookup-table backend: 64 sites per iteration.
//!
//! The gathered state of a site (six direction bits and the wall bit 7) gets its chirality bit
//! in the unused rest-particle bit 6, which makes a 256-entry table. Four `zmm` registers hold
//! it; two `vpermi2b` look up the halves with bit 7 clear and set, and a blend on bit 7 picks
//! one. The scalar path of [`crate::cpu::lut`] handles the tail of a row and CPUs without VBMI; the
//! tests check both paths give the same lattice.

use std::arch::x86_64::*;

use crate::REST;

/// Whether this CPU runs the VBMI path (checked once, when a backend is built).
pub(crate) fn available() -> bool {
    is_x86_feature_detected!("avx512f")
        && is_x86_feature_detected!("avx512bw")
        && is_x86_feature_detected!("avx512vbmi")
}

/// Chirality bits of the 64 sites `site, site + 1, ...` (bit b for site `site + b`), from the
/// hashes of [`crate::random`]: bit `s % 32` of [`crate::random::chirality_word`]`(key, s / 32)`.
#[inline(always)]
pub(crate) fn chirality_mask(key: u32, site: u32) -> u64 {
    let (k, off) = (site >> 5, site & 31);
    let h = |x: u32| u128::from(crate::random::chirality_word(key, x));
    let mut bits = h(k) | h(k.wrapping_add(1)) << 32;
    if off != 0 {
        bits |= h(k.wrapping_add(2)) << 64;
    }
    (bits >> off) as u64
}

/// Streams and collides the first `64 * (out.len() / 64)` sites of a row and returns how many
/// it did. `table` is indexed by `state | chirality << 6`. `mid`, `up`, `down` are the padded rows (length `out.len() + 2`, padded index
/// `i + 1` is site `i`) of the row and its northern and southern neighbours; `first_site` is
/// the global index of site 0 of the row; `key` the step's chirality key.
///
/// # Safety
/// The CPU must support AVX-512F, AVX-512BW and AVX-512 VBMI ([`available`]).
#[target_feature(enable = "avx512f,avx512bw,avx512vbmi")]
pub(crate) unsafe fn sites<const ODD: bool>(
    table: &[u8; 256],
    out: &mut [u8],
    rows: [&[u8]; 3],
    first_site: u32,
    key: u32,
) -> usize {
    let [mid, up, down] = rows;
    let w = out.len();
    let n = w / 64 * 64;
    assert!(mid.len() >= w + 2 && up.len() >= w + 2 && down.len() >= w + 2);
    // SAFETY: `table` has 256 bytes: four unaligned 64-byte loads.
    let t = unsafe {
        let p = table.as_ptr();
        [
            _mm512_loadu_si512(p.cast()),
            _mm512_loadu_si512(p.add(64).cast()),
            _mm512_loadu_si512(p.add(128).cast()),
            _mm512_loadu_si512(p.add(192).cast()),
        ]
    };
    let bit = |b: u8| _mm512_set1_epi8(b as i8);
    let (b1, b2, b4, b8, b16, b32, rest, wall) = (
        bit(1),
        bit(2),
        bit(4),
        bit(8),
        bit(16),
        bit(32),
        bit(REST),
        bit(crate::WALL),
    );
    for i in (0..n).step_by(64) {
        // SAFETY: i + 64 <= w, so every load of 64 bytes at padded offset i + o (o <= 2) stays
        // inside a padded row of length >= w + 2.
        let ld =
            |row: &[u8], o: usize| unsafe { _mm512_loadu_si512(row.as_ptr().add(i + o).cast()) };
        let and = _mm512_and_si512;
        let or = _mm512_or_si512;
        // Padded index i + 1 is site i; its left neighbour is i, its right one i + 2.
        let mut v = or(
            or(and(ld(mid, 0), b1), and(ld(mid, 2), b8)),
            and(ld(mid, 1), wall),
        );
        v = if ODD {
            or(
                v,
                or(
                    or(and(ld(up, 1), b2), and(ld(up, 2), b4)),
                    or(and(ld(down, 2), b16), and(ld(down, 1), b32)),
                ),
            )
        } else {
            or(
                v,
                or(
                    or(and(ld(up, 0), b2), and(ld(up, 1), b4)),
                    or(and(ld(down, 1), b16), and(ld(down, 0), b32)),
                ),
            )
        };
        let chir = chirality_mask(key, first_site.wrapping_add(i as u32));
        v = or(v, _mm512_maskz_mov_epi8(chir, rest));
        let low = _mm512_permutex2var_epi8(t[0], v, t[1]);
        let high = _mm512_permutex2var_epi8(t[2], v, t[3]);
        let res = _mm512_mask_blend_epi8(_mm512_movepi8_mask(v), low, high);
        // SAFETY: i + 64 <= w = out.len().
        unsafe { _mm512_storeu_si512(out.as_mut_ptr().add(i).cast(), res) };
    }
    n
}
