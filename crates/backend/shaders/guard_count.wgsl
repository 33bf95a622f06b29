// Counts a passed check (one invocation, after the keeps).

@group(0) @binding(0) var<storage, read_write> flags: array<u32>;

@compute @workgroup_size(1)
fn count() {
    if (flags[1] == 0u) {
        flags[0] = flags[0] + 1u;
    }
}
