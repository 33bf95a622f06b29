// Scatters particle ids into cell order (order inside a cell fixed by nb_sort_cells).
@group(0) @binding(0) var<uniform> grid: NbGrid;
@group(0) @binding(1) var<storage, read> cell_of: array<u32>;
@group(0) @binding(2) var<storage, read> cell_start: array<u32>;
@group(0) @binding(3) var<storage, read_write> fill: array<atomic<u32>>;
@group(0) @binding(4) var<storage, read_write> scattered: array<u32>;

@compute @workgroup_size(256)
fn nb_scatter(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = linear_workgroup(wid, nwg) * 256u + lid;
    if (i >= grid.n_particles) {
        return;
    }
    let c = cell_of[i];
    let k = atomicAdd(&fill[c], 1u);
    scattered[cell_start[c] + k] = i;
}
