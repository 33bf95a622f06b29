//! Robustness: the public constructors, setters, queries and traversals of the CPU neighbour
//! search, driven with arbitrary values (NaN, ±inf, ±0, negative, huge, subnormal, lengths
//! that do not match, empty inputs, out-of-range indices). Every call must give `Ok` with a
//! valid result (pairs equal to brute force with finite separations within the cutoff,
//! indices in range, permutations that are permutations) or an `Err` whose message names the
//! bad value; a panic or an abort fails the test.
//!
//! Reproducible: every property runs a fixed number of cases drawn from a fixed seed
//! ([`SEED`], ChaCha), so a failure shows on every run and proptest prints the minimal input;
//! no regression files are written. Change `SEED` to explore other inputs.
//!
//! CPU only, sized to run in seconds: at most 24 particles, searches only on grids of at most
//! [`MAX_SEARCH_CELLS`] cells (larger valid grids are only checked as grids).

use std::collections::BTreeMap;

use proptest::prelude::*;
use simkit_backend::testing::robust::{self, awkward_f64, mostly};
use simkit_backend::{Backend, Error, Real};
use simkit_neighbor::{
    BlockedHalfList, BruteForce, CellGrid, Config, LinkedCells, ListKind, MAX_CELLS, NeighborLists,
    NeighborSearch, Neighbors, OutOfBox, SortedCells, TraversalKernel, VerletList,
};

/// The seed of every property in this file.
const SEED: u64 = 0x5eed_0f0e_19b0;

/// Grids with more cells are checked as grids but not searched (a traversal visits every
/// cell; the generated boxes have at most 15^3 cells unless a wild value makes them huge).
const MAX_SEARCH_CELLS: usize = 4096;

/// Indices and counts: small ones, and the values around the limits of `u32` and `usize`.
fn wild_usize() -> impl Strategy<Value = usize> {
    prop_oneof![
        4 => 0..40usize,
        1 => prop::sample::select(vec![
            u32::MAX as usize - 1,
            u32::MAX as usize,
            u32::MAX as usize + 1,
            1 << 26,
            1 << 40,
            usize::MAX - 1,
            usize::MAX,
        ]),
    ]
}

/// One coordinate of a particle, relative to its axis of the box.
#[derive(Clone, Debug)]
enum Coord {
    /// `origin + u * L`, `u` in `[0, 1)`.
    Inside(f64),
    /// Exactly the lower face.
    Lower,
    /// Exactly the upper face `origin + L`.
    Upper,
    /// One ulp below the upper face.
    BelowUpper,
    /// `origin + u * L` with `u` in `[-3, 4)`: outside the box; kept inside on closed axes
    /// of a tame case.
    Outside(f64),
    /// Any value, however wild.
    Raw(f64),
}

impl Coord {
    fn at(&self, origin: f64, l: f64, outside_ok: bool) -> f64 {
        match *self {
            Coord::Inside(u) => origin + u * l,
            Coord::Lower => origin,
            Coord::Upper => origin + l,
            Coord::BelowUpper => (origin + l).next_down(),
            Coord::Outside(u) if outside_ok => origin + u * l,
            Coord::Outside(u) => origin + u.rem_euclid(1.0) * l,
            Coord::Raw(v) => v,
        }
    }
}

fn tame_coord() -> impl Strategy<Value = Coord> {
    prop_oneof![
        10 => (0.0..1.0f64).prop_map(Coord::Inside),
        1 => Just(Coord::Lower),
        1 => Just(Coord::Upper),
        1 => Just(Coord::BelowUpper),
        2 => (-3.0..4.0f64).prop_map(Coord::Outside),
    ]
}

fn any_coord() -> impl Strategy<Value = Coord> {
    prop_oneof![3 => tame_coord(), 1 => awkward_f64().prop_map(Coord::Raw)]
}

/// Particles: a quarter of the cases may hold wild coordinates (and closed-axis excursions).
fn particles() -> impl Strategy<Value = (bool, Vec<[Coord; 3]>)> {
    prop_oneof![
        3 => prop::collection::vec(prop::array::uniform3(tame_coord()), 0..24)
            .prop_map(|p| (false, p)),
        1 => prop::collection::vec(prop::array::uniform3(any_coord()), 0..24)
            .prop_map(|p| (true, p)),
    ]
}

