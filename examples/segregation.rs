//! The source's segregating binary monolayer (chapter 2): equal spheres of two species
//! that differ only in restitution (`e_AA`, `e_BB`, `e_AB`) in a vertically vibrated
//! cylinder of height 1.5 d. The source reports that the species separate horizontally; the
//! order parameter is the fraction of like-species neighbour pairs (centres closer than
//! 1.2 d), which starts at its well-mixed value (the same fraction for the initial random
//! swaps). With this model (no rotation) it stays there within its sampling error over
//! 300 - 2000 cycles for every seed tried (docs/dem.md, `tests/segregation.rs`): the summary
//! prints the change in standard errors of the well-mixed value.
//!
//! ```text
//! cargo run --release --example segregation                       # 400 spheres, 300 cycles
//! cargo run --release --example segregation -- --cycles 1000 --n 600 --radius 17
//! cargo run --release --example segregation -- --gpu
//! ```
//! Writes top views `out/segregation/top_NNN.png` (species A orange, B blue) and
//! `order.csv`, and prints the order parameter over time. Options (scene defaults from
//! `MonolayerParams::default()`): `--n`, `--radius` (cylinder radius in diameters),
//! `--gamma`, `--freq` (Hz), `--seed`, `--mu`, `--cycles` (300), `--samples` (30), `--gpu`.

use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use simkit::backend::{Backend, Error, GpuContext, Result, Simulation};
use simkit::dem::scenes::{MonolayerParams, like_neighbor_fraction, segregation_monolayer};
use simkit::dem::{Config, Dem, Scene, State};
use simkit::output::csv::CsvWriter;
use simkit::output::particles::ParticleFrame;
use simkit::output::plot;

#[path = "common/progress.rs"]
mod progress;

/// The source's segregating binary monolayer in a vibrated cylinder (species differing only
/// in restitution): top views and the like-neighbour fraction under out/segregation/.
#[derive(Parser, Debug)]
#[command(version, allow_negative_numbers = true)]
struct Args {
    /// Number of spheres (half of each species)
    #[arg(long, default_value_t = MonolayerParams::default().n)]
    n: usize,
    /// Cylinder radius in sphere diameters
    #[arg(long, value_name = "DIAMETERS", default_value_t = MonolayerParams::default().radius)]
    radius: f64,
    /// Vibration strength Gamma = A omega^2 / g (dimensionless)
    #[arg(long, default_value_t = MonolayerParams::default().gamma)]
    gamma: f64,
    /// Vibration frequency in Hz
    #[arg(long, value_name = "HZ", default_value_t = MonolayerParams::default().freq_hz)]
    freq: f64,
    /// Seed of the random species swaps
    #[arg(long, default_value_t = MonolayerParams::default().seed)]
    seed: u32,
    /// Coulomb friction coefficient (0 = frictionless)
    #[arg(long, default_value_t = MonolayerParams::default().mu)]
    mu: f64,
    /// Vibration cycles to run
    #[arg(long, default_value_t = 300)]
    cycles: u32,
    /// Order-parameter samples (and top views) over the run
    #[arg(long, default_value_t = 30)]
    samples: u32,
    /// Run on the GPU backend instead of the CPU
    #[arg(long)]
    gpu: bool,
}

/// Top view (x-y) of the cylinder after `cycle` vibration cycles: species 0 orange,
/// species 1 blue, with a legend; lengths in small-grain diameters d.
fn top_view(scene: &Scene, s: &State, radius: f64, cycle: u32) -> ParticleFrame {
    let pos: Vec<[f64; 2]> = s.positions.iter().map(|x| [x[0], x[1]]).collect();
    let radii: Vec<f64> = scene.particles().iter().map(|p| p.radius).collect();
    let ids: Vec<usize> = scene
        .particles()
        .iter()
        .map(|p| usize::from(p.species != 0))
        .collect();
    let edge = radius + 1.0;
    ParticleFrame::new(&pos, &radii)
        .bounds(-edge, edge, -edge, edge)
        .by_species(&ids, &["species 0", "species 1"])
        .species_colors(&[[230, 120, 20], [30, 90, 200]])
        .circle((0.0, 0.0), radius)
        .title("vibrated monolayer, top view")
        .subtitle(format!("after {cycle} vibration cycles"))
        .x_label("x (d)")
        .y_label("y (d)")
}

fn main() -> ExitCode {
    simkit::cli::exit_code(run(&Args::parse()))
}

