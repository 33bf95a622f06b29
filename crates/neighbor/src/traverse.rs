//! The hot loop: one particle against runs of sorted neighbour cells.
//!
//! Squared distances of a whole run are computed into a buffer first (a branch-free loop the
//! compiler vectorises), then turned into 64-bit hit masks (also vectorised), and only the
//! hits reach the caller's callback. The entry points are compiled for AVX2+FMA
//! and AVX-512 as well as the baseline and picked at run time (`multiversion`).

use std::ops::Range;

use multiversion::multiversion;

use crate::CellGrid;
use crate::stencil::Shell;

/// Lanes the distance pass always computes together (one AVX-512 vector of `f64`).
const LANES: usize = 8;

/// Coordinates stored after the last particle so that the distance pass may read a whole
/// vector past the end of any run.
pub(crate) const COORD_PAD: usize = LANES - 1;

/// Borrowed sorted-cell data: what a traversal reads.
pub(crate) struct View<'a, const D: usize> {
    pub grid: &'a CellGrid<D>,
    pub cell_start: &'a [u32],
    pub order: &'a [u32],
    /// Sorted coordinates, each followed by [`COORD_PAD`] padding values.
    pub coords: [&'a [f64]; D],
}

/// Scratch buffers of one traversal (one per thread).
pub(crate) struct Scratch<const D: usize> {
    r2: Vec<f64>,
    shell: Shell<D>,
}

impl<const D: usize> Scratch<D> {
    pub fn new() -> Self {
        Self {
            r2: Vec::new(),
            shell: Shell::new(),
        }
    }
}

/// Which particles of the own cell (the first run of a half shell) are partners.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Own {
    /// Only those after `i` in sorted order (half shell).
    After,
    /// All but `i` itself (full shell).
    AllButSelf,
}

#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn particle_runs<const D: usize, const MI: bool, F: FnMut(usize, usize, [f64; D], f64)>(
    v: &View<'_, D>,
    i: usize,
    runs: &[crate::stencil::CellRun<D>],
    own: Own,
    rc2: f64,
    half_len: [f64; D],
    lengths: [f64; D],
    periodic: [bool; D],
    r2buf: &mut Vec<f64>,
    f: &mut F,
) {
    let pi: [f64; D] = std::array::from_fn(|d| v.coords[d][i]);
    for (k, run) in runs.iter().enumerate() {
        let j0 = if k == 0 && own == Own::After {
            i + 1
        } else {
            v.cell_start[run.first] as usize
        };
        let j1 = v.cell_start[run.end] as usize;
        if j0 >= j1 {
            continue;
        }
        let n = j1 - j0;
        // Whole vectors: the distance pass runs on past the run into the next particles (or
        // the padding after the last one, `COORD_PAD`); the hit masks drop those lanes.
        let nv = n.next_multiple_of(LANES);
        let jv = j0 + nv;
        if r2buf.len() < nv {
            r2buf.resize(nv, 0.0);
        }
        let buf = &mut r2buf[..nv];
        if !MI && D == 3 {
            // One fused pass (same operation order as the generic loop below).
            let (xs, ys, zs) = (
                &v.coords[0][j0..jv],
                &v.coords[1][j0..jv],
                &v.coords[2][j0..jv],
            );
            let (px, py, pz) = (pi[0], pi[1], pi[2]);
            let (sx, sy, sz) = (run.shift[0], run.shift[1], run.shift[2]);
            for (((b, &x), &y), &z) in buf.iter_mut().zip(xs).zip(ys).zip(zs) {
                let dx = (px - x) - sx;
                let dy = (py - y) - sy;
                let dz = (pz - z) - sz;
                *b = dx * dx + dy * dy + dz * dz;
            }
        } else if !MI && D == 2 {
            let (xs, ys) = (&v.coords[0][j0..jv], &v.coords[1][j0..jv]);
            let (px, py) = (pi[0], pi[1]);
            let (sx, sy) = (run.shift[0], run.shift[1]);
            for ((b, &x), &y) in buf.iter_mut().zip(xs).zip(ys) {
                let dx = (px - x) - sx;
                let dy = (py - y) - sy;
                *b = dx * dx + dy * dy;
            }
        } else {
            buf.fill(0.0);
            for d in 0..D {
                let xs = &v.coords[d][j0..jv];
                let (p, s, h, l) = (pi[d], run.shift[d], half_len[d], lengths[d]);
                if MI && periodic[d] {
                    for (b, &x) in buf.iter_mut().zip(xs) {
                        let mut dx = p - x;
                        dx = if dx > h {
                            dx - l
                        } else if dx < -h {
                            dx + l
                        } else {
                            dx
                        };
                        *b += dx * dx;
                    }
                } else {
                    for (b, &x) in buf.iter_mut().zip(xs) {
                        let dx = (p - x) - s;
                        *b += dx * dx;
                    }
                }
            }
        }
        // 64 candidates at a time: a bit mask of the hits (a compare-and-or reduction the
        // compiler vectorises), then one step per hit.
        for (chunk_no, chunk) in buf.chunks(64).enumerate() {
            let mut mask = 0u64;
            for (k, &r2) in chunk.iter().enumerate() {
                mask |= u64::from(r2 <= rc2) << k;
            }
            let left = n - chunk_no * 64;
            if left < 64 {
                mask &= (1u64 << left) - 1;
            }
            while mask != 0 {
                let jj = chunk_no * 64 + mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let j = j0 + jj;
                if own == Own::AllButSelf && j == i {
                    continue;
                }
                let mut sep = [0.0; D];
                for d in 0..D {
                    let mut dx = pi[d] - v.coords[d][j];
                    if MI && periodic[d] {
                        if dx > half_len[d] {
                            dx -= lengths[d];
                        } else if dx < -half_len[d] {
                            dx += lengths[d];
                        }
                    } else {
                        dx -= run.shift[d];
                    }
                    sep[d] = dx;
                }
                f(v.order[i] as usize, v.order[j] as usize, sep, buf[jj]);
            }
        }
    }
}

