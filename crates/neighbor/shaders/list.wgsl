// Neighbour list in CSR form, count then fill. One invocation per particle in cell order.
// HALF: keep only partners j > i (each unordered pair once); otherwise both directions.
override HALF: bool = false;

@group(0) @binding(0) var<uniform> grid: NbGrid;
@group(0) @binding(1) var<storage, read> cell_start: array<u32>;
@group(0) @binding(2) var<storage, read> sorted_ids: array<u32>;
@group(0) @binding(3) var<storage, read> sorted_pos: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> offsets: array<u32>;
@group(0) @binding(5) var<storage, read_write> neighbors: array<u32>;
// Count pass only: the total number of entries as a 64-bit number [low, high] (cleared by
// the host before the pass), so a total beyond u32 is detected instead of wrapping.
@group(0) @binding(6) var<storage, read_write> total: array<atomic<u32>>;

fn nb_list_particle(rank: u32, fill: bool) -> u32 {
    let i = sorted_ids[rank];
    let ti = sorted_pos[rank].xyz;
    let c = nb_cell_coord(grid, ti);
    let lo = nb_shell_lo(grid, c);
    let hi = nb_shell_hi(grid, c);
    var out = 0u;
    if (fill) {
        out = offsets[i];
    }
    var count = 0u;
    for (var oz = lo.z; oz <= hi.z; oz++) {
        for (var oy = lo.y; oy <= hi.y; oy++) {
            for (var ox = lo.x; ox <= hi.x; ox++) {
                let cell = nb_neighbor_cell(grid, c, vec3<i32>(ox, oy, oz));
                let end = cell_start[cell + 1u];
                for (var k = cell_start[cell]; k < end; k++) {
                    let j = sorted_ids[k];
                    if (j == i || (HALF && j < i)) {
                        continue;
                    }
                    let sep = nb_min_image(grid, ti - sorted_pos[k].xyz);
                    if (dot(sep, sep) <= grid.cutoff2) {
                        // The host sized `neighbors` from the scanned counts; the bound
                        // check only guards memory.
                        if (fill && out + count < arrayLength(&neighbors)) {
                            neighbors[out + count] = j;
                        }
                        count++;
                    }
                }
            }
        }
    }
    if (!fill) {
        offsets[i] = count;
    }
    return count;
}

@compute @workgroup_size(64)
fn nb_list_count(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let rank = linear_workgroup(wid, nwg) * 64u + lid;
    if (rank == 0u) {
        offsets[grid.n_particles] = 0u;
    }
    if (rank >= grid.n_particles) {
        return;
    }
    let count = nb_list_particle(rank, false);
    if (count > 0u) {
        let old = atomicAdd(&total[0], count);
        if (old + count < old) {
            atomicAdd(&total[1], 1u);
        }
    }
}

@compute @workgroup_size(64)
fn nb_list_fill(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let rank = linear_workgroup(wid, nwg) * 64u + lid;
    if (rank >= grid.n_particles) {
        return;
    }
    _ = nb_list_particle(rank, true);
}
