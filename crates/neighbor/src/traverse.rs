//! The hot loop: one particle against runs of sorted neighbour cells, three kernels (see
//! [`TraversalKernel`]), all evaluating every candidate with the same operations in the same order,
//! so they report the same pairs bit for bit (tested).
//!
//! - Packed (AVX-512F or AVX2, explicit intrinsics): all runs of a particle's shell in one
//!   branch-free pass that compares squared distances straight into a mask and packs the
//!   indices of the hits into one list (`vpcompressd`, or `vpermd` with a table); then one
//!   loop over that list recomputes each hit's separation and calls the callback. One
//!   unpredictable loop exit per particle instead of two per run, and no bounds check per
//!   hit (which would keep a caller's accumulator in memory).
//! - Portable (`multiversion`: AVX2+FMA clone and baseline): the squared distances of a run
//!   into a buffer (a loop the compiler vectorises), then 64-bit hit masks, one step per hit.
//!
//! The kernel is picked at run time ([`TraversalKernel::Auto`]), so no `-C target-cpu=native` is
//! needed.

use std::ops::Range;

use multiversion::multiversion;

use crate::CellGrid;
use crate::stencil::Shell;

/// Lanes the portable distance pass always computes together; `COORD_PAD` and the packed
/// hit list's slack are counted in it.
const LANES: usize = 8;

/// Coordinates stored after the last particle so that the distance pass may read whole
/// vectors past the end of any run (the AVX-512 kernel reads 16 candidates at a time).
pub(crate) const COORD_PAD: usize = 2 * LANES - 1;

/// Kernel of a monomorphised traversal: compiler-vectorised distances per run.
const PORTABLE: u8 = 0;

/// Kernel: all hits of a particle packed into one list with AVX2 (permutation table).
const PACKED_AVX2: u8 = 1;

/// Kernel: all hits of a particle packed into one list with AVX-512 (`vpcompressd`).
const PACKED_AVX512: u8 = 2;

/// Bits of a packed hit that hold the sorted position (the run index is above them).
pub(crate) const RUN_SHIFT: u32 = 27;

/// Mask of the sorted position in a packed hit.
const RUN_MASK: u32 = (1 << RUN_SHIFT) - 1;

/// Borrowed sorted-cell data: what a traversal reads.
pub(crate) struct View<'a, const D: usize> {
    pub grid: &'a CellGrid<D>,
    pub cell_start: &'a [u32],
    pub order: &'a [u32],
    /// The kernel to run.
    pub kernel: TraversalKernel,
    /// Sorted coordinates, each followed by [`COORD_PAD`] padding values.
    pub coords: [&'a [f64]; D],
    /// Single-precision copies of `coords` with their decision band, for the AVX-512
    /// kernel's first pass ([`Coords32`]); `None` where they are not built.
    pub coords32: Option<Coords32<'a, D>>,
}

/// Sorted coordinates rounded to `f32` (each followed by [`COORD_PAD`] padding values), for a
/// first pass that decides most candidates in single precision (16 lanes per AVX-512
/// register instead of 8): a candidate whose `f32` squared distance is at most `lo` is a
/// hit, above `hi` a miss, and in between (candidates within about `1e-5` of the cutoff
/// in a 100-wide box) it is decided by the `f64` squared distance computed exactly as the
/// `f64` kernels compute it. `lo` and `hi` bound the rounding ([`f32_band`]), so the hits
/// are exactly those of the `f64` kernels.
#[derive(Clone, Copy)]
pub(crate) struct Coords32<'a, const D: usize> {
    pub cols: [&'a [f32]; D],
    pub lo: f32,
    pub hi: f32,
}

/// The decision band `(lo, hi)` of a single-precision first pass ([`Coords32`]) over wrapped
/// coordinates in `[0, L]` (`L` the longest box side, also the largest periodic shift) and
/// cutoff `rc`, or `None` where the band would be wider than 5 % of the cutoff (coordinates
/// too large for `f32` to decide most candidates).
///
/// Derivation, with `u = 2^-24` (the `f32` unit roundoff) and `r` the exact distance: each
/// rounded coordinate is within `u L` of its value, the shifted position `p - s` (|.| <= 2L,
/// formed in `f64`, then rounded) within `2 u L (1 + 2^-29)`, and the rounded difference
/// adds `u (|e| + 3 u L)`, so each component of the `f32` separation is within
/// `u (3 L + r) (1 + 2u)` of the exact one and the vector within
/// `delta(r) = sqrt(D) u (3 L + r) (1 + 2u)`. The squares and sums add a relative
/// `(1 + u)^D - 1 < 2 D u`. With `eta = 2 delta(rc) + 1e-12 rc` (which also covers the
/// `f64` result's few ulps and the rounding of this computation), an `f32` value at most
/// `lo = (1 - 2 D u) (rc - eta)^2` implies `r < rc (1 - 2^-51)`, so the `f64` squared distance
/// is below `rc^2`; a value above `hi = (1 + 2 D u) (rc + eta)^2` implies
/// `r > rc (1 + 2^-51)`, so the `f64` one is above (both as `r -+ delta(r)` is increasing
/// in `r`). `lo` is rounded down and `hi` up to `f32`.
pub(crate) fn f32_band(longest: f64, rc: f64, dims: usize) -> Option<(f32, f32)> {
    let u = f64::from(f32::EPSILON) / 2.0;
    let delta = (dims as f64).sqrt() * u * (3.0 * longest + rc) * (1.0 + 2.0 * u);
    let eta = 2.0 * delta + 1e-12 * rc;
    // Also refuses a NaN band (a non-finite box or cutoff).
    if eta.is_nan() || eta >= 0.05 * rc || !longest.is_finite() {
        return None;
    }
    let lo = (1.0 - 2.0 * dims as f64 * u) * (rc - eta) * (rc - eta);
    let hi = (1.0 + 2.0 * dims as f64 * u) * (rc + eta) * (rc + eta);
    let down = |x: f64| {
        let f = x as f32;
        if f64::from(f) > x { f.next_down() } else { f }
    };
    let up = |x: f64| {
        let f = x as f32;
        if f64::from(f) < x { f.next_up() } else { f }
    };
    let (lo, hi) = (down(lo), up(hi));
    (lo.is_finite() && hi.is_finite() && lo > 0.0).then_some((lo, hi))
}

