//! Counter-based random numbers shared bit for bit by the CPU and the WGSL shaders.
//!
//! The generator is stateless: a random word is a hash of a key `(seed, step, index)`, so every
//! backend, thread and work item draws the same bits for the same key without any shared state.
//! The mixing function is the PCG-family integer hash of Jarzynski & Olano (JCGT 2020): one
//! 32-bit multiply-add, a data-dependent shift, xor and a second multiply. The WGSL twin lives
//! in `shaders/rng.wgsl` of this crate ([`RNG_WGSL`]) and uses only the same 32-bit wrapping integer
//! operations, so results are identical on every device.

/// WGSL source of the same functions (`pcg_hash`, `rng_u32`, `rng_uniform`, `rng_bit`).
pub const RNG_WGSL: &str = crate::wgsl!("rng.wgsl");

/// The PCG hash: a bijective mixing of a 32-bit word.
#[inline(always)]
pub fn pcg_hash(input: u32) -> u32 {
    let state = input.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// The random word for key `(seed, step, index)`.
///
/// Each key component passes through the hash before the next is mixed in, so neighbouring
/// indices, steps and seeds give unrelated words. `step` wraps at 2^32.
#[inline(always)]
pub fn rng_u32(seed: u32, step: u32, index: u32) -> u32 {
    pcg_hash(index ^ pcg_hash(step ^ pcg_hash(seed)))
}

/// A uniform float in `[0, 1)` with 24 random bits, identical to the WGSL `rng_uniform`.
#[inline(always)]
pub fn rng_uniform(seed: u32, step: u32, index: u32) -> f32 {
    (rng_u32(seed, step, index) >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// A random bit (the top bit of the word), identical to the WGSL `rng_bit`.
#[inline(always)]
pub fn rng_bit(seed: u32, step: u32, index: u32) -> u32 {
    rng_u32(seed, step, index) >> 31
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hash_is_a_bijection_on_a_sample() {
        let mut seen = std::collections::HashSet::new();
        for i in 0..200_000u32 {
            assert!(seen.insert(pcg_hash(i)));
        }
    }

    #[test]
    fn uniform_mean_and_bit_balance() {
        let n = 1_000_000u32;
        let mean: f64 = (0..n).map(|i| rng_uniform(7, 3, i) as f64).sum::<f64>() / n as f64;
        // Standard error of the mean of U(0,1) over 1e6 draws is 2.9e-4.
        assert!((mean - 0.5).abs() < 2e-3, "mean {mean}");
        let ones: u32 = (0..n).map(|i| rng_bit(1, 0, i)).sum();
        let frac = ones as f64 / n as f64;
        assert!((frac - 0.5).abs() < 2e-3, "bit fraction {frac}");
        // Consecutive steps at one index are not correlated.
        let agree = (0..n)
            .filter(|&s| rng_bit(1, s, 5) == rng_bit(1, s + 1, 5))
            .count();
        assert!((agree as f64 / n as f64 - 0.5).abs() < 2e-3);
    }

    #[test]
    fn uniform_is_in_unit_interval() {
        for i in 0..100_000 {
            let u = rng_uniform(u32::MAX, u32::MAX, i);
            assert!((0.0..1.0).contains(&u));
        }
    }
}
