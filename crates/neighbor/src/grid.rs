//! The simulation box and its cell grid: validation, wrapping, cell assignment, minimum image.

use simkit_backend::{Error, Real, Result};

/// Cells are at least `cutoff * (1 + CELL_MARGIN)` wide.
///
/// The margin keeps the cell assignment of single-precision GPU positions consistent with the
/// cell size (an `f32` rounding can move a particle across a cell face by about 1e-7 of the
/// box length, which the margin absorbs for boxes up to about 4000 cells per axis).
pub const CELL_MARGIN: f64 = 1e-3;

/// The largest number of cells a grid may have (2^26, a 256 MiB `cell_start` array).
///
/// A very large sparse box with a small cutoff is refused instead of allocating gigabytes.
pub const MAX_CELLS: usize = 1 << 26;

/// The smallest cutoff [`CellGrid::new`] accepts (its square is the smallest normal `f64`).
const MIN_CUTOFF: f64 = 1.4916681462400413e-154;

/// The largest cutoff [`CellGrid::new`] accepts (its square is finite).
const MAX_CUTOFF: f64 = 1.3407807929942596e154;

/// Cells per axis over `lengths` at least `width` wide (`max(1, floor(L / width))`), the
/// width raised by 25 % at a time until there are at most `limit`, and their total.
pub(crate) fn fit_cells<const D: usize>(
    lengths: &[f64; D],
    width: f64,
    limit: f64,
) -> ([usize; D], f64) {
    let mut width = width;
    loop {
        let cells: [f64; D] = std::array::from_fn(|d| (lengths[d] / width).floor().max(1.0));
        let total = cells.iter().product::<f64>();
        if total <= limit || cells.iter().all(|&c| c == 1.0) {
            // An f64 count past `usize::MAX` saturates; the caller refuses it first.
            return (cells.map(|c| c as usize), total);
        }
        width *= 1.25;
    }
}

/// What to do with a position outside the box along a non-periodic axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum OutOfBox {
    /// Return an error naming the particle index and the coordinate (the default).
    #[default]
    Error,
    /// Put the particle in the nearest boundary cell. Pairs stay exact (the separation uses
    /// the true position); only the cell assignment is clamped.
    Clamp,
}

/// A 2D (`D = 2`) or 3D (`D = 3`) box with per-axis periodicity, divided into cells at least
/// as wide as the interaction cutoff.
///
/// Positions are `[f64; D]` (a `glam::DVec3` converts with `.to_array()`). Cells per axis are
/// `max(1, floor(L / (cutoff * (1 + CELL_MARGIN))))`; cell `(cx, cy, cz)` has linear index
/// `cx + nx * (cy + ny * cz)`.
///
/// Every method in this crate works on *wrapped coordinates*: `t = x - origin`, reduced into
/// `[0, L)` along periodic axes. Separations are `t_i - t_j` reduced to the minimum image
/// along periodic axes, and a pair is reported when its squared distance is `<= cutoff^2`.
/// Any periodic length is handled exactly, including boxes shorter than `2 * cutoff` (one or
/// two cells along the axis): every unordered pair is then reported once, with its minimum
/// image separation.
#[derive(Clone, Debug, PartialEq)]
pub struct CellGrid<const D: usize> {
    origin: [f64; D],
    lengths: [f64; D],
    periodic: [bool; D],
    cutoff: f64,
    cells: [usize; D],
    cell_size: [f64; D],
    inv_cell: [f64; D],
    n_cells: usize,
    out_of_box: OutOfBox,
}

impl<const D: usize> CellGrid<D> {
    /// A grid over the box `[origin, origin + lengths)` with the given periodic axes and
    /// interaction cutoff.
    ///
    /// Errors: `D` other than 2 or 3, non-finite origin, non-finite or non-positive lengths
    /// or cutoff, a cutoff whose square is not a normal `f64` (outside about
    /// `[1.5e-154, 1.3e154]`), or more than [`MAX_CELLS`] cells.
    pub fn new(
        origin: [f64; D],
        lengths: [f64; D],
        periodic: [bool; D],
        cutoff: f64,
    ) -> Result<Self> {
        Self::build(origin, lengths, periodic, cutoff, None)
    }

