// simkit dem: the linear spring-dashpot with tangential and rolling springs (Rust twin:
// <LinearHistory as ContactLaw>::force in src/contact.rs). Needs law.wgsl and spin.wgsl.
// Coefficients (mirror: LinearHistory::gpu): the normal spring and dashpot per unit
// reduced mass, k_t / k_n, mu, mu_r.
struct DemCoeff {
    kappa: f32,
    two_b: f32,
    ratio: f32,
    mu: f32,
    mu_r: f32,
    pad0: f32,
    pad1: f32,
    pad2: f32,
}

fn dem_contact_force(c: DemCoeff, k: DemContact, h: ptr<function, DemHistory>, friction: bool) -> DemForce {
    let f_n = dem_spring_dashpot(c.kappa, c.two_b, k.m_ij, k.delta, k.v_n);
    let out = DemForce(f_n * k.n, vec3<f32>(0.0));
    if (!friction) {
        return out;
    }
    let k_t = c.ratio * c.kappa * k.m_ij;
    let g_t = 0.5 * c.two_b * k.m_ij;
    return dem_springs_add(out, k, f_n, h, k_t, g_t, c.mu, k_t, g_t, c.mu_r);
}