fn realize<const D: usize>(
    coords: &[[Coord; 3]],
    wild: bool,
    origin: [f64; D],
    lengths: [f64; D],
    periodic: [bool; D],
) -> Vec<[f64; D]> {
    coords
        .iter()
        .map(|c| std::array::from_fn(|d| c[d].at(origin[d], lengths[d], wild || periodic[d])))
        .collect()
}

/// The error message names one of `names`.
fn assert_names(e: &Error, names: &[&str]) {
    let s = e.to_string();
    assert!(
        names.iter().any(|n| s.contains(n)),
        "the error names none of {names:?}: {s}"
    );
}

/// Unordered pairs (smaller index first) with the separation seen from the smaller index.
type Pairs<const D: usize> = BTreeMap<(usize, usize), ([f64; D], f64)>;

/// Adds one reported pair after checking it: two different particles of `n`, a finite
/// separation whose squared length is the reported `r2`, within the cutoff, reported once.
fn add<const D: usize>(
    m: &mut Pairs<D>,
    n: usize,
    rc2: f64,
    (i, j, sep, r2): (usize, usize, [f64; D], f64),
) {
    assert!(i != j && i < n && j < n, "pair ({i}, {j}) of {n} particles");
    assert!(sep.iter().all(|v| v.is_finite()), "separation {sep:?}");
    let sum = sep.iter().fold(0.0, |acc, v| acc + v * v);
    assert_eq!(r2, sum, "r2 of separation {sep:?}");
    assert!(
        r2 <= rc2,
        "pair ({i}, {j}) at r2 = {r2} beyond the cutoff^2 {rc2}"
    );
    let (key, s) = if i < j {
        ((i, j), sep)
    } else {
        ((j, i), sep.map(|v| -v))
    };
    assert!(
        m.insert(key, (s, r2)).is_none(),
        "pair {key:?} reported twice"
    );
}

/// The checked pairs of a built search.
fn pairs<const D: usize, S: NeighborSearch<D>>(s: &mut S, rc2: f64) -> Pairs<D> {
    let n = s.particle_count();
    let mut m = Pairs::new();
    s.for_each_pair(|i, j, sep, r2| add(&mut m, n, rc2, (i, j, sep, r2)))
        .expect("enumerating the pairs of a built search");
    m
}

