//! Neighbour search throughput: build + enumerate every pair within the cutoff, in
//! unordered pairs per second, for each method of the `neighbor` crate and for the `kiddo`
//! k-d tree (its fastest path: per-point `within().unsorted().visit()` queries issued in the
//! tree's own order, rayon-parallel).
//!
//! Workload: N uniform random points at number density 1 in a cube (square in
//! 2D), closed box, cutoff 2.5 (about 65 neighbours per point in 3D, 20 in 2D),
//! N = 1e4, 1e5, 1e6. Run: `cargo bench --bench neighbor`. Before the criterion groups it
//! prints a side-by-side summary (sorted cells and kiddo timed alternately, medians of 7)
//! with the sorted-cells / kiddo ratio and the build-time scaling from N = 1e4 to 1e6.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rand::{RngExt, SeedableRng};
use rayon::prelude::*;
use simkit::backend::{GpuBuffer, GpuContext};
use simkit::neighbor::{
    BlockedHalfList, BruteForce, CellGrid, GpuCellList, GpuNeighborList, LinkedCells, ListKind,
    NeighborSearch, SortedCells, TraversalKernel, VerletList, positions_to_f32,
};

const CUTOFF: f64 = 2.5;
const SIZES: [usize; 3] = [10_000, 100_000, 1_000_000];

fn points<const D: usize>(n: usize) -> (CellGrid<D>, Vec<[f64; D]>) {
    let side = (n as f64).powf(1.0 / D as f64);
    let mut rng = rand_pcg::Pcg64::seed_from_u64(42);
    let p = (0..n)
        .map(|_| std::array::from_fn(|_| rng.random::<f64>() * side))
        .collect();
    let grid = CellGrid::new([0.0; D], [side; D], [false; D], CUTOFF).expect("grid");
    (grid, p)
}

/// Sorted cells, rayon: build + half-shell enumeration; returns the pair count.
fn sorted_par<const D: usize>(cells: &mut SortedCells<D>, p: &[[f64; D]]) -> usize {
    cells.build(p).expect("build");
    cells.par_pair_count()
}

/// kiddo, rayon: tree build + per-point queries in tree order; returns the pair count.
fn kiddo_par(p: &[[f64; 3]]) -> usize {
    let tree: ImmutableKdTree<f64, 3> = ImmutableKdTree::new_from_slice(p).expect("kiddo tree");
    let order: Vec<[f64; 3]> = tree.iter().map(|(_, q)| q).collect();
    let r2 = CUTOFF * CUTOFF;
    let hits: usize = order
        .par_iter()
        .map(|q| {
            let mut c = 0usize;
            tree.query(q)
                .within::<SquaredEuclidean<f64>>(r2)
                .unsorted()
                .visit(|_| c += 1);
            c
        })
        .sum();
    (hits - p.len()) / 2
}

fn configure<'a>(
    c: &'a mut Criterion,
    name: &str,
) -> criterion::BenchmarkGroup<'a, criterion::measurement::WallTime> {
    let mut g = c.benchmark_group(name);
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    g
}

