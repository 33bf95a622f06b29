//! Coulomb explosion of a cold uniform sphere of equal charges, against the analytic radius
//! t(xi) = [sqrt(xi (xi - 1)) + ln(sqrt(xi) + sqrt(xi - 1))] / (sqrt(2) omega).
//!
//! ```text
//! cargo run --release --example coulomb_explosion                  # N = 20,000, CPU f32
//! cargo run --release --example coulomb_explosion -- --n 50000 --f64
//! cargo run --release --example coulomb_explosion -- --gpu --n 8192
//! ```
//! Writes `out/coulomb_explosion/radius.png` (measured xi(t) against the analytic curve),
//! `radius.csv`, and VTK frames `frame_*.vtp` with `explosion.pvd` for ParaView and OVITO
//! (arrays `Velocity`, `distance_from_centre`, and `radius`: the point charges have no size,
//! so it is half the mean spacing of the initial sphere, `(4 pi / 3 N)^(1/3) / 2`). Options:
//! `--n N` (charges, 20,000), `--f64` (double precision; f32 by default), `--gpu`.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;
use simkit::backend::{Backend, GpuContext, Result, Simulation};
use simkit::output::csv::write_csv;
use simkit::output::plot::{Plot, Series, Style};
use simkit::output::vtk::{self, Particles as VtkParticles};
use simkit::pp_coulomb::analytic::{explosion_omega, explosion_time, explosion_xi};
use simkit::pp_coulomb::scenes::{Expansion, cold_sphere, crossing_time, run_explosion};
use simkit::pp_coulomb::{Config, ForceLaw, PpCoulomb, Precision};

#[path = "common/progress.rs"]
mod progress;

/// Coulomb explosion of a cold uniform sphere of equal charges (radius 1, total charge 1)
/// against the analytic radius; plot, CSV and VTK frames under out/coulomb_explosion/.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    /// Number of charges
    #[arg(long, value_name = "N", default_value_t = 20_000)]
    n: usize,
    /// Double precision (f64) instead of f32
    #[arg(long)]
    f64: bool,
    /// Run on the GPU backend instead of the CPU
    #[arg(long)]
    gpu: bool,
}

/// The number of steps [`run_explosion`] takes if the radius follows the analytic curve
/// exactly: the progress bar's length (the run may take a step or two more or fewer).
fn expected_steps(omega: f64, courant: f64, xi_max: f64, t_max: f64) -> u64 {
    let (mut t, mut xi, mut steps) = (0.0, 1.0f64, 0);
    while xi < xi_max && t < t_max {
        t += courant * xi.powf(1.5) / omega;
        xi = explosion_xi(t, omega);
        steps += 1;
    }
    steps
}

fn main() -> ExitCode {
    simkit::cli::exit_code(run(&Args::parse()))
}

