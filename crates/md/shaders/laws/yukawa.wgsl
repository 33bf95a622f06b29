// The screened Coulomb (Yukawa) potential, twin of <simkit_md::Yukawa as PairLaw>::force_energy:
// phi = a exp(-kappa r) / r - shift, f / r = a exp(-kappa r) (1 + kappa r) / r^3; (0, 0) at
// r2 >= rc2. Mirror: YukawaCoeff<f32> as [f32; 4].
struct MdCoeff {
    a: f32,
    kappa: f32,
    rc2: f32,
    shift: f32,
}

fn md_pair_force_energy(c: MdCoeff, r2: f32) -> vec2<f32> {
    if (r2 < c.rc2) {
        let r = sqrt(r2);
        let e = c.a * exp(-(c.kappa * r)) / r;
        return vec2<f32>(e * (1.0 + c.kappa * r) / r2, e - c.shift);
    }
    return vec2<f32>(0.0, 0.0);
}
