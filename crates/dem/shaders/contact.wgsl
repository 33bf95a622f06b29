// simkit dem: the linear spring-dashpot contact law (Rust twins in src/contact.rs).
// Coefficients c = (kappa, 2b, mu_s, mu_k): spring and dashpot per unit reduced mass,
// Coulomb and viscous tangential coefficients.

// Reduced mass m_i m_j / (m_i + m_j).
fn dem_reduced_mass(m_i: f32, m_j: f32) -> f32 {
    return m_i * m_j / (m_i + m_j);
}

// Normal force magnitude (positive = repulsive): m_ij (kappa delta - 2b v_n).
fn dem_normal_force(c: vec4<f32>, m_ij: f32, delta: f32, v_n: f32) -> f32 {
    return m_ij * (c.x * delta - c.y * v_n);
}

// Tangential force -min(mu_s |F_n|, mu_k m_ij |v_t|) v_t / |v_t| with v_t = v_rel - v_n n;
// zero when v_t = 0.
fn dem_friction_force(c: vec4<f32>, n: vec3<f32>, v_n: f32, v_rel: vec3<f32>, f_n: f32, m_ij: f32) -> vec3<f32> {
    let vt = v_rel - v_n * n;
    let vt2 = dot(vt, vt);
    if (vt2 <= 0.0) {
        return vec3<f32>(0.0);
    }
    let vtn = sqrt(vt2);
    let ft = min(c.z * abs(f_n), c.w * m_ij * vtn);
    return -(ft / vtn) * vt;
}
