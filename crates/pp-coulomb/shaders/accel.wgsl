// All-pairs field with workgroup tiles: each invocation owns TPI target particles (1, 2, 4
// or 8), WG apart; the workgroup stages WG source particles at a time in workgroup memory and
// every invocation sums their fields on its targets, so that one read of a source from
// workgroup memory serves TPI targets. Every target sums its sources in index order whatever
// WG and TPI are: the result does not depend on the tile. REAL (f32 or f64), rsqrt_real and
// pair_weight come from the sources concatenated before this one, and the line
// `const WG: u32 = ..; const TPI: u32 = ..;` from the host (see crates/pp-coulomb/src/gpu.rs).
// The targets are unrolled by hand behind `TPI >= 2u`, `>= 4u`, `>= 8u` (constant conditions)
// rather than looped over: a loop would count against the loop limit of software drivers.

override N: u32;            // particles
override NPAD: u32;         // particles padded to a multiple of WG * TPI (zero-charge padding)
override EXACT: bool;       // flag coincident pairs (exact law only)

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

// Adds source j (s) to the field e of target i at x, and records j + 1 in c when the two
// coincide (exact law only).
fn add_source(
    e: ptr<function, vec3<REAL>>,
    c: ptr<function, u32>,
    x: vec3<REAL>,
    s: vec4<REAL>,
    p: REAL,
    i: u32,
    j: u32,
) {
    let d = x - s.xyz;
    let r2 = dot(d, d);
    *e += (s.w * pair_weight(r2, p)) * d;
    if (EXACT && r2 == 0.0 && j != i) {
        *c = j + 1u;
    }
}

// Writes target i's acceleration and its coincident partner, if any.
fn store(i: u32, e: vec3<REAL>, coincident: u32) {
    if (i < N) {
        acc[i] = vec4<REAL>(e * vel[i].w, 0.0);
        if (coincident != 0u) {
            partner[i] = coincident;
            coincident_flag[i] = FLAG;
        }
    }
}

@compute @workgroup_size(WG)
fn accel(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let g = linear_workgroup(wid, nwg);
    if (g * WG * TPI >= NPAD) {
        return;
    }
    let i0 = g * WG * TPI + lid;
    let i1 = i0 + WG;
    let i2 = i0 + 2u * WG;
    let i3 = i0 + 3u * WG;
    let i4 = i0 + 4u * WG;
    let i5 = i0 + 5u * WG;
    let i6 = i0 + 6u * WG;
    let i7 = i0 + 7u * WG;
    let x0 = pos[i0].xyz;
    var x1 = x0;
    var x2 = x0;
    var x3 = x0;
    var x4 = x0;
    var x5 = x0;
    var x6 = x0;
    var x7 = x0;
    if (TPI >= 2u) {
        x1 = pos[i1].xyz;
    }
    if (TPI >= 4u) {
        x2 = pos[i2].xyz;
        x3 = pos[i3].xyz;
    }
    if (TPI >= 8u) {
        x4 = pos[i4].xyz;
        x5 = pos[i5].xyz;
        x6 = pos[i6].xyz;
        x7 = pos[i7].xyz;
    }
    let p = coef[0];
    var e0 = vec3<REAL>(0.0, 0.0, 0.0);
    var e1 = e0;
    var e2 = e0;
    var e3 = e0;
    var e4 = e0;
    var e5 = e0;
    var e6 = e0;
    var e7 = e0;
    var c0 = 0u;
    var c1 = 0u;
    var c2 = 0u;
    var c3 = 0u;
    var c4 = 0u;
    var c5 = 0u;
    var c6 = 0u;
    var c7 = 0u;
    for (var t = 0u; t < NPAD; t += WG) {
        workgroupBarrier();
        tile[lid] = pos[t + lid];
        workgroupBarrier();
        for (var k = 0u; k < WG; k++) {
            let s = tile[k];
            add_source(&e0, &c0, x0, s, p, i0, t + k);
            if (TPI >= 2u) {
                add_source(&e1, &c1, x1, s, p, i1, t + k);
            }
            if (TPI >= 4u) {
                add_source(&e2, &c2, x2, s, p, i2, t + k);
                add_source(&e3, &c3, x3, s, p, i3, t + k);
            }
            if (TPI >= 8u) {
                add_source(&e4, &c4, x4, s, p, i4, t + k);
                add_source(&e5, &c5, x5, s, p, i5, t + k);
                add_source(&e6, &c6, x6, s, p, i6, t + k);
                add_source(&e7, &c7, x7, s, p, i7, t + k);
            }
        }
    }
    store(i0, e0, c0);
    if (TPI >= 2u) {
        store(i1, e1, c1);
    }
    if (TPI >= 4u) {
        store(i2, e2, c2);
        store(i3, e3, c3);
    }
    if (TPI >= 8u) {
        store(i4, e4, c4);
        store(i5, e5, c5);
        store(i6, e6, c6);
        store(i7, e7, c7);
    }
}
