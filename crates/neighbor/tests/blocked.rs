//! [`BlockedHalfList`]: its half list equals the brute-force pairs within the list range
//! (with the minimum-image shifts), on random 2D and 3D boxes with mixed periodicity, on
//! sparse boxes and at block edges; the list is the same serial and on the rayon pool.

use std::collections::BTreeMap;

use rand::{RngExt, SeedableRng};
use simkit_backend::Real;
use simkit_neighbor::BlockedHalfList;

/// Sorted-slot pair `(i, j)`, `i < j` -> image shift (bits of each component as `f64`).
type Pairs<const D: usize> = BTreeMap<(usize, usize), [u64; D]>;

/// Every listed pair, checking the CSR layout of every block on the way.
fn listed<T: Real, const D: usize>(list: &BlockedHalfList<T, D>) -> Pairs<D> {
    let n = list.particle_count();
    let blocks = list.blocks();
    let mut m = Pairs::new();
    let mut next = 0;
    for (t, b) in blocks.iter().enumerate() {
        assert_eq!(b.start(), next, "block {t} does not follow its predecessor");
        assert!(b.len() <= list.block_size());
        if t + 1 < blocks.len() {
            assert_eq!(
                b.len(),
                list.block_size(),
                "only the last block may be short"
            );
        }
        next = b.end();
        assert_eq!(b.offsets().len(), b.len() + 1);
        assert_eq!(b.image_offsets().len(), b.len() + 1);
        assert_eq!(*b.offsets().last().unwrap() as usize, b.partners().len());
        assert_eq!(
            *b.image_offsets().last().unwrap() as usize,
            b.image_partners().len()
        );
        let past = |j: u32| j as usize + 1;
        let near = b
            .partners()
            .iter()
            .map(|&j| past(j))
            .fold(b.end(), usize::max);
        assert_eq!(b.near_reach(), near, "block {t}: near reach");
        let image = b.image_partners().iter().map(|&(j, _)| past(j));
        assert_eq!(b.reach(), image.fold(near, usize::max), "block {t}: reach");
        for k in 0..b.len() {
            let i = b.start() + k;
            for &j in b.partners_of(k).expect("built") {
                let j = j as usize;
                assert!(j > i && j < n, "partner {j} of {i}");
                assert!(m.insert((i, j), [0.0f64.to_bits(); D]).is_none());
            }
            for &(j, s) in b.image_partners_of(k).expect("built") {
                let j = j as usize;
                assert!(j > i && j < n, "image partner {j} of {i}");
                assert!(
                    s.iter().any(|c| c.to_f64() != 0.0),
                    "zero shift stored apart"
                );
                let bits = std::array::from_fn(|d| (s[d].to_f64() + 0.0).to_bits());
                assert!(
                    m.insert((i, j), bits).is_none(),
                    "pair ({i}, {j}) listed twice"
                );
            }
        }
    }
    assert_eq!(next, n, "blocks do not cover the particles");
    assert_eq!(m.len(), list.pair_count());
    m
}

/// Brute force over the sorted positions: pairs closer than `range` at their minimum image,
/// with the shift `s` such that the separation is `(x_i - x_j) - s`.
fn brute<T: Real, const D: usize>(
    pos: &[[T; D]],
    len: [f64; D],
    periodic: [bool; D],
    range: f64,
) -> Pairs<D> {
    let mut m = Pairs::new();
    for i in 0..pos.len() {
        for j in i + 1..pos.len() {
            let mut r2 = 0.0;
            let mut shift = [0.0f64; D];
            for d in 0..D {
                let mut s = pos[i][d].to_f64() - pos[j][d].to_f64();
                if periodic[d] {
                    if s > 0.5 * len[d] {
                        s -= len[d];
                        shift[d] = len[d];
                    } else if s < -0.5 * len[d] {
                        s += len[d];
                        shift[d] = -len[d];
                    }
                }
                r2 += s * s;
            }
            if r2 < range * range {
                // The list stores the shift in `T`.
                m.insert(
                    (i, j),
                    std::array::from_fn(|d| (T::from_f64(shift[d]).to_f64() + 0.0).to_bits()),
                );
            }
        }
    }
    m
}

