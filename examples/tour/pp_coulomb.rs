//! Tour scene: Coulomb explosion of a small cold sphere against the analytic radius.

use std::path::Path;
use std::time::Instant;

use simkit::backend::{Backend, Error, Result, Simulation};
use simkit::output::plot::{Plot, Series, Style};
use simkit::pp_coulomb::analytic::{explosion_omega, explosion_time, explosion_xi};
use simkit::pp_coulomb::scenes::{Expansion, cold_sphere, crossing_time, run_explosion};
use simkit::pp_coulomb::{Config, ForceLaw, PpCoulomb, Precision};

use crate::Row;

/// 2,000 equal charges in a unit sphere, exact force, f32, leapfrog with a step that grows
/// with the dynamical time, until the radius has grown fourfold.
pub fn run(backend: Backend<'_>, out: &Path) -> Result<Row> {
    let (n, radius) = (2000, 1.0);
    let particles = cold_sphere(n, radius, 7)?;
    let omega = explosion_omega(particles.charge[0], 1.0, particles.mass[0], radius);
    let expansion = Expansion::new(&particles.position, radius);
    let config = Config::new(0.05, ForceLaw::Exact).with_precision(Precision::F32);
    let mut sim = PpCoulomb::new(particles, &config, backend)?;
    let start = Instant::now();
    let t_end = explosion_time(4.5, omega);
    let samples = run_explosion(
        &mut sim,
        &expansion,
        omega,
        0.05,
        4.5,
        2.0 * t_end,
        |_, _| Ok(()),
    )?;
    let elapsed = start.elapsed().as_secs_f64();
    let t4 = crossing_time(&samples, 4.0)
        .ok_or_else(|| Error::invalid("explosion", "xi < 4", "the sphere did not expand"))?;
    let want = explosion_time(4.0, omega);
    let t: Vec<f64> = samples.iter().map(|s| s.time).collect();
    let xi: Vec<f64> = samples.iter().map(|s| s.xi).collect();
    let t_line: Vec<f64> = (0..=100).map(|k| t_end * k as f64 / 100.0).collect();
    let xi_line: Vec<f64> = t_line.iter().map(|&t| explosion_xi(t, omega)).collect();
    Plot::new(format!("Coulomb explosion, N = {n}"))
        .x_label("ω t (dimensionless; ω from the initial density)")
        .y_label("R(t) / R(0) (dimensionless)")
        .series(Series::line("analytic", &t_line, &xi_line))
        .series(Series::points("simulation", &t, &xi).style(Style::Points))
        .write(out.join("explosion_radius.png"))?;
    Ok(Row {
        scene: "pp_coulomb explosion".into(),
        backend: sim.backend_name(),
        steps: sim.steps_done(),
        throughput: sim.interactions_per_step() * sim.steps_done() as f64 / elapsed,
        unit: "pair interactions/s",
        check: format!(
            "t(R=4R0) {t4:.3} vs analytic {want:.3} ({:.2}%)",
            100.0 * (t4 - want).abs() / want
        ),
    })
}
