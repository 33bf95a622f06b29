//! An independent cross-check: the pairs of sorted cells equal the pairs found by the `kiddo`
//! k-d tree (a separate implementation: a tree, not cells) within the same radius.

use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rand::{RngExt, SeedableRng};
use simkit_neighbor::{CellGrid, SortedCells};

/// N = 20,000 uniform points at number density 1 in a closed cube (kiddo has no periodic
/// images), cutoff 2.5, `f64`: kiddo's within-radius query from every point (`<= r^2`, the
/// same boundary rule as the cells), reduced to `i < j`, is exactly the sorted-cell pair set.
#[test]
fn sorted_cells_find_exactly_the_pairs_of_a_kd_tree() {
    const N: usize = 20_000;
    const CUTOFF: f64 = 2.5;
    let side = (N as f64).cbrt();
    let mut rng = rand_pcg::Pcg64::seed_from_u64(2026);
    let p: Vec<[f64; 3]> = (0..N)
        .map(|_| std::array::from_fn(|_| rng.random::<f64>() * side))
        .collect();

    let grid = CellGrid::new([0.0; 3], [side; 3], [false; 3], CUTOFF).unwrap();
    let mut cells = SortedCells::new(&grid);
    cells.build(&p).unwrap();
    let mut ours = Vec::new();
    cells.for_each_pair(|i, j, _, _| ours.push((i.min(j) as u32, i.max(j) as u32)));
    ours.sort_unstable();

    let tree: ImmutableKdTree<f64, 3> = ImmutableKdTree::new_from_slice(&p).unwrap();
    let mut theirs = Vec::new();
    for (i, q) in p.iter().enumerate() {
        tree.query(q)
            .within::<SquaredEuclidean<f64>>(CUTOFF * CUTOFF)
            .unsorted()
            .visit(|hit| {
                let j = hit.item as usize;
                if i < j {
                    theirs.push((i as u32, j as u32));
                }
            });
    }
    theirs.sort_unstable();

    println!(
        "kiddo cross-check: N = {N}, cutoff {CUTOFF}, closed cube of side {side:.3}: \
         {} pairs from sorted cells, {} from kiddo",
        ours.len(),
        theirs.len()
    );
    assert!(ours.windows(2).all(|w| w[0] != w[1]), "a pair twice");
    // About N/2 * (4/3) pi rc^3 = 654,000 pairs without walls; the walls remove some.
    assert!(ours.len() > 400_000, "{}", ours.len());
    if ours != theirs {
        let only_ours = ours.iter().filter(|k| theirs.binary_search(k).is_err());
        let only_theirs = theirs.iter().filter(|k| ours.binary_search(k).is_err());
        panic!(
            "pair sets differ: {} pairs only from sorted cells (first {:?}), {} only from \
             kiddo (first {:?})",
            only_ours.clone().count(),
            only_ours.take(3).collect::<Vec<_>>(),
            only_theirs.clone().count(),
            only_theirs.take(3).collect::<Vec<_>>()
        );
    }
}