/// Sorts, checks the permutation and the cell order, builds serially and in parallel, and
/// compares both with brute force. Returns the number of pairs.
fn check<T: Real, const D: usize>(
    lo: [f64; D],
    len: [f64; D],
    periodic: [bool; D],
    range: f64,
    pos: &[[T; D]],
) -> usize {
    let mut list = BlockedHalfList::<T, D>::new(lo, len, periodic, range, pos.len()).unwrap();
    let order = list.sort(pos).unwrap();
    let mut seen = vec![false; pos.len()];
    for &k in &order {
        assert!(
            !std::mem::replace(&mut seen[k as usize], true),
            "not a permutation"
        );
    }
    let sorted: Vec<[T; D]> = order.iter().map(|&k| pos[k as usize]).collect();
    list.build(&sorted, false).unwrap();
    let serial = listed(&list);
    list.build(&sorted, true).unwrap();
    let parallel = listed(&list);
    assert_eq!(
        serial, parallel,
        "the parallel build differs from the serial one"
    );
    let reference = brute(&sorted, len, periodic, range);
    assert_eq!(serial, reference, "the list differs from brute force");
    // A second sort of the sorted positions keeps them in place (stable within a cell).
    let again = list.sort(&sorted).unwrap();
    assert!(again.iter().enumerate().all(|(k, &o)| o as usize == k));
    // Within a cell the slots are in increasing first coordinate (NaN last).
    let cells = list.cells();
    let cell = |x: &[T; D]| -> [usize; D] {
        std::array::from_fn(|d| {
            let t = ((x[d].to_f64() - lo[d]) * (cells[d] as f64 / len[d])).floor();
            if t >= 0.0 {
                (t as usize).min(cells[d] - 1)
            } else {
                0
            }
        })
    };
    for k in 1..sorted.len() {
        let (a, b) = (sorted[k - 1][0].to_f64(), sorted[k][0].to_f64());
        if cell(&sorted[k - 1]) == cell(&sorted[k]) && !b.is_nan() {
            assert!(a <= b || (a == 0.0 && b == 0.0), "slots {k}: {a} then {b}");
        }
    }
    serial.len()
}

/// `n` random positions in the box (periodic axes inside `[lo, lo + len)`; closed axes
/// with a few points up to one range outside), some in tight clusters.
fn random_positions<const D: usize>(
    rng: &mut rand_pcg::Pcg64,
    lo: [f64; D],
    len: [f64; D],
    periodic: [bool; D],
    range: f64,
    n: usize,
) -> Vec<[f64; D]> {
    let mut pos = Vec::with_capacity(n);
    while pos.len() < n {
        let x: [f64; D] = std::array::from_fn(|d| {
            let out = if periodic[d] { 0.0 } else { range };
            lo[d] - out + rng.random_range(0.0..1.0) * (len[d] + 2.0 * out)
        });
        pos.push(x);
        // A small cluster around it, wrapped into the box along periodic axes.
        for _ in 0..rng.random_range(0..3usize) {
            if pos.len() < n {
                pos.push(std::array::from_fn(|d| {
                    let mut y = x[d] + rng.random_range(-0.6..0.6) * range;
                    if periodic[d] {
                        if y < lo[d] {
                            y += len[d];
                        } else if y >= lo[d] + len[d] {
                            y -= len[d];
                        }
                    }
                    y
                }));
            }
        }
    }
    pos
}

