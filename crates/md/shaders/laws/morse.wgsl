// The Morse potential, twin of <simkit_md::Morse as PairLaw>::force_energy: with
// x = exp(-alpha (r - r0)), phi = d0 (x^2 - 2 x) - shift and f / r = 2 alpha d0 x (x - 1) / r;
// (0, 0) at r2 >= rc2. Mirror: MorseCoeff<f32> as [f32; 6].
struct MdCoeff {
    d0: f32,
    alpha: f32,
    r0: f32,
    two_alpha_d0: f32,
    rc2: f32,
    shift: f32,
}

fn md_pair_force_energy(c: MdCoeff, r2: f32) -> vec2<f32> {
    if (r2 < c.rc2) {
        let r = sqrt(r2);
        let x = exp(-(c.alpha * (r - c.r0)));
        return vec2<f32>(c.two_alpha_d0 * x * (x - 1.0) / r, c.d0 * (x * x - 2.0 * x) - c.shift);
    }
    return vec2<f32>(0.0, 0.0);
}
