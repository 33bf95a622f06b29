//! The hot loop: one particle against runs of sorted neighbour cells.
//!
//! On CPUs with AVX-512F an explicit kernel computes 8 squared distances per instruction
//! sequence and compares them straight into a bit mask (`vcmppd` to a mask register); only
//! the hits reach the caller's callback. Elsewhere the squared distances of a whole run go
//! to a buffer first (a branch-free loop the compiler vectorises, built for AVX2+FMA and the
//! baseline and picked at run time with `multiversion`), then become 64-bit hit masks. Both
//! kernels evaluate every candidate with the same operations in the same order, so they
//! report the same pairs bit for bit (tested).

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
fn particle_runs<
    const D: usize,
    const MI: bool,
    const AVX512: bool,
    F: FnMut(usize, usize, [f64; D], f64),
>(
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
        // One hit: candidate `jj` of the run at squared distance `r2`.
        let mut emit = |jj: usize, r2: f64| {
            let j = j0 + jj;
            if own == Own::AllButSelf && j == i {
                return;
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
            f(v.order[i] as usize, v.order[j] as usize, sep, r2);
        };
        #[cfg(target_arch = "x86_64")]
        if AVX512 && !MI && D == 3 {
            let p = [pi[0], pi[1], pi[2]];
            let sh = [run.shift[0], run.shift[1], run.shift[2]];
            let cols = [
                &v.coords[0][j0..jv],
                &v.coords[1][j0..jv],
                &v.coords[2][j0..jv],
            ];
            // SAFETY: `AVX512` is only set by `visit_cells_avx512`/`visit_particle_avx512`,
            // which run after `is_x86_feature_detected!("avx512f")`.
            unsafe { avx512::run_hits_3d(cols, p, sh, rc2, n, &mut emit) };
            continue;
        }
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
                emit(jj, buf[jj]);
            }
        }
    }
}

#[inline(always)]
fn visit_impl<
    const D: usize,
    const MI: bool,
    const AVX512: bool,
    F: FnMut(usize, usize, [f64; D], f64),
>(
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
            particle_runs::<D, MI, AVX512, F>(
                v, i, runs, own, rc2, half_len, lengths, periodic, &mut s.r2, f,
            );
        }
    }
}

/// Visits the pairs of every particle in `cells` with its half shell (`half`) or full shell.
pub(crate) fn visit_cells<const D: usize, F: FnMut(usize, usize, [f64; D], f64)>(
    v: &View<'_, D>,
    cells: Range<usize>,
    half: bool,
    s: &mut Scratch<D>,
    f: &mut F,
) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx512f") {
        // SAFETY: the CPU has AVX-512F (checked above).
        unsafe { visit_cells_avx512(v, cells, half, s, f) };
        return;
    }
    visit_cells_portable(v, cells, half, s, f);
}

/// [`visit_cells`] with the explicit AVX-512 distance-and-mask kernel.
///
/// # Safety
/// The CPU must support AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
unsafe fn visit_cells_avx512<const D: usize, F: FnMut(usize, usize, [f64; D], f64)>(
    v: &View<'_, D>,
    cells: Range<usize>,
    half: bool,
    s: &mut Scratch<D>,
    f: &mut F,
) {
    if v.grid.needs_min_image_per_pair() {
        visit_impl::<D, true, true, F>(v, cells, half, s, f);
    } else {
        visit_impl::<D, false, true, F>(v, cells, half, s, f);
    }
}

/// [`visit_cells`] for CPUs without AVX-512 (compiler-vectorised, AVX2 where present).
#[multiversion(targets("x86_64+avx2+fma"), dispatcher = "direct")]
fn visit_cells_portable<const D: usize, F: FnMut(usize, usize, [f64; D], f64)>(
    v: &View<'_, D>,
    cells: Range<usize>,
    half: bool,
    s: &mut Scratch<D>,
    f: &mut F,
) {
    if v.grid.needs_min_image_per_pair() {
        visit_impl::<D, true, false, F>(v, cells, half, s, f);
    } else {
        visit_impl::<D, false, false, F>(v, cells, half, s, f);
    }
}

/// Visits the neighbours of the particle at sorted position `rank` in cell `cell`: its half
/// shell (partners after it in the own cell, and the forward cells) or its full shell.
pub(crate) fn visit_particle<const D: usize, F: FnMut(usize, usize, [f64; D], f64)>(
    v: &View<'_, D>,
    rank: usize,
    cell: usize,
    half: bool,
    s: &mut Scratch<D>,
    f: &mut F,
) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx512f") {
        // SAFETY: the CPU has AVX-512F (checked above).
        unsafe { visit_particle_avx512(v, rank, cell, half, s, f) };
        return;
    }
    visit_particle_portable(v, rank, cell, half, s, f);
}

/// [`visit_particle`] with the explicit AVX-512 kernel.
///
/// # Safety
/// The CPU must support AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
unsafe fn visit_particle_avx512<const D: usize, F: FnMut(usize, usize, [f64; D], f64)>(
    v: &View<'_, D>,
    rank: usize,
    cell: usize,
    half: bool,
    s: &mut Scratch<D>,
    f: &mut F,
) {
    particle_impl::<D, true, F>(v, rank, cell, half, s, f);
}

/// [`visit_particle`] for CPUs without AVX-512.
#[multiversion(targets("x86_64+avx2+fma"), dispatcher = "direct")]
fn visit_particle_portable<const D: usize, F: FnMut(usize, usize, [f64; D], f64)>(
    v: &View<'_, D>,
    rank: usize,
    cell: usize,
    half: bool,
    s: &mut Scratch<D>,
    f: &mut F,
) {
    particle_impl::<D, false, F>(v, rank, cell, half, s, f);
}

