// simkit neighbor: cell-grid helpers for WGSL kernels (Rust: neighbor::CELLS_WGSL).
//
// Concatenate this file before your own kernel source. It declares no bindings: bind the
// grid parameters yourself (`var<uniform> grid: NbGrid;`, from GpuCellList::params()) and
// pass them to the functions below. Positions are wrapped coordinates relative to the
// origin (GpuCellList::wrapped() by particle id, GpuCellList::sorted_pos() in cell order).
//
// Full-shell loop over the neighbours of a particle with wrapped position `ti`:
//
//   let c = nb_cell_coord(grid, ti);
//   let lo = nb_shell_lo(grid, c);
//   let hi = nb_shell_hi(grid, c);
//   for (var oz = lo.z; oz <= hi.z; oz++) {
//     for (var oy = lo.y; oy <= hi.y; oy++) {
//       for (var ox = lo.x; ox <= hi.x; ox++) {
//         let cell = nb_neighbor_cell(grid, c, vec3<i32>(ox, oy, oz));
//         for (var k = cell_start[cell]; k < cell_start[cell + 1u]; k++) {
//           let j = sorted_ids[k];                       // skip j == i yourself
//           let sep = nb_min_image(grid, ti - sorted_pos[k].xyz);
//           if (dot(sep, sep) <= grid.cutoff2) { ... }
//         }
//       }
//     }
//   }
//
// The shell ranges are clipped at closed faces and de-duplicated along periodic axes with
// fewer than 3 cells, so every neighbour cell is visited exactly once.

struct NbGrid {
    origin: vec4<f32>,
    length: vec4<f32>,
    // Cells per unit length along each axis.
    inv_cell: vec4<f32>,
    // Cells per axis (z = 1 in 2D).
    cells: vec4<u32>,
    // 1 for a periodic axis.
    periodic: vec4<u32>,
    n_particles: u32,
    n_cells: u32,
    // 1: clamp positions outside closed faces into the boundary cells; 0: flag them.
    clamp_out: u32,
    dim: u32,
    cutoff2: f32,
    _pad0: f32,
    _pad1: f32,
    _pad2: f32,
}

// True for NaN and infinities (a bit test: compilers may not fold it away).
fn nb_not_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7fffffffu) >= 0x7f800000u;
}

// Position relative to the origin, wrapped into [0, L) along periodic axes.
fn nb_wrap(g: NbGrid, p: vec3<f32>) -> vec3<f32> {
    var t = p - g.origin.xyz;
    for (var d = 0u; d < 3u; d++) {
        if (g.periodic[d] != 0u) {
            let l = g.length[d];
            var v = t[d];
            if (v < 0.0 || v >= l) {
                v = v - l * floor(v / l);
                if (v < 0.0) {
                    v = v + l;
                }
                if (v >= l) {
                    v = 0.0;
                }
            }
            t[d] = v;
        }
    }
    if (g.dim == 2u) {
        t.z = 0.0;
    }
    return t;
}

// Whether a wrapped position lies outside a closed (non-periodic) face.
fn nb_outside(g: NbGrid, t: vec3<f32>) -> bool {
    var out = false;
    for (var d = 0u; d < g.dim; d++) {
        if (g.periodic[d] == 0u && (t[d] < 0.0 || t[d] > g.length[d])) {
            out = true;
        }
    }
    return out;
}

// Per-axis cell coordinates of a wrapped position (clamped into the grid).
fn nb_cell_coord(g: NbGrid, t: vec3<f32>) -> vec3<i32> {
    let c = floor(t * g.inv_cell.xyz);
    let hi = vec3<f32>(g.cells.xyz) - vec3<f32>(1.0);
    return vec3<i32>(clamp(c, vec3<f32>(0.0), hi));
}

// Linear cell index cx + nx * (cy + ny * cz).
fn nb_cell_index(g: NbGrid, c: vec3<i32>) -> u32 {
    return u32(c.x) + g.cells.x * (u32(c.y) + g.cells.y * u32(c.z));
}

// Lowest shell offset per axis for a particle in cell c.
fn nb_shell_lo(g: NbGrid, c: vec3<i32>) -> vec3<i32> {
    var lo = vec3<i32>(-1);
    for (var d = 0u; d < 3u; d++) {
        if (g.periodic[d] != 0u) {
            if (g.cells[d] < 3u) {
                lo[d] = 0;
            }
        } else if (c[d] == 0) {
            lo[d] = 0;
        }
    }
    return lo;
}

// Highest shell offset per axis for a particle in cell c.
fn nb_shell_hi(g: NbGrid, c: vec3<i32>) -> vec3<i32> {
    var hi = vec3<i32>(1);
    for (var d = 0u; d < 3u; d++) {
        let n = i32(g.cells[d]);
        if (g.periodic[d] != 0u) {
            if (n == 1) {
                hi[d] = 0;
            }
        } else if (c[d] + 1 >= n) {
            hi[d] = 0;
        }
    }
    return hi;
}

// Linear index of the cell at offset o from cell c (wrapped along periodic axes).
fn nb_neighbor_cell(g: NbGrid, c: vec3<i32>, o: vec3<i32>) -> u32 {
    let n = vec3<i32>(g.cells.xyz);
    let q = (c + o + n) % n;
    return nb_cell_index(g, q);
}

// Minimum image of a separation of two wrapped positions.
fn nb_min_image(g: NbGrid, d: vec3<f32>) -> vec3<f32> {
    var s = d;
    for (var k = 0u; k < 3u; k++) {
        if (g.periodic[k] != 0u) {
            let l = g.length[k];
            if (s[k] > 0.5 * l) {
                s[k] = s[k] - l;
            } else if (s[k] < -0.5 * l) {
                s[k] = s[k] + l;
            }
        }
    }
    return s;
}
