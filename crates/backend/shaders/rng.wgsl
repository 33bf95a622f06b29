// Counter-based random numbers, bit-identical to `backend::rng` in Rust.
// A random word is the PCG hash (Jarzynski & Olano 2020) of a key (seed, step, index).

fn pcg_hash(input: u32) -> u32 {
    let state = input * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

fn rng_u32(seed: u32, step: u32, index: u32) -> u32 {
    return pcg_hash(index ^ pcg_hash(step ^ pcg_hash(seed)));
}

// Uniform in [0, 1) with 24 random bits.
fn rng_uniform(seed: u32, step: u32, index: u32) -> f32 {
    return f32(rng_u32(seed, step, index) >> 8u) * (1.0 / 16777216.0);
}

fn rng_bit(seed: u32, step: u32, index: u32) -> u32 {
    return rng_u32(seed, step, index) >> 31u;
}
