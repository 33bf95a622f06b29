// One invocation per cell: writes the cell's ids in ascending order (so the result does not
// depend on the order of the scatter's atomics) by ranking each id among the cell's ids,
// and gathers the wrapped positions into cell order. Reads the scatter output, writes
// separate buffers (no in-place update).
@group(0) @binding(0) var<uniform> grid: NbGrid;
@group(0) @binding(1) var<storage, read> cell_start: array<u32>;
@group(0) @binding(2) var<storage, read> scattered: array<u32>;
@group(0) @binding(3) var<storage, read_write> sorted_ids: array<u32>;
@group(0) @binding(4) var<storage, read> wrapped: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> sorted_pos: array<vec4<f32>>;

@compute @workgroup_size(64)
fn nb_sort_cells(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let c = linear_workgroup(wid, nwg) * 64u + lid;
    if (c >= grid.n_cells) {
        return;
    }
    let a = cell_start[c];
    let b = cell_start[c + 1u];
    for (var k = a; k < b; k++) {
        let v = scattered[k];
        var rank = 0u;
        for (var m = a; m < b; m++) {
            rank += select(0u, 1u, scattered[m] < v);
        }
        sorted_ids[a + rank] = v;
        sorted_pos[a + rank] = wrapped[v];
    }
}
