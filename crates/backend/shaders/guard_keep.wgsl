// Copies a watched buffer into its snapshot while no check has failed (needs guard.wgsl,
// dispatch.wgsl).

@group(0) @binding(0) var<storage, read> src: array<u32>;
@group(0) @binding(1) var<storage, read_write> dst: array<u32>;
@group(0) @binding(2) var<storage, read> flags: array<u32>;
@group(0) @binding(3) var<uniform> p: GuardParams;

@compute @workgroup_size(256)
fn keep(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = linear_workgroup(wid, nwg) * 256u + lid;
    if (i >= p.count || flags[1] != 0u) {
        return;
    }
    dst[i] = src[i];
}
