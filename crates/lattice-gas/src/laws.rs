//! Each rule of the model stated once, for users who check or reuse it: the lattice vectors
//! and the density and momentum of a site, the FHP collision as boolean logic on six
//! direction bits ([`collide_bits`], with its WGSL twin [`COLLIDE_WGSL`]) and the rotation,
//! reflection and invariants behind the lookup tables, and the counter-based random bits
//! (chirality and body force, with [`RANDOM_WGSL`]) that every backend draws alike. The
//! tests compare each Rust function with its WGSL twin.

pub use crate::field::{CX, CY, site_density, site_momentum};
pub use crate::random::{
    FORCE_STREAM, RANDOM_WGSL, chirality, chirality_word, force_draw, force_hit, force_threshold,
    step_key,
};
pub use crate::rules::{
    COLLIDE_WGSL, collide_bits, collision_group, invariants, reverse, rotate_ccw, rotate_cw,
};
