// One invocation per slot of the scatter output: ranks the slot's particle id among the ids
// of its cell and writes it there, so the ids inside each cell come out ascending (the
// result does not depend on the order of the scatter's atomics). Also gathers the wrapped
// positions into cell order. Reads the scatter output, writes separate buffers.
@group(0) @binding(0) var<uniform> grid: NbGrid;
@group(0) @binding(1) var<storage, read> cell_start: array<u32>;
@group(0) @binding(2) var<storage, read> cell_of: array<u32>;
@group(0) @binding(3) var<storage, read> scattered: array<u32>;
@group(0) @binding(4) var<storage, read_write> sorted_ids: array<u32>;
@group(0) @binding(5) var<storage, read> wrapped: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> sorted_pos: array<vec4<f32>>;

@compute @workgroup_size(64)
fn nb_sort_cells(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let k = linear_workgroup(wid, nwg) * 64u + lid;
    if (k >= grid.n_particles) {
        return;
    }
    let v = scattered[k];
    let c = cell_of[v];
    let a = cell_start[c];
    let b = cell_start[c + 1u];
    var rank = 0u;
    for (var m = a; m < b; m++) {
        rank += select(0u, 1u, scattered[m] < v);
    }
    sorted_ids[a + rank] = v;
    sorted_pos[a + rank] = wrapped[v];
}
