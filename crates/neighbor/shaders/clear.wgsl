// Resets the per-cell counters and the status words before a cell-list build.
@group(0) @binding(0) var<uniform> grid: NbGrid;
@group(0) @binding(1) var<storage, read_write> cell_start: array<u32>;
@group(0) @binding(2) var<storage, read_write> fill: array<u32>;
@group(0) @binding(3) var<storage, read_write> status: array<u32>;

@compute @workgroup_size(256)
fn nb_clear(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = linear_workgroup(wid, nwg) * 256u + lid;
    if (i <= grid.n_cells) {
        cell_start[i] = 0u;
    }
    if (i < grid.n_cells) {
        fill[i] = 0u;
    }
    if (i == 0u) {
        status[0] = 0u;
        status[1] = 0xffffffffu;
        status[2] = 0u;
    }
}
