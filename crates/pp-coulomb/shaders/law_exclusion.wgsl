// Bare Coulomb weight 1/r^3 outside the exclusion radius (p = radius^2), 0 inside.
fn pair_weight(r2: REAL, p: REAL) -> REAL {
    let inv = rsqrt_real(r2);
    return select(0.0, inv * inv * inv, r2 > p);
}