/// Scratch buffers of one traversal (one per thread).
pub(crate) struct Scratch<const D: usize> {
    r2: Vec<f64>,
    /// Packed hits (`sorted position | run << RUN_SHIFT`) of the packed kernels.
    hits: Vec<u32>,
    shell: Shell<D>,
}

impl<const D: usize> Scratch<D> {
    pub fn new() -> Self {
        Self {
            r2: Vec::new(),
            hits: Vec::new(),
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
    const KERNEL: u8,
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
    hits: &mut Vec<u32>,
    r2buf: &mut Vec<f64>,
    f: &mut F,
) {
    let pi: [f64; D] = std::array::from_fn(|d| v.coords[d][i]);
    // The non-empty runs as sorted positions `j0..j1` (the own cell of a half shell from
    // after `i`), with their shifts.
    let mut spans = [(0usize, 0usize); 27];
    let mut shifts = [[0.0f64; D]; 27];
    let mut nr = 0;
    for (k, run) in runs.iter().enumerate() {
        let j0 = if k == 0 && own == Own::After {
            i + 1
        } else {
            v.cell_start[run.first] as usize
        };
        let j1 = v.cell_start[run.end] as usize;
        if j0 < j1 {
            spans[nr] = (j0, j1);
            shifts[nr] = run.shift;
            nr += 1;
        }
    }
    let (spans, shifts) = (&spans[..nr], &shifts[..nr]);
    #[cfg(target_arch = "x86_64")]
    if KERNEL != PORTABLE && !MI {
        // All runs in one branch-free pass that packs the hits into a list, then one loop
        // over the list (see `avx512::particle_hits`, `avx2::particle_hits`).
        let total: usize = spans.iter().map(|&(a, b)| b - a).sum();
        if hits.len() < total + 2 * LANES {
            hits.resize(total + 2 * LANES, 0);
        }
        // SAFETY: `KERNEL` is a packed kernel only in `visit_*_avx512` / `visit_*_avx2`, which
        // run after `packed_kernel` checked the CPU feature and that there are at most
        // `1 << RUN_SHIFT` particles; the coordinates carry `COORD_PAD` = 15 padding values;
        // at most 27 runs; `hits` holds the total plus 16.
        let count = unsafe {
            if KERNEL == PACKED_AVX512 {
                match &v.coords32 {
                    Some(c32) => {
                        avx512::particle_hits_f32(v.coords, c32, pi, spans, shifts, rc2, hits)
                    }
                    None => avx512::particle_hits(v.coords, pi, spans, shifts, rc2, hits),
                }
            } else {
                avx2::particle_hits(v.coords, pi, spans, shifts, rc2, hits)
            }
        };
        let oi = v.order[i] as usize;
        for &packed in &hits[..count] {
            let (j, r) = ((packed & RUN_MASK) as usize, (packed >> RUN_SHIFT) as usize);
            if own == Own::AllButSelf && j == i {
                continue;
            }
            let mut sep = [0.0; D];
            let mut r2 = 0.0;
            for d in 0..D {
                // SAFETY: `j` is a sorted position of one of the runs (below the particle
                // count) and `r < shifts.len()`. Without bounds checks the hit loop has no exit
                // but its end, so a caller's accumulator can stay in a register.
                sep[d] = unsafe {
                    (pi[d] - *v.coords[d].get_unchecked(j))
                        - *shifts.get_unchecked(r).get_unchecked(d)
                };
                // The kernel's operations in its order: the same bits.
                r2 = if d == 0 {
                    sep[d] * sep[d]
                } else {
                    r2 + sep[d] * sep[d]
                };
            }
            // SAFETY: as above.
            f(oi, unsafe { *v.order.get_unchecked(j) } as usize, sep, r2);
        }
        return;
    }
    for (&(j0, j1), shift) in spans.iter().zip(shifts) {
        let n = j1 - j0;
        // Whole vectors: the distance pass runs on past the run into the next particles (or
        // the padding after the last one, `COORD_PAD`); the hit masks drop those lanes.
        let nv = n.next_multiple_of(LANES);
        let jv = j0 + nv;
        // Hits are handed on without bounds checks: a checked index would be a possible exit
        // (panic) on every hit, which keeps the caller's accumulator (e.g. a pair counter)
        // in memory instead of a register, a store-to-load chain through every hit.
        let (oi, orun) = (v.order[i] as usize, &v.order[j0..j1]);
        let crun: [&[f64]; D] = std::array::from_fn(|d| &v.coords[d][j0..j1]);
        // One hit: candidate `jj` of the run at squared distance `r2`.
        let mut emit = |jj: usize, r2: f64| {
            debug_assert!(jj < n);
            if own == Own::AllButSelf && j0 + jj == i {
                return;
            }
            let mut sep = [0.0; D];
            for d in 0..D {
                // SAFETY: hit indices are below `n`, the length of the run slices (lanes at
                // or past `n` are masked off before any hit is enumerated).
                let mut dx = pi[d] - unsafe { *crun[d].get_unchecked(jj) };
                if MI && periodic[d] {
                    if dx > half_len[d] {
                        dx -= lengths[d];
                    } else if dx < -half_len[d] {
                        dx += lengths[d];
                    }
                } else {
                    dx -= shift[d];
                }
                sep[d] = dx;
            }
            // SAFETY: as above.
            f(oi, unsafe { *orun.get_unchecked(jj) } as usize, sep, r2);
        };
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
            let (sx, sy, sz) = (shift[0], shift[1], shift[2]);
            for (((b, &x), &y), &z) in buf.iter_mut().zip(xs).zip(ys).zip(zs) {
                let dx = (px - x) - sx;
                let dy = (py - y) - sy;
                let dz = (pz - z) - sz;
                *b = dx * dx + dy * dy + dz * dz;
            }
        } else if !MI && D == 2 {
            let (xs, ys) = (&v.coords[0][j0..jv], &v.coords[1][j0..jv]);
            let (px, py) = (pi[0], pi[1]);
            let (sx, sy) = (shift[0], shift[1]);
            for ((b, &x), &y) in buf.iter_mut().zip(xs).zip(ys) {
                let dx = (px - x) - sx;
                let dy = (py - y) - sy;
                *b = dx * dx + dy * dy;
            }
        } else {
            buf.fill(0.0);
            for d in 0..D {
                let xs = &v.coords[d][j0..jv];
                let (p, s, h, l) = (pi[d], shift[d], half_len[d], lengths[d]);
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
                // SAFETY: `jj < n <= nv`, the length of `buf`.
                emit(jj, unsafe { *buf.get_unchecked(jj) });
            }
        }
    }
}

#[inline(always)]
fn visit_impl<
    const D: usize,
    const MI: bool,
    const KERNEL: u8,
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
            particle_runs::<D, MI, KERNEL, F>(
                v,
                i,
                runs,
                own,
                rc2,
                half_len,
                lengths,
                periodic,
                &mut s.hits,
                &mut s.r2,
                f,
            );
        }
    }
}

