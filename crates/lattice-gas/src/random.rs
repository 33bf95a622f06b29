//! The random bits of the automaton, defined once and drawn identically by every backend.
//!
//! All draws use [`simkit_backend::rng::rng_u32`] (a stateless hash of `(seed, step, index)`), where
//! `step` is the number of steps completed before the current one and the site index is
//! `s = j * width + i`.
//!
//! - **Chirality** (the +-60 degree choice of the dual channels): bit `s % 32` of
//!   `rng_u32(seed, step, s / 32)`. One hash serves 32 consecutive sites, so the multi-spin
//!   backend packs a 64-site word from two hashes and the GPU shares one hash per 32 sites.
//! - **Body force** (turn a west-mover into an east-mover with probability `p`): the draw
//!   `rng_u32(seed ^ FORCE_STREAM, step, s) >> 8` (24 bits) is compared with
//!   `round(p * 2^24)`; the force acts when the draw is smaller.

use simkit_backend::rng::pcg_hash;

/// Salt xor-ed into the seed for the body-force stream.
pub const FORCE_STREAM: u32 = 0x5bd1_e995;

/// The per-step hash key: `rng_u32(seed, step, x) == pcg_hash(x ^ step_key(seed, step))`.
#[inline(always)]
pub fn step_key(seed: u32, step: u32) -> u32 {
    pcg_hash(step ^ pcg_hash(seed))
}

/// WGSL twins of this module's functions: `fhp_step_key`, `fhp_chirality_word`,
/// `fhp_chirality` and `fhp_force_hit` (after the backend's `RNG_WGSL`).
pub const RANDOM_WGSL: &str = simkit_backend::wgsl!("random.wgsl");

/// The 32 chirality bits of sites `32 word .. 32 word + 31` (bit `b` is site `32 word + b`)
/// under the step key `key` ([`step_key`]).
#[inline(always)]
pub fn chirality_word(key: u32, word: u32) -> u32 {
    pcg_hash(word ^ key)
}

/// The chirality bit (0 or 1) of site `site` at step `step`.
#[inline(always)]
pub fn chirality(seed: u32, step: u32, site: u32) -> u32 {
    (chirality_word(step_key(seed, step), site >> 5) >> (site & 31)) & 1
}

/// The 24-bit threshold of a body-force probability `p` in `[0, 1]`.
pub fn force_threshold(p: f64) -> u32 {
    (p * 16_777_216.0).round() as u32
}

/// Whether the body force acts on site `site` under the force key
/// `step_key(seed ^ FORCE_STREAM, step)`: its 24-bit draw `pcg_hash(site ^ key) >> 8` is
/// below `threshold` ([`force_threshold`]).
#[inline(always)]
pub fn force_hit(force_key: u32, site: u32, threshold: u32) -> bool {
    (pcg_hash(site ^ force_key) >> 8) < threshold
}

/// Whether the body force acts on site `site` at step `step` (threshold from
/// [`force_threshold`]).
#[inline(always)]
pub fn force_draw(seed: u32, step: u32, site: u32, threshold: u32) -> bool {
    force_hit(step_key(seed ^ FORCE_STREAM, step), site, threshold)
}

#[cfg(test)]
mod tests {
    use super::*;
    use simkit_backend::rng::rng_u32;

    #[test]
    fn step_key_matches_rng() {
        for x in [0u32, 1, 77, u32::MAX] {
            assert_eq!(pcg_hash(x ^ step_key(5, 9)), rng_u32(5, 9, x));
        }
        for site in [0u32, 31, 32, 1000, u32::MAX] {
            assert_eq!(
                chirality(5, 9, site),
                (rng_u32(5, 9, site >> 5) >> (site & 31)) & 1
            );
            assert_eq!(
                force_draw(5, 9, site, 1 << 23),
                (rng_u32(5 ^ FORCE_STREAM, 9, site) >> 8) < 1 << 23
            );
        }
        let ones: u32 = (0..64_000).map(|s| chirality(3, 4, s)).sum();
        assert!((ones as f64 / 64_000.0 - 0.5).abs() < 0.01);
    }
}
