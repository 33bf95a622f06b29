// simkit dem: the reduced mass of a contact, which the force kernel hands to every contact
// law (Rust twin: simkit_dem::reduced_mass).
fn dem_reduced_mass(m_i: f32, m_j: f32) -> f32 {
    return m_i * m_j / (m_i + m_j);
}
