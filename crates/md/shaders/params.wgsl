// Run parameters of the md GPU kernels (mirror: GpuParams in src/gpu.rs).
struct MdParams {
    // Box corner, upper faces and lengths (unused axes: 0, 1, 1).
    lo: vec4<f32>,
    hi: vec4<f32>,
    len: vec4<f32>,
    // 1 for a periodic axis, 0 for a reflecting one.
    periodic: vec4<u32>,
    dt: f32,
    half_dt: f32,
    n: u32,
    n_species: u32,
    // 1: leapfrog (half-step velocities), 0: velocity Verlet.
    leapfrog: u32,
    dim: u32,
    // Seed of the Langevin thermostat's random numbers.
    seed: u32,
    _pad1: u32,
}
