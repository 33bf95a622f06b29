//! The conformance suite every simkit simulation crate runs (`conformance_tests!` of
//! `simkit-backend`, compiled into `tests/restart.rs`): the backends agree, split calls
//! equal one call, restart bit for bit, rollback after a blow-up, damaged checkpoints
//! refused; on a vibrated 2D bed with friction (the CPU in `f32`, as the GPU computes).

use simkit_backend::testing::{max_abs_diff, within};
use simkit_backend::{Backend, Precision, Result};
use simkit_dem::{Config, Dem, Dim, Material, Particle, Scene, State, safe_dt};

/// 40 discs in a vibrated box with friction, moving from the start.
fn bed() -> Result<Scene> {
    let m = Material::new(0.8, 0.05).with_friction(0.4, 30.0);
    let mut s = Scene::new(Dim::Two, [0.0; 3], [9.0, 12.0, 0.0], m)?;
    s.set_gravity(1.0)?.set_vibration(0.3, 6.0)?;
    s.add_box_walls(m, true)?;
    for k in 0..40 {
        let (x, y) = ((k % 8) as f64, (k / 8) as f64);
        let v = [0.3 * ((k % 5) as f64 - 2.0), 0.2 * ((k % 3) as f64), 0.0];
        s.add_particle(
            Particle::new([0.9 + 1.05 * x, 0.9 + 1.05 * y, 0.0], 0.5, 1.0).with_velocity(v),
        )?;
    }
    Ok(s)
}

fn vibrated(backend: Backend<'_>) -> Result<Dem> {
    let config = Config::default()
        .with_precision(Precision::F32)
        .with_check_every(7);
    Dem::new(bed()?, &config, backend)
}

/// Three times the safe time step (every contact diverges), checked every 25 steps.
fn unstable(backend: Backend<'_>) -> Result<Dem> {
    let scene = bed()?;
    let config = Config::default()
        .with_precision(Precision::F32)
        .with_dt(3.0 * safe_dt(&scene))
        .allow_unstable_dt()
        .with_check_every(25);
    Dem::new(scene, &config, backend)
}

/// Positions within 3e-5 diameters: two f32 runs of the same contacts (the bound of the
/// dilute-gas comparison in `tests/conformance.rs`, measured there 1.1e-5 after 50 steps).
fn within_f32(cpu: &State, gpu: &State) -> std::result::Result<(), String> {
    let flat = |s: &State| -> Vec<f64> { s.positions.iter().flatten().copied().collect() };
    within(
        "positions (diameters)",
        max_abs_diff(&flat(cpu), &flat(gpu)),
        3e-5,
    )
}

simkit_backend::conformance_tests! {
    sim: Dem,
    make: vibrated,
    steps: 60,
    compare: within_f32,
    blow_up: unstable,
    blow_up_steps: 5000,
}
