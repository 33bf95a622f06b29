// Energy of the exact law for the blow-up guard: each invocation owns one particle and sums
// q_j pair_potential(r2) over all sources in workgroup tiles (as accel.wgsl sums the field);
// each workgroup then reduces its particles' kinetic m v^2 / 2 and potential q_i phi_i / 2
// to one pair of partial sums, which the host adds in f64 (one small read-back). REAL,
// rsqrt_real and pair_potential come from the sources concatenated before this one.

override N: u32;            // particles
override NPAD: u32;         // particles padded to a multiple of WG (zero-charge padding)
const WG: u32 = 128u;

@group(0) @binding(0) var<storage, read> pos: array<vec4<REAL>>;        // x, y, z, charge
@group(0) @binding(1) var<storage, read> vel: array<vec4<REAL>>;        // vx, vy, vz, q/m
@group(0) @binding(2) var<storage, read> mass: array<REAL>;
@group(0) @binding(3) var<storage, read_write> partial: array<REAL>;    // [K_g, U_g] per group

var<workgroup> tile: array<vec4<REAL>, WG>;
var<workgroup> sums: array<vec2<REAL>, WG>;

@compute @workgroup_size(WG)
fn energy(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let g = linear_workgroup(wid, nwg);
    if (g * WG >= NPAD) {
        return;
    }
    let i = g * WG + lid;
    let xi = pos[i].xyz;
    var phi: REAL = 0.0;
    for (var t = 0u; t < NPAD; t += WG) {
        workgroupBarrier();
        tile[lid] = pos[t + lid];
        workgroupBarrier();
        for (var k = 0u; k < WG; k++) {
            let s = tile[k];
            let d = xi - s.xyz;
            phi += s.w * pair_potential(dot(d, d));
        }
    }
    var e = vec2<REAL>(0.0, 0.0);
    if (i < N) {
        let v = vel[i].xyz;
        e = vec2<REAL>(0.5 * mass[i] * dot(v, v), 0.5 * pos[i].w * phi);
    }
    sums[lid] = e;
    workgroupBarrier();
    for (var h = WG / 2u; h > 0u; h = h / 2u) {
        if (lid < h) {
            sums[lid] += sums[lid + h];
        }
        workgroupBarrier();
    }
    if (lid == 0u) {
        partial[2u * g] = sums[0].x;
        partial[2u * g + 1u] = sums[0].y;
    }
}
