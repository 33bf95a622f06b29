//! The public API takes `glam` vectors as well as arrays and gives states back as both.

use glam::{DVec3, Vec3};
use simkit_pp_coulomb::{Particles, Species};

#[test]
fn glam_vectors_and_arrays_give_the_same_particles() {
    let mut arrays = Particles::new();
    let e = arrays.add_species(Species::new("e", -1.0, 1.0)).unwrap();
    arrays.push(e, [0.5, -1.0, 2.0], [0.0, 0.25, 0.0]).unwrap();
    let mut vectors = Particles::new();
    let e = vectors.add_species(Species::new("e", -1.0, 1.0)).unwrap();
    vectors
        .push(e, DVec3::new(0.5, -1.0, 2.0), Vec3::new(0.0, 0.25, 0.0))
        .unwrap();
    assert_eq!(arrays, vectors);
    assert_eq!(vectors.positions_dvec3()[0], DVec3::new(0.5, -1.0, 2.0));
    assert_eq!(vectors.velocities_dvec3()[0].y, 0.25);
    // Non-finite values are refused whatever form they come in.
    assert!(
        vectors
            .push(e, DVec3::new(f64::NAN, 0.0, 0.0), DVec3::ZERO)
            .is_err()
    );
}
