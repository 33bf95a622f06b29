// Full rebuild of the slot lists from neighbor's GpuCellList (ascending ids inside a cell),
// one invocation per cell. A cell holding more than CAP particles keeps the first CAP and
// sets health[0] to NaN (the guard reports it as a capacity error).
@group(0) @binding(0) var<uniform> grid: NbGrid;
@group(0) @binding(1) var<storage, read> cell_start: array<u32>;
@group(0) @binding(2) var<storage, read> sorted_ids: array<u32>;
@group(0) @binding(3) var<storage, read_write> counts: array<u32>;
@group(0) @binding(4) var<storage, read_write> slots: array<u32>;
@group(0) @binding(5) var<storage, read_write> health: array<f32>;

@compute @workgroup_size(64)
fn md_block_fill(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let cell = linear_workgroup(wid, nwg) * 64u + lid;
    if (cell >= grid.n_cells) {
        return;
    }
    let s = cell_start[cell];
    let m = cell_start[cell + 1u] - s;
    if (m > CAP) {
        health[0] = md_block_flag();
    }
    let kept = min(m, CAP);
    for (var k = 0u; k < kept; k++) {
        slots[cell * CAP + k] = sorted_ids[s + k];
    }
    counts[cell] = kept;
}
