//! Verlet lists: no pair within the cutoff is missed while every particle stays within
//! skin / 2 of its build position, and `needs_rebuild` fires when one moves farther.

use crate::common;

use rand::{RngExt, SeedableRng};
use simkit_neighbor::{BruteForce, CellGrid, ListKind, NeighborSearch, VerletList};

use common::pairs_of;

fn random_positions(rng: &mut rand_pcg::Pcg64, n: usize, l: f64) -> Vec<[f64; 3]> {
    (0..n)
        .map(|_| std::array::from_fn(|_| rng.random::<f64>() * l))
        .collect()
}

#[test]
fn small_moves_miss_no_pair_and_large_moves_trigger_rebuild() {
    let mut rng = rand_pcg::Pcg64::seed_from_u64(11);
    let (l, rc, skin) = (12.0, 1.5, 0.4);
    let grid = CellGrid::new([0.0; 3], [l, l, l], [true, true, false], rc).unwrap();
    for kind in [ListKind::Half, ListKind::Full] {
        let p0 = random_positions(&mut rng, 2000, l);
        let mut p = p0.clone();
        let mut v = VerletList::new(&grid, skin, kind).unwrap();
        v.build(&p).unwrap();
        for _step in 0..5 {
            // Random displacements from the build positions, of length up to just under
            // skin / 2 (z kept inside the box).
            let moved: Vec<[f64; 3]> = p0
                .iter()
                .map(|q| {
                    let dir: [f64; 3] = std::array::from_fn(|_| rng.random::<f64>() - 0.5);
                    let norm = dir.iter().map(|x| x * x).sum::<f64>().sqrt().max(1e-9);
                    let len = 0.4999 * skin * rng.random::<f64>().sqrt();
                    let mut r: [f64; 3] = std::array::from_fn(|d| q[d] + dir[d] / norm * len);
                    r[2] = r[2].clamp(0.0, l);
                    r
                })
                .collect();
            assert!(!v.needs_rebuild(&moved).unwrap());
            assert!(
                !v.update(&moved).unwrap(),
                "rebuilt although no one moved skin/2"
            );
            let reference = pairs_of(&mut BruteForce::new(&grid), &moved);
            let mut got = common::PairMap::new();
            v.for_each_pair(|i, j, sep, r2| {
                let (key, s) = if i < j {
                    ((i, j), sep)
                } else {
                    ((j, i), sep.map(|x| -x))
                };
                assert!(got.insert(key, (s, r2)).is_none());
            });
            assert_eq!(
                got, reference,
                "{kind:?}: the stale list missed or invented a pair"
            );
            p = moved;
        }
        let before = v.builds();
        // One particle moves a little more than skin / 2 from its build position.
        let mut far = p.clone();
        let built_at = v.grid().wrap(0, far[0]).unwrap();
        far[0] = [
            built_at[0] + 0.51 * skin + 0.5 * skin,
            built_at[1],
            built_at[2],
        ];
        assert!(v.needs_rebuild(&far).unwrap());
        assert!(v.update(&far).unwrap());
        assert_eq!(v.builds(), before + 1);
        let reference = pairs_of(&mut BruteForce::new(&grid), &far);
        assert_eq!(v.pair_count().unwrap(), reference.len());
    }
}

#[test]
fn needs_rebuild_threshold_is_half_the_skin() {
    let grid = CellGrid::new([0.0; 3], [10.0; 3], [true; 3], 1.0).unwrap();
    let mut v = VerletList::new(&grid, 0.2, ListKind::Half).unwrap();
    let p = vec![[5.0, 5.0, 5.0], [5.5, 5.0, 5.0]];
    v.build(&p).unwrap();
    assert!(
        !v.needs_rebuild(&[[5.099, 5.0, 5.0], [5.5, 5.0, 5.0]])
            .unwrap()
    );
    assert!(
        v.needs_rebuild(&[[5.101, 5.0, 5.0], [5.5, 5.0, 5.0]])
            .unwrap()
    );
    // Across the periodic face the displacement is measured with the minimum image.
    let q = vec![[9.95, 5.0, 5.0], [5.5, 5.0, 5.0]];
    v.build(&q).unwrap();
    assert!(
        !v.needs_rebuild(&[[10.04, 5.0, 5.0], [5.5, 5.0, 5.0]])
            .unwrap()
    );
    assert!(
        v.needs_rebuild(&[[5.5, 5.0, 5.0]]).unwrap(),
        "particle count changed"
    );
    assert!(VerletList::new(&grid, -0.1, ListKind::Half).is_err());
    assert!(VerletList::new(&grid, f64::NAN, ListKind::Half).is_err());
}

#[test]
fn half_list_par_gather_is_refused() {
    let grid = CellGrid::new([0.0; 2], [10.0; 2], [true; 2], 1.0).unwrap();
    let mut v = VerletList::new(&grid, 0.2, ListKind::Half).unwrap();
    v.build(&[[1.0, 1.0]]).unwrap();
    let mut out = vec![0u32; 1];
    assert!(
        v.par_for_each_particle(&mut out, |_, _, _, _, _| {})
            .is_err()
    );
}
