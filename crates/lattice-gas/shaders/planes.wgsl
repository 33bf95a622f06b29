// One FHP step on bit-planes: one invocation per 32-site word of one row, six direction
// planes, collisions as boolean logic, streaming as shifts (the multi-spin scheme of the CPU
// backend with 32-bit words). Include after common/rng.wgsl and common/dispatch.wgsl.
// Layout: planes[(j * 6 + d) * nw + k] holds direction d of sites 32k..32k+31 of row j
// (bit b = site 32k + b); walls[j * nw + k] the wall flags. The width is a multiple of 32, so
// the chirality word of the 32 sites is exactly one hash, pcg_hash(word ^ key).
// FLAGS (override): bit 0 periodic x, 1 periodic y, 2 inflow, 3 outflow, 4 body force.
// FULL (override): 1 = the full rule set, 0 = FHP-I.

override FLAGS: u32 = 0u;
override FULL: u32 = 0u;

struct Params {
    width: u32,
    height: u32,
    nw: u32,
    n_words: u32,
    seed: u32,
    force_seed: u32,
    threshold: u32,
    pad: u32,
}

@group(0) @binding(0) var<storage, read> src: array<u32>;
@group(0) @binding(1) var<storage, read_write> dst: array<u32>;
@group(0) @binding(2) var<storage, read> walls: array<u32>;
@group(0) @binding(3) var<uniform> P: Params;
@group(0) @binding(4) var<storage, read> counter: array<u32>;

const WG: u32 = 64u;

fn plane(j: u32, d: u32, k: u32) -> u32 {
    return src[(j * 6u + d) * P.nw + k];
}

// Word k of plane d of row j, shifted so that site i holds the bit of site i - 1.
fn from_left(j: u32, d: u32, k: u32) -> u32 {
    var carry = 0u;
    if (k > 0u) {
        carry = plane(j, d, k - 1u) >> 31u;
    } else if ((FLAGS & 1u) != 0u) {
        carry = plane(j, d, P.nw - 1u) >> 31u;
    }
    return (plane(j, d, k) << 1u) | carry;
}

// Word k of plane d of row j, shifted so that site i holds the bit of site i + 1.
fn from_right(j: u32, d: u32, k: u32) -> u32 {
    var carry = 0u;
    if (k + 1u < P.nw) {
        carry = plane(j, d, k + 1u) << 31u;
    } else if ((FLAGS & 1u) != 0u) {
        carry = plane(j, d, 0u) << 31u;
    }
    return (plane(j, d, k) >> 1u) | carry;
}

@compute @workgroup_size(64)
fn fhp_planes(@builtin(local_invocation_id) lid: vec3<u32>,
              @builtin(workgroup_id) wid: vec3<u32>,
              @builtin(num_workgroups) nwg: vec3<u32>) {
    let word = linear_workgroup(wid, nwg) * WG + lid.x;
    if (word >= P.n_words) { return; }
    let nw = P.nw;
    let j = word / nw;
    let k = word % nw;
    var has_up = j + 1u < P.height;
    var up = j + 1u;
    if (!has_up && (FLAGS & 2u) != 0u) { has_up = true; up = 0u; }
    var has_down = j > 0u;
    var down = 0u;
    if (has_down) { down = j - 1u; } else if ((FLAGS & 2u) != 0u) { has_down = true; down = P.height - 1u; }
    let odd = (j & 1u) == 1u;

    // Pull streaming: the incoming particles of each direction.
    let a = from_left(j, 0u, k);
    let dd = from_right(j, 3u, k);
    var b = 0u;
    var c = 0u;
    var e = 0u;
    var f = 0u;
    if (has_up) {
        if (odd) { b = plane(up, 1u, k); c = from_right(up, 2u, k); }
        else { b = from_left(up, 1u, k); c = plane(up, 2u, k); }
    }
    if (has_down) {
        if (odd) { e = from_right(down, 4u, k); f = plane(down, 5u, k); }
        else { e = plane(down, 4u, k); f = from_left(down, 5u, k); }
    }

    // Collision.
    let t = counter[0];
    let r = pcg_hash(word ^ pcg_hash(t ^ pcg_hash(P.seed)));
    let wall = walls[word];
    let p1 = a & dd;
    let p2 = b & e;
    let p3 = c & f;
    let z1 = ~(a | dd);
    let z2 = ~(b | e);
    let z3 = ~(c | f);
    var rot = (p1 & z2 & z3) | (p2 & z1 & z3) | (p3 & z1 & z2)
        | ((a ^ b) & (b ^ c) & (c ^ dd) & (dd ^ e) & (e ^ f));
    var fl1 = 0u;
    var fl2 = 0u;
    var fl3 = 0u;
    if (FULL != 0u) {
        rot = rot | (p1 & p2 & z3) | (p1 & p3 & z2) | (p2 & p3 & z1);
        // A head-on pair with a spectator on one axis moves to the third axis.
        let s1 = (a ^ dd) & ((p2 & z3) | (p3 & z2));
        let s2 = (b ^ e) & ((p1 & z3) | (p3 & z1));
        let s3 = (c ^ f) & ((p1 & z2) | (p2 & z1));
        fl1 = s2 | s3;
        fl2 = s1 | s3;
        fl3 = s1 | s2;
    }
    let s = array<u32, 6>(a, b, c, dd, e, f);
    // Chirality 1 rotates clockwise: new direction d holds old d - 1.
    let cw = array<u32, 6>(f, a, b, c, dd, e);
    let ccw = array<u32, 6>(b, c, dd, e, f, a);
    let flips = array<u32, 6>(fl1, fl2, fl3, fl1, fl2, fl3);
    let rev = array<u32, 6>(dd, e, f, a, b, c);
    var o: array<u32, 6>;
    for (var d = 0u; d < 6u; d++) {
        let rotated = (r & cw[d]) | (~r & ccw[d]);
        let fluid = (rot & rotated) | (~rot & (s[d] ^ flips[d]));
        o[d] = (wall & rev[d]) | (~wall & fluid);
    }

    // Body force: a west-mover without an east-mover turns east with probability p.
    if ((FLAGS & 16u) != 0u) {
        let fkey = pcg_hash(t ^ pcg_hash(P.force_seed));
        let base = word * 32u;
        var hits = 0u;
        for (var bit = 0u; bit < 32u; bit++) {
            if ((pcg_hash((base + bit) ^ fkey) >> 8u) < P.threshold) { hits |= 1u << bit; }
        }
        let cond = hits & o[3] & ~o[0] & ~wall;
        o[0] |= cond;
        o[3] &= ~cond;
    }
    if ((FLAGS & 4u) != 0u && k == 0u && (wall & 1u) == 0u) {
        for (var d = 0u; d < 6u; d++) { o[d] &= ~1u; }
        o[0] |= 1u;
    }
    if ((FLAGS & 8u) != 0u && k == nw - 1u && (wall >> 31u) == 0u) {
        for (var d = 0u; d < 6u; d++) { o[d] &= ~(1u << 31u); }
    }
    for (var d = 0u; d < 6u; d++) {
        dst[(j * 6u + d) * nw + k] = o[d];
    }
}
