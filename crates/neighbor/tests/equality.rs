//! Property tests: brute force, linked cells, sorted cells, Verlet lists, rayon and GPU find
//! identical pairs, plus edge cases. The properties draw their cases from a fixed seed (see
//! `config`), so every run checks the same inputs.

use crate::common;

use proptest::prelude::*;
use proptest::test_runner::{RngAlgorithm, RngSeed};
#[cfg(feature = "gpu")]
use simkit_backend::testing::gpu_or_skip;
use simkit_neighbor::{CellGrid, NeighborSearch, SortedCells, TraversalKernel};

use common::check_cpu;
#[cfg(feature = "gpu")]
use common::check_gpu;

/// A coordinate along one axis: uniform, or one of the edge values (exactly the lower face,
/// exactly the upper face `origin + L`, one ulp below it, and on periodic axes values below
/// the origin, one ulp below it, and beyond the upper face).
fn coord(origin: f64, l: f64, periodic: bool, kind: u8, u: f64) -> f64 {
    match kind {
        0 => origin,
        1 => origin + l,
        2 => (origin + l).next_down(),
        3 if periodic => origin - u * 2.5 * l,
        4 if periodic => origin + l + u * 1.5 * l,
        5 if periodic => origin.next_down(),
        _ => origin + u * l,
    }
}

/// A coordinate strictly inside cell `cell` of `cells` along an axis of length `l`.
fn in_cell(origin: f64, l: f64, cells: usize, cell: usize, u: f64) -> f64 {
    let size = l / cells as f64;
    origin + (cell as f64 + 0.01 + 0.98 * u) * size
}

#[derive(Debug, Clone)]
struct Case<const D: usize> {
    origin: [f64; D],
    lengths: [f64; D],
    periodic: [bool; D],
    cutoff: f64,
    positions: Vec<[f64; D]>,
}

impl<const D: usize> Case<D> {
    fn grid(&self) -> CellGrid<D> {
        CellGrid::new(self.origin, self.lengths, self.periodic, self.cutoff).unwrap()
    }
}

fn case<const D: usize>(max_n: usize) -> impl Strategy<Value = Case<D>> {
    (
        prop::array::uniform3(prop::sample::select(vec![0.0, -4.0, 2.5])),
        prop::array::uniform3(4u32..120),
        prop::array::uniform3(any::<bool>()),
        0.2f64..4.0,
        0..max_n,
        any::<u64>(),
        0u8..4,
    )
        .prop_map(move |(o, l8, per, cutoff, n, seed, layout)| {
            use rand::{RngExt, SeedableRng};
            let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
            let origin: [f64; D] = std::array::from_fn(|d| o[d]);
            let lengths: [f64; D] = std::array::from_fn(|d| f64::from(l8[d]) / 8.0);
            let periodic: [bool; D] = std::array::from_fn(|d| per[d]);
            // The checks cost about the number of pairs: keep every case near or below
            // MAX_PAIRS, so that many cases fit in the time. Clustered layouts make every
            // pair of the cluster a neighbour; uniform ones about n^2 / 2 times the
            // cutoff volume over the box volume.
            let volume: f64 = lengths.iter().product();
            let reach = if D == 2 {
                std::f64::consts::PI * cutoff * cutoff
            } else {
                4.0 / 3.0 * std::f64::consts::PI * cutoff.powi(3)
            };
            let uniform = ((2.0 * MAX_PAIRS / (reach / volume).min(1.0)).sqrt()) as usize;
            let cluster = (2.0 * MAX_PAIRS).sqrt() as usize;
            let n = match layout {
                2 => n.min(cluster),
                3 => n.min(2 * cluster).min(2 * uniform),
                _ => n.min(uniform),
            };
            // layout 0: uniform; 1: uniform with edge values; 2: all in one cell; 3: half
            // in one cell, half uniform with edge values.
            let cells = CellGrid::new(origin, lengths, periodic, cutoff)
                .expect("valid grid")
                .cells_per_axis();
            let cluster: [usize; D] = std::array::from_fn(|d| rng.random_range(0..cells[d]));
            let positions = (0..n)
                .map(|_| {
                    let clustered = layout == 2 || (layout == 3 && rng.random::<f64>() < 0.5);
                    std::array::from_fn(|d| {
                        let u = rng.random::<f64>();
                        if clustered {
                            return in_cell(origin[d], lengths[d], cells[d], cluster[d], u);
                        }
                        let kind = if layout == 1 || layout == 3 {
                            rng.random_range(0u8..12)
                        } else {
                            11
                        };
                        coord(origin[d], lengths[d], periodic[d], kind, u)
                    })
                })
                .collect();
            Case {
                origin,
                lengths,
                periodic,
                cutoff,
                positions,
            }
        })
}

