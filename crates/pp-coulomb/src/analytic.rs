//! Analytic results the simulations are validated against.

/// Time for a cold uniform sphere of radius R, total charge Q, to expand to `xi R` under its
/// own Coulomb repulsion (particles of charge q and mass m; `omega^2 = q Q / (m R^3)` with
/// k_e = 1): `t(xi) = [sqrt(xi (xi - 1)) + ln(sqrt(xi) + sqrt(xi - 1))] / (sqrt(2) omega)`.
///
/// Returns NaN for `xi < 1`.
pub fn explosion_time(xi: f64, omega: f64) -> f64 {
    if xi < 1.0 {
        return f64::NAN;
    }
    ((xi * (xi - 1.0)).sqrt() + (xi.sqrt() + (xi - 1.0).sqrt()).ln())
        / (std::f64::consts::SQRT_2 * omega)
}

/// `omega = sqrt(q Q / (m R^3))` of [`explosion_time`].
pub fn explosion_omega(q: f64, total_charge: f64, m: f64, radius: f64) -> f64 {
    (q * total_charge / (m * radius.powi(3))).sqrt()
}

/// Inverse of [`explosion_time`]: the expansion factor `xi` at time `t` (bisection).
///
/// Returns 1 for `t <= 0` and NaN for a non-finite `t` or `omega <= 0`.
pub fn explosion_xi(t: f64, omega: f64) -> f64 {
    if !(t.is_finite() && omega > 0.0 && omega.is_finite()) {
        return f64::NAN;
    }
    if t <= 0.0 {
        return 1.0;
    }
    let (mut lo, mut hi) = (1.0, 2.0);
    while explosion_time(hi, omega) < t {
        hi *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if explosion_time(mid, omega) < t {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Rutherford scattering angle in the centre-of-mass frame:
/// `theta = 2 atan(k / (mu v^2 b))` for `k = q1 q2` (repulsive), reduced mass `mu`,
/// relative speed at infinity `v` and impact parameter `b`.
pub fn rutherford_angle(k: f64, mu: f64, v_inf: f64, b: f64) -> f64 {
    2.0 * (k / (mu * v_inf * v_inf * b)).atan()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn explosion_time_inverse_and_limits() {
        assert_eq!(explosion_time(1.0, 2.0), 0.0);
        let t = explosion_time(4.0, 1.0);
        let want = (12f64.sqrt() + (2.0 + 3f64.sqrt()).ln()) / 2f64.sqrt();
        assert!((t - want).abs() < 1e-14);
        assert!((explosion_xi(t, 1.0) - 4.0).abs() < 1e-12);
        assert_eq!(explosion_xi(0.0, 1.0), 1.0);
        assert!(explosion_xi(1.0, -1.0).is_nan() && explosion_xi(f64::INFINITY, 1.0).is_nan());
        assert!((rutherford_angle(1.0, 0.5, 1.0, 2.0) - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
    }
}
