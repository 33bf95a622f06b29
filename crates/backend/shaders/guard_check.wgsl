// Marks the first non-finite value of one watched buffer (needs guard.wgsl, dispatch.wgsl).

@group(0) @binding(0) var<storage, read> data: array<u32>;
@group(0) @binding(1) var<storage, read_write> flags: array<atomic<u32>>;
@group(0) @binding(2) var<uniform> p: GuardParams;

@compute @workgroup_size(256)
fn check(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = linear_workgroup(wid, nwg) * 256u + lid;
    if (i >= p.count) {
        return;
    }
    var ok: bool;
    if (p.words == 1u) {
        ok = finite_f32_bits(data[i]);
    } else {
        ok = finite_f64_high_bits(data[2u * i + 1u]);
    }
    if (!ok) {
        atomicOr(&flags[1], 1u);
        atomicMin(&flags[2u + p.id], i);
    }
}
