//! Rotation: moments of inertia, the contact point's relative velocity, and the
//! Cundall–Strack spring that tangential and rolling history laws share.

use simkit_backend::Real;

use crate::{Contact, ContactForce, Dim};

/// Moment of inertia of a solid disc (2D, about its axis: `m R^2 / 2`) or a solid sphere
/// (3D: `2 m R^2 / 5`) of mass `m` and radius `r`.
pub fn moment_of_inertia(dim: Dim, m: f64, r: f64) -> f64 {
    match dim {
        Dim::Two => 0.5 * m * r * r,
        Dim::Three => 0.4 * m * r * r,
    }
}

/// The opening half kick of a velocity Verlet step for the rotation: `w += alpha dt / 2`,
/// then the angular velocity predicted at the force time, `w_p = w + alpha dt / 2` (the
/// translation's scheme), component by component; `h = dt / 2`.
#[inline(always)]
pub(crate) fn open_spin<T: Real>(w: &mut [T], w_p: &mut [T], alpha: &[T], h: T) {
    for ((w, wp), &a) in w.iter_mut().zip(w_p.iter_mut()).zip(alpha) {
        *w += a * h;
        *wp = *w + a * h;
    }
}

/// A `D`-vector as a 3-vector (`z = 0` in 2D).
#[inline(always)]
pub(crate) fn to3<T: Real, const D: usize>(v: &[T; D]) -> [T; 3] {
    std::array::from_fn(|d| if d < D { v[d] } else { T::ZERO })
}

