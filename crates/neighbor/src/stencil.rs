//! Half-shell and full-shell cell stencils, expanded for one cell into runs of consecutive
//! neighbour cells that share one periodic shift.

use crate::CellGrid;

/// Half-shell offsets in 2D: the own cell first, then one of each pair `o`, `-o` (5 cells).
pub const HALF_SHELL_2D: [[i32; 2]; 5] = [[0, 0], [1, 0], [-1, 1], [0, 1], [1, 1]];

/// Half-shell offsets in 3D: the own cell first, then one of each pair `o`, `-o` (14 cells).
pub const HALF_SHELL_3D: [[i32; 3]; 14] = [
    [0, 0, 0],
    [1, 0, 0],
    [-1, 1, 0],
    [0, 1, 0],
    [1, 1, 0],
    [-1, -1, 1],
    [0, -1, 1],
    [1, -1, 1],
    [-1, 0, 1],
    [0, 0, 1],
    [1, 0, 1],
    [-1, 1, 1],
    [0, 1, 1],
    [1, 1, 1],
];

/// A run of neighbour cells `first..end` (linear indices, consecutive in sorted order) whose
/// particles are seen through one periodic `shift`: separation `= (t_i - t_j) - shift`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct CellRun<const D: usize> {
    pub first: usize,
    pub end: usize,
    pub shift: [f64; D],
}

/// The runs of one cell's shell (at most 27).
pub(crate) struct Shell<const D: usize> {
    pub runs: [CellRun<D>; 27],
    pub len: usize,
}

impl<const D: usize> Shell<D> {
    pub fn new() -> Self {
        Self {
            runs: [CellRun {
                first: 0,
                end: 0,
                shift: [0.0; D],
            }; 27],
            len: 0,
        }
    }

    pub fn as_slice(&self) -> &[CellRun<D>] {
        &self.runs[..self.len]
    }

    fn push(&mut self, cell: usize, shift: [f64; D]) {
        if self.len > 0 {
            let last = &mut self.runs[self.len - 1];
            if last.end == cell && last.shift == shift {
                last.end += 1;
                return;
            }
        }
        self.runs[self.len] = CellRun {
            first: cell,
            end: cell + 1,
            shift,
        };
        self.len += 1;
    }
}

impl<const D: usize> CellGrid<D> {
    /// Neighbour cell of `c` at offset `o` and its shift, or `None` past a non-periodic face.
    fn offset_cell(&self, c: [usize; D], o: &[i32]) -> Option<(usize, [f64; D])> {
        let n = self.cells_per_axis();
        let mut shift = [0.0; D];
        let mut nc = [0usize; D];
        for d in 0..D {
            let v = c[d] as i64 + i64::from(o[d]);
            let nd = n[d] as i64;
            if v < 0 || v >= nd {
                if !self.periodic()[d] {
                    return None;
                }
                shift[d] = if v < 0 {
                    -self.lengths()[d]
                } else {
                    self.lengths()[d]
                };
                nc[d] = v.rem_euclid(nd) as usize;
            } else {
                nc[d] = v as usize;
            }
        }
        Some((self.linear_of(nc), shift))
    }

    /// Distinct cells of the full shell of `c` in ascending (z, y, x) offset order, for grids
    /// that need the minimum image per pair (no shifts).
    fn distinct_shell(&self, c: [usize; D], mut visit: impl FnMut(usize)) {
        let n = self.cells_per_axis();
        let range = |d: usize| -> (i32, i32) {
            if self.periodic()[d] {
                match n[d] {
                    1 => (0, 0),
                    2 => (0, 1),
                    _ => (-1, 1),
                }
            } else {
                (
                    if c[d] == 0 { 0 } else { -1 },
                    if c[d] + 1 == n[d] { 0 } else { 1 },
                )
            }
        };
        let r: [(i32, i32); D] = std::array::from_fn(range);
        let (zlo, zhi) = if D == 3 { r[2] } else { (0, 0) };
        for oz in zlo..=zhi {
            for oy in r[1].0..=r[1].1 {
                for ox in r[0].0..=r[0].1 {
                    let o = [ox, oy, oz];
                    let nc: [usize; D] = std::array::from_fn(|d| {
                        (c[d] as i64 + i64::from(o[d])).rem_euclid(n[d] as i64) as usize
                    });
                    visit(self.linear_of(nc));
                }
            }
        }
    }