/// `CellGrid` from arbitrary values, its queries, and every CPU search on it.
#[allow(clippy::too_many_arguments)]
fn grid_case<const D: usize>(
    origin: [f64; 3],
    lengths: [f64; 3],
    periodic: [bool; 3],
    cutoff: f64,
    clamp: bool,
    (wild, coords): (bool, Vec<[Coord; 3]>),
    skin: f64,
    kind: ListKind,
    kernel: TraversalKernel,
    probes: &[usize],
    moves: &[f64],
) {
    let origin: [f64; D] = std::array::from_fn(|d| origin[d]);
    let lengths: [f64; D] = std::array::from_fn(|d| lengths[d]);
    let periodic: [bool; D] = std::array::from_fn(|d| periodic[d]);
    let grid = match CellGrid::new(origin, lengths, periodic, cutoff) {
        Ok(g) => g,
        Err(e) => {
            assert_names(&e, &["origin", "box length", "cutoff", "cell count"]);
            let fine = origin.iter().all(|o| o.is_finite())
                && lengths.iter().all(|l| l.is_finite() && *l > 0.0)
                && cutoff.is_finite()
                && cutoff > 0.0
                && (cutoff * cutoff).is_normal();
            // A valid box and cutoff may only be refused for its cell count.
            assert!(!fine || e.to_string().contains("cell count"), "{e}");
            return;
        }
    };
    let grid = if clamp {
        grid.with_out_of_box(OutOfBox::Clamp)
    } else {
        grid
    };
    let cells = grid.cells_per_axis();
    let rc2 = grid.cutoff() * grid.cutoff();
    assert!(rc2.is_normal());
    assert!(cells.iter().all(|&c| c >= 1));
    assert_eq!(grid.n_cells(), cells.iter().product::<usize>());
    assert!(grid.n_cells() <= MAX_CELLS);
    for (&c, &size) in cells.iter().zip(&grid.cell_size()) {
        assert!(size.is_finite() && size > 0.0);
        assert!(c == 1 || size >= cutoff, "cell {size} < cutoff {cutoff}");
    }

    // Index queries: Some exactly for indices inside the grid, and consistent.
    for &p in probes {
        match grid.coords(p) {
            Some(c) => {
                assert!(p < grid.n_cells());
                assert_eq!(grid.linear(c), Some(p));
            }
            None => assert!(p >= grid.n_cells()),
        }
        let c: [usize; D] = std::array::from_fn(|d| p / (d + 1));
        let inside = (0..D).all(|d| c[d] < cells[d]);
        assert_eq!(grid.linear(c).is_some(), inside, "{c:?} in {cells:?}");
    }
    for &v in moves {
        let t = [v; D];
        let cc = grid.cell_coords_of(t);
        assert!((0..D).all(|d| cc[d] < cells[d]));
        assert!(grid.cell_of(t) < grid.n_cells());
    }

    // Wrapping: finite coordinates in the box, or an error naming the particle.
    let positions = realize(&coords, wild, origin, lengths, periodic);
    let mut wrapped = Vec::new();
    for (i, &p) in positions.iter().enumerate() {
        match grid.wrap(i, p) {
            Ok(t) => {
                for d in 0..D {
                    let l = lengths[d];
                    let ok = if periodic[d] {
                        (0.0..l).contains(&t[d])
                    } else if clamp {
                        t[d].is_finite()
                    } else {
                        (0.0..=l).contains(&t[d])
                    };
                    assert!(ok, "wrapped {:?} of {p:?} in the box {lengths:?}", t);
                }
                wrapped.push(t);
            }
            Err(e) => assert_names(&e, &[&format!("position[{i}]")]),
        }
    }
    // Separations of wrapped positions: finite, the minimum image on periodic axes.
    for w in wrapped.windows(2) {
        let (sep, r2) = grid.separation(w[0], w[1]);
        for d in 0..D {
            let bound = if periodic[d] {
                0.5 * lengths[d]
            } else {
                lengths[d]
            };
            assert!(sep[d].is_finite() && sep[d].abs() <= bound || clamp && !periodic[d]);
        }
        assert!(!r2.is_nan());
    }
    let valid = wrapped.len() == positions.len();

    if grid.n_cells() > MAX_SEARCH_CELLS {
        return;
    }
    // Every method finds the brute-force pairs, or every method refuses the positions.
    let mut brute = BruteForce::new(&grid);
    let built = brute.build(&positions);
    assert_eq!(built.is_ok(), valid, "{built:?}");
    if let Err(e) = &built {
        assert_names(e, &["position["]);
    }
    let reference = if valid {
        pairs(&mut brute, rc2)
    } else {
        Pairs::new()
    };
    let n = positions.len();
    let check = |name: &str, s: &mut dyn FnMut() -> simkit_backend::Result<Pairs<D>>| match s() {
        Ok(m) => {
            assert!(valid, "{name} accepted positions brute force refused");
            assert_eq!(m, reference, "{name} differs from brute force");
        }
        Err(e) => {
            assert!(!valid, "{name} refused valid positions: {e}");
            assert_names(&e, &["position["]);
        }
    };
    check("linked cells", &mut || {
        let mut s = LinkedCells::new(&grid);
        s.build(&positions)?;
        assert_eq!(s.head().len(), grid.n_cells());
        Ok(pairs(&mut s, rc2))
    });
    for k in [
        TraversalKernel::Auto,
        TraversalKernel::Portable,
        TraversalKernel::PackedAvx2,
        TraversalKernel::PackedAvx512,
    ] {
        match SortedCells::new(&grid).with_kernel(k) {
            Ok(mut s) => check("sorted cells", &mut || {
                s.build(&positions)?;
                Ok(pairs(&mut s, rc2))
            }),
            Err(e) => {
                assert!(!k.is_supported());
                assert_names(&e, &["TraversalKernel::Auto"]);
            }
        }
    }
    match Neighbors::new(&grid, &Config { kernel }, Backend::Cpu) {
        Ok(mut s) => check("Neighbors", &mut || {
            s.build(&positions)?;
            assert_eq!(s.particle_count(), n);
            let m = pairs(&mut s, rc2);
            assert_eq!(s.pair_count()?, m.len());
            let counts = s.neighbor_counts()?;
            let lists = s.neighbor_lists()?;
            assert_eq!(lists.counts()?, counts);
            assert_eq!(lists.len(), n);
            for &(i, j) in m.keys() {
                let li = lists.of(i).expect("a particle's list");
                assert!(li.binary_search(&(j as u32)).is_ok());
            }
            assert_eq!(lists.of(n), None);
            Ok(m)
        }),
        Err(e) => {
            assert!(!kernel.is_supported());
            assert_names(&e, &["TraversalKernel::Auto"]);
        }
    }

    // Sorted cells: permutations, reordering with lengths that do not match, queries.
    let mut sorted = SortedCells::new(&grid);
    if sorted.build(&positions).is_ok() {
        let order = sorted.order();
        assert_eq!(sorted.len(), n);
        assert_eq!(sorted.cell_start().len(), grid.n_cells() + 1);
        assert_eq!(*sorted.cell_start().last().unwrap() as usize, n);
        let mut seen = vec![false; n];
        for (k, &i) in order.iter().enumerate() {
            assert!(!std::mem::replace(&mut seen[i as usize], true));
            assert_eq!(sorted.rank()[i as usize] as usize, k);
        }
        let data: Vec<usize> = (0..n).collect();
        assert_eq!(
            sorted.restore(&sorted.reorder(&data).unwrap()).unwrap(),
            data
        );
        for &p in probes {
            let len = p % (n + 3);
            let r = sorted.reorder(&vec![0u8; len]);
            assert_eq!(r.is_ok(), len == n);
            if let Err(e) = r {
                assert_names(&e, &["reorder: data length"]);
            }
            assert_eq!(sorted.restore(&vec![0u8; len]).is_ok(), len == n);
            let mut out = vec![0u32; len];
            let r = sorted.par_for_each_particle(&mut out, |c, _, _, _, _| *c += 1);
            assert_eq!(r.is_ok(), len == n);
            assert_eq!(sorted.sorted_coords(p).is_some(), p < D);
            let mut mine = Vec::new();
            match sorted.for_each_neighbor_of(p, |j, sep, r2| mine.push((j, sep, r2))) {
                Ok(()) => {
                    assert!(p < n);
                    let want: Vec<usize> = reference
                        .keys()
                        .filter_map(|&(a, b)| (a == p).then_some(b).or((b == p).then_some(a)))
                        .collect();
                    let mut got: Vec<usize> = mine.iter().map(|m| m.0).collect();
                    got.sort_unstable();
                    assert_eq!(got, want, "neighbours of {p}");
                }
                Err(e) => {
                    assert!(p >= n);
                    assert_names(&e, &["particle index"]);
                }
            }
        }
    }

    // Verlet lists: any skin, index queries, and after `update` exactly the brute-force
    // pairs of the new positions.
    let mut verlet = match VerletList::new(&grid, skin, kind) {
        Ok(v) => v,
        Err(e) => {
            assert_names(&e, &["skin"]);
            let fine = skin.is_finite() && skin >= 0.0 && (cutoff + skin).powi(2).is_normal();
            assert!(!fine || e.to_string().contains("cell count"), "{e}");
            return;
        }
    };
    let built = verlet.build(&positions);
    assert_eq!(built.is_ok(), valid, "{built:?}");
    if built.is_err() {
        return;
    }
    assert_eq!(pairs(&mut verlet, rc2), reference);
    for &p in probes {
        assert_eq!(verlet.list_of(p).is_some(), p < n);
        let mut out = vec![0u32; p % (n + 3)];
        let r = verlet.par_for_each_particle(&mut out, |c, _, _, _, _| *c += 1);
        assert_eq!(r.is_ok(), kind == ListKind::Full && out.len() == n, "{r:?}");
    }
    let moved: Vec<[f64; D]> = positions
        .iter()
        .enumerate()
        .map(|(i, p)| std::array::from_fn(|d| p[d] + moves.get(i * D + d).copied().unwrap_or(0.0)))
        .collect();
    for next in [&moved[..], &moved[..n.saturating_sub(1)], &positions[..]] {
        let mut brute = BruteForce::new(&grid);
        let ok = brute.build(next).is_ok();
        match verlet.update(next) {
            Ok(_) => {
                assert!(ok, "update accepted positions brute force refused");
                assert_eq!(pairs(&mut verlet, rc2), pairs(&mut brute, rc2));
            }
            Err(e) => {
                assert!(!ok, "update refused valid positions: {e}");
                assert_names(&e, &["position["]);
                return;
            }
        }
    }
}

