// Parameters of both step kernels (fhp_step on bytes, fhp_planes on bit-planes); the Rust
// mirror is GpuParams in src/gpu.rs (layout test there). Prepended to each step kernel.

struct Params {
    // Sites per row.
    width: u32,
    // Rows.
    height: u32,
    // Sites (width * height).
    n_sites: u32,
    // Words per row of one bit-plane (bit-plane layout; width / 32).
    nw: u32,
    // Invocations: one per u32 word of the lattice buffer (bytes) or of one plane (bit-planes).
    n_words: u32,
    // Chirality key seed (random.rs: rng_u32(seed, step, site / 32)).
    seed: u32,
    // Body-force seed: seed ^ FORCE_STREAM.
    force_seed: u32,
    // Body-force threshold round(p * 2^24) for the 24-bit draw.
    threshold: u32,
}
