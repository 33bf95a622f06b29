// The blow-up check of the GPU backends (simkit_backend::gpu::GpuGuard): shared pieces.
//
// flags[0]: checks passed so far in this step(n) call; flags[1]: 1 once a check failed;
// flags[2 + b]: index of the first bad value found in watched buffer b (0xffffffff: none).

struct GuardParams {
    // Which watched buffer this dispatch covers.
    id: u32,
    // u32 words per value: 1 (f32) or 2 (f64).
    words: u32,
    // Values to check, or words to copy.
    count: u32,
    pad: u32,
}

// Whether the f32 with these bits is finite (its exponent is not all ones): the twin of
// f32::is_finite, on the bits so that no compiler option can assume NaN away.
fn finite_f32_bits(bits: u32) -> bool {
    return (bits & 0x7f800000u) != 0x7f800000u;
}

// Whether the f64 whose high (second, little-endian) word is `hi` is finite.
fn finite_f64_high_bits(hi: u32) -> bool {
    return (hi & 0x7ff00000u) != 0x7ff00000u;
}
