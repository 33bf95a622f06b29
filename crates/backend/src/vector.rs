//! Points and vectors at the public API: `glam` vectors or plain arrays.
//!
//! The particle crates (`dem`, `md`, `pp-coulomb`) take a particle's position and velocity
//! as any [`IntoVec3`] value — `glam::DVec3`, `glam::Vec3`, `glam::DVec2`, `glam::Vec2`,
//! `[f64; 3]` or `[f64; 2]` (2D values get `z = 0`) — and hand
//! states back both as `[f64; 3]` arrays and, without copying, as `glam::DVec3` slices
//! through [`as_dvec3`]. Internal layouts stay free: a backend may store its particles in
//! any order, precision or structure of arrays.
//!
//! Neighbour searches take `&[[f64; D]]`; [`as_arrays`] views a `&[DVec3]` as one without
//! copying.
//!
//! ```
//! use glam::{DVec3, Vec2};
//! use simkit_backend::vector::{IntoVec3, as_arrays, as_dvec3};
//!
//! assert_eq!(DVec3::new(1.0, 2.0, 3.0).into_vec3(), [1.0, 2.0, 3.0]);
//! assert_eq!(Vec2::new(0.5, 0.25).into_vec3(), [0.5, 0.25, 0.0]);
//! let points = vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]];
//! let v: &[DVec3] = as_dvec3(&points);
//! assert_eq!(v[1].y, 5.0);
//! assert_eq!(as_arrays(v), &points[..]);
//! ```

use glam::{DVec2, DVec3, Vec2, Vec3};

/// A point or vector that converts to three `f64` components (2D values get `z = 0`).
///
/// Implemented for the `glam` vectors `DVec3`, `Vec3`, `DVec2`, `Vec2` and for the arrays
/// `[f64; 3]` and `[f64; 2]`. The conversion is exact (`f32` widens to `f64` exactly).
/// `f32` arrays are left out on purpose, so that an array of untyped float literals or
/// variables stays `f64` without annotations; convert them with `glam::Vec3::from`.
pub trait IntoVec3: Copy {
    /// The three components `[x, y, z]`.
    fn into_vec3(self) -> [f64; 3];
}

impl IntoVec3 for [f64; 3] {
    fn into_vec3(self) -> [f64; 3] {
        self
    }
}

impl IntoVec3 for [f64; 2] {
    fn into_vec3(self) -> [f64; 3] {
        [self[0], self[1], 0.0]
    }
}

impl IntoVec3 for DVec3 {
    fn into_vec3(self) -> [f64; 3] {
        self.to_array()
    }
}

impl IntoVec3 for Vec3 {
    fn into_vec3(self) -> [f64; 3] {
        self.as_dvec3().to_array()
    }
}

impl IntoVec3 for DVec2 {
    fn into_vec3(self) -> [f64; 3] {
        self.extend(0.0).to_array()
    }
}

impl IntoVec3 for Vec2 {
    fn into_vec3(self) -> [f64; 3] {
        self.as_dvec2().extend(0.0).to_array()
    }
}

/// Views `[f64; 3]` points as `glam::DVec3` values without copying.
pub fn as_dvec3(points: &[[f64; 3]]) -> &[DVec3] {
    bytemuck::cast_slice(points)
}

/// Views `glam::DVec3` values as `[f64; 3]` points without copying (for the neighbour
/// searches, which take `&[[f64; D]]`).
pub fn as_arrays(points: &[DVec3]) -> &[[f64; 3]] {
    bytemuck::cast_slice(points)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_form_gives_the_same_components() {
        let want = [0.5, -1.25, 3.0];
        assert_eq!(want.into_vec3(), want);
        assert_eq!(DVec3::from_array(want).into_vec3(), want);
        assert_eq!(Vec3::new(0.5, -1.25, 3.0).into_vec3(), want);
        let flat = [0.5, -1.25, 0.0];
        assert_eq!([0.5, -1.25].into_vec3(), flat);
        assert_eq!(DVec2::new(0.5, -1.25).into_vec3(), flat);
        assert_eq!(Vec2::new(0.5, -1.25).into_vec3(), flat);
    }

    #[test]
    fn views_round_trip_without_copying() {
        let p = vec![[1.0, 2.0, 3.0], [f64::NAN, -0.0, 1e300]];
        let v = as_dvec3(&p);
        assert_eq!(v.as_ptr() as usize, p.as_ptr() as usize);
        assert_eq!(v[0], DVec3::new(1.0, 2.0, 3.0));
        assert!(v[1].x.is_nan() && v[1].z == 1e300);
        assert_eq!(as_arrays(v).as_ptr(), p.as_ptr());
    }
}
