// Shared by the cell-block kernels (one workgroup per cell; see src/gpu/cell_block.rs).
// The host prepends `const CAP: u32`, the slots per cell (= invocations per workgroup).
// Slot lists: cell c holds counts[c] particle ids in slots[c * CAP .. c * CAP + counts[c]],
// in ascending id order.

// Per-axis coordinates of linear cell index `cell` (inverse of nb_cell_index).
fn md_block_coord(g: NbGrid, cell: u32) -> vec3<i32> {
    let nx = g.cells.x;
    let ny = g.cells.y;
    return vec3<i32>(i32(cell % nx), i32((cell / nx) % ny), i32(cell / (nx * ny)));
}

// The cell of a position (the cell list's rule: wrap, then clamp into the grid).
fn md_block_cell_of(g: NbGrid, p: vec3<f32>) -> vec3<i32> {
    return nb_cell_coord(g, nb_wrap(g, p));
}

// A quiet NaN: the flag value the blow-up guard sees.
fn md_block_flag() -> f32 {
    return bitcast<f32>(0x7fc00000u);
}
