//! Wall geometry, written once for every path (CPU force loop, wall candidate lists,
//! diagnostics): the overlap and normal of a particle with a plane or a cylinder wall, the
//! surface velocity of a turning cylinder (a rotating drum), and the motion of a vibrating
//! wall. WGSL twins in `shaders/walls.wgsl`.

use simkit_backend::Real;

/// Overlap `delta = r - (n . x - offset - lift)` of a particle (centre `x`, radius `r`)
/// with the plane `n . y = offset + lift` (`n` the unit normal pointing into the particle
/// region, `lift` the displacement of a moving wall along `n`): positive when they touch,
/// minus the gap otherwise. The contact normal is `n`.
///
/// WGSL twin: `dem_plane_overlap(n, offset, lift, x, r)` in `shaders/walls.wgsl`.
#[inline(always)]
pub fn plane_overlap<T: Real, const D: usize>(
    normal: &[T; D],
    offset: T,
    lift: T,
    x: &[T; D],
    r: T,
) -> T {
    let mut h = -offset;
    for d in 0..D {
        h += normal[d] * x[d];
    }
    r - (h - lift)
}

/// Overlap `delta = rho + r - R` of a particle (radius `r`, centre at `x` in the plane
/// normal to the axis) with the inside of a cylinder wall (axis through `center`, radius
/// `R`), where `rho = |x - center|`, and the unit contact normal `-(x - center) / rho`
/// pointing from the wall to the axis. A particle centred on the axis (`rho = 0`) has no
/// normal and is reported as not touching: `(0, [0, 0])`.
///
/// WGSL twin: `dem_cylinder_overlap(center, radius, x, r)` in `shaders/walls.wgsl`,
/// returning `(normal, delta)`.
#[inline(always)]
pub fn cylinder_overlap<T: Real>(center: [T; 2], radius: T, x: [T; 2], r: T) -> (T, [T; 2]) {
    let dx = x[0] - center[0];
    let dy = x[1] - center[1];
    let rho = (dx * dx + dy * dy).sqrt();
    if rho <= T::ZERO {
        return (T::ZERO, [T::ZERO; 2]);
    }
    (rho + r - radius, [-(dx / rho), -(dy / rho)])
}

/// Velocity `(v_x, v_y)` of the surface of a cylinder wall of radius `R` turning at `spin`
/// (radians per time unit, counter-clockwise seen from +z) where it touches a particle
/// whose contact normal is `n` ([`cylinder_overlap`]): the contact point is `center - R n`,
/// so the wall moves there at `spin z x (-R n) = spin R (n_y, -n_x)`.
///
/// WGSL twin: `dem_cylinder_surface_velocity(spin, radius, n)` in `shaders/walls.wgsl`.
#[inline(always)]
pub fn cylinder_surface_velocity<T: Real>(spin: T, radius: T, n: [T; 2]) -> [T; 2] {
    let s = spin * radius;
    [s * n[1], -(s * n[0])]
}

/// Vertical displacement and velocity of a vibrating wall at phase `omega t`:
/// `z_w = -A cos(omega t)`, `v_w = A omega sin(omega t)`.
///
/// WGSL twin: `dem_wall_motion(amplitude, omega, phase)` in `shaders/walls.wgsl`,
/// returning `(z_w, v_w)`.
#[inline]
pub fn wall_motion(amplitude: f64, omega: f64, phase: f64) -> (f64, f64) {
    (-amplitude * phase.cos(), amplitude * omega * phase.sin())
}
