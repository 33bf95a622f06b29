// The random bits of the automaton, twins of src/random.rs (tests/laws.rs compares them).
// Include after the backend's rng.wgsl (pcg_hash).

// The per-step key: rng_u32(seed, step, x) == pcg_hash(x ^ fhp_step_key(seed, step)).
fn fhp_step_key(seed: u32, step: u32) -> u32 {
    return pcg_hash(step ^ pcg_hash(seed));
}

// Chirality bits of the 32 sites 32 word .. 32 word + 31 (bit b is site 32 word + b).
fn fhp_chirality_word(key: u32, word: u32) -> u32 {
    return pcg_hash(word ^ key);
}

// Chirality bit (0 or 1) of one site.
fn fhp_chirality(key: u32, site: u32) -> u32 {
    return (fhp_chirality_word(key, site >> 5u) >> (site & 31u)) & 1u;
}

// Whether the body force acts on a site: the 24-bit draw is below the threshold.
fn fhp_force_hit(force_key: u32, site: u32, threshold: u32) -> bool {
    return (pcg_hash(site ^ force_key) >> 8u) < threshold;
}
