// The dem blow-up check at a check step, one invocation per particle (after the step
// kernels, before the GpuGuard records; needs guard.wgsl for finite_f32_bits). Failures:
// 1 non-finite position, 2 non-finite velocity, 3 centre more than its radius outside the
// box along a closed axis, 4 a contact deeper than max_overlap of the smaller radius
// (acc.w, written by dem_force), 5 more contacts than the particle's history slots hold
// (clock[1], written by dem_force). A failing particle keeps its first failure of this
// step(n) call in `evidence` (kind * 4 + axis, value bits, check step relative to the call's
// start, epoch), `first` gets the earliest failing relative step, and `alarm` turns
// non-finite, which stops the guard's snapshots (the state is then rolled back).
struct DemCheck {
    // Box corners (x, y, z, unused), vibration travel included.
    lo: vec4<f32>,
    hi: vec4<f32>,
    // 1 for a closed (non-periodic) axis x, y, z; w: 1 when the overlap limit is on.
    closed: vec4<u32>,
    max_overlap: f32,
    // Tags this step(n) call's evidence.
    epoch: u32,
    // The device step counter at the start of the call.
    begin: u32,
    pad: u32,
}

@group(0) @binding(0) var<uniform> prm: DemParams;
@group(0) @binding(1) var<uniform> chk: DemCheck;
@group(0) @binding(2) var<storage, read> pos: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> vel: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> acc: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> clock: array<u32>;
@group(0) @binding(6) var<storage, read_write> evidence: array<vec4<u32>>;
@group(0) @binding(7) var<storage, read_write> first: array<atomic<u32>>;
@group(0) @binding(8) var<storage, read_write> alarm: array<u32>;

@compute @workgroup_size(64)
fn dem_check(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = linear_workgroup(wid, nwg) * 64u + lid;
    if (i >= prm.n) {
        return;
    }
    let x = pos[i];
    let v = vel[i];
    var kind = 0u;
    var axis = 0u;
    var value = 0u;
    for (var d = 0u; d < prm.dim; d++) {
        if (kind == 0u && !finite_f32_bits(bitcast<u32>(x[d]))) {
            kind = 1u;
            axis = d;
            value = bitcast<u32>(x[d]);
        }
    }
    for (var d = 0u; d < prm.dim; d++) {
        if (kind == 0u && !finite_f32_bits(bitcast<u32>(v[d]))) {
            kind = 2u;
            axis = d;
            value = bitcast<u32>(v[d]);
        }
    }
    for (var d = 0u; d < prm.dim; d++) {
        if (kind == 0u && chk.closed[d] != 0u
            && (x[d] < chk.lo[d] - x.w || x[d] > chk.hi[d] + x.w)) {
            kind = 3u;
            axis = d;
            value = bitcast<u32>(x[d]);
        }
    }
    let ratio = acc[i].w;
    if (kind == 0u && chk.closed.w != 0u
        && (!finite_f32_bits(bitcast<u32>(ratio)) || ratio > chk.max_overlap)) {
        kind = 4u;
        value = bitcast<u32>(ratio);
    }
    if (kind == 0u && clock[1] == i + 1u) {
        kind = 5u;
    }
    if (kind != 0u) {
        let rel = clock[0] - chk.begin;
        if (evidence[i].w != chk.epoch) {
            evidence[i] = vec4<u32>(kind * 4u + axis, value, rel, chk.epoch);
        }
        atomicMin(&first[0], rel);
        alarm[0] = 0x7f800000u;
    }
}