/// The CPU traversal kernel of [`SortedCells`](crate::SortedCells) and the lists built from
/// it. Every kernel reports the same pairs with the same bits in the same order (tested);
/// they differ in speed only (figures in `docs/neighbor.md`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TraversalKernel {
    /// The fastest kernel the CPU supports: packed AVX-512, else packed AVX2, else portable.
    #[default]
    Auto,
    /// Compiler-vectorised squared distances per run of cells, then hit masks (any CPU).
    Portable,
    /// All hits of a particle packed into one list with AVX2 (x86-64 with AVX2 and FMA).
    PackedAvx2,
    /// All hits of a particle packed into one list with AVX-512 (x86-64 with AVX-512F,
    /// AVX-512VL, AVX2 and FMA).
    PackedAvx512,
}

impl TraversalKernel {
    /// Whether this CPU can run the kernel.
    pub fn is_supported(self) -> bool {
        match self {
            TraversalKernel::Auto | TraversalKernel::Portable => true,
            // Every feature the kernel's functions are compiled with (`target_feature`).
            #[cfg(target_arch = "x86_64")]
            TraversalKernel::PackedAvx2 => {
                std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("fma")
                    && std::arch::is_x86_feature_detected!("popcnt")
            }
            #[cfg(target_arch = "x86_64")]
            TraversalKernel::PackedAvx512 => {
                std::arch::is_x86_feature_detected!("avx512f")
                    && std::arch::is_x86_feature_detected!("avx512vl")
                    && std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("fma")
                    && std::arch::is_x86_feature_detected!("popcnt")
            }
            #[cfg(not(target_arch = "x86_64"))]
            TraversalKernel::PackedAvx2 | TraversalKernel::PackedAvx512 => false,
        }
    }

    /// The kernel [`TraversalKernel::Auto`] picks on this CPU.
    pub fn best() -> TraversalKernel {
        [TraversalKernel::PackedAvx512, TraversalKernel::PackedAvx2]
            .into_iter()
            .find(|k| k.is_supported())
            .unwrap_or(TraversalKernel::Portable)
    }
}

