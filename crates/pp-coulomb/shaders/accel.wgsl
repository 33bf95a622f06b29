// All-pairs field with workgroup tiles: each invocation owns one target particle; the
// workgroup stages WG source particles at a time in workgroup memory and every invocation
// sums their fields on its target. REAL (f32 or f64), rsqrt_real and pair_weight come from
// the sources concatenated before this one (see crates/pp-coulomb/src/gpu.rs).

override N: u32;            // particles
override NPAD: u32;         // particles padded to a multiple of WG (zero-charge padding)
override EXACT: bool;       // flag coincident pairs (exact law only)
const WG: u32 = 128u;

@group(0) @binding(0) var<storage, read> pos: array<vec4<REAL>>;        // x, y, z, charge
@group(0) @binding(1) var<storage, read> vel: array<vec4<REAL>>;        // vx, vy, vz, q/m
@group(0) @binding(2) var<storage, read_write> acc: array<vec4<REAL>>;  // ax, ay, az, 0
@group(0) @binding(3) var<storage, read_write> partner: array<u32>;     // coincident j + 1
@group(0) @binding(4) var<storage, read> coef: array<REAL>;             // [law parameter]
// NaN bits (as f32) where a particle met a coincident partner: the blow-up guard, which
// checks this buffer for non-finite values, catches it with the state (exact law only).
@group(0) @binding(5) var<storage, read_write> coincident_flag: array<u32>;
const FLAG: u32 = 0x7fc00000u;

var<workgroup> tile: array<vec4<REAL>, WG>;

@compute @workgroup_size(WG)
fn accel(
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
    let p = coef[0];
    var e = vec3<REAL>(0.0, 0.0, 0.0);
    var coincident = 0u;
    for (var t = 0u; t < NPAD; t += WG) {
        workgroupBarrier();
        tile[lid] = pos[t + lid];
        workgroupBarrier();
        for (var k = 0u; k < WG; k++) {
            let s = tile[k];
            let d = xi - s.xyz;
            let r2 = dot(d, d);
            e += (s.w * pair_weight(r2, p)) * d;
            if (EXACT) {
                if (r2 == 0.0 && t + k != i) {
                    coincident = t + k + 1u;
                }
            }
        }
    }
    if (i < N) {
        acc[i] = vec4<REAL>(e * vel[i].w, 0.0);
        if (coincident != 0u) {
            partner[i] = coincident;
            coincident_flag[i] = FLAG;
        }
    }
}
