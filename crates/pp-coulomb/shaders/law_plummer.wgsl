// Plummer-softened weight (r^2 + eps^2)^(-3/2) (p = eps^2).
fn pair_weight(r2: REAL, p: REAL) -> REAL {
    let inv = rsqrt_real(r2 + p);
    return inv * inv * inv;
}