fn run(args: &Args) -> Result<()> {
    let n = args.n;
    let precision = if args.f64 {
        Precision::F64
    } else {
        Precision::F32
    };
    let ctx = if args.gpu {
        Some(GpuContext::new()?)
    } else {
        None
    };
    let backend = ctx.as_ref().map_or(Backend::Cpu, Backend::Gpu);
    let out = PathBuf::from("out/coulomb_explosion");

    let radius = 1.0;
    let particles = cold_sphere(n, radius, 2024)?;
    let q = particles.charge.first().copied().unwrap_or(1.0);
    let m = particles.mass.first().copied().unwrap_or(1.0);
    let omega = explosion_omega(q, 1.0, m, radius);
    let expansion = Expansion::new(&particles.position, radius);
    let config = Config::new(0.05, ForceLaw::Exact).with_precision(precision);
    let mut sim = PpCoulomb::new(particles, &config, backend)?;
    println!(
        "Coulomb explosion: N = {n}, R = 1, total charge 1, omega = {omega}, {}",
        sim.backend_name()
    );

    let (xi_max, courant) = (5.0, 0.05);
    let t_end = explosion_time(xi_max, omega);
    let bar = progress::bar(
        "explosion",
        expected_steps(omega, courant, xi_max, 2.0 * t_end),
        "steps",
    );
    let mut frames: Vec<(f64, String)> = Vec::new();
    // The drawn size of a point charge: half the mean spacing in the initial sphere.
    let draw_radius = 0.5 * radius * (4.0 * std::f64::consts::PI / (3.0 * n as f64)).cbrt();
    let start = std::time::Instant::now();
    let mut write_frame = |p: &simkit::pp_coulomb::Particles, t: f64| -> Result<()> {
        let name = format!("frame_{:04}.vtp", frames.len());
        let mut v = VtkParticles::from_xyz(&p.position)?;
        let vel: Vec<f64> = p.velocity.iter().flatten().copied().collect();
        let r: Vec<f64> = p
            .position
            .iter()
            .map(|x| (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt())
            .collect();
        v.add_scalar("radius", &vec![draw_radius; r.len()])?
            .add_scalar("distance_from_centre", &r)?
            .add_vector("Velocity", &vel, 3)?;
        v.write(out.join(&name))?;
        frames.push((t, name));
        Ok(())
    };
    write_frame(&sim.state()?, 0.0)?;
    let mut next_frame = 0.5;
    let samples = run_explosion(
        &mut sim,
        &expansion,
        omega,
        courant,
        xi_max,
        2.0 * t_end,
        |p, s| {
            bar.inc(1);
            if bar.position() >= bar.length().unwrap_or(0) {
                bar.inc_length(1); // more steps than the analytic estimate
            }
            if s.time >= next_frame {
                next_frame += 0.5;
                write_frame(p, s.time)?;
            }
            Ok(())
        },
    )?;
    bar.set_length(bar.position());
    bar.finish();
    let elapsed = start.elapsed().as_secs_f64();
    vtk::write_pvd(out.join("explosion.pvd"), &frames)?;

    let rows: Vec<[f64; 3]> = samples
        .iter()
        .map(|s| [s.time, s.xi, explosion_xi(s.time, omega)])
        .collect();
    write_csv(
        out.join("radius.csv"),
        &["t", "xi_measured", "xi_analytic"],
        &rows,
    )?;
    let t_last = samples.last().map_or(t_end, |s| s.time);
    let t_line: Vec<f64> = (0..=200).map(|k| t_last * k as f64 / 200.0).collect();
    let xi_line: Vec<f64> = t_line.iter().map(|&t| explosion_xi(t, omega)).collect();
    let t_meas: Vec<f64> = samples.iter().map(|s| s.time).collect();
    let xi_meas: Vec<f64> = samples.iter().map(|s| s.xi).collect();
    Plot::new(format!("Coulomb explosion, N = {n}"))
        .x_label("ω t (dimensionless; ω from the initial density)")
        .y_label("R(t) / R(0) (dimensionless)")
        .series(Series::line("analytic", &t_line, &xi_line))
        .series(Series::points("simulation", &t_meas, &xi_meas).style(Style::Points))
        .write(out.join("radius.png"))?;

    let steps = sim.steps_done();
    println!(
        "{steps} steps in {elapsed:.2} s: {:.3e} pair interactions/s",
        sim.interactions_per_step() * steps as f64 / elapsed
    );
    for xi in [2.0, 4.0] {
        let want = explosion_time(xi, omega);
        match crossing_time(&samples, xi) {
            Some(t) => println!(
                "xi = {xi}: t = {t:.4}, analytic {want:.4}, relative error {:.2e}",
                (t - want).abs() / want
            ),
            None => println!("xi = {xi}: not reached"),
        }
    }
    println!(
        "wrote {}/radius.png, radius.csv, explosion.pvd and {} frames",
        out.display(),
        frames.len()
    );
    Ok(())
}