/// Host-side GPU grid parameters (no device needed): finite `f32` values, or an error
/// naming the value that `f32` cannot hold.
#[cfg(feature = "gpu")]
fn gpu_params_case<const D: usize>(grid: &CellGrid<D>) {
    match simkit_neighbor::GpuGridParams::new(grid, 7) {
        Ok(p) => {
            for d in 0..D {
                assert!(p.origin[d].is_finite());
                assert!(p.length[d].is_normal() && p.inv_cell[d].is_normal());
            }
            assert!(p.cutoff2.is_normal());
            assert_eq!(p.n_cells as usize, grid.n_cells());
        }
        Err(e) => assert_names(&e, &["f32", "cells per axis"]),
    }
}

/// Box (origin, lengths, periodic axes, cutoff, clamping), particles, Verlet list and kernel
/// (skin, kind, kernel), probes (indices, small values and displacements).
type GridInput = (
    ([f64; 3], [f64; 3], [bool; 3], f64, bool),
    (bool, Vec<[Coord; 3]>),
    (f64, ListKind, TraversalKernel),
    (Vec<usize>, Vec<f64>),
);

fn grid_inputs() -> impl Strategy<Value = GridInput> {
    (
        (
            prop::array::uniform3(mostly(-5.0..5.0)),
            prop::array::uniform3(mostly(0.5..6.0)),
            prop::array::uniform3(any::<bool>()),
            mostly(0.4..4.0),
            any::<bool>(),
        ),
        particles(),
        (
            mostly(0.0..1.0),
            prop::sample::select(vec![ListKind::Half, ListKind::Full]),
            prop::sample::select(vec![
                TraversalKernel::Auto,
                TraversalKernel::Portable,
                TraversalKernel::PackedAvx2,
                TraversalKernel::PackedAvx512,
            ]),
        ),
        (
            prop::collection::vec(wild_usize(), 0..6),
            prop::collection::vec(mostly(-0.5..0.5), 0..72),
        ),
    )
}

