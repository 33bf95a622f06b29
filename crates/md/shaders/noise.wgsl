// Gaussian numbers of the Langevin thermostat, twins of normal_pair and gaussians in
// src/thermostat.rs: Box-Muller pairs from the counter-based uniforms of keys
// (seed, step, 4 i + k), k = 0..4 (needs RNG_WGSL).
fn md_normal_pair(u1: f32, u2: f32) -> vec2<f32> {
    let r = sqrt(-2.0 * log(1.0 - u1));
    let a = 6.283185307179586 * u2;
    return vec2<f32>(r * cos(a), r * sin(a));
}

fn md_gaussians(seed: u32, step: u32, i: u32) -> vec3<f32> {
    let base = i * 4u;
    let a = md_normal_pair(rng_uniform(seed, step, base), rng_uniform(seed, step, base + 1u));
    let b = md_normal_pair(rng_uniform(seed, step, base + 2u), rng_uniform(seed, step, base + 3u));
    return vec3<f32>(a, b.x);
}
