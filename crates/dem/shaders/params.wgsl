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