fn cpu_methods(c: &mut Criterion) {
    for &n in &SIZES {
        let (grid, p) = points::<3>(n);
        let mut cells = SortedCells::new(&grid);
        let pairs = sorted_par(&mut cells, &p);
        println!(
            "N = {n}: {pairs} pairs within {CUTOFF} ({:.1} neighbours each)",
            2.0 * pairs as f64 / n as f64
        );

        let mut g = configure(c, "neighbor_3d_build_and_pairs");
        g.throughput(Throughput::Elements(pairs as u64));
        g.bench_with_input(BenchmarkId::new("sorted_cells_rayon", n), &n, |b, _| {
            b.iter(|| black_box(sorted_par(&mut cells, &p)))
        });
        // The same with each other kernel this CPU runs (docs/neighbor.md compares them).
        for kernel in [TraversalKernel::PackedAvx2, TraversalKernel::Portable] {
            if kernel.is_supported() && kernel != TraversalKernel::best() {
                let mut forced = SortedCells::new(&grid).with_kernel(kernel).expect("kernel");
                let id = format!("sorted_cells_rayon_{kernel:?}");
                g.bench_with_input(BenchmarkId::new(id, n), &n, |b, _| {
                    b.iter(|| black_box(sorted_par(&mut forced, &p)))
                });
            }
        }
        g.bench_with_input(BenchmarkId::new("sorted_cells_serial", n), &n, |b, _| {
            b.iter(|| {
                cells.build(&p).expect("build");
                let mut k = 0usize;
                cells.for_each_pair(|_, _, _, r2| k += usize::from(r2 >= 0.0));
                black_box(k)
            })
        });
        if n <= 10_000 {
            let mut brute = BruteForce::new(&grid);
            g.bench_with_input(BenchmarkId::new("brute_force_serial", n), &n, |b, _| {
                b.iter(|| {
                    brute.build(&p).expect("build");
                    black_box(brute.pair_count().expect("pairs"))
                })
            });
        }
        let mut linked = LinkedCells::new(&grid);
        g.bench_with_input(BenchmarkId::new("linked_cells_serial", n), &n, |b, _| {
            b.iter(|| {
                linked.build(&p).expect("build");
                black_box(linked.pair_count().expect("pairs"))
            })
        });
        let mut verlet = VerletList::new(&grid, 0.3, ListKind::Half).expect("verlet");
        g.bench_with_input(
            BenchmarkId::new("verlet_half_rayon_build", n),
            &n,
            |b, _| {
                b.iter(|| {
                    verlet.build(&p).expect("build");
                    black_box(verlet.par_fold_pairs(|| 0usize, |k, _, _, _, _| *k += 1))
                })
            },
        );
        g.bench_with_input(
            BenchmarkId::new("verlet_half_rayon_reuse", n),
            &n,
            |b, _| b.iter(|| black_box(verlet.par_fold_pairs(|| 0usize, |k, _, _, _, _| *k += 1))),
        );
        g.bench_with_input(BenchmarkId::new("kiddo_rayon_tree_order", n), &n, |b, _| {
            b.iter(|| black_box(kiddo_par(&p)))
        });
        g.finish();

        let mut g = configure(c, "neighbor_3d_build_only");
        g.throughput(Throughput::Elements(n as u64));
        g.bench_with_input(BenchmarkId::new("sorted_cells", n), &n, |b, _| {
            b.iter(|| cells.build(&p).expect("build"))
        });
        g.finish();
    }
}

/// `BlockedHalfList::build` (the half list of `dem` and `md`) on LAMMPS's `in.lj` system:
/// 32,000 atoms on a `20^3`-cell FCC lattice at density 0.8442 with a small random
/// displacement, periodic cube, range 2.5 + 0.3; serial and on the rayon pool. Throughput in
/// atoms per second.
fn blocked_half_list(c: &mut Criterion) {
    let a = (4.0f64 / 0.8442).powf(1.0 / 3.0);
    let (nc, side) = (20usize, 20.0 * a);
    let mut rng = rand_pcg::Pcg64::seed_from_u64(9);
    let basis = [
        [0.0, 0.0, 0.0],
        [0.5, 0.5, 0.0],
        [0.5, 0.0, 0.5],
        [0.0, 0.5, 0.5],
    ];
    let mut pos = Vec::with_capacity(4 * nc * nc * nc);
    for k in 0..nc * nc * nc {
        let cell = [k % nc, (k / nc) % nc, k / (nc * nc)];
        for b in basis {
            pos.push(std::array::from_fn::<f64, 3, _>(|d| {
                ((cell[d] as f64 + b[d]) * a + rng.random_range(-0.05..0.05)).rem_euclid(side)
            }));
        }
    }
    let mut list = BlockedHalfList::<f64, 3>::new([0.0; 3], [side; 3], [true; 3], 2.8, pos.len())
        .expect("list");
    let order = list.sort(&pos).expect("sort");
    let sorted: Vec<[f64; 3]> = order.iter().map(|&k| pos[k as usize]).collect();
    let mut g = configure(c, "blocked_half_list_build_in_lj_32000");
    g.throughput(Throughput::Elements(pos.len() as u64));
    for parallel in [false, true] {
        let name = if parallel { "rayon" } else { "serial" };
        g.bench_function(name, |b| {
            b.iter(|| {
                list.build(&sorted, parallel).expect("build");
                black_box(list.pair_count())
            })
        });
    }
    g.finish();
}

