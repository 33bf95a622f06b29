// Wraps every position, finds its cell and counts particles per cell.
// status[0]: number of bad particles (NaN, or outside a closed face without clamping);
// status[1]: the smallest bad particle index.
// status[2]: number of cells holding more than MAX_PER_CELL particles (refused: the host sets
// it from GpuCellList::max_per_cell, which keeps every shell walk within the adapter's shader
// loop limit, and the per-cell sort's quadratic cost bounded).
override MAX_PER_CELL: u32;
@group(0) @binding(0) var<uniform> grid: NbGrid;
@group(0) @binding(1) var<storage, read> positions: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> wrapped: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> cell_of: array<u32>;
@group(0) @binding(4) var<storage, read_write> counts: array<atomic<u32>>;
@group(0) @binding(5) var<storage, read_write> status: array<atomic<u32>>;

@compute @workgroup_size(256)
fn nb_assign(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = linear_workgroup(wid, nwg) * 256u + lid;
    if (i >= grid.n_particles) {
        return;
    }
    let p = positions[i];
    var bad = nb_not_finite(p.x) || nb_not_finite(p.y);
    if (grid.dim == 3u) {
        bad = bad || nb_not_finite(p.z);
    }
    var t = vec3<f32>(0.0);
    if (!bad) {
        t = nb_wrap(grid, p.xyz);
        bad = grid.clamp_out == 0u && nb_outside(grid, t);
    }
    if (bad) {
        atomicAdd(&status[0], 1u);
        atomicMin(&status[1], i);
    }
    let c = nb_cell_index(grid, nb_cell_coord(grid, t));
    // A rejected particle keeps its raw input, so the host can name the bad coordinate.
    wrapped[i] = select(vec4<f32>(t, p.w), p, bad);
    cell_of[i] = c;
    let before = atomicAdd(&counts[c], 1u);
    if (before == MAX_PER_CELL) {
        atomicAdd(&status[2], 1u);
    }
}
