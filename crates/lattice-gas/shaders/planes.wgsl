// One FHP step on bit-planes: one invocation per 32-site word of one row, six direction
// planes, collisions as boolean logic, streaming as shifts (the multi-spin scheme of the CPU
// backend with 32-bit words). Include after the backend's rng.wgsl and dispatch.wgsl and
// this crate's params.wgsl, random.wgsl and collide.wgsl.
// Layout: planes[(j * 6 + d) * nw + k] holds direction d of sites 32k..32k+31 of row j
// (bit b = site 32k + b); walls[j * nw + k] the wall flags. The width is a multiple of 32, so
// the chirality word of the 32 sites is exactly one hash, fhp_chirality_word(key, word).
// FLAGS (override): bit 0 periodic x, 1 periodic y, 2 inflow, 3 outflow, 4 body force.
// FULL (override): 1 = the full rule set, 0 = FHP-I.

override FLAGS: u32 = 0u;
override FULL: u32 = 0u;

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
    let r = fhp_chirality_word(fhp_step_key(P.seed, t), word);
    let wall = walls[word];
    var o = fhp_collide(array<u32, 6>(a, b, c, dd, e, f), r, wall, FULL != 0u);

    // Body force: a west-mover without an east-mover turns east with probability p.
    if ((FLAGS & 16u) != 0u) {
        let fkey = fhp_step_key(P.force_seed, t);
        let base = word * 32u;
        var hits = 0u;
        for (var bit = 0u; bit < 32u; bit++) {
            if (fhp_force_hit(fkey, base + bit, P.threshold)) { hits |= 1u << bit; }
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
