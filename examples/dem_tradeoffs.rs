//! DEM trade-off sweep: time step `dt = t_c / div` for div in {5, 10, 20, 30, 50,
//! 100}, velocity vs position Verlet, f64 vs f32 (CPU backend), measuring
//!
//! - the restitution error of a head-on binary collision (requested e = 0.5, mass ratio 3,
//!   averaged over 8 impact phases within a step; the worst single phase is also listed),
//! - the energy error of an elastic (e = 1), frictionless periodic 2D gas of 4096 discs at
//!   area fraction 0.5: max |E(t) - E(0)| / E(0) over 20 contact times,
//! - the wall time per step of that gas (2 threads).
//!
//! ```text
//! cargo run --release --example dem_tradeoffs                    # writes out/dem_tradeoffs/dem.png
//! cargo run --release --example dem_tradeoffs -- --update-docs   # writes docs/tradeoffs/dem.png
//! ```
//! Prints a Markdown table (the one of docs/tradeoffs/dem.md) and writes the plot
//! `out/dem_tradeoffs/dem.png`; `--update-docs` writes it to `docs/tradeoffs/dem.png`
//! instead.

use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use simkit::backend::{Backend, Result, Simulation};
use simkit::dem::{Config, Dem, Dim, Integrator, Material, Particle, Precision, Scene};
use simkit::output::plot::{Plot, Scale, Series, Style};

#[path = "common/progress.rs"]
mod progress;
#[path = "common/tradeoffs.rs"]
mod tradeoffs;

/// DEM trade-off sweep (time step, integrator, precision): restitution and energy errors
/// and time per step; prints a Markdown table and writes the plot under out/dem_tradeoffs/.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    #[command(flatten)]
    out: tradeoffs::TradeoffArgs,
}

const TC: f64 = 0.05;

fn config(div: f64, integrator: Integrator, precision: Precision) -> Config {
    Config::default()
        .with_dt(TC / div)
        .with_integrator(integrator)
        .with_precision(precision)
}

/// Measured restitution of one head-on collision whose contact starts `phase` steps after
/// a step boundary.
fn restitution(cfg: &Config, e: f64, phase: f64) -> Result<f64> {
    let dt = cfg.dt.unwrap_or(TC / 30.0);
    let mut s = Scene::new(Dim::Two, [0.0; 3], [10.0, 4.0, 0.0], Material::new(e, TC))?;
    let (v0, v1) = (0.75, -0.25);
    let x1 = 5.0 + (2.0 * TC + phase * dt) * (v0 - v1);
    s.add_particle(Particle::new([4.0, 2.0, 0.0], 0.5, 1.0).with_velocity([v0, 0.0, 0.0]))?;
    s.add_particle(Particle::new([x1, 2.0, 0.0], 0.5, 3.0).with_velocity([v1, 0.0, 0.0]))?;
    let mut sim = Dem::new(s, cfg, Backend::Cpu)?;
    let steps = ((4.0 * TC + 4.0 * dt) / dt).ceil() as u32;
    sim.step(steps)?;
    let st = sim.state()?;
    Ok((st.velocities[1][0] - st.velocities[0][0]) / (v0 - v1))
}

fn gas() -> Result<Scene> {
    let side = 64;
    let spacing = (std::f64::consts::PI / 4.0 / 0.5).sqrt();
    let l = side as f64 * spacing;
    let mut s = Scene::new(Dim::Two, [0.0; 3], [l, l, 0.0], Material::new(1.0, TC))?;
    s.set_periodic([true, true, false]);
    for k in 0..side * side {
        let (i, j) = (k % side, k / side);
        let h = |a: u32| simkit::backend::rng::rng_uniform(9, a, k as u32) as f64 - 0.5;
        let p = [(i as f64 + 0.5) * spacing, (j as f64 + 0.5) * spacing, 0.0];
        s.add_particle(Particle::new(p, 0.5, 1.0).with_velocity([h(0), h(1), 0.0]))?;
    }
    Ok(s)
}

/// (max relative energy error, seconds per step).
fn energy(scene: &Scene, cfg: &Config, div: f64) -> Result<(f64, f64)> {
    let mut sim = Dem::new(scene.clone(), cfg, Backend::Cpu)?;
    let d = sim.diagnostics()?;
    let e0 = d.kinetic + d.elastic;
    let chunk = (div as u32).max(1);
    let mut worst = 0.0f64;
    let mut secs = 0.0;
    for _ in 0..20 {
        let t = Instant::now();
        sim.step(chunk)?;
        secs += t.elapsed().as_secs_f64();
        let d = sim.diagnostics()?;
        let err = if d.finite {
            ((d.kinetic + d.elastic - e0) / e0).abs()
        } else {
            f64::INFINITY
        };
        worst = worst.max(err);
    }
    Ok((worst, secs / f64::from(20 * chunk)))
}

fn main() -> ExitCode {
    simkit::cli::exit_code(run(&Args::parse()))
}

fn run(args: &Args) -> Result<()> {
    let divs = [5.0, 10.0, 20.0, 30.0, 50.0, 100.0];
    let e = 0.5;
    let scene = gas()?;
    println!(
        "| integrator | precision | t_c/dt | restitution error (8-phase mean) | worst phase | energy error (e=1 gas) | time/step (4096 discs) |"
    );
    println!("|---|---|---|---|---|---|---|");
    let mut series = Vec::new();
    let bar = progress::bar("dem sweep", 4 * divs.len() as u64, "configurations");
    for integrator in [Integrator::VelocityVerlet, Integrator::PositionVerlet] {
        for precision in [Precision::F64, Precision::F32] {
            let mut xs = Vec::new();
            let mut re = Vec::new();
            let mut ee = Vec::new();
            for &div in &divs {
                let cfg = config(div, integrator, precision);
                let mut mean = 0.0;
                let mut worst = 0.0f64;
                for k in 0..8 {
                    let m = restitution(&cfg, e, f64::from(k) / 8.0)?;
                    mean += m / 8.0;
                    worst = worst.max((m - e).abs() / e);
                }
                let rerr = (mean - e).abs() / e;
                let (eerr, spt) = energy(&scene, &cfg, div)?;
                bar.inc(1);
                bar.suspend(|| {
                    println!(
                        "| {integrator:?} | {precision:?} | {div} | {rerr:.2e} | {worst:.2e} | {eerr:.2e} | {:.0} µs |",
                        spt * 1e6
                    );
                });
                xs.push(div);
                re.push(rerr.max(1e-8));
                ee.push(eerr.max(1e-8));
            }
            let tag = format!(
                "{} {}",
                if integrator == Integrator::VelocityVerlet {
                    "VV"
                } else {
                    "PV"
                },
                if precision == Precision::F64 {
                    "f64"
                } else {
                    "f32"
                }
            );
            series.push(
                Series::line(format!("restitution {tag}"), &xs, &re).style(Style::LinePoints),
            );
            series.push(Series::line(format!("energy {tag}"), &xs, &ee).style(Style::LinePoints));
        }
    }
    let mut plot = Plot::new("dem: relative error vs t_c / Δt")
        .x_label("t_c / Δt (steps per contact)")
        .y_label("relative error (dimensionless)")
        .x_scale(Scale::Log10)
        .y_scale(Scale::Log10)
        .size(900, 560);
    for s in series {
        plot = plot.series(s);
    }
    bar.finish();
    let path = args.out.dir("dem_tradeoffs").join("dem.png");
    plot.write(&path)?;
    println!("\nwrote {}", path.display());
    Ok(())
}