#[inline(always)]
fn particle_impl<const D: usize, const AVX512: bool, F: FnMut(usize, usize, [f64; D], f64)>(
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
        particle_runs::<D, true, AVX512, F>(
            v, rank, runs, own, rc2, half_len, lengths, periodic, &mut s.r2, f,
        );
    } else {
        particle_runs::<D, false, AVX512, F>(
            v, rank, runs, own, rc2, half_len, lengths, periodic, &mut s.r2, f,
        );
    }
}

/// The explicit AVX-512 kernel of one 3D run.
#[cfg(target_arch = "x86_64")]
mod avx512 {
    use std::arch::x86_64::*;

    /// Calls `hit(jj, r2)` for every candidate `jj < n` of a run whose squared distance
    /// `r2` from `p` (separation `(p - x_j) - shift`) is within `rc2`, in ascending `jj`.
    /// `cols` hold the run's coordinates, a whole number of 8-lane vectors long (at least
    /// `n`); lanes at or past `n` are computed and dropped. Same operation order as the
    /// portable pass, so both decide every candidate identically.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn run_hits_3d(
        cols: [&[f64]; 3],
        p: [f64; 3],
        shift: [f64; 3],
        rc2: f64,
        n: usize,
        hit: &mut impl FnMut(usize, f64),
    ) {
        let nv = cols[0].len();
        assert!(nv.is_multiple_of(8) && nv >= n && cols[1].len() == nv && cols[2].len() == nv);
        let (px, py, pz) = (
            _mm512_set1_pd(p[0]),
            _mm512_set1_pd(p[1]),
            _mm512_set1_pd(p[2]),
        );
        let (sx, sy, sz) = (
            _mm512_set1_pd(shift[0]),
            _mm512_set1_pd(shift[1]),
            _mm512_set1_pd(shift[2]),
        );
        let cut = _mm512_set1_pd(rc2);
        let mut r2s = [0.0f64; 64];
        let mut base = 0;
        while base < nv {
            let end = (base + 64).min(nv);
            let mut mask = 0u64;
            let mut k = base;
            while k < end {
                // SAFETY: `k + 8 <= nv` (both multiples of 8, `k < end <= nv`), so the
                // loads stay inside the columns; the store stays inside `r2s`.
                unsafe {
                    let x = _mm512_loadu_pd(cols[0].as_ptr().add(k));
                    let y = _mm512_loadu_pd(cols[1].as_ptr().add(k));
                    let z = _mm512_loadu_pd(cols[2].as_ptr().add(k));
                    let dx = _mm512_sub_pd(_mm512_sub_pd(px, x), sx);
                    let dy = _mm512_sub_pd(_mm512_sub_pd(py, y), sy);
                    let dz = _mm512_sub_pd(_mm512_sub_pd(pz, z), sz);
                    let r2 = _mm512_add_pd(
                        _mm512_add_pd(_mm512_mul_pd(dx, dx), _mm512_mul_pd(dy, dy)),
                        _mm512_mul_pd(dz, dz),
                    );
                    _mm512_storeu_pd(r2s.as_mut_ptr().add(k - base), r2);
                    let m = _mm512_cmp_pd_mask::<_CMP_LE_OQ>(r2, cut);
                    mask |= u64::from(m) << (k - base);
                }
                k += 8;
            }
            if n - base < 64 {
                mask &= (1u64 << (n - base)) - 1;
            }
            while mask != 0 {
                let jj = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                hit(base + jj, r2s[jj]);
            }
            base = end;
        }
    }
}

#[cfg(test)]
mod tests {
    use rand::{RngExt, SeedableRng};

    use super::*;
    use crate::SortedCells;

    type Pairs<const D: usize> = Vec<(usize, usize, [u64; D], u64)>;

    /// Every pair a traversal reports, bit for bit, in report order.
    fn collect<const D: usize>(
        visit: impl Fn(&View<'_, D>, &mut Scratch<D>, &mut dyn FnMut(usize, usize, [f64; D], f64)),
        cells: &SortedCells<D>,
    ) -> Pairs<D> {
        let mut out = Vec::new();
        let mut s = Scratch::new();
        visit(&cells.view(), &mut s, &mut |i, j, sep, r2| {
            out.push((i, j, sep.map(f64::to_bits), r2.to_bits()))
        });
        out
    }

    fn kernels_agree<const D: usize>(periodic: [bool; D], seed: u64) {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
        let l = 9.0;
        let p: Vec<[f64; D]> = (0..3000)
            .map(|_| std::array::from_fn(|_| rng.random::<f64>() * l))
            .collect();
        let grid = CellGrid::new([0.0; D], [l; D], periodic, 1.3).unwrap();
        let mut cells = SortedCells::new(&grid);
        cells.build(&p).unwrap();
        let nc = grid.n_cells();
        for half in [true, false] {
            let portable = collect(
                |v, s, mut f| visit_cells_portable(v, 0..nc, half, s, &mut f),
                &cells,
            );
            assert!(!portable.is_empty());
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx512f") {
                // SAFETY: checked above.
                let avx = collect(
                    |v, s, mut f| unsafe { visit_cells_avx512(v, 0..nc, half, s, &mut f) },
                    &cells,
                );
                assert_eq!(avx, portable, "AVX-512 and portable kernels differ");
            }
        }
    }

    /// The explicit AVX-512 kernel reports exactly what the portable one does (same pairs,
    /// same order, same bits), open and periodic boxes.
    #[test]
    fn avx512_kernel_matches_the_portable_kernel() {
        kernels_agree::<3>([false; 3], 1);
        kernels_agree::<3>([true, false, true], 2);
        kernels_agree::<2>([true, true], 3);
    }
}