fn cpu_2d(c: &mut Criterion) {
    for &n in &SIZES {
        let (grid, p) = points::<2>(n);
        let mut cells = SortedCells::new(&grid);
        let pairs = sorted_par(&mut cells, &p);
        let mut g = configure(c, "neighbor_2d_build_and_pairs");
        g.throughput(Throughput::Elements(pairs as u64));
        g.bench_with_input(BenchmarkId::new("sorted_cells_rayon", n), &n, |b, _| {
            b.iter(|| black_box(sorted_par(&mut cells, &p)))
        });
        g.finish();
    }
}

fn gpu(c: &mut Criterion) {
    let ctx = match GpuContext::new() {
        Ok(ctx) => ctx,
        Err(e) => {
            println!("GPU benchmarks skipped: {e}");
            return;
        }
    };
    println!("GPU adapter: {}", ctx.summary());
    for &n in &SIZES {
        let (grid, p) = points::<3>(n);
        let buf = GpuBuffer::from_slice(&ctx, "positions", &positions_to_f32(&p)).expect("upload");
        let cells = GpuCellList::new(&ctx, &grid, &buf).expect("cells");
        let mut list = GpuNeighborList::new(&ctx, &cells, ListKind::Half).expect("list");
        cells.build(&ctx).expect("build");
        let pairs = list.build(&ctx, &cells).expect("list");
        let mut g = configure(c, "neighbor_3d_gpu");
        g.throughput(Throughput::Elements(pairs as u64));
        g.bench_with_input(BenchmarkId::new("cells_and_half_list", n), &n, |b, _| {
            b.iter(|| {
                cells.build(&ctx).expect("build");
                black_box(list.build(&ctx, &cells).expect("list"))
            })
        });
        g.finish();
    }
}

/// Repetitions of the summary's timings.
const REPS: usize = 7;

/// Median of a list of times.
fn median(mut t: Vec<f64>) -> f64 {
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

/// Times `a` and `b` alternately, [`REPS`] times each (so a burst of other load on the
/// machine hits both); returns their median times and last results.
fn interleaved(
    mut a: impl FnMut() -> usize,
    mut b: impl FnMut() -> usize,
) -> ((f64, usize), (f64, usize)) {
    let (mut ta, mut tb, mut ka, mut kb) = (Vec::new(), Vec::new(), 0, 0);
    for _ in 0..REPS {
        let s = Instant::now();
        ka = black_box(a());
        ta.push(s.elapsed().as_secs_f64());
        let s = Instant::now();
        kb = black_box(b());
        tb.push(s.elapsed().as_secs_f64());
    }
    ((median(ta), ka), (median(tb), kb))
}

fn summary(_: &mut Criterion) {
    println!(
        "\nSummary (medians of {REPS}, sorted cells and kiddo timed alternately, rayon threads = {}):",
        rayon::current_num_threads()
    );
    let mut build_times = Vec::new();
    for &n in &SIZES {
        let (grid, p) = points::<3>(n);
        let mut cells = SortedCells::new(&grid);
        sorted_par(&mut cells, &p); // allocate the buffers before timing
        let ((ts, ps), (tk, pk)) = interleaved(|| sorted_par(&mut cells, &p), || kiddo_par(&p));
        let tb = median(
            (0..REPS)
                .map(|_| {
                    let s = Instant::now();
                    cells.build(&p).expect("build");
                    s.elapsed().as_secs_f64()
                })
                .collect(),
        );
        build_times.push(tb);
        assert_eq!(ps, pk, "sorted cells and kiddo disagree on the pair count");
        println!(
            "N = {n:>8}: sorted cells {:.3e} pairs/s ({ts:.4} s), kiddo {:.3e} pairs/s ({tk:.4} s), \
             ratio {:.1}x, build {tb:.4} s",
            ps as f64 / ts,
            pk as f64 / tk,
            tk / ts
        );
    }
    println!(
        "build time N=1e6 / N=1e4: {:.1}x (linear: 100x, target <= 130x)",
        build_times[2] / build_times[0]
    );
}

criterion_group!(
    benches,
    summary,
    cpu_methods,
    blocked_half_list,
    cpu_2d,
    gpu
);
criterion_main!(benches);