fn random_boxes<const D: usize>(seed: u64, cases: usize) {
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let mut total = 0;
    for case in 0..cases {
        let range = rng.random_range(0.5..2.0);
        let lo: [f64; D] = std::array::from_fn(|_| rng.random_range(-5.0..5.0));
        let periodic: [bool; D] = std::array::from_fn(|d| (case >> d) & 1 == 1);
        let len: [f64; D] = std::array::from_fn(|_| {
            // Down to the shortest periodic length allowed (2 range, two cells).
            range * rng.random_range(2.0..12.0)
        });
        // Several blocks in most cases (blocks hold 256 particles or more).
        let n = rng.random_range(0..1400usize);
        let pos = random_positions(&mut rng, lo, len, periodic, range, n);
        total += check(lo, len, periodic, range, &pos);
        let pos32: Vec<[f32; D]> = pos.iter().map(|x| x.map(|c| c as f32)).collect();
        check(lo, len, periodic, range, &pos32);
    }
    assert!(total > 1000, "too few pairs tested: {total}");
}

#[test]
fn half_list_equals_brute_force_in_random_2d_boxes() {
    random_boxes::<2>(1, 24);
}

#[test]
fn half_list_equals_brute_force_in_random_3d_boxes() {
    random_boxes::<3>(2, 24);
}

#[test]
fn half_list_equals_brute_force_in_sparse_boxes() {
    // Far more cells of the list range than 8 n + 4096: the cells are widened.
    let mut rng = rand_pcg::Pcg64::seed_from_u64(3);
    for (case, n) in [0usize, 1, 2, 40, 300].into_iter().enumerate() {
        let periodic = [case % 2 == 0, true, case % 3 == 0];
        let (lo, len, range) = ([-100.0; 3], [400.0, 300.0, 500.0], 0.7);
        let pos = random_positions(&mut rng, lo, len, periodic, range, n);
        let list = BlockedHalfList::<f64, 3>::new(lo, len, periodic, range, n).unwrap();
        let c = list.cells();
        assert!(c.iter().product::<usize>() <= 8 * n + 4096, "{c:?}");
        assert!(len[0] / (c[0] as f64) > range, "cells were not widened");
        check(lo, len, periodic, range, &pos);
        let p2: Vec<[f64; 2]> = pos.iter().map(|x| [x[0], x[1]]).collect();
        check(
            [lo[0], lo[1]],
            [len[0], len[1]],
            [periodic[0], periodic[1]],
            range,
            &p2,
        );
    }
    // Two pairs, one across each periodic face of a huge 2D box.
    let pos = [
        [0.1, 50.0],
        [999.8, 50.0],
        [500.0, 0.2],
        [500.3, 899.9],
        [300.0, 300.0],
    ];
    let pairs = check([0.0; 2], [1000.0, 900.0], [true; 2], 0.5, &pos[..]);
    assert_eq!(pairs, 2);
}

#[test]
fn invalid_input_is_refused() {
    let new = |len: f64, periodic: bool, range: f64| {
        BlockedHalfList::<f64, 2>::new([0.0; 2], [len, 10.0], [periodic, false], range, 4)
    };
    assert!(new(10.0, true, 1.0).is_ok());
    assert!(new(10.0, true, 5.0).is_ok());
    assert!(
        new(9.9, true, 5.0).is_err(),
        "periodic box shorter than 2 range"
    );
    assert!(new(9.9, false, 5.0).is_ok());
    assert!(new(10.0, false, 0.0).is_err());
    assert!(new(10.0, false, f64::NAN).is_err());
    assert!(new(-1.0, false, 1.0).is_err());
    assert!(new(f64::INFINITY, false, 1.0).is_err());
    assert!(BlockedHalfList::<f64, 2>::new([f64::NAN, 0.0], [1.0; 2], [false; 2], 0.1, 1).is_err());
    assert!(BlockedHalfList::<f64, 4>::new([0.0; 4], [1.0; 4], [false; 4], 0.1, 1).is_err());
    let mut list = new(10.0, true, 1.0).unwrap();
    assert!(list.sort(&[[1.0, 1.0]; 3]).is_err(), "wrong position count");
    assert!(
        list.build(&[[1.0, 1.0]; 5], false).is_err(),
        "wrong position count"
    );
    assert!(list.sort(&[[1.0, 1.0]; 4]).is_ok());
}

