// Integrator pass kick_drift: v += a coef[0]; x_out = x_in + v coef[1] (positions are
// double-buffered: x_in is never written). The lone kick of leapfrog is in kick.wgsl.

override N: u32;
const WG: u32 = 128u;

@group(0) @binding(0) var<storage, read> pos_in: array<vec4<REAL>>;
@group(0) @binding(1) var<storage, read_write> pos_out: array<vec4<REAL>>;
@group(0) @binding(2) var<storage, read_write> vel: array<vec4<REAL>>;
@group(0) @binding(3) var<storage, read> acc: array<vec4<REAL>>;
@group(0) @binding(4) var<storage, read> coef: array<REAL>;

@compute @workgroup_size(WG)
fn kick_drift(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = linear_workgroup(wid, nwg) * WG + lid;
    if (i >= N) {
        return;
    }
    let v = vel[i].xyz + acc[i].xyz * coef[0];
    vel[i] = vec4<REAL>(v, vel[i].w);
    pos_out[i] = vec4<REAL>(pos_in[i].xyz + v * coef[1], pos_in[i].w);
}
