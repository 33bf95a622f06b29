// The Mie n-m potential, twin of <simkit_md::Mie as PairLaw>::force_energy: with
// l = log(1 / r^2), rep = c_n exp(half_n l), att = c_m exp(half_m l), phi = rep - att - shift
// and f / r = (n rep - m att) / r^2; (0, 0) at r2 >= rc2. Mirror: MieCoeff<f32> as [f32; 8].
struct MdCoeff {
    c_n: f32,
    c_m: f32,
    half_n: f32,
    half_m: f32,
    n: f32,
    m: f32,
    rc2: f32,
    shift: f32,
}

fn md_pair_force_energy(c: MdCoeff, r2: f32) -> vec2<f32> {
    if (r2 < c.rc2) {
        let ir2 = 1.0 / r2;
        let l = log(ir2);
        let rep = c.c_n * exp(c.half_n * l);
        let att = c.c_m * exp(c.half_m * l);
        return vec2<f32>((c.n * rep - c.m * att) * ir2, rep - att - c.shift);
    }
    return vec2<f32>(0.0, 0.0);
}