/// Which kernel a traversal runs: the view's choice ([`TraversalKernel::best`] for `Auto`), as long
/// as the CPU supports it and every sorted position fits the packed hit format (at most
/// `1 << RUN_SHIFT`, 134 million particles); the portable kernel otherwise.
#[cfg(target_arch = "x86_64")]
fn packed_kernel<const D: usize>(v: &View<'_, D>) -> u8 {
    let k = match v.kernel {
        TraversalKernel::Auto => TraversalKernel::best(),
        k => k,
    };
    if v.order.len() > 1 << RUN_SHIFT || !k.is_supported() {
        return PORTABLE;
    }
    match k {
        TraversalKernel::PackedAvx512 => PACKED_AVX512,
        TraversalKernel::PackedAvx2 => PACKED_AVX2,
        _ => PORTABLE,
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
    match packed_kernel(v) {
        // SAFETY: the CPU has the kernel's features (checked by `packed_kernel`).
        PACKED_AVX512 => return unsafe { visit_cells_avx512(v, cells, half, s, f) },
        // SAFETY: as above.
        PACKED_AVX2 => return unsafe { visit_cells_avx2(v, cells, half, s, f) },
        _ => {}
    }
    visit_cells_portable(v, cells, half, s, f);
}

/// [`visit_cells`] with the packed AVX-512 kernel.
///
/// # Safety
/// The CPU must support AVX-512F, AVX-512VL, AVX2, FMA and POPCNT.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx2,fma,popcnt")]
unsafe fn visit_cells_avx512<const D: usize, F: FnMut(usize, usize, [f64; D], f64)>(
    v: &View<'_, D>,
    cells: Range<usize>,
    half: bool,
    s: &mut Scratch<D>,
    f: &mut F,
) {
    visit_mi_or_not::<D, PACKED_AVX512, F>(v, cells, half, s, f);
}

/// [`visit_cells`] with the packed AVX2 kernel.
///
/// # Safety
/// The CPU must support AVX2, FMA and POPCNT.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,popcnt")]
unsafe fn visit_cells_avx2<const D: usize, F: FnMut(usize, usize, [f64; D], f64)>(
    v: &View<'_, D>,
    cells: Range<usize>,
    half: bool,
    s: &mut Scratch<D>,
    f: &mut F,
) {
    visit_mi_or_not::<D, PACKED_AVX2, F>(v, cells, half, s, f);
}

#[inline(always)]
fn visit_mi_or_not<const D: usize, const KERNEL: u8, F: FnMut(usize, usize, [f64; D], f64)>(
    v: &View<'_, D>,
    cells: Range<usize>,
    half: bool,
    s: &mut Scratch<D>,
    f: &mut F,
) {
    if v.grid.needs_min_image_per_pair() {
        visit_impl::<D, true, KERNEL, F>(v, cells, half, s, f);
    } else {
        visit_impl::<D, false, KERNEL, F>(v, cells, half, s, f);
    }
}

/// [`visit_cells`] without a packed kernel (compiler-vectorised, AVX2 where present).
#[multiversion(targets("x86_64+avx2+fma"), dispatcher = "direct")]
fn visit_cells_portable<const D: usize, F: FnMut(usize, usize, [f64; D], f64)>(
    v: &View<'_, D>,
    cells: Range<usize>,
    half: bool,
    s: &mut Scratch<D>,
    f: &mut F,
) {
    visit_mi_or_not::<D, PORTABLE, F>(v, cells, half, s, f);
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
    match packed_kernel(v) {
        // SAFETY: the CPU has the kernel's features (checked by `packed_kernel`).
        PACKED_AVX512 => return unsafe { visit_particle_avx512(v, rank, cell, half, s, f) },
        // SAFETY: as above.
        PACKED_AVX2 => return unsafe { visit_particle_avx2(v, rank, cell, half, s, f) },
        _ => {}
    }
    visit_particle_portable(v, rank, cell, half, s, f);
}

/// [`visit_particle`] with the packed AVX-512 kernel.
///
/// # Safety
/// The CPU must support AVX-512F, AVX-512VL, AVX2, FMA and POPCNT.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx2,fma,popcnt")]
unsafe fn visit_particle_avx512<const D: usize, F: FnMut(usize, usize, [f64; D], f64)>(
    v: &View<'_, D>,
    rank: usize,
    cell: usize,
    half: bool,
    s: &mut Scratch<D>,
    f: &mut F,
) {
    particle_impl::<D, PACKED_AVX512, F>(v, rank, cell, half, s, f);
}

/// [`visit_particle`] with the packed AVX2 kernel.
///
/// # Safety
/// The CPU must support AVX2, FMA and POPCNT.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,popcnt")]
unsafe fn visit_particle_avx2<const D: usize, F: FnMut(usize, usize, [f64; D], f64)>(
    v: &View<'_, D>,
    rank: usize,
    cell: usize,
    half: bool,
    s: &mut Scratch<D>,
    f: &mut F,
) {
    particle_impl::<D, PACKED_AVX2, F>(v, rank, cell, half, s, f);
}

/// [`visit_particle`] without a packed kernel.
#[multiversion(targets("x86_64+avx2+fma"), dispatcher = "direct")]
fn visit_particle_portable<const D: usize, F: FnMut(usize, usize, [f64; D], f64)>(
    v: &View<'_, D>,
    rank: usize,
    cell: usize,
    half: bool,
    s: &mut Scratch<D>,
    f: &mut F,
) {
    particle_impl::<D, PORTABLE, F>(v, rank, cell, half, s, f);
}

#[inline(always)]
fn particle_impl<const D: usize, const KERNEL: u8, F: FnMut(usize, usize, [f64; D], f64)>(
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
        particle_runs::<D, true, KERNEL, F>(
            v,
            rank,
            runs,
            own,
            rc2,
            half_len,
            lengths,
            periodic,
            &mut s.hits,
            &mut s.r2,
            f,
        );
    } else {
        particle_runs::<D, false, KERNEL, F>(
            v,
            rank,
            runs,
            own,
            rc2,
            half_len,
            lengths,
            periodic,
            &mut s.hits,
            &mut s.r2,
            f,
        );
    }
}

/// The explicit AVX-512 kernel: all candidates of one particle, hits packed into a list.
#[cfg(target_arch = "x86_64")]
mod avx512 {
    use std::arch::x86_64::*;

    use super::RUN_SHIFT;

    /// Squared distances from `p` (separation `(p - x) - s`, summed over the axes in order)
    /// of the 8 particles at sorted positions `k..k + 8`.
    ///
    /// # Safety
    /// The CPU must support AVX-512F and POPCNT; `k + 8` must not exceed any column's length.
    #[inline]
    #[target_feature(enable = "avx512f,popcnt")]
    unsafe fn r2_of<const D: usize>(
        cols: &[&[f64]; D],
        k: usize,
        p: &[__m512d; D],
        s: &[__m512d; D],
    ) -> __m512d {
        let mut r2 = _mm512_setzero_pd();
        for d in 0..D {
            // SAFETY: in bounds per the caller's contract.
            let x = unsafe { _mm512_loadu_pd(cols[d].as_ptr().add(k)) };
            let dx = _mm512_sub_pd(_mm512_sub_pd(p[d], x), s[d]);
            let sq = _mm512_mul_pd(dx, dx);
            r2 = if d == 0 { sq } else { _mm512_add_pd(r2, sq) };
        }
        r2
    }

