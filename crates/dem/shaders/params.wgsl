// simkit dem: parameters shared by the step kernels (Rust: dem::gpu::GpuParams).
struct DemParams {
    // Gravity acceleration vector (w unused).
    gravity: vec4<f32>,
    dt: f32,
    half_dt: f32,
    // omega * dt: the vibration phase advance per step.
    omega_dt: f32,
    amplitude: f32,
    omega: f32,
    n: u32,
    n_walls: u32,
    n_species: u32,
    vertical: u32,
    dim: u32,
    _pad0: u32,
    _pad1: u32,
}

// One wall's geometry (Rust: dem::gpu::GpuWall); its contact coefficients follow the
// species pairs' in the force kernel's coefficient table.
struct DemWall {
    // Unit normal into the particle region, offset (plane walls; grid-origin coordinates).
    plane: vec4<f32>,
    // Axis (x, y) in grid-origin coordinates, radius, kind (1 = cylinder, 0 = plane).
    cylinder: vec4<f32>,
    // (1 if the wall vibrates else 0, angular velocity of a cylinder wall, 0, 0).
    motion: vec4<f32>,
}