#[test]
fn blocks_depend_only_on_the_particle_count_and_the_box() {
    // A box of 50^3 with range 1: 50 cells per axis (fewer for tiny counts).
    for (n, size, count) in [
        (0, 256, 1),
        (256, 256, 1),
        (257, 256, 2),
        (40_000, 2500, 16),
        // Blocks of one layer of cells (20,000 particles) beyond 65,536.
        (1_000_000, 20_000, 50),
    ] {
        let list = BlockedHalfList::<f32, 3>::new([0.0; 3], [50.0; 3], [true; 3], 1.0, n).unwrap();
        assert_eq!(list.block_size(), size, "n = {n}");
        let sized = BlockedHalfList::<f32, 3>::block_size_for(n, list.cells());
        assert_eq!(sized, size, "n = {n}");
        assert_eq!(list.blocks().len(), count, "n = {n}");
    }
    // A flat box (5 layers): blocks of 4,096 at least ...
    let list =
        BlockedHalfList::<f32, 3>::new([0.0; 3], [500.0, 500.0, 5.0], [true; 3], 1.0, 10_000_000)
            .unwrap();
    assert_eq!(list.cells()[2], 5);
    // ... and one layer (2 million) would leave 5 blocks: 16 blocks of n / 16 instead.
    assert_eq!(list.block_size(), 625_000);
    // A tall box: layers of 400 particles, blocks of 4,096.
    let list =
        BlockedHalfList::<f32, 3>::new([0.0; 3], [20.0, 20.0, 2500.0], [true; 3], 1.0, 1_000_000)
            .unwrap();
    assert_eq!(list.block_size(), 4096);
}

#[test]
fn half_list_equals_brute_force_with_one_to_four_cells_per_axis() {
    // Periodic axes with 1 or 2 cells (the same neighbour cell is reached through both
    // faces) take the per-pair minimum image; 3 and more take the per-cell image shifts.
    let mut rng = rand_pcg::Pcg64::seed_from_u64(5);
    let range = 1.0;
    for case in 0..64usize {
        let periodic = [case & 1 == 1, case & 2 == 2, case & 4 == 4];
        // 2.0 -> 2 cells (1 cell only when closed and shorter), 1.5 -> 1 cell (closed only).
        let len: [f64; 3] = std::array::from_fn(|d| {
            let c = [2.0, 2.5, 3.0, 3.5, 4.2, 2.0, 3.0, 1.5][(case >> (3 + d)) & 7];
            if periodic[d] { c.max(2.0) } else { c }
        });
        let lo = [0.5, -1.0, 2.0];
        let pos = random_positions(&mut rng, lo, len, periodic, range, 300);
        check(lo, len, periodic, range, &pos);
        let p2: Vec<[f64; 2]> = pos.iter().map(|x| [x[0], x[1]]).collect();
        check(
            [lo[0], lo[1]],
            [len[0], len[1]],
            [periodic[0], periodic[1]],
            range,
            &p2,
        );
    }
}

#[test]
fn non_finite_positions_are_in_range_of_nothing() {
    // Both build paths (3 and 2 cells per periodic axis); no panic, the finite pairs kept.
    for len in [12.0, 5.0] {
        let mut pos = vec![[1.0, 1.0, 1.0], [1.5, 1.0, 1.0], [len - 0.2, 1.0, 1.0]];
        pos.extend([
            [f64::NAN, 1.0, 1.0],
            [1.0, f64::INFINITY, 1.0],
            [-f64::INFINITY; 3],
        ]);
        let mut list =
            BlockedHalfList::<f64, 3>::new([0.0; 3], [len; 3], [true; 3], 1.5, pos.len()).unwrap();
        let order = list.sort(&pos).unwrap();
        let sorted: Vec<[f64; 3]> = order.iter().map(|&k| pos[k as usize]).collect();
        for parallel in [false, true] {
            list.build(&sorted, parallel).unwrap();
            let pairs = listed(&list);
            assert_eq!(pairs.len(), 2, "len {len}: {pairs:?}");
            for &(i, j) in pairs.keys() {
                assert!(sorted[i].iter().chain(&sorted[j]).all(|x| x.is_finite()));
            }
        }
    }
}