    /// Writes every hit of particle `p` against the runs `spans` (sorted positions
    /// `j0..j1`, seen through `shifts`) to `hits` as `j | run << RUN_SHIFT`, in run order and
    /// ascending `j`; returns the hit count. Branch-free per 16 candidates: two 8-lane
    /// squared-distance vectors, compared straight into one 16-bit mask, the hit lanes'
    /// indices compressed into one vector and stored whole, the count advanced by the
    /// number of hits (a store may write up to 16 slots past the last hit). Same
    /// operations in the same order as the portable pass, so the same hits.
    ///
    /// # Safety
    /// The CPU must support AVX-512F and POPCNT. Every `j1` must be at most `cols[d].len() - 15` (the
    /// coordinate padding) and at most `1 << RUN_SHIFT`, there may be at most
    /// `1 << (32 - RUN_SHIFT)` runs, and `hits` must hold the total run length plus 16.
    #[inline]
    #[target_feature(enable = "avx512f,popcnt")]
    pub(super) unsafe fn particle_hits<const D: usize>(
        cols: [&[f64]; D],
        p: [f64; D],
        spans: &[(usize, usize)],
        shifts: &[[f64; D]],
        rc2: f64,
        hits: &mut [u32],
    ) -> usize {
        let len = cols.iter().map(|c| c.len()).min().unwrap_or(0);
        let total: usize = spans.iter().map(|&(a, b)| b - a).sum();
        assert!(
            spans
                .iter()
                .all(|&(_, b)| b + 15 <= len && b <= 1 << RUN_SHIFT)
        );
        assert!(spans.len() <= 1 << (32 - RUN_SHIFT) && hits.len() >= total + 16);
        let pv: [__m512d; D] = std::array::from_fn(|d| _mm512_set1_pd(p[d]));
        let cut = _mm512_set1_pd(rc2);
        let mut count = 0usize;
        for (r, (&(j0, j1), shift)) in spans.iter().zip(shifts).enumerate() {
            let sv: [__m512d; D] = std::array::from_fn(|d| _mm512_set1_pd(shift[d]));
            let tag = (r as u32) << RUN_SHIFT;
            let mut k = j0;
            while k < j1 {
                let lanes = (j1 - k).min(16) as u32;
                let tail = (0xffffu32 >> (16 - lanes)) as u16;
                // SAFETY: `k + 16 <= j1 + 15 <= len` (asserted), so the loads stay inside
                // the columns; `count + 16 <= total + 16` (at most one hit per candidate so
                // far), so the store stays inside `hits`.
                unsafe {
                    let lo = r2_of(&cols, k, &pv, &sv);
                    let hi = r2_of(&cols, k + 8, &pv, &sv);
                    let m_lo = _mm512_cmp_pd_mask::<_CMP_LE_OQ>(lo, cut);
                    let m_hi = _mm512_cmp_pd_mask::<_CMP_LE_OQ>(hi, cut);
                    let m = (u16::from(m_lo) | (u16::from(m_hi) << 8)) & tail;
                    count = pack(hits, count, tag, k, m);
                }
                k += 16;
            }
        }
        count
    }

    /// [`particle_hits`] with a single-precision first pass ([`super::Coords32`]): 16
    /// candidates per register, each separation `(p - s) - x` with the shifted position
    /// formed in `f64` and rounded once per run; lanes at most `lo` are hits, lanes in
    /// `(lo, hi]` are decided by [`exact_hits`] (the `f64` squared distance of
    /// [`particle_hits`]), so the hits, their order and the count are those of
    /// [`particle_hits`].
    ///
    /// # Safety
    /// As [`particle_hits`]; the columns of `c32` are at least as long as those of `cols`.
    #[inline]
    #[target_feature(enable = "avx512f,popcnt")]
    pub(super) unsafe fn particle_hits_f32<const D: usize>(
        cols: [&[f64]; D],
        c32: &super::Coords32<'_, D>,
        p: [f64; D],
        spans: &[(usize, usize)],
        shifts: &[[f64; D]],
        rc2: f64,
        hits: &mut [u32],
    ) -> usize {
        let len = cols.iter().map(|c| c.len()).min().unwrap_or(0);
        let total: usize = spans.iter().map(|&(a, b)| b - a).sum();
        assert!(c32.cols.iter().all(|c| c.len() >= len));
        assert!(
            spans
                .iter()
                .all(|&(_, b)| b + 15 <= len && b <= 1 << RUN_SHIFT)
        );
        assert!(spans.len() <= 1 << (32 - RUN_SHIFT) && hits.len() >= total + 16);
        let (lo, hi) = (_mm512_set1_ps(c32.lo), _mm512_set1_ps(c32.hi));
        let mut count = 0usize;
        for (r, (&(j0, j1), shift)) in spans.iter().zip(shifts).enumerate() {
            let q: [__m512; D] = std::array::from_fn(|d| _mm512_set1_ps((p[d] - shift[d]) as f32));
            let tag = (r as u32) << RUN_SHIFT;
            let mut k = j0;
            while k < j1 {
                let lanes = (j1 - k).min(16) as u32;
                let tail = (0xffffu32 >> (16 - lanes)) as u16;
                // SAFETY: `k + 16 <= j1 + 15 <= len` (asserted), so the loads stay inside
                // the columns of both precisions; `count + 16 <= total + 16` (at most one hit
                // per candidate so far), so the store stays inside `hits`.
                unsafe {
                    let mut r2 = _mm512_setzero_ps();
                    for (qd, col) in q.iter().zip(&c32.cols) {
                        let e = _mm512_sub_ps(*qd, _mm512_loadu_ps(col.as_ptr().add(k)));
                        r2 = _mm512_fmadd_ps(e, e, r2);
                    }
                    let mut m = _mm512_cmp_ps_mask::<_CMP_LE_OQ>(r2, lo) & tail;
                    let near = _mm512_cmp_ps_mask::<_CMP_LE_OQ>(r2, hi) & tail & !m;
                    if near != 0 {
                        m |= exact_hits(&cols, p, shift, rc2, k, near);
                    }
                    count = pack(hits, count, tag, k, m);
                }
                k += 16;
            }
        }
        count
    }

    /// Stores the indices `j | tag` of the hit lanes `m` of candidates `k..k + 16` at
    /// `hits[count..]` (packed with `vpcompressd`, stored as a whole vector) and returns the
    /// count with them.
    ///
    /// # Safety
    /// The CPU must support AVX-512F and POPCNT; `count + 16 <= hits.len()`.
    #[inline]
    #[target_feature(enable = "avx512f,popcnt")]
    unsafe fn pack(hits: &mut [u32], count: usize, tag: u32, k: usize, m: u16) -> usize {
        let iota = _mm512_set_epi32(15, 14, 13, 12, 11, 10, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0);
        let idx = _mm512_add_epi32(_mm512_set1_epi32((tag | k as u32) as i32), iota);
        // SAFETY: 16 slots from `count` are inside `hits` (the caller's contract).
        unsafe {
            _mm512_storeu_si512(
                hits.as_mut_ptr().add(count).cast(),
                _mm512_maskz_compress_epi32(m, idx),
            )
        };
        count + m.count_ones() as usize
    }

