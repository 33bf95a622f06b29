// Multi-level exclusive prefix sum of u32 (see backend::gpu::scan).
// Each workgroup scans one block of SCAN_BLOCK = 1024 values in place (256 invocations x 4
// consecutive values) and writes the block total to `sums`; the host recurses over `sums`
// and finally adds each block's scanned offset back with `add_offsets`.

struct ScanParams {
    n: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<storage, read_write> data: array<u32>;
@group(0) @binding(1) var<storage, read_write> sums: array<u32>;
@group(0) @binding(2) var<uniform> params: ScanParams;

const SCAN_WG: u32 = 256u;
const SCAN_PER: u32 = 4u;
const SCAN_BLOCK: u32 = 1024u;

var<workgroup> partial: array<u32, 256>;

@compute @workgroup_size(256)
fn scan_blocks(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let block = linear_workgroup(wid, nwg);
    let base = block * SCAN_BLOCK + lid * SCAN_PER;
    var local_prefix: array<u32, 4>;
    var total = 0u;
    for (var k = 0u; k < SCAN_PER; k++) {
        let i = base + k;
        var x = 0u;
        if (i < params.n) {
            x = data[i];
        }
        local_prefix[k] = total;
        total += x;
    }
    partial[lid] = total;
    workgroupBarrier();
    // Inclusive Hillis-Steele scan of the 256 per-invocation totals.
    for (var off = 1u; off < SCAN_WG; off = off << 1u) {
        var t = 0u;
        if (lid >= off) {
            t = partial[lid - off];
        }
        workgroupBarrier();
        partial[lid] += t;
        workgroupBarrier();
    }
    let before = partial[lid] - total;
    for (var k = 0u; k < SCAN_PER; k++) {
        let i = base + k;
        if (i < params.n) {
            data[i] = before + local_prefix[k];
        }
    }
    if (lid == SCAN_WG - 1u && block * SCAN_BLOCK < params.n) {
        sums[block] = partial[lid];
    }
}

@compute @workgroup_size(256)
fn add_offsets(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let block = linear_workgroup(wid, nwg);
    if (block * SCAN_BLOCK >= params.n) {
        return;
    }
    let offset = sums[block];
    let base = block * SCAN_BLOCK + lid * SCAN_PER;
    for (var k = 0u; k < SCAN_PER; k++) {
        let i = base + k;
        if (i < params.n) {
            data[i] += offset;
        }
    }
}
