// Bare Coulomb weight 1/r^3; the self pair (r = 0) contributes nothing.
fn pair_weight(r2: REAL, p: REAL) -> REAL {
    let inv = rsqrt_real(r2);
    return select(0.0, inv * inv * inv, r2 > 0.0);
}

// Bare Coulomb potential 1/r from r^2; the self pair (r = 0) gives 0 (the energy check's).
fn pair_potential(r2: REAL) -> REAL {
    return select(0.0, rsqrt_real(r2), r2 > 0.0);
}
