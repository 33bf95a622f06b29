// Second half-kick of leapfrog: v += a coef[0].

override N: u32;
const WG: u32 = 128u;

@group(0) @binding(0) var<storage, read_write> vel: array<vec4<REAL>>;
@group(0) @binding(1) var<storage, read> acc: array<vec4<REAL>>;
@group(0) @binding(2) var<storage, read> coef: array<REAL>;

@compute @workgroup_size(WG)
fn kick(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = linear_workgroup(wid, nwg) * WG + lid;
    if (i >= N) {
        return;
    }
    vel[i] = vec4<REAL>(vel[i].xyz + acc[i].xyz * coef[0], vel[i].w);
}