    /// A grid as [`CellGrid::new`] with at most `limit` cells (never more than
    /// [`MAX_CELLS`]): where cells the cutoff wide would be more, they are widened (25 % at a
    /// time) until they fit. The cutoff, hence the pairs reported, is the same; wider cells
    /// only cost distance checks. For boxes that are sparse, or that only bound where the
    /// particles happen to be (one far-flung particle must not cost gigabytes of cells).
    ///
    /// Errors: those of [`CellGrid::new`] but the cell count.
    pub fn new_sparse(
        origin: [f64; D],
        lengths: [f64; D],
        periodic: [bool; D],
        cutoff: f64,
        limit: usize,
    ) -> Result<Self> {
        Self::build(origin, lengths, periodic, cutoff, Some(limit))
    }

    fn build(
        origin: [f64; D],
        lengths: [f64; D],
        periodic: [bool; D],
        cutoff: f64,
        limit: Option<usize>,
    ) -> Result<Self> {
        if D != 2 && D != 3 {
            return Err(Error::Unsupported(format!(
                "CellGrid<{D}>: only 2D and 3D grids exist; use CellGrid<2> or CellGrid<3>"
            )));
        }
        const AXES: [&str; 3] = ["x", "y", "z"];
        for d in 0..D {
            if !origin[d].is_finite() {
                return Err(Error::invalid(
                    format!("origin.{}", AXES[d]),
                    origin[d],
                    "must be finite",
                ));
            }
            if !(lengths[d].is_finite() && lengths[d] > 0.0) {
                return Err(Error::invalid(
                    format!("box length along {}", AXES[d]),
                    lengths[d],
                    "must be finite and > 0",
                ));
            }
        }
        if !(cutoff.is_finite() && cutoff > 0.0) {
            return Err(Error::invalid("cutoff", cutoff, "must be finite and > 0"));
        }
        // Pairs are selected by comparing squared distances with cutoff^2: an infinite square
        // would take every pair, one flushed to zero only coincident ones.
        if !(cutoff * cutoff).is_normal() {
            return Err(Error::invalid(
                "cutoff",
                cutoff,
                format!(
                    "cutoff^2 = {:e} is not a normal f64; use a cutoff between {:e} and {:e} \
                     (rescale the length unit)",
                    cutoff * cutoff,
                    MIN_CUTOFF,
                    MAX_CUTOFF
                ),
            ));
        }
        let width = cutoff * (1.0 + CELL_MARGIN);
        let fit = limit.map_or(f64::INFINITY, |l| l.min(MAX_CELLS) as f64);
        let (cells, total) = fit_cells(&lengths, width, fit);
        if total > MAX_CELLS as f64 {
            return Err(Error::invalid(
                "cell count",
                format!("{total:e} cells"),
                format!(
                    "the box {lengths:?} with cutoff {cutoff} needs more than {MAX_CELLS} \
                     cells; use a larger cutoff (cells are at least the cutoff wide) or a \
                     smaller box"
                ),
            ));
        }
        let cell_size = std::array::from_fn(|d| lengths[d] / cells[d] as f64);
        let inv_cell = std::array::from_fn(|d| cells[d] as f64 / lengths[d]);
        Ok(Self {
            origin,
            lengths,
            periodic,
            cutoff,
            cells,
            cell_size,
            inv_cell,
            n_cells: total as usize,
            out_of_box: OutOfBox::Error,
        })
    }

    /// The same grid with another out-of-box policy for non-periodic axes.
    pub fn with_out_of_box(mut self, policy: OutOfBox) -> Self {
        self.out_of_box = policy;
        self
    }

    /// The same box with another cutoff (e.g. `cutoff + skin` for a Verlet list).
    pub fn with_cutoff(&self, cutoff: f64) -> Result<Self> {
        Ok(Self::new(self.origin, self.lengths, self.periodic, cutoff)?
            .with_out_of_box(self.out_of_box))
    }

