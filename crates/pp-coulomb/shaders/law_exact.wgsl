// Bare Coulomb weight 1/r^3; the self pair (r = 0) contributes nothing.
fn pair_weight(r2: REAL, p: REAL) -> REAL {
    let inv = rsqrt_real(r2);
    return select(0.0, inv * inv * inv, r2 > 0.0);
}
