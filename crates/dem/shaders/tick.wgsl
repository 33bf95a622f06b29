// Advances the device-side step counter (read by the wall motion of the next step).
@group(0) @binding(0) var<storage, read_write> clock: array<u32>;

@compute @workgroup_size(1)
fn dem_tick() {
    clock[0] = clock[0] + 1u;
}