    /// Lower corner of the box.
    pub fn origin(&self) -> [f64; D] {
        self.origin
    }

    /// Box lengths.
    pub fn lengths(&self) -> [f64; D] {
        self.lengths
    }

    /// Which axes are periodic.
    pub fn periodic(&self) -> [bool; D] {
        self.periodic
    }

    /// Interaction cutoff.
    pub fn cutoff(&self) -> f64 {
        self.cutoff
    }

    /// Out-of-box policy for non-periodic axes.
    pub fn out_of_box(&self) -> OutOfBox {
        self.out_of_box
    }

    /// Cells per axis.
    pub fn cells_per_axis(&self) -> [usize; D] {
        self.cells
    }

    /// Cell edge lengths (each `>= cutoff`).
    pub fn cell_size(&self) -> [f64; D] {
        self.cell_size
    }

    /// Total number of cells.
    pub fn n_cells(&self) -> usize {
        self.n_cells
    }

    /// Whether some periodic axis has fewer than 3 cells, so that neighbour offsets -1 and +1
    /// reach the same cell. Traversals then de-duplicate cells and use the minimum image per
    /// pair instead of one shift per cell.
    pub fn needs_min_image_per_pair(&self) -> bool {
        (0..D).any(|d| self.periodic[d] && self.cells[d] < 3)
    }

    /// Wrapped coordinates of particle `index` at `p` (see the type docs).
    ///
    /// Any finite coordinate along a periodic axis wraps into `[0, L)`, however far from the
    /// box.
    ///
    /// Errors: a NaN or infinite coordinate, a coordinate so far from the origin that
    /// `x - origin` overflows, or (with [`OutOfBox::Error`]) a coordinate outside
    /// `[origin, origin + L]` along a non-periodic axis; the message names the particle
    /// index and the coordinate.
    #[inline]
    pub fn wrap(&self, index: usize, p: [f64; D]) -> Result<[f64; D]> {
        let mut t = [0.0; D];
        for d in 0..D {
            let x = p[d];
            if !x.is_finite() {
                return Err(bad_position(index, d, x, "must be finite"));
            }
            let l = self.lengths[d];
            let mut v = x - self.origin[d];
            if !v.is_finite() {
                return Err(bad_position(
                    index,
                    d,
                    x,
                    &format!(
                        "is too far from the box origin {} for its offset to be an f64; move \
                         the origin or the particle",
                        self.origin[d]
                    ),
                ));
            }
            if self.periodic[d] {
                if !(0.0..l).contains(&v) {
                    let shift = l * (v / l).floor();
                    let w = v - shift;
                    if shift.is_finite() && w > -l && w < 2.0 * l {
                        v = w;
                        if v < 0.0 {
                            v += l;
                        }
                        if v >= l {
                            v = 0.0;
                        }
                    } else {
                        // Far from the box `l * floor(v / l)` rounds by more than a box
                        // length (or overflows): the remainder is exact.
                        v = v.rem_euclid(l);
                        if v >= l {
                            v = 0.0;
                        }
                    }
                }
            } else if self.out_of_box == OutOfBox::Error && !(0.0..=l).contains(&v) {
                return Err(bad_position(
                    index,
                    d,
                    x,
                    &format!(
                        "outside the non-periodic box [{}, {}]; enlarge the box, make the axis \
                         periodic, or opt in to OutOfBox::Clamp",
                        self.origin[d],
                        self.origin[d] + l
                    ),
                ));
            }
            t[d] = v;
        }
        Ok(t)
    }

    /// [`wrap`](Self::wrap) for every position.
    pub fn wrap_all(&self, positions: &[[f64; D]]) -> Result<Vec<[f64; D]>> {
        positions
            .iter()
            .enumerate()
            .map(|(i, &p)| self.wrap(i, p))
            .collect()
    }