/// Cases of each CPU property.
const CPU_CASES: u32 = 256;

/// Cases of each GPU property (each also runs the CPU checks).
#[cfg(feature = "gpu")]
const GPU_CASES: u32 = 48;

/// About the most pairs a generated case has (see `case`).
const MAX_PAIRS: f64 = 10_000.0;

/// The seed of the properties in this file.
const SEED: u64 = 0x5eed_e9a1_17e5;

/// `cases` cases drawn from the fixed seed [`SEED`] (ChaCha), so every run checks the same
/// inputs and a failure reproduces (proptest prints the minimal case); no regression files
/// are written. Change `SEED` to explore other inputs.
fn config(cases: u32) -> ProptestConfig {
    ProptestConfig {
        cases,
        rng_algorithm: RngAlgorithm::ChaCha,
        rng_seed: RngSeed::Fixed(SEED),
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

proptest! {
    #![proptest_config(config(CPU_CASES))]

    #[test]
    fn cpu_methods_agree_2d(c in case::<2>(3000)) {
        check_cpu(&c.grid(), &c.positions);
    }

    #[test]
    fn cpu_methods_agree_3d(c in case::<3>(3000)) {
        check_cpu(&c.grid(), &c.positions);
    }
}

proptest! {
    #![proptest_config(config(GPU_CASES))]

    #[cfg(feature = "gpu")]
    #[test]
    fn gpu_agrees_2d(c in case::<2>(3000)) {
        let Some(ctx) = gpu_or_skip("gpu_agrees_2d") else { return Ok(()) };
        let grid = c.grid();
        let reference = check_cpu(&grid, &c.positions);
        check_gpu(&ctx, &grid, &c.positions, &reference);
    }

    #[cfg(feature = "gpu")]
    #[test]
    fn gpu_agrees_3d(c in case::<3>(3000)) {
        let Some(ctx) = gpu_or_skip("gpu_agrees_3d") else { return Ok(()) };
        let grid = c.grid();
        let reference = check_cpu(&grid, &c.positions);
        check_gpu(&ctx, &grid, &c.positions, &reference);
    }
}

#[test]
fn a_kernel_the_cpu_lacks_is_an_error() {
    let grid = CellGrid::new([0.0; 3], [5.0; 3], [true; 3], 1.0).unwrap();
    for kernel in [
        TraversalKernel::Auto,
        TraversalKernel::Portable,
        TraversalKernel::PackedAvx2,
        TraversalKernel::PackedAvx512,
    ] {
        let r = SortedCells::new(&grid).with_kernel(kernel);
        if kernel.is_supported() {
            assert_eq!(r.unwrap().kernel(), kernel);
        } else {
            let e = r.unwrap_err().to_string();
            assert!(
                e.contains(&format!("{kernel:?}")) && e.contains("TraversalKernel::Auto"),
                "{e}"
            );
        }
    }
    assert!(TraversalKernel::best().is_supported());
}

#[test]
fn empty_and_single_particle() {
    let grid = CellGrid::new([0.0; 3], [5.0; 3], [true; 3], 1.0).unwrap();
    for p in [vec![], vec![[1.0, 2.0, 3.0]]] {
        let r = check_cpu(&grid, &p);
        assert!(r.is_empty());
        #[cfg(feature = "gpu")]
        if let Some(ctx) = gpu_or_skip("empty_and_single_particle") {
            check_gpu(&ctx, &grid, &p, &r);
        }
    }
}

#[test]
fn coincident_particles_are_one_pair_at_zero_distance() {
    let grid = CellGrid::new([0.0; 2], [5.0; 2], [false; 2], 1.0).unwrap();
    let p = vec![[2.0, 2.0], [2.0, 2.0]];
    let r = check_cpu(&grid, &p);
    assert_eq!(r.len(), 1);
    assert_eq!(r[&(0, 1)], ([0.0, 0.0], 0.0));
    #[cfg(feature = "gpu")]
    if let Some(ctx) = gpu_or_skip("coincident_particles") {
        check_gpu(&ctx, &grid, &p, &r);
    }
}

#[test]
fn a_pair_exactly_at_the_cutoff_is_a_neighbor_and_one_ulp_beyond_is_not() {
    // Separations with exact squared distances (3-4-5 triangles, rc = 5): r2 = rc^2 exactly
    // in one cell, across cells and across the periodic x face is a pair (the rule is
    // r2 <= rc^2); a separation one ulp longer is not. The cells are 6.67 wide (3 per axis).
    // Every CPU method must give the expected set itself, not only agree with brute force.
    let grid = CellGrid::new([0.0; 3], [20.0, 20.0, 20.0], [true, false, false], 5.0).unwrap();
    let p = vec![
        [10.0, 10.0, 10.0],            // 0
        [13.0, 14.0, 10.0],            // 1: (3, 4, 0) from 0, the next cell in y
        [10.0, 10.0, 15.0],            // 2: (0, 0, 5) from 0, the next cell in z
        [10.0, 6.0 - 1e-9, 19.0],      // 3: no partner
        [2.5, 1.0, 1.0],               // 4
        [17.5, 1.0, 1.0],              // 5: 2.5 - 17.5 + 20 = 5 from 4 across the face
        [3.0, 17.0, 3.0],              // 6
        [6.0f64.next_up(), 13.0, 3.0], // 7: (3 + ulp, 4, 0) from 6: just beyond
        [2.5, 4.0, 5.0],               // 8: (0, 3, 4) from 4, the same cell
    ];
    let r = check_cpu(&grid, &p);
    let mut keys: Vec<(usize, usize)> = r.keys().copied().collect();
    keys.sort_unstable();
    assert_eq!(keys, vec![(0, 1), (0, 2), (4, 5), (4, 8)], "{r:?}");
    for k in keys {
        assert_eq!(r[&k].1, 25.0, "pair {k:?} at exactly rc^2");
    }
    #[cfg(feature = "gpu")]
    if let Some(ctx) = gpu_or_skip("a_pair_exactly_at_the_cutoff") {
        // f32 decides these pairs either way (check_gpu allows it for r2 within 1e-4 rc^2).
        check_gpu(&ctx, &grid, &p, &r);
    }
}

#[test]
fn cutoff_over_half_a_periodic_box_counts_each_pair_once() {
    // L = 3 with cutoff 2: one cell, several images within the cutoff; the minimum image
    // decides and the pair is reported once.
    let grid = CellGrid::new([0.0; 2], [3.0, 3.0], [true, true], 2.0).unwrap();
    assert_eq!(grid.cells_per_axis(), [1, 1]);
    let p = vec![[0.1, 0.1], [1.6, 0.1], [2.9, 2.9]];
    let r = check_cpu(&grid, &p);
    assert_eq!(r.len(), 3);
    let (sep, r2) = r[&(0, 1)];
    assert!((sep[0] - -1.5).abs() < 1e-12 && (r2 - 2.25).abs() < 1e-12);
    let (sep, _) = r[&(0, 2)];
    assert!((sep[0] - 0.2).abs() < 1e-12 && (sep[1] - 0.2).abs() < 1e-12);
    #[cfg(feature = "gpu")]
    if let Some(ctx) = gpu_or_skip("cutoff_over_half_box") {
        check_gpu(&ctx, &grid, &p, &r);
    }
}

#[test]
fn one_two_and_three_cells_along_a_periodic_axis() {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
    for (l, cells) in [(1.5, 1usize), (2.5, 2), (3.5, 3), (4.2, 4)] {
        let grid = CellGrid::new([0.0; 3], [l, 6.0, 6.0], [true, true, false], 1.0).unwrap();
        assert_eq!(grid.cells_per_axis()[0], cells);
        let p: Vec<[f64; 3]> = (0..400)
            .map(|_| std::array::from_fn(|d| rng.random::<f64>() * [l, 6.0, 6.0][d]))
            .collect();
        let r = check_cpu(&grid, &p);
        assert!(!r.is_empty());
        #[cfg(feature = "gpu")]
        if let Some(ctx) = gpu_or_skip("few_cells_periodic") {
            check_gpu(&ctx, &grid, &p, &r);
        }
    }
}

#[test]
fn errors_name_the_particle() {
    let grid = CellGrid::new([0.0; 2], [5.0; 2], [true, false], 1.0).unwrap();
    let mut s = SortedCells::new(&grid);
    let e = s.build(&[[1.0, 1.0], [-3.0, 6.0]]).unwrap_err().to_string();
    assert!(e.contains("position[1].y"), "{e}");
    let e = s.build(&[[f64::NAN, 1.0]]).unwrap_err().to_string();
    assert!(e.contains("position[0].x"), "{e}");
    let mut b = simkit_neighbor::BruteForce::new(&grid);
    assert!(b.build(&[[1.0, f64::INFINITY]]).is_err());
    #[cfg(feature = "gpu")]
    if let Some(ctx) = gpu_or_skip("gpu_errors") {
        let mut g = simkit_neighbor::GpuNeighborSearch::new(&ctx, &grid).unwrap();
        assert!(g.build(&[[1.0, 1.0], [-3.0, 6.0]]).is_err());
        // The device-side check catches what bypasses host validation.
        let buf = simkit_backend::GpuBuffer::from_slice(
            &ctx,
            "p",
            &[[1.0f32, 1.0, 0.0, 0.0], [1.0, 9.0, 0.0, 0.0]],
        )
        .unwrap();
        let cells = simkit_neighbor::GpuCellList::new(&ctx, &grid, &buf).unwrap();
        let e = cells.build(&ctx).unwrap_err().to_string();
        assert!(e.contains("position[1].y") && e.contains('9'), "{e}");
        let buf = simkit_backend::GpuBuffer::from_slice(
            &ctx,
            "p",
            &[
                [1.0f32, 1.0, 0.0, 0.0],
                [f32::NAN, 1.0, 0.0, 0.0],
                [1.0, f32::NAN, 0.0, 0.0],
            ],
        )
        .unwrap();
        let cells = simkit_neighbor::GpuCellList::new(&ctx, &grid, &buf).unwrap();
        let e = cells.build(&ctx).unwrap_err().to_string();
        assert!(
            e.contains("position[1].x") && e.contains("2 particle(s)"),
            "{e}"
        );
    }
}

#[test]
fn parallel_counting_sort_is_thread_count_independent() {
    use rand::{RngExt, SeedableRng};
    use simkit_neighbor::LinkedCells;
    // Large enough for the chunked two-pass sort; compared across pool sizes and with
    // linked cells.
    let mut rng = rand_pcg::Pcg64::seed_from_u64(5);
    let n = 70_000;
    let side = (n as f64).cbrt();
    let p: Vec<[f64; 3]> = (0..n)
        .map(|_| std::array::from_fn(|_| rng.random::<f64>() * side))
        .collect();
    let grid = CellGrid::new([0.0; 3], [side; 3], [true, false, true], 1.2).unwrap();
    let build = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut s = SortedCells::new(&grid);
            s.build(&p).unwrap();
            s
        })
    };
    let one = build(1);
    for threads in [2, 3, 4] {
        let many = build(threads);
        assert_eq!(one.cell_start(), many.cell_start());
        assert_eq!(one.order(), many.order(), "{threads} threads");
        assert_eq!(one.rank(), many.rank());
        for d in 0..3 {
            assert_eq!(one.sorted_coords(d), many.sorted_coords(d));
            assert!(one.sorted_coords(d).is_some());
        }
    }
    for c in 0..grid.n_cells() {
        let ids = &one.order()[one.cell_start()[c] as usize..one.cell_start()[c + 1] as usize];
        assert!(
            ids.windows(2).all(|w| w[0] < w[1]),
            "ids ascending in a cell"
        );
        assert!(ids.iter().all(|&i| one.cell_of()[i as usize] as usize == c));
    }
    for (k, &i) in one.order().iter().enumerate() {
        assert_eq!(one.rank()[i as usize] as usize, k);
        assert_eq!(
            one.sorted_coords(0).unwrap()[k],
            one.wrapped()[i as usize][0]
        );
    }
    let mut linked = LinkedCells::new(&grid);
    linked.build(&p).unwrap();
    let mut sorted = build(4);
    let want = linked.neighbor_counts().unwrap();
    assert_eq!(sorted.neighbor_counts().unwrap(), want);
    assert_eq!(
        sorted.par_pair_count(),
        want.iter().map(|&c| c as usize).sum::<usize>() / 2
    );
}

