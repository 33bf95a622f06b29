// simkit dem: the Hertz-Mindlin law with tangential and rolling springs (Rust twin:
// <HertzMindlin as ContactLaw>::force in src/hertz.rs). Needs law.wgsl and spin.wgsl.
// Coefficients (mirror: HertzMindlin::gpu): E*, G*, the damping factor, mu, mu_r, k_roll,
// gamma_roll.
struct DemCoeff {
    e_star: f32,
    g_star: f32,
    damping: f32,
    mu: f32,
    mu_r: f32,
    k_r: f32,
    gamma_r: f32,
    pad: f32,
}

fn dem_contact_force(c: DemCoeff, k: DemContact, h: ptr<function, DemHistory>, friction: bool) -> DemForce {
    let a = sqrt(k.r_eff * k.delta);
    let s_n = 2.0 * c.e_star * a;
    let f_n = (2.0 / 3.0) * s_n * k.delta - c.damping * sqrt(s_n * k.m_ij) * k.v_n;
    let out = DemForce(f_n * k.n, vec3<f32>(0.0));
    if (!friction) {
        return out;
    }
    let k_t = 8.0 * c.g_star * a;
    let g_t = c.damping * sqrt(k_t * k.m_ij);
    return dem_springs_add(out, k, f_n, h, k_t, g_t, c.mu, c.k_r, c.gamma_r, c.mu_r);
}
