// One FHP step (byte rule) of one rank's block of a distributed lattice, one site per u32:
// src and dst hold the block padded with one ghost layer, (nx + 2) x (ny + 2) sites
// row-major with the block's site (0, 0) at padded (1, 1); the ghosts hold the neighbours'
// sites (exchanged through the host, halo.wgsl) or 0 past a closed edge of the lattice, as
// the single-process kernel reads them. Writes the interior of dst. Include after the
// backend's rng.wgsl and dispatch.wgsl and this crate's random.wgsl and site.wgsl.
// FLAGS (override): bit 2 inflow, 3 outflow, 4 body force (periodic axes are the ghosts').

override FLAGS: u32 = 0u;

// The Rust mirror is BlockParams in src/gpu_block.rs (layout test there).
struct BlockParams {
    // Block sites along x and y.
    nx: u32,
    ny: u32,
    // Global column and row of the block's site (0, 0).
    x0: u32,
    y0: u32,
    // Sites per row of the whole lattice (site indices key the random bits; the last
    // column is the outflow).
    width: u32,
    // Chirality key seed and body-force seed (as Params in params.wgsl).
    seed: u32,
    force_seed: u32,
    // Body-force threshold round(p * 2^24) for the 24-bit draw.
    threshold: u32,
    // The step counter (low 32 bits) that keys the random bits.
    step: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(0) var<storage, read> src: array<u32>;
@group(0) @binding(1) var<storage, read_write> dst: array<u32>;
@group(0) @binding(2) var<storage, read> table: array<u32>;
@group(0) @binding(3) var<uniform> B: BlockParams;

const WG: u32 = 64u;
var<workgroup> lut: array<u32, 512>;

// The site at padded coordinates (i, j): ghosts are ordinary sites of the buffer.
fn site_byte(i: i32, j: i32) -> u32 {
    return src[u32(j) * (B.nx + 2u) + u32(i)];
}

@compute @workgroup_size(64)
fn fhp_block(@builtin(local_invocation_id) lid: vec3<u32>,
             @builtin(workgroup_id) wid: vec3<u32>,
             @builtin(num_workgroups) nwg: vec3<u32>) {
    for (var k = lid.x; k < 512u; k += WG) {
        lut[k] = table[k];
    }
    workgroupBarrier();
    let k = linear_workgroup(wid, nwg) * WG + lid.x;
    if (k >= B.nx * B.ny) { return; }
    let il = k % B.nx;
    let jl = k / B.nx;
    let gi = B.x0 + il;
    let gj = B.y0 + jl;
    let key = fhp_step_key(B.seed, B.step);
    let fkey = fhp_step_key(B.force_seed, B.step);
    let v = fhp_site(i32(il) + 1, i32(jl) + 1, (gj & 1u) == 1u, gj * B.width + gi, i32(gi),
                     i32(B.width) - 1, key, fkey, B.threshold);
    dst[(jl + 1u) * (B.nx + 2u) + il + 1u] = v;
}