#[test]
fn clamped_positions_outside_closed_faces_keep_exact_pairs() {
    use simkit_neighbor::OutOfBox;
    // Opt-in clamping: particles up to 3 cutoffs outside the closed y and z faces are put
    // in the boundary cells, and every method still finds exactly the brute-force pairs.
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_pcg::Pcg64::seed_from_u64(21);
    let grid = CellGrid::new([0.0; 3], [6.0, 5.0, 4.0], [true, false, false], 1.0)
        .unwrap()
        .with_out_of_box(OutOfBox::Clamp);
    let p: Vec<[f64; 3]> = (0..1500)
        .map(|_| {
            [
                rng.random::<f64>() * 6.0,
                rng.random::<f64>() * 11.0 - 3.0,
                rng.random::<f64>() * 10.0 - 3.0,
            ]
        })
        .collect();
    let r = check_cpu(&grid, &p);
    assert!(!r.is_empty());
    #[cfg(feature = "gpu")]
    if let Some(ctx) = gpu_or_skip("clamped_positions") {
        check_gpu(&ctx, &grid, &p, &r);
    }
    // Without the opt-in the same positions are an error naming a particle.
    let strict = CellGrid::new([0.0; 3], [6.0, 5.0, 4.0], [true, false, false], 1.0).unwrap();
    let e = SortedCells::new(&strict).build(&p).unwrap_err().to_string();
    assert!(e.contains("position["), "{e}");
}