    /// Per-axis cell coordinates of a wrapped position (clamped into the grid).
    #[inline]
    pub fn cell_coords_of(&self, t: [f64; D]) -> [usize; D] {
        // `as usize` truncates toward zero and saturates (negative -> 0), which is `floor`
        // followed by the clamp for every input, without a libm call on baseline x86_64.
        std::array::from_fn(|d| ((t[d] * self.inv_cell[d]) as usize).min(self.cells[d] - 1))
    }

    /// Linear cell index of a wrapped position.
    #[inline]
    pub fn cell_of(&self, t: [f64; D]) -> usize {
        self.linear_of(self.cell_coords_of(t))
    }

    /// Linear index `cx + nx * (cy + ny * cz)` of per-axis cell coordinates, or `None` when
    /// a coordinate is outside the grid (`c[d] >= cells_per_axis()[d]`).
    #[inline]
    pub fn linear(&self, c: [usize; D]) -> Option<usize> {
        (0..D)
            .all(|d| c[d] < self.cells[d])
            .then(|| self.linear_of(c))
    }

    /// [`linear`](Self::linear) for coordinates known to be inside the grid.
    #[inline]
    pub(crate) fn linear_of(&self, c: [usize; D]) -> usize {
        let mut idx = 0;
        for d in (0..D).rev() {
            debug_assert!(c[d] < self.cells[d]);
            idx = idx * self.cells[d] + c[d];
        }
        idx
    }

    /// Per-axis cell coordinates of a linear cell index, or `None` when there is no such
    /// cell (`cell >= n_cells()`).
    #[inline]
    pub fn coords(&self, cell: usize) -> Option<[usize; D]> {
        (cell < self.n_cells).then(|| self.coords_of(cell))
    }

    /// [`coords`](Self::coords) for a cell index known to be below `n_cells()`.
    #[inline]
    pub(crate) fn coords_of(&self, mut cell: usize) -> [usize; D] {
        std::array::from_fn(|d| {
            let c = cell % self.cells[d];
            cell /= self.cells[d];
            c
        })
    }

    /// Minimum image separation `t_i - t_j` of two wrapped positions and its squared length,
    /// computed exactly as every traversal of this crate computes it.
    #[inline]
    pub fn separation(&self, ti: [f64; D], tj: [f64; D]) -> ([f64; D], f64) {
        let mut sep = [0.0; D];
        let mut r2 = 0.0;
        for d in 0..D {
            let mut v = ti[d] - tj[d];
            if self.periodic[d] {
                let l = self.lengths[d];
                if v > 0.5 * l {
                    v -= l;
                } else if v < -0.5 * l {
                    v += l;
                }
            }
            sep[d] = v;
            r2 += v * v;
        }
        (sep, r2)
    }
}

fn bad_position(index: usize, axis: usize, value: f64, reason: &str) -> Error {
    const AXES: [&str; 3] = ["x", "y", "z"];
    Error::invalid(
        format!("position[{index}].{}", AXES[axis]),
        value,
        reason.to_string(),
    )
}

