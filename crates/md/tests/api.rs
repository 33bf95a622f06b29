//! The public API takes `glam` vectors as well as arrays and gives states back as both.

use glam::{DVec3, Vec3};
use simkit_backend::{Backend, Simulation};
use simkit_md::{Config, Dim, LennardJones, Md, PairTable, System};

fn table() -> PairTable {
    PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5)).unwrap()
}

#[test]
fn glam_vectors_and_arrays_build_the_same_system() {
    let mut arrays = System::new(
        Dim::Three,
        [0.0; 3],
        [6.0; 3],
        [true; 3],
        vec![1.0],
        table(),
    )
    .unwrap();
    arrays
        .add_particle(0, [2.0, 3.0, 3.0], [0.0, 0.5, 0.0])
        .unwrap();
    arrays.add_particle(0, [3.5, 3.0, 3.0], [0.0; 3]).unwrap();

    let mut vectors = System::new(
        Dim::Three,
        DVec3::ZERO,
        DVec3::splat(6.0),
        [true; 3],
        vec![1.0],
        table(),
    )
    .unwrap();
    vectors
        .add_particle(0, DVec3::new(2.0, 3.0, 3.0), Vec3::new(0.0, 0.5, 0.0))
        .unwrap();
    vectors
        .add_particle(0, Vec3::new(3.5, 3.0, 3.0), DVec3::ZERO)
        .unwrap();
    assert_eq!(arrays, vectors);

    let mut md = Md::new(vectors, &Config::default(), Backend::Cpu).unwrap();
    md.step(20).unwrap();
    let s = md.state().unwrap();
    let p = s.positions_dvec3();
    assert_eq!(p.len(), 2);
    for (a, b) in p.iter().zip(&s.positions) {
        assert_eq!(a.to_array(), *b);
    }
    // The pair attracts: the gap has closed, seen through the glam view.
    assert!(p[1].distance(p[0]) < 1.5);
    assert_eq!(s.velocities_dvec3()[0].y, s.velocities[0][1]);
}
