// One FHP step (pull streaming + collision + optional force, inflow, outflow) for 4 sites
// packed in one u32 word. Include after the backend's rng.wgsl and dispatch.wgsl and this
// crate's params.wgsl, random.wgsl and site.wgsl (the update of one site).
// FLAGS (override): bit 0 periodic x, 1 periodic y, 2 inflow, 3 outflow, 4 body force.

override FLAGS: u32 = 0u;

@group(0) @binding(0) var<storage, read> src: array<u32>;
@group(0) @binding(1) var<storage, read_write> dst: array<u32>;
@group(0) @binding(2) var<storage, read> table: array<u32>;
@group(0) @binding(3) var<uniform> P: Params;
@group(0) @binding(4) var<storage, read> counter: array<u32>;

const WG: u32 = 64u;
var<workgroup> lut: array<u32, 512>;

// Byte of site (i, j), where i and j may lie one outside the lattice: wrapped or zero.
fn site_byte(i: i32, j: i32) -> u32 {
    var ii = i;
    var jj = j;
    let w = i32(P.width);
    let h = i32(P.height);
    if (ii < 0 || ii >= w) {
        if ((FLAGS & 1u) == 0u) { return 0u; }
        ii = (ii + w) % w;
    }
    if (jj < 0 || jj >= h) {
        if ((FLAGS & 2u) == 0u) { return 0u; }
        jj = (jj + h) % h;
    }
    let s = u32(jj) * P.width + u32(ii);
    return (src[s >> 2u] >> ((s & 3u) * 8u)) & 0xffu;
}

@compute @workgroup_size(64)
fn fhp_step(@builtin(local_invocation_id) lid: vec3<u32>,
            @builtin(workgroup_id) wid: vec3<u32>,
            @builtin(num_workgroups) nwg: vec3<u32>) {
    for (var k = lid.x; k < 512u; k += WG) {
        lut[k] = table[k];
    }
    workgroupBarrier();
    let word = linear_workgroup(wid, nwg) * WG + lid.x;
    if (word >= P.n_words) { return; }
    let t = counter[0];
    let key = fhp_step_key(P.seed, t);
    let fkey = fhp_step_key(P.force_seed, t);
    var out = 0u;
    for (var b = 0u; b < 4u; b++) {
        let s = word * 4u + b;
        if (s >= P.n_sites) { break; }
        let i = i32(s % P.width);
        let j = i32(s / P.width);
        let v = fhp_site(i, j, (j & 1) == 1, s, i, i32(P.width) - 1, key, fkey, P.threshold);
        out |= v << (b * 8u);
    }
    dst[word] = out;
}