/// Wraps the periodic coordinates of `x` into `[lo, hi)` (`hi = lo + len`) by one box
/// length at most: a coordinate that moved further stays outside (the callers' checks
/// report it), and one that lands on `hi` by rounding after the shift goes to `lo`. The
/// boundary rule of every particle engine's list build (`md`, `dem`, their distributed
/// runs).
#[inline(always)]
pub fn wrap_periodic<T: Real, const D: usize>(
    x: &mut [T; D],
    lo: [T; D],
    hi: [T; D],
    len: [T; D],
    periodic: [bool; D],
) {
    for d in 0..D {
        if periodic[d] {
            if x[d] < lo[d] {
                x[d] += len[d];
                if x[d] >= hi[d] {
                    x[d] = lo[d];
                }
            } else if x[d] >= hi[d] {
                x[d] = x[d] - len[d];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validation_errors_name_the_value() {
        assert!(CellGrid::<3>::new([0.0; 3], [1.0, 0.0, 1.0], [false; 3], 0.1).is_err());
        assert!(CellGrid::<3>::new([0.0; 3], [1.0; 3], [false; 3], 0.0).is_err());
        assert!(CellGrid::<3>::new([0.0; 3], [1.0; 3], [false; 3], f64::NAN).is_err());
        assert!(CellGrid::<2>::new([f64::NAN, 0.0], [1.0; 2], [false; 2], 0.1).is_err());
        assert!(CellGrid::<2>::new([0.0; 2], [f64::INFINITY, 1.0], [false; 2], 0.1).is_err());
        let e = CellGrid::<3>::new([0.0; 3], [1e6; 3], [true; 3], 1e-3).unwrap_err();
        assert!(e.to_string().contains("cell count"), "{e}");
        assert!(CellGrid::<4>::new([0.0; 4], [1.0; 4], [false; 4], 0.1).is_err());
    }

    #[test]
    fn sparse_grids_widen_their_cells_and_keep_the_pairs() {
        // Two close pairs, one far away: cells a cutoff wide would be 4e10.
        let x = [
            [0.0, 0.0],
            [0.5, 0.2],
            [2e5 - 1.0, 2e5 - 1.0],
            [2e5 - 1.3, 2e5 - 1.0],
        ];
        let strict = CellGrid::<2>::new([0.0; 2], [2e5; 2], [false; 2], 1.0);
        assert!(strict.is_err());
        let g = CellGrid::<2>::new_sparse([0.0; 2], [2e5; 2], [false; 2], 1.0, 4096).unwrap();
        assert!(g.n_cells() <= 4096, "{}", g.n_cells());
        assert_eq!(g.cutoff(), 1.0);
        let mut cells = crate::SortedCells::new(&g);
        cells.build(&x).unwrap();
        let mut pairs = Vec::new();
        cells.for_each_pair(|i, j, _, _| pairs.push((i.min(j), i.max(j))));
        pairs.sort_unstable();
        assert_eq!(pairs, [(0, 1), (2, 3)]);
        // A box that fits: the same cells as `new`.
        let a = CellGrid::<3>::new([0.0; 3], [10.0; 3], [true; 3], 1.0).unwrap();
        let b = CellGrid::<3>::new_sparse([0.0; 3], [10.0; 3], [true; 3], 1.0, 4096).unwrap();
        assert_eq!(a, b);
    }

    #[test]
    fn cells_are_at_least_the_cutoff() {
        let g = CellGrid::<3>::new([0.0; 3], [10.0, 7.5, 2.0], [true; 3], 2.5).unwrap();
        assert_eq!(g.cells_per_axis(), [3, 2, 1]);
        for d in 0..3 {
            // A single cell may be shorter than the cutoff (the whole axis is one cell).
            assert!(g.cell_size()[d] >= g.cutoff() || g.cells_per_axis()[d] == 1);
        }
    }

    #[test]
    fn wrapping_edges() {
        let g = CellGrid::<2>::new([-1.0, 0.0], [4.0, 4.0], [true, false], 1.0).unwrap();
        assert_eq!(g.wrap(0, [3.0, 0.0]).unwrap(), [0.0, 0.0]);
        assert_eq!(g.wrap(0, [-1.5, 4.0]).unwrap(), [3.5, 4.0]);
        let below = 3.0f64.next_down();
        let t = g.wrap(0, [below, 1.0]).unwrap();
        assert!(t[0] < 4.0 && t[0] >= 0.0);
        assert!(g.cell_coords_of(t)[0] < 3);
        let e = g.wrap(7, [0.0, 4.5]).unwrap_err().to_string();
        assert!(e.contains("position[7].y"), "{e}");
        let e = g.wrap(3, [f64::NAN, 1.0]).unwrap_err().to_string();
        assert!(e.contains("position[3].x"), "{e}");
        let c = g.clone().with_out_of_box(OutOfBox::Clamp);
        let t = c.wrap(0, [0.0, 9.0]).unwrap();
        assert_eq!(c.cells_per_axis(), [3, 3]);
        assert_eq!(c.cell_coords_of(t)[1], 2);
    }
}