#[test]
fn half_list_equals_brute_force_in_dense_boxes() {
    // About 16 particles per cell (as in a Lennard-Jones liquid): a jittered FCC lattice
    // (many particles near the same planes) and uniform positions, periodic and closed, in
    // f64 and f32, and their 2D projections.
    let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
    for case in 0..4usize {
        let periodic = [case & 1 == 1; 3];
        let lattice = case & 2 == 2;
        let (range, side) = (1.4, 4usize);
        let a = 1.0;
        let l = side as f64 * a * 2.0;
        let mut pos: Vec<[f64; 3]> = Vec::new();
        if lattice {
            let m = 2 * side;
            for k in 0..m * m * m {
                let cell = [k % m, (k / m) % m, k / (m * m)];
                for b in [
                    [0.0, 0.0, 0.0],
                    [0.5, 0.5, 0.0],
                    [0.5, 0.0, 0.5],
                    [0.0, 0.5, 0.5],
                ] {
                    pos.push(std::array::from_fn(|d| {
                        ((cell[d] as f64 + b[d]) * a + rng.random_range(-0.02..0.02)).rem_euclid(l)
                    }));
                }
            }
        } else {
            pos = (0..2048)
                .map(|_| std::array::from_fn(|_| rng.random_range(0.0..l)))
                .collect();
        }
        let pairs = check([0.0; 3], [l; 3], periodic, range, &pos);
        assert!(pairs > 10 * pos.len(), "case {case}: {pairs} pairs");
        let p32: Vec<[f32; 3]> = pos.iter().map(|x| x.map(|c| c as f32)).collect();
        check([0.0; 3], [l; 3], periodic, range, &p32);
        let p2: Vec<[f64; 2]> = pos.iter().take(1500).map(|x| [x[0], x[1]]).collect();
        check([0.0; 2], [l; 2], [periodic[0]; 2], 0.4, &p2);
    }
}

#[test]
fn positions_out_of_cell_order_still_give_every_pair() {
    // `build` expects the positions of the last `sort`; given a cell in another order it
    // notices and checks every candidate of the stencil cells.
    let mut rng = rand_pcg::Pcg64::seed_from_u64(8);
    let (len, periodic, range) = ([6.0; 3], [true, false, true], 1.0);
    let pos = random_positions(&mut rng, [0.0; 3], len, periodic, range, 1500);
    let mut list = BlockedHalfList::<f64, 3>::new([0.0; 3], len, periodic, range, 1500).unwrap();
    let order = list.sort(&pos).unwrap();
    let mut sorted: Vec<[f64; 3]> = order.iter().map(|&k| pos[k as usize]).collect();
    let same_cell =
        |a: &[f64; 3], b: &[f64; 3]| (0..3).all(|d| (a[d] * 1.0).floor() == (b[d] * 1.0).floor());
    // Reverse the slots of every cell (its particles stay in it).
    let mut k = 0;
    while k < sorted.len() {
        let mut e = k + 1;
        while e < sorted.len() && same_cell(&sorted[k], &sorted[e]) {
            e += 1;
        }
        sorted[k..e].reverse();
        k = e;
    }
    for parallel in [false, true] {
        list.build(&sorted, parallel).unwrap();
        assert_eq!(listed(&list), brute(&sorted, len, periodic, range));
    }
}