    /// The half shell of cell `c`: the first run starts with `c` itself (pairs inside it are
    /// taken with `j` after `i`), every other neighbour cell pair is visited from exactly one
    /// side. Periodic axes with fewer than 3 cells use de-duplicated cells and `c' > c`.
    pub(crate) fn half_shell(&self, cell: usize, out: &mut Shell<D>) {
        out.len = 0;
        let c = self.coords_of(cell);
        if self.needs_min_image_per_pair() {
            out.push(cell, [0.0; D]);
            let mut cells = [0usize; 27];
            let mut k = 0;
            self.distinct_shell(c, |nc| {
                if nc > cell {
                    cells[k] = nc;
                    k += 1;
                }
            });
            cells[..k].sort_unstable();
            for &nc in &cells[..k] {
                out.push(nc, [0.0; D]);
            }
        } else if D == 2 {
            for o in &HALF_SHELL_2D {
                if let Some((nc, s)) = self.offset_cell(c, o) {
                    out.push(nc, s);
                }
            }
        } else {
            for o in &HALF_SHELL_3D {
                if let Some((nc, s)) = self.offset_cell(c, o) {
                    out.push(nc, s);
                }
            }
        }
    }

    /// The full shell of cell `c` (9 or 27 cells, fewer at non-periodic faces; distinct cells
    /// when a periodic axis has fewer than 3 cells).
    pub(crate) fn full_shell(&self, cell: usize, out: &mut Shell<D>) {
        out.len = 0;
        let c = self.coords_of(cell);
        if self.needs_min_image_per_pair() {
            let mut cells = [0usize; 27];
            let mut k = 0;
            self.distinct_shell(c, |nc| {
                cells[k] = nc;
                k += 1;
            });
            cells[..k].sort_unstable();
            for &nc in &cells[..k] {
                out.push(nc, [0.0; D]);
            }
        } else {
            let (zlo, zhi) = if D == 3 { (-1, 1) } else { (0, 0) };
            for oz in zlo..=zhi {
                for oy in -1..=1 {
                    for ox in -1..=1 {
                        if let Some((nc, s)) = self.offset_cell(c, &[ox, oy, oz]) {
                            out.push(nc, s);
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_shells_hold_one_of_each_opposite_pair() {
        fn check<const D: usize>(stencil: &[[i32; D]]) {
            assert_eq!(stencil[0], [0; D]);
            let total = 3usize.pow(D as u32);
            assert_eq!(stencil.len(), (total - 1) / 2 + 1);
            for (a, o) in stencil.iter().enumerate() {
                for p in &stencil[a + 1..] {
                    assert_ne!(o, p);
                    let neg: [i32; D] = std::array::from_fn(|d| -p[d]);
                    assert_ne!(*o, neg, "{o:?} and its opposite are both in the stencil");
                }
            }
        }
        check(&HALF_SHELL_2D);
        check(&HALF_SHELL_3D);
    }

    #[test]
    fn interior_half_shell_merges_rows() {
        let g = CellGrid::<3>::new([0.0; 3], [10.0; 3], [false; 3], 1.0).unwrap();
        let mut s = Shell::new();
        g.half_shell(g.linear_of([4, 4, 4]), &mut s);
        // self + (+1,0,0) merged, one y row, three z rows.
        assert_eq!(s.len, 5);
        let cells: usize = s.as_slice().iter().map(|r| r.end - r.first).sum();
        assert_eq!(cells, 14);
        g.full_shell(g.linear_of([4, 4, 4]), &mut s);
        assert_eq!(s.len, 9);
    }
}
