// The Lennard-Jones family, twin of <simkit_md::LennardJones as PairLaw>::force_energy:
// phi = c12 / r^12 - c6 / r^6 - shift with c12 = 4 eps a sigma^12, c6 = 4 eps b sigma^6;
// returns (f / r, phi) for squared distance r2, f / r = (12 c12 / r^12 - 6 c6 / r^6) / r^2;
// (0, 0) at r2 >= rc2. Mirror: LjCoeff<f32> as [f32; 4].
struct MdCoeff {
    c12: f32,
    c6: f32,
    rc2: f32,
    shift: f32,
}

fn md_pair_force_energy(c: MdCoeff, r2: f32) -> vec2<f32> {
    if (r2 < c.rc2) {
        let ir2 = 1.0 / r2;
        let ir6 = ir2 * ir2 * ir2;
        let rep = c.c12 * ir6 * ir6;
        let att = c.c6 * ir6;
        return vec2<f32>((12.0 * rep - 6.0 * att) * ir2, rep - att - c.shift);
    }
    return vec2<f32>(0.0, 0.0);
}