#[inline(always)]
fn visit_impl<const D: usize, const MI: bool, F: FnMut(usize, usize, [f64; D], f64)>(
    v: &View<'_, D>,
    cells: Range<usize>,
    half: bool,
    s: &mut Scratch<D>,
    f: &mut F,
) {
    let g = v.grid;
    let rc2 = g.cutoff() * g.cutoff();
    let lengths = g.lengths();
    let half_len = lengths.map(|l| 0.5 * l);
    let periodic = g.periodic();
    let own = if half { Own::After } else { Own::AllButSelf };
    for c in cells {
        let (a, b) = (v.cell_start[c] as usize, v.cell_start[c + 1] as usize);
        if a == b {
            continue;
        }
        if half {
            g.half_shell(c, &mut s.shell);
        } else {
            g.full_shell(c, &mut s.shell);
        }
        let runs = s.shell.as_slice();
        for i in a..b {
            particle_runs::<D, MI, F>(
                v, i, runs, own, rc2, half_len, lengths, periodic, &mut s.r2, f,
            );
        }
    }
}

/// Visits the pairs of every particle in `cells` with its half shell (`half`) or full shell.
#[multiversion(
    targets("x86_64+avx512f+avx512vl+avx2+fma", "x86_64+avx2+fma"),
    dispatcher = "direct"
)]
pub(crate) fn visit_cells<const D: usize, F: FnMut(usize, usize, [f64; D], f64)>(
    v: &View<'_, D>,
    cells: Range<usize>,
    half: bool,
    s: &mut Scratch<D>,
    f: &mut F,
) {
    if v.grid.needs_min_image_per_pair() {
        visit_impl::<D, true, F>(v, cells, half, s, f);
    } else {
        visit_impl::<D, false, F>(v, cells, half, s, f);
    }
}

/// Visits the neighbours of the particle at sorted position `rank` in cell `cell`: its half
/// shell (partners after it in the own cell, and the forward cells) or its full shell.
#[multiversion(
    targets("x86_64+avx512f+avx512vl+avx2+fma", "x86_64+avx2+fma"),
    dispatcher = "direct"
)]
pub(crate) fn visit_particle<const D: usize, F: FnMut(usize, usize, [f64; D], f64)>(
    v: &View<'_, D>,
    rank: usize,
    cell: usize,
    half: bool,
    s: &mut Scratch<D>,
    f: &mut F,
) {
    let g = v.grid;
    let rc2 = g.cutoff() * g.cutoff();
    let lengths = g.lengths();
    let half_len = lengths.map(|l| 0.5 * l);
    let periodic = g.periodic();
    let own = if half {
        g.half_shell(cell, &mut s.shell);
        Own::After
    } else {
        g.full_shell(cell, &mut s.shell);
        Own::AllButSelf
    };
    let runs = s.shell.as_slice();
    if g.needs_min_image_per_pair() {
        particle_runs::<D, true, F>(
            v, rank, runs, own, rc2, half_len, lengths, periodic, &mut s.r2, f,
        );
    } else {
        particle_runs::<D, false, F>(
            v, rank, runs, own, rc2, half_len, lengths, periodic, &mut s.r2, f,
        );
    }
}