proptest! {
    #![proptest_config(robust::config(SEED, 5000))]

    #[test]
    fn grids_and_searches_2d(((o, l, per, cutoff, clamp), p, (skin, kind, kernel), (probes, moves)) in grid_inputs()) {
        grid_case::<2>(o, l, per, cutoff, clamp, p, skin, kind, kernel, &probes, &moves);
        #[cfg(feature = "gpu")]
        if let Ok(g) = CellGrid::<2>::new([o[0], o[1]], [l[0], l[1]], [per[0], per[1]], cutoff) {
            gpu_params_case(&g);
        }
    }

    #[test]
    fn grids_and_searches_3d(((o, l, per, cutoff, clamp), p, (skin, kind, kernel), (probes, moves)) in grid_inputs()) {
        grid_case::<3>(o, l, per, cutoff, clamp, p, skin, kind, kernel, &probes, &moves);
        #[cfg(feature = "gpu")]
        if let Ok(g) = CellGrid::<3>::new(o, l, per, cutoff) {
            gpu_params_case(&g);
        }
    }
}

proptest! {
    #![proptest_config(robust::config(SEED, 5000))]

    /// `NeighborLists::from_pairs` with any count and pairs, and hand-built lists whose
    /// public fields are anything.
    #[test]
    fn neighbor_lists_from_anything(
        n in prop_oneof![
            6 => 0..12usize,
            1 => prop::sample::select(vec![u32::MAX as usize + 1, 1 << 40, usize::MAX - 1, usize::MAX]),
        ],
        pairs in prop::collection::vec(
            (prop_oneof![8 => 0..12u32, 1 => any::<u32>()], prop_oneof![8 => 0..12u32, 1 => any::<u32>()]),
            0..20,
        ),
        offsets in prop::collection::vec(prop_oneof![4 => 0..12usize, 1 => wild_usize()], 0..8),
        neighbors in prop::collection::vec(any::<u32>(), 0..12),
        probes in prop::collection::vec(wild_usize(), 0..6),
    ) {
        let valid = n <= u32::MAX as usize
            && pairs.iter().all(|&(i, j)| i != j && (i as usize) < n && (j as usize) < n);
        match NeighborLists::from_pairs(n, &pairs) {
            Ok(lists) => {
                prop_assert!(valid);
                prop_assert_eq!(lists.len(), n);
                let counts = lists.counts().unwrap();
                prop_assert_eq!(counts.iter().map(|&c| c as usize).sum::<usize>(), 2 * pairs.len());
                for (i, &c) in counts.iter().enumerate() {
                    let l = lists.of(i).unwrap();
                    prop_assert!(l.windows(2).all(|w| w[0] <= w[1]));
                    prop_assert_eq!(l.len(), c as usize);
                }
                for &(i, j) in &pairs {
                    prop_assert!(lists.of(i as usize).unwrap().contains(&j));
                    prop_assert!(lists.of(j as usize).unwrap().contains(&i));
                }
                for &p in &probes {
                    prop_assert_eq!(lists.of(p).is_some(), p < n);
                }
            }
            Err(e) => {
                prop_assert!(!valid, "valid pairs refused: {}", e);
                assert_names(&e, &["pairs[", "particle count"]);
            }
        }
        // Any public fields: `of` and `counts` answer or refuse, never panic.
        let lists = NeighborLists { offsets: offsets.clone(), neighbors };
        prop_assert_eq!(lists.len(), offsets.len().saturating_sub(1));
        for &p in &probes {
            if let Some(l) = lists.of(p) {
                prop_assert_eq!(l.len(), offsets[p + 1] - offsets[p]);
            }
        }
        let csr = offsets.windows(2).all(|w| w[0] <= w[1] && w[1] - w[0] <= u32::MAX as usize)
            && offsets.last().is_none_or(|&l| l <= lists.neighbors.len());
        match lists.counts() {
            Ok(c) => {
                prop_assert!(csr);
                for (i, &k) in c.iter().enumerate() {
                    prop_assert_eq!(lists.of(i).map(<[u32]>::len), Some(k as usize));
                }
            }
            Err(e) => {
                prop_assert!(!csr, "CSR lists refused: {}", e);
                assert_names(&e, &["offsets["]);
            }
        }
    }
}

