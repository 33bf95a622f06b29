// simkit dem: what the GPU force kernel hands a contact law (Rust twins in src/law.rs), put
// before every law's WGSL together with spin.wgsl.

// The values a law keeps per contact on the device (at most 7: the kernel stores a contact
// as its partner and these values in 8 words).
alias DemHistory = array<f32, 7>;

// One contact of particle i with j (another particle, or a wall of infinite mass); twin of
// Contact<f32, 3> (in 2D the z components are 0).
struct DemContact {
    // Unit normal from j to i.
    n: vec3<f32>,
    // Overlap R_i + R_j - |r_i - r_j| > 0.
    delta: f32,
    // Relative velocity of the surfaces at the contact point (of the centres in a scene
    // without rotation).
    v_rel: vec3<f32>,
    // Normal relative velocity of the centres (negative when approaching).
    v_n: f32,
    // Relative angular velocity w_i - w_j (0 without rotation).
    w_rel: vec3<f32>,
    // Reduced mass m_i m_j / (m_i + m_j) (against a wall: m_i).
    m_ij: f32,
    // Effective radius R_i R_j / (R_i + R_j) (against a wall: R_i).
    r_eff: f32,
    // The time step.
    dt: f32,
}

// The force on i and the couple on i beyond the lever arm of that force; twin of
// ContactForce<f32, 3>.
struct DemForce {
    force: vec3<f32>,
    torque: vec3<f32>,
}

// The linear spring-dashpot's normal force (positive = repulsive):
// m_ij (kappa delta - 2b v_n) (twin of normal_force in src/contact.rs).
fn dem_spring_dashpot(kappa: f32, two_b: f32, m_ij: f32, delta: f32, v_n: f32) -> f32 {
    return m_ij * (kappa * delta - two_b * v_n);
}
