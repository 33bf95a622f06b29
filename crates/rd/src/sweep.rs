//! Temporal blocking for the CPU backend: several explicit Euler steps in one sweep.
//!
//! The interior rows are cut into bands. For `k` fused steps, a band of rows `r0..r1` is
//! computed from the source fields through `k - 1` intermediate levels: level `l` covers rows
//! `r0 - (k - l) .. r1 + (k - l)` (the halo shrinks by one row per level), and the last level
//! writes rows `r0..r1` of the destination. The rows are visited as a wavefront (level `l`
//! trails level `l - 1` by one row), so a level only ever reads the last three rows the level
//! below wrote. Each intermediate level therefore keeps only a window of [`WINDOW_ROWS`] rows
//! in a per-thread scratch buffer (when a window is full, its last two rows are copied to its
//! top and it goes on from there), so the intermediate rows are reused from the core's caches
//! while they are hot, and the shared cache or main memory sees one read of the fields and one
//! write per `k` steps instead of per step.
//!
//! Every cell value is computed by the same row kernel from the same inputs as in the plain
//! pass, and the ghost cells of every intermediate level are filled with the same formula
//! (`boundary::ghost_value`), so the result is bit-identical to `k` plain passes.
//!
//! With periodic south/north edges a level has no ghost rows: its halo rows past the bottom
//! or top of the grid are rows from the other end, computed like any other row from the rows
//! below and above them (at level 1 from the source, whose periodic ghost rows already hold
//! the wrapped rows). A band near an edge thus recomputes rows of the band at the other end,
//! as interior bands recompute rows of their neighbours; on grids lower than the halo a
//! grid row may appear several times in one level.

use std::sync::Mutex;

use rayon::prelude::*;

use crate::boundary::{Boundaries, Boundary, ghost_value};
use crate::model::{Model, RowIn};
use simkit_backend::Real;
use simkit_backend::max_or_nan;

/// Rows in the window of each intermediate level (two of them are copied each time the window
/// fills). 32 rows: 0.8 MB of scratch per thread for Gray–Scott f64 at 512 columns and k = 4
/// (it fits L2), 3.1 MB for f32 at 4096 columns. For Gray–Scott, 16 rows measured the same
/// at 512^2 f64 and 0–5 % slower at 4096^2 f32 (more copies); 5 rows (512 KiB at 4096
/// columns) 12–17 % slower there.
const WINDOW_ROWS: usize = 32;

/// Calls `f` with the slices `parts` yields, gathered on the stack when there are at most
/// four of them (every provided model), else in a `Vec`: the row loops run this per row.
pub(crate) fn with_slices<'a, T: 'a, R>(
    parts: impl ExactSizeIterator<Item = &'a mut [T]>,
    f: impl FnOnce(&mut [&'a mut [T]]) -> R,
) -> R {
    let n = parts.len();
    if n <= 4 {
        let mut on_stack: [&mut [T]; 4] = Default::default();
        for (slot, part) in on_stack.iter_mut().zip(parts) {
            *slot = part;
        }
        f(&mut on_stack[..n])
    } else {
        f(&mut parts.collect::<Vec<_>>())
    }
}

/// Scratch buffers kept between sweeps, one per parallel job at most.
#[derive(Debug, Default)]
pub(crate) struct ScratchPool<T>(Mutex<Vec<Vec<T>>>);

/// A scratch buffer on loan from a [`ScratchPool`]; returned when dropped.
pub(crate) struct Lease<'a, T> {
    buf: Vec<T>,
    pool: &'a ScratchPool<T>,
}

impl<T: Real> ScratchPool<T> {
    /// A buffer of at least `len` values.
    fn lease(&self, len: usize) -> Lease<'_, T> {
        let mut buf = self
            .0
            .lock()
            .map(|mut v| v.pop().unwrap_or_default())
            .unwrap_or_default();
        if buf.len() < len {
            buf.resize(len, T::default());
        }
        Lease { buf, pool: self }
    }
}

impl<T> Drop for Lease<'_, T> {
    fn drop(&mut self) {
        if let Ok(mut v) = self.pool.0.lock() {
            v.push(std::mem::take(&mut self.buf));
        }
    }
}