/// `BlockedHalfList` from arbitrary box, range and count, sorted and built from arbitrary
/// positions: the exact brute-force pairs for finite positions inside the periodic box.
#[allow(clippy::too_many_arguments)]
fn blocked_case<T: Real + std::fmt::Debug, const D: usize>(
    lo: [f64; 3],
    len: [f64; 3],
    periodic: [bool; 3],
    range: f64,
    n: usize,
    (wild, coords): (bool, Vec<[Coord; 3]>),
    parallel: bool,
    probes: &[usize],
) {
    let lo: [f64; D] = std::array::from_fn(|d| lo[d]);
    let len: [f64; D] = std::array::from_fn(|d| len[d]);
    let periodic: [bool; D] = std::array::from_fn(|d| periodic[d]);
    let mut list = match BlockedHalfList::<T, D>::new(lo, len, periodic, range, n) {
        Ok(l) => l,
        Err(e) => {
            assert_names(&e, &["range", "box origin", "box length", "particle count"]);
            return;
        }
    };
    assert_eq!(list.particle_count(), n);
    let cells: usize = list.cells().iter().product();
    assert!(cells <= MAX_CELLS && cells <= n.saturating_mul(8).saturating_add(4096));
    assert_eq!(
        list.block_size(),
        BlockedHalfList::<T, D>::block_size_for(n, list.cells())
    );
    let mut next = 0;
    for b in list.blocks() {
        assert_eq!(b.start(), next);
        next = b.end();
    }
    assert_eq!(next, n);

    // Positions in the periodic box (wrapped) unless the case is wild; any count.
    let pos: Vec<[T; D]> = coords
        .iter()
        .map(|c| {
            std::array::from_fn(|d| {
                let x = c[d].at(lo[d], len[d], wild || !periodic[d]);
                let x = if !wild && periodic[d] && x >= lo[d] + len[d] {
                    lo[d]
                } else {
                    x
                };
                T::from_f64(x)
            })
        })
        .collect();
    let order = match list.sort(&pos) {
        Ok(o) => o,
        Err(e) => {
            assert_ne!(pos.len(), n);
            assert_names(&e, &["position count"]);
            assert!(list.build(&pos, parallel).is_err());
            return;
        }
    };
    assert_eq!(pos.len(), n);
    let mut seen = vec![false; n];
    for &i in &order {
        assert!(!std::mem::replace(&mut seen[i as usize], true));
    }
    let sorted: Vec<[T; D]> = order.iter().map(|&k| pos[k as usize]).collect();
    list.build(&sorted, parallel).unwrap();
    let mut got = BTreeMap::new();
    for b in list.blocks() {
        for k in 0..b.len() {
            let i = b.start() + k;
            for &j in b.partners_of(k).unwrap() {
                assert!((j as usize) > i && (j as usize) < n);
                assert!(got.insert((i, j as usize), [T::ZERO; D]).is_none());
            }
            for &(j, s) in b.image_partners_of(k).unwrap() {
                assert!((j as usize) > i && (j as usize) < n);
                assert!(got.insert((i, j as usize), s).is_none());
            }
        }
        for &p in probes {
            assert_eq!(b.partners_of(p).is_some(), p < b.len());
            assert_eq!(b.image_partners_of(p).is_some(), p < b.len());
        }
    }
    assert_eq!(got.len(), list.pair_count());
    let in_box = sorted.iter().all(|x| {
        (0..D).all(|d| {
            let v = x[d].to_f64();
            v.is_finite() && (!periodic[d] || (lo[d]..=lo[d] + len[d]).contains(&v))
        })
    });
    let range2 = range * range;
    let mut want = BTreeMap::new();
    for i in 0..n {
        for j in i + 1..n {
            let mut r2 = 0.0;
            let mut shift = [T::ZERO; D];
            for d in 0..D {
                let mut s = sorted[i][d].to_f64() - sorted[j][d].to_f64();
                if periodic[d] {
                    if s > 0.5 * len[d] {
                        s -= len[d];
                        shift[d] = T::from_f64(len[d]);
                    } else if s < -0.5 * len[d] {
                        s += len[d];
                        shift[d] = T::from_f64(-len[d]);
                    }
                }
                r2 += s * s;
            }
            if r2 < range2 {
                want.insert((i, j), shift);
            }
        }
    }
    if in_box {
        assert_eq!(got, want, "the list differs from brute force");
    } else {
        // Outside the wrapped box only the pairs found are guaranteed to be real.
        for (k, s) in &got {
            assert_eq!(want.get(k), Some(s), "pair {k:?} is not within range");
        }
    }
}

