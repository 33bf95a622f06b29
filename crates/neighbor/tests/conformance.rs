//! Conformance: the [`Neighbors`] facade finds the brute-force pairs on every backend
//! (`simkit_backend::testing::backends`: the CPU, then the GPU when compiled and present).
//! The property tests in `equality.rs` check every method against brute force on random and
//! edge-case boxes.

use simkit_backend::testing::backends;
use simkit_neighbor::{BruteForce, CellGrid, Config, NeighborSearch, Neighbors, TraversalKernel};

#[test]
fn neighbors_on_every_backend_find_the_brute_force_pairs() {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_pcg::Pcg64::seed_from_u64(11);
    let grid = CellGrid::new([0.0; 3], [8.0; 3], [true, false, true], 1.3).unwrap();
    let p: Vec<[f64; 3]> = (0..600)
        .map(|_| std::array::from_fn(|_| rng.random::<f64>() * 8.0))
        .collect();
    let mut reference = BruteForce::new(&grid);
    reference.build(&p).unwrap();
    let want = reference.neighbor_lists().unwrap();
    assert!(want.neighbors.len() > 600, "a dense enough sample");
    // No pair of this sample lies within 1e-5 (relative) of the cutoff, far beyond f32
    // rounding, so the GPU's f32 decision must agree exactly with the f64 reference.
    let w = grid.wrap_all(&p).unwrap();
    let rc2 = grid.cutoff() * grid.cutoff();
    for i in 0..w.len() {
        for j in 0..i {
            let (_, r2) = grid.separation(w[i], w[j]);
            assert!(
                (r2 - rc2).abs() > 1e-5 * rc2,
                "pair ({i}, {j}) is borderline"
            );
        }
    }
    for backend in backends("neighbors_on_every_backend_find_the_brute_force_pairs") {
        let mut search = Neighbors::new(&grid, &Config::default(), backend).unwrap();
        search.build(&p).unwrap();
        assert_eq!(search.particle_count(), p.len());
        assert_eq!(search.neighbor_lists().unwrap(), want, "{}", search.name());
    }
    // A kernel this CPU lacks is refused through the facade as through SortedCells.
    for kernel in [TraversalKernel::PackedAvx2, TraversalKernel::PackedAvx512] {
        let made = Neighbors::new(&grid, &Config { kernel }, simkit_backend::Backend::Cpu);
        assert_eq!(made.is_ok(), kernel.is_supported());
    }
}
