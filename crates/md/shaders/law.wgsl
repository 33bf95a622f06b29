// The pair law, twin of simkit_md::pair_force_energy: c = (c12, c6, rc2, shift) with
// c12 = 4 eps a sigma^12, c6 = 4 eps b sigma^6; returns (f / r, phi) for squared distance
// r2, phi = c12 / r^12 - c6 / r^6 - shift, f / r = (12 c12 / r^12 - 6 c6 / r^6) / r^2;
// (0, 0) at r2 >= rc2.
fn md_pair_force_energy(c: vec4<f32>, r2: f32) -> vec2<f32> {
    if (r2 < c.z) {
        let ir2 = 1.0 / r2;
        let ir6 = ir2 * ir2 * ir2;
        let rep = c.x * ir6 * ir6;
        let att = c.y * ir6;
        return vec2<f32>((12.0 * rep - 6.0 * att) * ir2, rep - att - c.w);
    }
    return vec2<f32>(0.0, 0.0);
}