fn run(args: &Args) -> Result<()> {
    let d = MonolayerParams::default();
    let params = MonolayerParams {
        n: args.n,
        radius: args.radius,
        gamma: args.gamma,
        freq_hz: args.freq,
        seed: args.seed,
        mu: args.mu,
        ..d
    };
    let (cycles, samples) = (args.cycles, args.samples);
    let ctx = if args.gpu {
        Some(GpuContext::new()?)
    } else {
        None
    };
    let backend = ctx.as_ref().map_or(Backend::Cpu, Backend::Gpu);
    let (scene, units) = segregation_monolayer(&params)?;
    println!("inputs: {params:?}");
    println!(
        "reduced units: g' = {:.5}, A' = {:.5}, t_c = {:.5}",
        units.gravity(),
        units.amplitude(params.gamma),
        units.time(params.contact_time_s)
    );
    let mut sim = Dem::new(scene.clone(), &Config::default(), backend)?;
    let per_cycle = (2.0 * std::f64::consts::PI / sim.dt()).round() as u32;
    let cycles_per_sample = (cycles / samples.max(1)).max(1);
    println!(
        "backend {}, dt = {:.4e}, {per_cycle} steps per cycle",
        sim.backend_name(),
        sim.dt()
    );
    let out = Path::new("out/segregation");
    std::fs::create_dir_all(out).map_err(|e| simkit::output::atomic::io_error(out, &e))?;
    let mut csv = CsvWriter::create(out.join("order.csv"), &["cycle", "like_fraction"])?;
    let range = 1.2;
    let s0 = sim.state()?;
    let mixed = like_neighbor_fraction(&scene, &s0.positions, range);
    top_view(&scene, &s0, params.radius, 0).write(out.join("top_000.png"))?;
    csv.row(&[0.0, mixed])?;
    println!("\ncycle  like-species neighbour fraction");
    println!(
        "{:5}  {mixed:.4}  (initial, random swaps: the well-mixed value)",
        0
    );
    let mut curve = vec![(0.0, mixed)];
    // The loop below runs whole samples: up to the next multiple of `cycles_per_sample`.
    let total = cycles.div_ceil(cycles_per_sample) * cycles_per_sample;
    let bar = progress::bar("segregation", u64::from(total), "cycles");
    let t0 = Instant::now();
    let mut cycle = 0;
    let mut frame = 1;
    while cycle < cycles {
        for _ in 0..cycles_per_sample {
            sim.step(per_cycle)?;
            bar.inc(1);
        }
        cycle += cycles_per_sample;
        let s = sim.state()?;
        if !sim.diagnostics_of(&s)?.finite {
            return Err(Error::invalid("state", "NaN", "the monolayer blew up"));
        }
        let f = like_neighbor_fraction(&scene, &s.positions, range);
        csv.row(&[f64::from(cycle), f])?;
        curve.push((f64::from(cycle), f));
        bar.suspend(|| println!("{cycle:5}  {f:.4}"));
        top_view(&scene, &s, params.radius, cycle)
            .write(out.join(format!("top_{frame:03}.png")))?;
        frame += 1;
    }
    let secs = t0.elapsed().as_secs_f64();
    bar.finish();
    csv.finish()?;
    let (xs, ys): (Vec<f64>, Vec<f64>) = curve.iter().copied().unzip();
    plot::Plot::new("segregation: like-species neighbour fraction")
        .x_label("vibration cycles")
        .y_label("like-species neighbour fraction (1)")
        .series(plot::Series::line("like fraction", &xs, &ys).style(plot::Style::LinePoints))
        .write(out.join("order.png"))?;
    let last = curve.last().map_or(mixed, |c| c.1);
    // Standard error of the like fraction of randomly labelled pairs, sqrt(p (1 - p) / M),
    // with M about 1.73 pairs per sphere at this packing (693 for 400 spheres).
    let pairs = 1.73 * params.n as f64;
    let se = (0.25 / pairs).sqrt();
    println!(
        "\nsummary: {} spheres, {cycle} cycles ({} steps) in {secs:.1} s = {:.3e} particle-steps/s ({}); \
         like fraction {mixed:.3} -> {last:.3} ({:+.1} standard errors of a random mixture); \
         pictures in {}",
        params.n,
        sim.steps_done(),
        params.n as f64 * sim.steps_done() as f64 / secs,
        sim.backend_name(),
        (last - mixed) / se,
        out.display()
    );
    Ok(())
}