/// Box (origin, lengths, periodic axes, range), particle count, positions, parallel build,
/// index probes.
type BlockedInput = (
    ([f64; 3], [f64; 3], [bool; 3], f64),
    usize,
    (bool, Vec<[Coord; 3]>),
    bool,
    Vec<usize>,
);

fn blocked_inputs() -> impl Strategy<Value = BlockedInput> {
    (
        (
            prop::array::uniform3(mostly(-5.0..5.0)),
            prop::array::uniform3(mostly(3.0..6.0)),
            prop::array::uniform3(any::<bool>()),
            mostly(0.4..1.5),
        ),
        prop_oneof![
            8 => 0..24usize,
            1 => prop::sample::select(vec![
                u32::MAX as usize + 1,
                1 << 40,
                usize::MAX,
            ]),
        ],
        prop_oneof![
            3 => prop::collection::vec(prop::array::uniform3(tame_coord()), 24)
                .prop_map(|p| (false, p)),
            1 => prop::collection::vec(prop::array::uniform3(any_coord()), 24)
                .prop_map(|p| (true, p)),
        ],
        // Usually as many positions as particles; sometimes another count.
        prop_oneof![3 => Just(None), 1 => (0..24usize).prop_map(Some)],
        any::<bool>(),
        prop::collection::vec(wild_usize(), 0..4),
    )
        .prop_map(|(b, n, (wild, mut coords), count, parallel, probes)| {
            coords.truncate(count.unwrap_or(n));
            (b, n, (wild, coords), parallel, probes)
        })
}

proptest! {
    #![proptest_config(robust::config(SEED, 3000))]

    #[test]
    fn blocked_half_list_f64((b, n, p, parallel, probes) in blocked_inputs()) {
        let (lo, len, per, range) = b;
        blocked_case::<f64, 2>(lo, len, per, range, n, p.clone(), parallel, &probes);
        blocked_case::<f64, 3>(lo, len, per, range, n, p, parallel, &probes);
    }

    #[test]
    fn blocked_half_list_f32((b, n, p, parallel, probes) in blocked_inputs()) {
        let (lo, len, per, range) = b;
        blocked_case::<f32, 2>(lo, len, per, range, n, p.clone(), parallel, &probes);
        blocked_case::<f32, 3>(lo, len, per, range, n, p, parallel, &probes);
    }
}