#[test]
fn reorder_and_restore_are_inverse_permutations() {
    let grid = CellGrid::new([0.0; 2], [4.0, 4.0], [true, true], 1.0).unwrap();
    let p = vec![[3.5, 3.5], [0.2, 0.1], [2.2, 0.3], [0.4, 0.2], [3.9, 0.0]];
    let mut s = SortedCells::new(&grid);
    s.build(&p).unwrap();
    let data: Vec<usize> = (0..p.len()).collect();
    let sorted = s.reorder(&data).unwrap();
    // Cell order: cell (0,0) holds 1 and 3 (ascending), then (2,0) holds 2, (3,0) holds 4,
    // then (3,3) holds 0.
    assert_eq!(sorted, vec![1, 3, 2, 4, 0]);
    assert_eq!(s.restore(&sorted).unwrap(), data);
    assert!(s.reorder(&data[..3]).is_err());
    assert!(s.restore(&data[..3]).is_err());
}

#[cfg(feature = "gpu")]
#[test]
fn gpu_cell_at_the_per_cell_limit_works_and_one_more_is_an_error() {
    use simkit_neighbor::{GPU_LOOP_RESERVE, GPU_MAX_PER_CELL, GpuCellList};
    // All particles in one cell. At the adapter's limit the build must give every id once,
    // ascending (the cell order), and the neighbour lists must match the CPU's; one particle
    // more must be refused. On llvmpipe the limit comes from its shader loop limit (one cell
    // past it was measured to lose particles silently); elsewhere it is GPU_MAX_PER_CELL.
    let Some(ctx) = gpu_or_skip("gpu_cell_at_the_per_cell_limit") else {
        return;
    };
    let grid = CellGrid::new([0.0; 3], [10.0; 3], [false; 3], 2.5).unwrap();
    let max = GpuCellList::<3>::max_per_cell(&ctx);
    match ctx.shader_loop_limit() {
        Some(limit) => {
            // A full-shell walk over 3^D cells of `max + 1` steps each (population plus
            // the exit test) must leave GPU_LOOP_RESERVE iterations of the loop limit:
            // 2,388 in 3D and 7,166 in 2D for llvmpipe's 65,535 (docs/neighbor.md).
            let walk = (limit - GPU_LOOP_RESERVE) as usize;
            assert_eq!(max, walk / 27 - 1, "3D limit under loop limit {limit}");
            assert!(27 * (max + 1) <= walk && 27 * (max + 2) > walk);
            let max_2d = GpuCellList::<2>::max_per_cell(&ctx);
            assert_eq!(max_2d, walk / 9 - 1, "2D limit under loop limit {limit}");
            println!(
                "gpu_cell_at_the_per_cell_limit: RELAXED: adapter '{}' ends shader loops after \
                 {limit} iterations, so the per-cell limit tested here is {max} (3D; 2D: \
                 {max_2d}), not GPU_MAX_PER_CELL = {GPU_MAX_PER_CELL}",
                ctx.adapter_info().name
            );
        }
        None => assert_eq!(max, GPU_MAX_PER_CELL),
    }
    let positions = |n: usize| -> Vec<[f64; 3]> {
        (0..n)
            .map(|i| {
                let u = i as f64 / n as f64;
                [1.0 + 0.1 * u, 1.1 - 0.1 * u, 1.0]
            })
            .collect()
    };
    for (n, ok) in [(max, true), (max + 1, false)] {
        let p = positions(n);
        let buf = simkit_backend::GpuBuffer::from_slice(
            &ctx,
            "p",
            &simkit_neighbor::positions_to_f32(&p),
        )
        .unwrap();
        let cells = GpuCellList::new(&ctx, &grid, &buf).unwrap();
        let r = cells.build(&ctx);
        if ok {
            r.unwrap();
            let ids = cells.sorted_ids().download(&ctx).unwrap();
            assert!(ids.iter().enumerate().all(|(k, &i)| i as usize == k));
            // Every particle sees all others (the cell is 0.1 wide, the cutoff 2.5): the
            // device's full list must hold them all, in ascending order. It has n (n - 1)
            // entries: affordable only for a small limit.
            if n <= 10_000 {
                let mut search = simkit_neighbor::GpuNeighborSearch::new(&ctx, &grid).unwrap();
                search.build(&p).unwrap();
                let cells = search.cells().expect("built");
                let mut full = simkit_neighbor::GpuNeighborList::new(
                    &ctx,
                    cells,
                    simkit_neighbor::ListKind::Full,
                )
                .unwrap();
                assert_eq!(full.build(&ctx, cells).unwrap(), n * (n - 1));
                let lists = full.download(&ctx).unwrap();
                for i in 0..n {
                    let others = (0..n as u32).filter(|&j| j as usize != i);
                    assert!(
                        lists.of(i).unwrap().iter().copied().eq(others),
                        "particle {i}"
                    );
                }
            } else {
                println!(
                    "gpu_cell_at_the_per_cell_limit: SKIPPED the full-list check at n = {n}: \
                     n (n - 1) = {} entries is too large for a test; checked the cell order only",
                    n * (n - 1)
                );
            }
        } else {
            let e = r.unwrap_err().to_string();
            assert!(e.contains(&format!("more than {max} particles")), "{e}");
        }
    }
}

#[test]
fn neighbor_lists_of_a_missing_particle_is_none() {
    let lists = simkit_neighbor::NeighborLists::from_pairs(3, &[(0, 1), (1, 2)]).unwrap();
    assert_eq!(lists.len(), 3);
    assert_eq!(lists.of(1), Some(&[0u32, 2][..]));
    assert_eq!(lists.of(2), Some(&[1u32][..]));
    // Particle 5 of 3 used to panic with an out-of-bounds index.
    assert_eq!(lists.of(3), None);
    assert_eq!(lists.of(5), None);
    assert_eq!(lists.of(usize::MAX), None);
    // Hand-built lists whose offsets point past `neighbors` are refused, not sliced.
    let broken = simkit_neighbor::NeighborLists {
        offsets: vec![0, 4],
        neighbors: vec![1],
    };
    assert_eq!(broken.of(0), None);
}
