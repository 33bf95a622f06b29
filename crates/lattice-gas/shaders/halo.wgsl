// Copies between a block's padded sites (one per u32) and a packed list, for the halo
// exchange of a distributed lattice through the host: `pack` gathers the sites that idx
// lists into vals (the block's edge sites, then downloaded), `unpack` writes vals into the
// sites idx lists (the ghosts, after the upload). Include after the backend's dispatch.wgsl.

@group(0) @binding(0) var<storage, read_write> grid: array<u32>;
@group(0) @binding(1) var<storage, read> idx: array<u32>;
@group(0) @binding(2) var<storage, read_write> vals: array<u32>;

@compute @workgroup_size(64)
fn pack(@builtin(local_invocation_id) lid: vec3<u32>,
        @builtin(workgroup_id) wid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    let k = linear_workgroup(wid, nwg) * 64u + lid.x;
    if (k >= arrayLength(&idx)) { return; }
    vals[k] = grid[idx[k]];
}

@compute @workgroup_size(64)
fn unpack(@builtin(local_invocation_id) lid: vec3<u32>,
          @builtin(workgroup_id) wid: vec3<u32>,
          @builtin(num_workgroups) nwg: vec3<u32>) {
    let k = linear_workgroup(wid, nwg) * 64u + lid.x;
    if (k >= arrayLength(&idx)) { return; }
    grid[idx[k]] = vals[k];
}
