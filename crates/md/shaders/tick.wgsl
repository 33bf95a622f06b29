// Advances the device step counter that keys the thermostat's random numbers.
@group(0) @binding(0) var<storage, read_write> tick: array<u32>;

@compute @workgroup_size(64)
fn md_tick(@builtin(local_invocation_index) lid: u32) {
    if (lid == 0u) {
        tick[0] = tick[0] + 1u;
    }
}
