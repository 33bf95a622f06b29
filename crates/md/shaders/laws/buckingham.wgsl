// The Buckingham exp-6 potential, twin of <simkit_md::Buckingham as PairLaw>::force_energy:
// phi = a exp(-r inv_rho) - c / r^6 - shift, f / r = a inv_rho exp(-r inv_rho) / r - 6 c / r^8;
// (0, 0) at r2 >= rc2. Mirror: BuckCoeff<f32> as [f32; 5].
struct MdCoeff {
    a: f32,
    inv_rho: f32,
    c: f32,
    rc2: f32,
    shift: f32,
}

fn md_pair_force_energy(c: MdCoeff, r2: f32) -> vec2<f32> {
    if (r2 < c.rc2) {
        let r = sqrt(r2);
        let ex = c.a * exp(-(r * c.inv_rho));
        let ir2 = 1.0 / r2;
        let att = c.c * ir2 * ir2 * ir2;
        return vec2<f32>(ex * c.inv_rho / r - 6.0 * att * ir2, ex - att - c.shift);
    }
    return vec2<f32>(0.0, 0.0);
}
