// simkit dem: the linear spring-dashpot contact law (Rust twins in src/contact.rs).
// Coefficients: spring and dashpot per unit reduced mass, Coulomb and viscous tangential
// coefficients (mirror: ContactCoefficients<f32> as [f32; 4]).
struct DemCoeff {
    kappa: f32,
    two_b: f32,
    mu_s: f32,
    mu_k: f32,
}

// Normal force magnitude (positive = repulsive): m_ij (kappa delta - 2b v_n).
fn dem_normal_force(c: DemCoeff, m_ij: f32, delta: f32, v_n: f32) -> f32 {
    return dem_spring_dashpot(c.kappa, c.two_b, m_ij, delta, v_n);
}

// Tangential force -min(mu_s |F_n|, mu_k m_ij |v_t|) v_t / |v_t| with v_t = v_rel - v_n n;
// zero when v_t = 0.
fn dem_friction_force(c: DemCoeff, n: vec3<f32>, v_n: f32, v_rel: vec3<f32>, f_n: f32, m_ij: f32) -> vec3<f32> {
    let vt = v_rel - v_n * n;
    let vt2 = dot(vt, vt);
    if (vt2 <= 0.0) {
        return vec3<f32>(0.0);
    }
    let vtn = sqrt(vt2);
    let ft = min(c.mu_s * abs(f_n), c.mu_k * m_ij * vtn);
    return -(ft / vtn) * vt;
}

// The contact force on i (twin of <Material as ContactLaw>::force): the normal force along
// n, plus the tangential force when `friction`; no couple, no history.
fn dem_contact_force(c: DemCoeff, k: DemContact, h: ptr<function, DemHistory>, friction: bool) -> DemForce {
    let fnorm = dem_normal_force(c, k.m_ij, k.delta, k.v_n);
    var f = fnorm * k.n;
    if (friction) {
        f += dem_friction_force(c, k.n, k.v_n, k.v_rel, fnorm, k.m_ij);
    }
    return DemForce(f, vec3<f32>(0.0));
}