/// What one sweep needs besides the fields.
pub(crate) struct Sweep<'a, T: Real, M: Model> {
    pub model: &'a M,
    pub nx: usize,
    pub ny: usize,
    pub boundaries: &'a Boundaries,
    /// Padded coefficient planes.
    pub coef: &'a [T],
    pub dt: f64,
    pub inv_h2: f64,
    /// Columns per row segment handed to the row kernel.
    pub block_cols: usize,
}

/// The padded grid row (1..=ny) that row `g` of an unbounded periodic-y grid stands for.
fn wrap_row(g: isize, ny: usize) -> usize {
    (g - 1).rem_euclid(ny as isize) as usize + 1
}

impl<T: Real, M: Model> Sweep<'_, T, M> {
    fn width(&self) -> usize {
        self.nx + 2
    }

    /// Scratch values one thread needs for `k` fused steps.
    fn scratch_len(&self, k: usize) -> usize {
        (k - 1) * self.model.species() * WINDOW_ROWS * self.width()
    }

    /// Advances `src` by `k >= 1` Euler steps into the interior of `dst` (ghosts not filled).
    /// Bands are scheduled dynamically (rayon work stealing); each parallel job leases a
    /// scratch buffer from `pool` and gives it back, so buffers are allocated once.
    pub(crate) fn run(
        &self,
        k: usize,
        band: usize,
        src: &[T],
        dst: &mut [T],
        pool: &ScratchPool<T>,
        want_max: bool,
    ) -> Option<f64> {
        let (ny, w) = (self.ny, self.width());
        let plane = w * (ny + 2);
        let mut per_plane: Vec<_> = dst
            .chunks_mut(plane)
            .map(|p| p[w..(ny + 1) * w].chunks_mut(band * w))
            .collect();
        let bands: Vec<Vec<&mut [T]>> = (0..ny.div_ceil(band))
            .map(|_| per_plane.iter_mut().filter_map(|it| it.next()).collect())
            .collect();
        let need = self.scratch_len(k);
        let d = bands
            .into_par_iter()
            .enumerate()
            .map_init(
                || pool.lease(need),
                |lease, (b, mut out)| {
                    let r0 = 1 + b * band;
                    let r1 = (r0 + band).min(ny + 1);
                    self.band(k, r0, r1, src, &mut out, r0, &mut lease.buf, want_max)
                },
            )
            .reduce(|| 0.0, max_or_nan);
        want_max.then_some(d)
    }

    /// `k` steps for padded rows `r0..r1`; `out` holds the destination rows from `out_row0`.
    /// With `want_max`, returns the model's largest effective diffusivity over the rows
    /// written (each taken right after the row is written, while it is in cache); else 0.
    #[allow(clippy::too_many_arguments)]
    fn band(
        &self,
        k: usize,
        r0: usize,
        r1: usize,
        src: &[T],
        out: &mut [&mut [T]],
        out_row0: usize,
        buf: &mut [T],
        want_max: bool,
    ) -> f64 {
        let (nx, ny, w) = (self.nx, self.ny, self.width());
        let plane = w * (ny + 2);
        // Periodic edges pair up, so south alone tells whether y wraps.
        let periodic = self.boundaries.south == Boundary::Periodic;
        // Rows of level l (1..=k): r0 - (k - l) .. r1 + (k - l), clipped to the padded grid
        // unless y wraps.
        let span = |l: usize| {
            let (lo, hi) = (r0 as isize - (k - l) as isize, (r1 + k - l) as isize);
            if periodic {
                (lo, hi)
            } else {
                (lo.max(0), hi.min(ny as isize + 2))
            }
        };
        // Intermediate level l (1..k) lives in a window of `window` rows at
        // buf[(l - 1) * lsize..], species s at s * lplane; grid row g at window row
        // g - first[l - 1].
        let window = WINDOW_ROWS;
        let lplane = window * w;
        let lsize = self.model.species() * lplane;
        let buf = &mut buf[..(k - 1) * lsize];
        let mut first: Vec<isize> = (1..k).map(|l| span(l).0).collect();
        let base = r0 as isize - (k - 1) as isize;
        let mut dmax = 0.0f64;
        for tau in 0..r1 - r0 + 2 * (k - 1) {
            for l in 1..=k {
                let g = base + tau as isize - (l as isize - 1);
                let (lo, hi) = span(l);
                if g < lo || g >= hi {
                    continue;
                }
                let (below, level) = buf.split_at_mut((l - 1) * lsize);
                // Window row of g (intermediate levels). A full window moves its last two rows
                // to the top first: the next level reads them with the new row.
                let mut r = 0;
                if l < k {
                    r = (g - first[l - 1]) as usize;
                    if r == window {
                        for p in level[..lsize].chunks_mut(lplane) {
                            p.copy_within((window - 2) * w.., 0);
                        }
                        first[l - 1] += (window - 2) as isize;
                        r = 2;
                    }
                }
                // The grid row this row holds: past an edge, a ghost row (not periodic) or a
                // row from the other end (periodic).
                let row = if periodic {
                    wrap_row(g, ny)
                } else {
                    // Ghost rows of intermediate levels (l < k, as r0 >= 1 and r1 <= ny + 1):
                    // row 0 is set right after row 1, row ny + 1 from row ny (done a step
                    // earlier).
                    let g = g as usize;
                    if g == 0 {
                        continue;
                    }
                    if g == ny + 1 {
                        self.ghost_row(
                            &mut level[..lsize],
                            lplane,
                            r,
                            r - 1,
                            &self.boundaries.north,
                        );
                        continue;
                    }
                    g
                };
                let input = if l == 1 {
                    RowIn {
                        species: src,
                        species_plane: plane,
                        species_row: row,
                        coefficients: self.coef,
                        coefficient_plane: plane,
                        row,
                        width: w,
                        i0: 1,
                        i1: nx + 1,
                    }
                } else {
                    RowIn {
                        species: &below[(l - 2) * lsize..],
                        species_plane: lplane,
                        species_row: (g - first[l - 2]) as usize,
                        coefficients: self.coef,
                        coefficient_plane: plane,
                        row,
                        width: w,
                        i0: 1,
                        i1: nx + 1,
                    }
                };
                if l == k {
                    let at = (row - out_row0) * w;
                    self.update(input, at, out);
                    if want_max {
                        let species: Vec<&[T]> =
                            out.iter().map(|o| &o[at + 1..at + 1 + nx]).collect();
                        let coef: Vec<&[T]> = self
                            .coef
                            .chunks(plane)
                            .map(|p| &p[row * w + 1..row * w + 1 + nx])
                            .collect();
                        dmax = max_or_nan(dmax, self.model.max_cell_diffusivity(&species, &coef));
                    }
                } else {
                    let level = &mut level[..lsize];
                    let at = r * w;
                    with_slices(level.chunks_mut(lplane), |planes| {
                        self.update(input, at, planes);
                        for (s, p) in planes.iter_mut().enumerate() {
                            let row = &mut p[at..at + w];
                            row[0] = ghost_value(&self.boundaries.west, s, row[1], row[nx]);
                            row[nx + 1] = ghost_value(&self.boundaries.east, s, row[nx], row[1]);
                        }
                    });
                    if !periodic && row == 1 && lo == 0 {
                        self.ghost_row(level, lplane, r - 1, r, &self.boundaries.south);
                    }
                }
            }
        }
        dmax
    }

    /// Runs the row kernel over the row in column blocks, writing each species' output at
    /// `offset + i0..offset + i1` of its `dst` slice.
    fn update(&self, input: RowIn<'_, T>, offset: usize, dst: &mut [&mut [T]]) {
        for i0 in (1..=self.nx).step_by(self.block_cols) {
            let i1 = (i0 + self.block_cols).min(self.nx + 1);
            let seg = RowIn { i0, i1, ..input };
            let outs = dst.iter_mut().map(|d| &mut d[offset + i0..offset + i1]);
            with_slices(outs, |outs| {
                self.model
                    .update_row(&seg, self.dt, self.inv_h2, outs, false)
            });
        }
    }

    /// Sets buffer row `target` of every species plane from row `inner` for a south or north
    /// edge condition (never periodic here).
    fn ghost_row(&self, level: &mut [T], lplane: usize, target: usize, inner: usize, b: &Boundary) {
        let w = self.width();
        for (s, p) in level.chunks_mut(lplane).enumerate() {
            for i in 1..=self.nx {
                let v = p[inner * w + i];
                p[target * w + i] = ghost_value(b, s, v, v);
            }
        }
    }
}