    /// The lanes of `lanes` (candidates `k + l`) whose `f64` squared distance from `p` is at
    /// most `rc2`, computed with the operations of [`r2_of`] in its order (so the same bits).
    #[cold]
    #[inline(never)]
    fn exact_hits<const D: usize>(
        cols: &[&[f64]; D],
        p: [f64; D],
        shift: &[f64; D],
        rc2: f64,
        k: usize,
        mut lanes: u16,
    ) -> u16 {
        let mut m = 0u16;
        while lanes != 0 {
            let l = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            let mut r2 = 0.0;
            for d in 0..D {
                let dx = (p[d] - cols[d][k + l]) - shift[d];
                let sq = dx * dx;
                r2 = if d == 0 { sq } else { r2 + sq };
            }
            if r2 <= rc2 {
                m |= 1 << l;
            }
        }
        m
    }
}

/// The packed kernel for AVX2: as [`avx512`], 8 candidates at a time, the hit lanes packed
/// with a permutation from a table instead of `vpcompressd`.
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use std::arch::x86_64::*;

    use super::RUN_SHIFT;

    /// For every 8-bit hit mask, the lanes of its set bits in ascending order, first: the
    /// `vpermd` permutation that packs the hit lanes to the front.
    static PACK: [[u32; 8]; 256] = pack_table();

    const fn pack_table() -> [[u32; 8]; 256] {
        let mut table = [[0u32; 8]; 256];
        let mut mask = 0;
        while mask < 256 {
            let (mut n, mut lane) = (0, 0);
            while lane < 8 {
                if (mask >> lane) & 1 == 1 {
                    table[mask][n] = lane as u32;
                    n += 1;
                }
                lane += 1;
            }
            mask += 1;
        }
        table
    }

    /// Squared distances from `p` (separation `(p - x) - s`, summed over the axes in order)
    /// of the 4 particles at sorted positions `k..k + 4`.
    ///
    /// # Safety
    /// The CPU must support AVX2 and POPCNT; `k + 4` must not exceed any column's length.
    #[inline]
    #[target_feature(enable = "avx2,popcnt")]
    unsafe fn r2_of<const D: usize>(
        cols: &[&[f64]; D],
        k: usize,
        p: &[__m256d; D],
        s: &[__m256d; D],
    ) -> __m256d {
        let mut r2 = _mm256_setzero_pd();
        for d in 0..D {
            // SAFETY: in bounds per the caller's contract.
            let x = unsafe { _mm256_loadu_pd(cols[d].as_ptr().add(k)) };
            let dx = _mm256_sub_pd(_mm256_sub_pd(p[d], x), s[d]);
            let sq = _mm256_mul_pd(dx, dx);
            r2 = if d == 0 { sq } else { _mm256_add_pd(r2, sq) };
        }
        r2
    }

    /// Same contract and output as [`super::avx512::particle_hits`], 8 candidates per step
    /// (a store may write up to 8 slots past the last hit).
    ///
    /// # Safety
    /// The CPU must support AVX2 and POPCNT. Every `j1` must be at most `cols[d].len() - 7` and at most
    /// `1 << RUN_SHIFT`, there may be at most `1 << (32 - RUN_SHIFT)` runs, and `hits` must
    /// hold the total run length plus 8.
    #[inline]
    #[target_feature(enable = "avx2,popcnt")]
    pub(super) unsafe fn particle_hits<const D: usize>(
        cols: [&[f64]; D],
        p: [f64; D],
        spans: &[(usize, usize)],
        shifts: &[[f64; D]],
        rc2: f64,
        hits: &mut [u32],
    ) -> usize {
        let len = cols.iter().map(|c| c.len()).min().unwrap_or(0);
        let total: usize = spans.iter().map(|&(a, b)| b - a).sum();
        assert!(
            spans
                .iter()
                .all(|&(_, b)| b + 7 <= len && b <= 1 << RUN_SHIFT)
        );
        assert!(spans.len() <= 1 << (32 - RUN_SHIFT) && hits.len() >= total + 8);
        let pv: [__m256d; D] = std::array::from_fn(|d| _mm256_set1_pd(p[d]));
        let cut = _mm256_set1_pd(rc2);
        let iota = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        let mut count = 0usize;
        for (r, (&(j0, j1), shift)) in spans.iter().zip(shifts).enumerate() {
            let sv: [__m256d; D] = std::array::from_fn(|d| _mm256_set1_pd(shift[d]));
            let tag = (r as u32) << RUN_SHIFT;
            let mut k = j0;
            while k < j1 {
                let lanes = (j1 - k).min(8) as u32;
                let tail = 0xffu32 >> (8 - lanes);
                // SAFETY: `k + 8 <= j1 + 7 <= len` (asserted), so the loads stay inside the
                // columns; `count + 8 <= total + 8` (at most one hit per candidate so far),
                // so the store stays inside `hits`; `m < 256` indexes the table.
                unsafe {
                    let lo = r2_of(&cols, k, &pv, &sv);
                    let hi = r2_of(&cols, k + 4, &pv, &sv);
                    let m_lo = _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_LE_OQ>(lo, cut)) as u32;
                    let m_hi = _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_LE_OQ>(hi, cut)) as u32;
                    let m = (m_lo | (m_hi << 4)) & tail;
                    let idx = _mm256_add_epi32(_mm256_set1_epi32((tag | k as u32) as i32), iota);
                    let perm = _mm256_loadu_si256(PACK.get_unchecked(m as usize).as_ptr().cast());
                    _mm256_storeu_si256(
                        hits.as_mut_ptr().add(count).cast(),
                        _mm256_permutevar8x32_epi32(idx, perm),
                    );
                    count += m.count_ones() as usize;
                }
                k += 8;
            }
        }
        count
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
        collect_view(visit, &cells.view())
    }

    /// [`collect`] on a given view.
    fn collect_view<const D: usize>(
        visit: impl Fn(&View<'_, D>, &mut Scratch<D>, &mut dyn FnMut(usize, usize, [f64; D], f64)),
        view: &View<'_, D>,
    ) -> Pairs<D> {
        let mut out = Vec::new();
        let mut s = Scratch::new();
        visit(view, &mut s, &mut |i, j, sep, r2| {
            out.push((i, j, sep.map(f64::to_bits), r2.to_bits()))
        });
        out
    }

    /// The packed kernels this CPU can run (the portable one always runs).
    fn packed_kernels() -> Vec<u8> {
        let mut k = Vec::new();
        if TraversalKernel::PackedAvx2.is_supported() {
            k.push(PACKED_AVX2);
        }
        if TraversalKernel::PackedAvx512.is_supported() {
            k.push(PACKED_AVX512);
        }
        k
    }

    /// `visit_cells` with the packed kernel `kernel`.
    #[cfg(target_arch = "x86_64")]
    fn visit_cells_with<const D: usize, F: FnMut(usize, usize, [f64; D], f64)>(
        kernel: u8,
        v: &View<'_, D>,
        cells: Range<usize>,
        half: bool,
        s: &mut Scratch<D>,
        f: &mut F,
    ) {
        // SAFETY: only kernels from `packed_kernels` (features checked) are passed.
        unsafe {
            match kernel {
                PACKED_AVX512 => visit_cells_avx512(v, cells, half, s, f),
                _ => visit_cells_avx2(v, cells, half, s, f),
            }
        }
    }

    /// `visit_particle` with the packed kernel `kernel`.
    #[cfg(target_arch = "x86_64")]
    fn visit_particle_with<const D: usize, F: FnMut(usize, usize, [f64; D], f64)>(
        kernel: u8,
        v: &View<'_, D>,
        (rank, cell): (usize, usize),
        half: bool,
        s: &mut Scratch<D>,
        f: &mut F,
    ) {
        // SAFETY: only kernels from `packed_kernels` (features checked) are passed.
        unsafe {
            match kernel {
                PACKED_AVX512 => visit_particle_avx512(v, rank, cell, half, s, f),
                _ => visit_particle_avx2(v, rank, cell, half, s, f),
            }
        }
    }

    /// The SIMD feature `simd_exercised` reports for a packed kernel: `avx512f` for the
    /// AVX-512 kernel, `avx2` for the AVX2 one.
    const KERNEL_FEATURES: [(u8, &str); 2] = [(PACKED_AVX512, "avx512f"), (PACKED_AVX2, "avx2")];

    /// Reports through [`simkit_backend::testing::simd_exercised`] which packed kernels
    /// `test` really ran (`ran`): on a CPU without a kernel's feature the test compared the
    /// portable kernel with itself, which is printed, and is a failure where
    /// `SIMKIT_REQUIRE_SIMD` names the feature.
    fn report_kernels(test: &str, ran: &[u8]) {
        for (kernel, feature) in KERNEL_FEATURES {
            simkit_backend::testing::simd_exercised(test, feature, ran.contains(&kernel));
        }
    }

    /// Compares every packed kernel this CPU runs with the portable one; returns the
    /// kernels compared.
    fn kernels_agree<const D: usize>(periodic: [bool; D], cutoff: f64, seed: u64) -> Vec<u8> {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
        let l = 9.0;
        let p: Vec<[f64; D]> = (0..3000)
            .map(|_| std::array::from_fn(|_| rng.random::<f64>() * l))
            .collect();
        kernels_agree_on(&p, [l; D], periodic, cutoff)
    }

    /// [`kernels_agree`] on given positions in a box of sides `lengths`; the AVX-512 kernel
    /// runs with and without its single-precision first pass (where the list built it).
    fn kernels_agree_on<const D: usize>(
        p: &[[f64; D]],
        lengths: [f64; D],
        periodic: [bool; D],
        cutoff: f64,
    ) -> Vec<u8> {
        let mut ran = Vec::new();
        let l = lengths.into_iter().fold(0.0, f64::max);
        let grid = CellGrid::new([0.0; D], lengths, periodic, cutoff).unwrap();
        let mut cells = SortedCells::new(&grid);
        cells.build(p).unwrap();
        let nc = grid.n_cells();
        for half in [true, false] {
            let portable = collect(
                |v, s, mut f| visit_cells_portable(v, 0..nc, half, s, &mut f),
                &cells,
            );
            assert!(!portable.is_empty());
            #[cfg(target_arch = "x86_64")]
            for kernel in packed_kernels() {
                let packed = collect(
                    |v, s, mut f| visit_cells_with(kernel, v, 0..nc, half, s, &mut f),
                    &cells,
                );
                assert_eq!(packed, portable, "kernel {kernel} and portable differ");
                if kernel == PACKED_AVX512 {
                    assert!(
                        cells.view().coords32.is_some() == f32_band(l, cutoff, D).is_some(),
                        "the list built its f32 coordinates where the band allows"
                    );
                    let mut plain = cells.view();
                    plain.coords32 = None;
                    let f64_only = collect_view(
                        |v, s, mut f| visit_cells_with(kernel, v, 0..nc, half, s, &mut f),
                        &plain,
                    );
                    assert_eq!(f64_only, portable, "AVX-512 without f32 pass and portable");
                }
                // One particle at a time (the gather traversal's entry point).
                for i in (0..p.len()).step_by(97) {
                    let at = (cells.rank()[i] as usize, cells.cell_of()[i] as usize);
                    let one = collect(
                        |v, s, mut f| visit_particle_portable(v, at.0, at.1, half, s, &mut f),
                        &cells,
                    );
                    let packed = collect(
                        |v, s, mut f| visit_particle_with(kernel, v, at, half, s, &mut f),
                        &cells,
                    );
                    assert_eq!(packed, one, "kernel {kernel}, particle {i}");
                }
                if !ran.contains(&kernel) {
                    ran.push(kernel);
                }
            }
        }
        ran
    }

    /// The single-precision first pass of the AVX-512 kernel reports exactly the `f64` hits
    /// where `f32` cannot decide: a 3000-wide periodic box (decision band about 1e-3 of the
    /// cutoff), 4000 random particles plus 1500 pairs planted at distances within a few
    /// `f64` ulps of the cutoff, some across the periodic faces; the planted pairs must reach
    /// the band's exact check (counted), and the kernels must agree pair for pair.
    #[test]
    fn f32_first_pass_keeps_the_f64_pairs() {
        let (box_len, rc) = ([3000.0, 6.0, 6.0], 1.0);
        let (lo, hi) = f32_band(box_len[0], rc, 3).expect("a band at L = 3000, rc = 1");
        assert!(f64::from(lo) < rc * rc && rc * rc < f64::from(hi));
        assert!(
            f32_band(1e9, 1.0, 3).is_none(),
            "no band where f32 cannot decide"
        );
        let mut rng = rand_pcg::Pcg64::seed_from_u64(11);
        let mut p: Vec<[f64; 3]> = (0..4000)
            .map(|_| std::array::from_fn(|d| rng.random::<f64>() * box_len[d]))
            .collect();
        let mut near = 0;
        for k in 0..1500 {
            let a: [f64; 3] = std::array::from_fn(|d| rng.random::<f64>() * box_len[d]);
            // A direction, scaled to the cutoff, nudged by -4..=4 f64 ulps of the cutoff.
            let dir: [f64; 3] = std::array::from_fn(|_| rng.random::<f64>() - 0.5);
            let norm = dir.iter().map(|x| x * x).sum::<f64>().sqrt();
            let r = rc + (k % 9) as f64 * rc * f64::EPSILON - 4.0 * rc * f64::EPSILON;
            let b: [f64; 3] =
                std::array::from_fn(|d| (a[d] + dir[d] / norm * r).rem_euclid(box_len[d]));
            let sep: [f64; 3] = std::array::from_fn(|d| {
                let x = (a[d] as f32 - b[d] as f32).abs();
                f64::from(x.min(box_len[d] as f32 - x))
            });
            let r2_32 = sep.iter().map(|x| x * x).sum::<f64>();
            if r2_32 > f64::from(lo) && r2_32 <= f64::from(hi) {
                near += 1;
            }
            p.push(a);
            p.push(b);
        }
        assert!(near > 1000, "only {near} planted pairs reach the band");
        let ran = kernels_agree_on(&p, box_len, [true; 3], rc);
        report_kernels("f32_first_pass_keeps_the_f64_pairs", &ran);
    }

    /// Both packed kernels report exactly the candidates of their runs that are within the
    /// cutoff, in order, even when the particles right after a run (read by its last vector)
    /// are hits.
    #[test]
    fn packed_kernels_stop_at_the_end_of_every_run() {
        // 60 particles on the x axis, every other one within the cutoff of the origin.
        let xs: Vec<f64> = (0..60 + COORD_PAD)
            .map(|k| if k % 2 == 0 { 0.5 } else { 5.0 })
            .collect();
        let zeros = vec![0.0; xs.len()];
        let spans = [(3, 21), (21, 22), (30, 47), (50, 60)];
        let shifts = [[0.0; 3]; 4];
        let want: Vec<u32> = spans
            .iter()
            .enumerate()
            .flat_map(|(r, &(a, b))| {
                (a..b)
                    .filter(|k| k % 2 == 0)
                    .map(move |k| k as u32 | (r as u32) << RUN_SHIFT)
            })
            .collect();
        let mut ran = Vec::new();
        #[cfg(target_arch = "x86_64")]
        for kernel in packed_kernels() {
            let mut hits = vec![u32::MAX; 80];
            let cols = [xs.as_slice(), &zeros, &zeros];
            // SAFETY: features checked by `packed_kernels`; runs end at 60 <= len - 15;
            // 4 runs; `hits` holds 46 + 16.
            let count = unsafe {
                match kernel {
                    PACKED_AVX512 => {
                        avx512::particle_hits(cols, [0.0; 3], &spans, &shifts, 1.0, &mut hits)
                    }
                    _ => avx2::particle_hits(cols, [0.0; 3], &spans, &shifts, 1.0, &mut hits),
                }
            };
            assert_eq!(&hits[..count], &want[..], "kernel {kernel}");
            ran.push(kernel);
        }
        report_kernels("packed_kernels_stop_at_the_end_of_every_run", &ran);
    }

    /// The packed AVX-512 and AVX2 kernels report exactly what the portable one does (same
    /// pairs, same order, same bits): open and periodic boxes, dense cells (runs of hundreds
    /// of candidates), a periodic axis of 2 cells (minimum image per pair), 2D.
    #[test]
    fn packed_kernels_match_the_portable_kernel() {
        let ran = [
            kernels_agree::<3>([false; 3], 1.3, 1),
            kernels_agree::<3>([true, false, true], 1.3, 2),
            kernels_agree::<3>([true; 3], 2.9, 3),
            kernels_agree::<3>([false, true, false], 4.0, 4),
            kernels_agree::<2>([true, true], 1.3, 5),
            kernels_agree::<2>([false, false], 0.4, 6),
        ];
        // A kernel counts as exercised only if every scene ran it.
        let all: Vec<u8> = KERNEL_FEATURES
            .iter()
            .map(|&(k, _)| k)
            .filter(|k| ran.iter().all(|r| r.contains(k)))
            .collect();
        report_kernels("packed_kernels_match_the_portable_kernel", &all);
    }
}