/// `a x b`.
#[inline(always)]
pub(crate) fn cross<T: Real>(a: &[T; 3], b: &[T; 3]) -> [T; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `a . b` over the first three components of two slices.
#[inline(always)]
fn dot<T: Real>(a: &[T], b: &[T]) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The relative velocity of the surfaces at the contact point of particles `i` and `j`
/// (radii `r_i`, `r_j`, angular velocities `w_i`, `w_j`, unit normal `n` from `j` to `i`):
/// `v_i - v_j - (r_i w_i + r_j w_j) x n`, with `v_rel = v_i - v_j`. Against a wall pass
/// `r_j = 0` (the wall does not spin). The lever arm is the full radius, as in
/// Cundall & Strack (1979).
///
/// WGSL twin: `dem_contact_point_velocity(v_rel, n, r_i, w_i, r_j, w_j)` in
/// `shaders/spin.wgsl` (3-vectors).
#[inline(always)]
pub fn contact_point_velocity<T: Real, const D: usize>(
    v_rel: &[T; D],
    n: &[T; D],
    r_i: T,
    w_i: &[T; 3],
    r_j: T,
    w_j: &[T; 3],
) -> [T; D] {
    let w: [T; 3] = std::array::from_fn(|d| r_i * w_i[d] + r_j * w_j[d]);
    let s = cross(&w, &to3(n));
    std::array::from_fn(|d| v_rel[d] - s[d])
}

/// One step of a Cundall–Strack spring in the contact plane, returning its force:
/// the stored displacement `xi` (3 values) is first turned into the plane normal to the
/// unit `n` (its projection, rescaled to the old length), then advanced by `v dt` with the
/// in-plane relative velocity `v`; the force `F = -k xi - gamma v` is capped at `cap`
/// (Coulomb: `mu |F_n|`), and while it slides the spring is reset to the length the capped
/// force implies, `xi = -(F + gamma v) / k`.
///
/// Shared by the tangential spring (`v` the tangential velocity of the contact point) and
/// the rolling spring (`v` the rolling velocity `R* (w_i - w_j) x n`) of
/// [`crate::HertzMindlin`].
///
/// WGSL twin: `dem_coulomb_spring(xi, n, v, dt, k, gamma, cap)` in `shaders/spin.wgsl`
/// (`xi` a pointer to a 3-vector), checked through the laws that call it.
#[inline(always)]
pub fn coulomb_spring<T: Real>(
    xi: &mut [T],
    n: &[T; 3],
    v: &[T; 3],
    dt: T,
    k: T,
    gamma: T,
    cap: T,
) -> [T; 3] {
    let old2 = dot(xi, xi);
    if old2 > T::ZERO {
        let along = dot(xi, n);
        for d in 0..3 {
            xi[d] = xi[d] - along * n[d];
        }
        let new2 = dot(xi, xi);
        if new2 > T::ZERO {
            let s = (old2 / new2).sqrt();
            for x in xi.iter_mut().take(3) {
                *x = *x * s;
            }
        }
    }
    for d in 0..3 {
        xi[d] += v[d] * dt;
    }
    let mut f: [T; 3] = std::array::from_fn(|d| -(k * xi[d]) - gamma * v[d]);
    let f2 = dot(&f, &f);
    if f2 > cap * cap {
        let s = cap / f2.sqrt();
        f = f.map(|x| x * s);
        if k > T::ZERO {
            for d in 0..3 {
                xi[d] = -(f[d] + gamma * v[d]) / k;
            }
        }
    }
    f
}

/// The tangential and rolling springs of a contact law with history: stiffness `k` and
/// damping `gamma` of the tangential spring, `k_r` and `gamma_r` of the rolling one,
/// Coulomb coefficients `mu` (tangential) and `mu_r` (rolling; 0 = no rolling
/// resistance). The history holds 6 values: the tangential displacement, then the
/// rolling displacement.
pub(crate) struct Springs<T> {
    pub k: T,
    pub gamma: T,
    pub mu: T,
    pub k_r: T,
    pub gamma_r: T,
    pub mu_r: T,
}

impl<T: Real> Springs<T> {
    /// Values per contact: the tangential and the rolling displacement.
    pub const HISTORY: usize = 6;

    /// The history of contact `(j, i)` from that of `(i, j)`: the tangential displacement
    /// changes sign; the rolling displacement `R* (w_i - w_j) x n` does not (both factors
    /// change sign).
    pub fn swap(history: &mut [T]) {
        for x in &mut history[..3] {
            *x = -*x;
        }
    }

    /// Adds to `out` the tangential force of contact `k` (normal force `f_n`) and, with
    /// `mu_r > 0`, the rolling couple `R* n x F_r`, advancing both springs
    /// ([`coulomb_spring`]).
    #[inline(always)]
    pub fn add<const D: usize>(
        &self,
        k: &Contact<T, D>,
        f_n: T,
        history: &mut [T],
        out: &mut ContactForce<T, D>,
    ) {
        let n3 = to3(&k.n);
        let v3 = to3(&k.v_rel);
        let v_t: [T; 3] = std::array::from_fn(|d| v3[d] - k.v_n * n3[d]);
        let f_abs = if f_n > T::ZERO { f_n } else { -f_n };
        let (tangential, rolling) = history.split_at_mut(3);
        let cap = self.mu * f_abs;
        let f_t = coulomb_spring(tangential, &n3, &v_t, k.dt, self.k, self.gamma, cap);
        for (f, x) in out.force.iter_mut().zip(f_t) {
            *f += x;
        }
        if self.mu_r > T::ZERO {
            let v_r = cross(&k.w_rel, &n3).map(|x| k.r_eff * x);
            let cap = self.mu_r * f_abs;
            let f_r = coulomb_spring(rolling, &n3, &v_r, k.dt, self.k_r, self.gamma_r, cap);
            out.torque = cross(&n3, &f_r).map(|x| k.r_eff * x);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stuck_spring_is_elastic_and_a_sliding_one_is_capped() {
        let n = [0.0, 0.0, 1.0];
        let mut xi = [0.0f64; 3];
        // Stuck: F = -k v dt.
        let f = coulomb_spring(&mut xi, &n, &[1.0, 0.0, 0.0], 0.1, 10.0, 0.0, 5.0);
        assert_eq!(f, [-1.0, 0.0, 0.0]);
        assert_eq!(xi, [0.1, 0.0, 0.0]);
        // Sliding: capped at 5, the spring holds exactly the capped force.
        let f = coulomb_spring(&mut xi, &n, &[10.0, 0.0, 0.0], 0.1, 10.0, 0.0, 5.0);
        assert!((f[0] + 5.0).abs() < 1e-12, "{f:?}");
        assert!((xi[0] - 0.5).abs() < 1e-12, "{xi:?}");
    }

    #[test]
    fn the_spring_turns_with_the_contact_plane_keeping_its_length() {
        // A spring along x; the normal tilts from z towards x: the spring keeps its
        // length in the new plane.
        let mut xi = [0.3, 0.0, 0.0];
        let (s, c) = (0.1f64.sin(), 0.1f64.cos());
        let n = [s, 0.0, c];
        coulomb_spring(&mut xi, &n, &[0.0; 3], 0.1, 1.0, 0.0, 1e9);
        let len = (xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2]).sqrt();
        assert!((len - 0.3).abs() < 1e-14, "{len}");
        assert!((xi[0] * n[0] + xi[2] * n[2]).abs() < 1e-14, "{xi:?}");
    }

    #[test]
    fn the_contact_point_of_a_rolling_sphere_is_at_rest() {
        // A sphere of radius 2 on a floor (normal +z), rolling along +x at 1: w_y = 0.5.
        let v = contact_point_velocity(
            &[1.0, 0.0, 0.0],
            &[0.0, 0.0, 1.0],
            2.0,
            &[0.0, 0.5, 0.0],
            0.0,
            &[0.0; 3],
        );
        assert_eq!(v, [0.0, 0.0, 0.0]);
        // A disc rolling along +x on a floor (normal +y): w_z = -v / R.
        let v = contact_point_velocity(
            &[1.0, 0.0],
            &[0.0, 1.0],
            2.0,
            &[0.0, 0.0, -0.5],
            0.0,
            &[0.0; 3],
        );
        assert_eq!(v, [0.0, 0.0]);
    }
}