/// A list for 2^32 - 1 particles in a large sparse box used to size its cell offsets by the
/// particle count alone (`8 n + 4096`, some 3.4e10 cells: a 137 GB allocation and an
/// abort); the cell count is now capped at `MAX_CELLS`.
#[test]
fn blocked_half_list_for_the_largest_count_allocates_a_bounded_grid() {
    let n = u32::MAX as usize;
    let list = BlockedHalfList::<f32, 3>::new([0.0; 3], [1e4; 3], [false; 3], 1.0, n).unwrap();
    let cells: usize = list.cells().iter().product();
    assert!(cells <= MAX_CELLS, "{cells} cells");
    assert_eq!(list.particle_count(), n);
    let e = BlockedHalfList::<f32, 3>::new([0.0; 3], [1e4; 3], [false; 3], 1.0, n + 1)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("particle count") && e.contains("4294967296"),
        "{e}"
    );
}

/// Values found by the properties above, kept as plain regressions.
#[test]
fn far_periodic_coordinates_wrap_exactly_and_huge_offsets_are_errors() {
    let grid = CellGrid::new([0.0; 2], [0.3, 1.0], [true, false], 0.1).unwrap();
    // 1e20 is 3.3e20 box lengths away: `L * floor(x / L)` is off by thousands of boxes,
    // the exact remainder is not.
    let t = grid.wrap(0, [1e20, 0.5]).unwrap();
    assert_eq!(t[0], 1e20f64.rem_euclid(0.3));
    assert!((0.0..0.3).contains(&t[0]));
    // -1e308 / 1e-150 overflows: the wrap used to give 0 without a word.
    let tiny = CellGrid::new([0.0; 2], [1e-150, 1e-153], [true, false], 2e-154).unwrap();
    let t = tiny.wrap(0, [-1e308, 0.0]).unwrap();
    assert_eq!(t[0], (-1e308f64).rem_euclid(1e-150));
    // x - origin overflows: an error naming the particle, periodic or clamped.
    let far = CellGrid::new([-1e308, 0.0], [1.0, 1.0], [true, false], 0.1)
        .unwrap()
        .with_out_of_box(OutOfBox::Clamp);
    let e = far.wrap(4, [1e308, 0.5]).unwrap_err().to_string();
    assert!(e.contains("position[4].x") && e.contains("too far"), "{e}");
    // A cutoff whose square is infinite (or zero) would take every pair (or none).
    for cutoff in [2e154, 1e-160] {
        let e = CellGrid::<2>::new([0.0; 2], [1e300; 2], [false; 2], cutoff).unwrap_err();
        assert!(e.to_string().contains("cutoff^2"), "{e}");
    }
}

#[test]
fn a_failed_sorted_build_leaves_the_last_one_intact() {
    // Before the fix a failed build resized the wrapped positions and cell indices and left
    // the rest: with fewer particles a query panicked out of bounds, with more it answered
    // with wrong neighbours.
    let grid = CellGrid::new([0.0; 2], [8.0; 2], [true; 2], 1.0).unwrap();
    let at = |k: usize| [(k as f64 * 0.37) % 8.0, (k as f64 * 0.61) % 8.0];
    let positions: Vec<[f64; 2]> = (0..40).map(at).collect();
    let mut sorted = SortedCells::new(&grid);
    sorted.build(&positions).unwrap();
    let pairs = |s: &SortedCells<2>| {
        let mut v = Vec::new();
        s.for_each_pair(|i, j, _, r2| v.push((i.min(j), i.max(j), r2.to_bits())));
        v.sort_unstable();
        v
    };
    let before = pairs(&sorted);
    assert!(!before.is_empty());
    for len in [20, 60] {
        let mut bad: Vec<[f64; 2]> = (0..len).map(at).collect();
        bad[len - 1][1] = f64::NAN;
        let err = sorted.build(&bad).unwrap_err();
        assert!(err.to_string().contains("must be finite"), "{err}");
        assert_eq!(sorted.len(), 40);
        assert_eq!(pairs(&sorted), before, "after a failed build of {len}");
        let mut near = Vec::new();
        sorted
            .for_each_neighbor_of(39, |j, _, _| near.push(j))
            .unwrap();
        assert!(near.iter().all(|&j| j < 40));
    }
}
