//! The source's bacterial-colony scene: 512 x 512 cells, h = 0.5, dt = 0.005, gamma = 0.5,
//! random d = 0.75 (1 +- 0.4), two 17 x 17 inoculated squares, no-flux edges, explicit Euler,
//! f32. The two colonies grow towards each other, eat the nutrient between them and stop,
//! leaving a gap.
//!
//! Writes PNG frames of b, an animated GIF, the gap width and totals over time (CSV and PNG
//! plot) and the final fields as VTK image data under `out/bacterial_colony/`, and prints the
//! gap width over time and the throughput.
//!
//! ```text
//! cargo run --release --example bacterial_colony                      # 40,000 steps, CPU
//! cargo run --release --example bacterial_colony -- --steps 8000 --gpu
//! cargo run --release --example bacterial_colony -- --steps 40000 --checkpoint-every 10000
//! cargo run --release --example bacterial_colony -- --resume out/bacterial_colony/checkpoint.ckpt
//! ```
//! `--checkpoint-every N` saves the run every N steps to `out/bacterial_colony/checkpoint.ckpt`;
//! `--resume FILE` continues it up to `--steps` in total, bit for bit as the uninterrupted
//! run (frames, CSV rows and the GIF then cover the resumed part). Options: `--steps N`
//! (total steps, at least 16; 40,000), `--gpu`, `--checkpoint-every N`, `--resume FILE`.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use simkit::backend::{Backend, GpuContext, Result, Simulation};
use simkit::output::csv::CsvWriter;
use simkit::output::gif::write_gif;
use simkit::output::heatmap::{HeatmapOptions, render_heatmap};
use simkit::output::plot::{Plot, Series};
use simkit::output::vtk::ImageData;
use simkit::rd::scenes::{colony_scene, gap_width};
use simkit::rd::{Config, Rd, Stepping};

const N: usize = 512;
const FRAMES: u32 = 16;
/// b below this counts as empty space when measuring the gap.
const GAP_THRESHOLD: f64 = 0.05;

#[path = "common/checkpoint.rs"]
mod checkpoint;
#[path = "common/progress.rs"]
mod progress;

/// The source's bacterial colony (512 x 512 cells, f32): two colonies grow towards each
/// other and leave a gap; frames, GIF, gap curve and VTK under out/bacterial_colony/.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    /// Total Euler steps (dt = 0.005 time units; at least 16, one per frame; a resumed run
    /// continues up to this many)
    #[arg(long, value_name = "N", default_value_t = 40_000,
          value_parser = clap::value_parser!(u32).range(i64::from(FRAMES)..))]
    steps: u32,
    /// Run on the GPU backend instead of the CPU
    #[arg(long)]
    gpu: bool,
    #[command(flatten)]
    checkpoint: checkpoint::CheckpointArgs,
}

fn main() -> ExitCode {
    simkit::cli::exit_code(run(&Args::parse()))
}

fn run(args: &Args) -> Result<()> {
    let steps = args.steps;
    let ctx = if args.gpu {
        Some(GpuContext::new()?)
    } else {
        None
    };
    let backend = ctx.as_ref().map_or(Backend::Cpu, Backend::Gpu);
    let out = PathBuf::from("out/bacterial_colony");

    let (grid, model) = colony_scene::<f32>(N, N, 2026)?;
    let (cy, left, right) = (N * 127 / 512, N * 103 / 512, N * 151 / 512);
    let checkpoints = args.checkpoint.checkpoints(&out);
    let mut sim = checkpoints.start(backend, |b| {
        Rd::new(grid, model, &Config::new(Stepping::euler(0.005)), b)
    })?;
    let first = sim.steps_done();
    println!(
        "bacterial colony: {N} x {N}, h = 0.5, dt = 0.005, gamma = 0.5, {steps} steps on {}",
        sim.backend_name()
    );
    println!("gap = widest run of b < {GAP_THRESHOLD} on row {cy} between the colony centres\n");
    println!(
        "{:>7} {:>8} {:>9} {:>10} {:>10}",
        "step", "time", "gap", "total b", "total n"
    );

    let mut csv = CsvWriter::create(
        out.join("gap.csv"),
        &["step", "time", "gap", "total_b", "total_n"],
    )?;
    let mut frames = Vec::new();
    let (mut ts, mut gaps) = (Vec::new(), Vec::new());
    let bar = progress::bar("colony", u64::from(steps), "steps");
    bar.set_position(first.min(u64::from(steps)));
    bar.reset_eta();
    let chunk = steps / FRAMES;
    let mut stepping_secs = 0.0;
    for f in 0..=FRAMES {
        // Frames are at fixed steps of the whole run; a resumed run starts at its step.
        let end = if f == FRAMES {
            u64::from(steps)
        } else {
            u64::from(chunk * f)
        };
        if end < first || (f > 0 && end == first) {
            continue;
        }
        if end > sim.steps_done() {
            // In tenths of a frame interval, for the progress bar (same result).
            let piece = (chunk / 10).max(1);
            let t = Instant::now();
            while sim.steps_done() < end {
                let n = piece.min((end - sim.steps_done()) as u32);
                checkpoints.step(&mut sim, n)?;
                bar.inc(u64::from(n));
            }
            stepping_secs += t.elapsed().as_secs_f64();
        }
        let g = sim.state()?;
        let gap = gap_width(&g, cy, left, right, GAP_THRESHOLD);
        let (tb, tn) = (g.total(0), g.total(1));
        csv.row(&[sim.steps_done() as f64, sim.time(), gap, tb, tn])?;
        ts.push(sim.time());
        gaps.push(gap);
        bar.suspend(|| {
            println!(
                "{:>7} {:>8.1} {:>9.2} {:>10.2} {:>10.2}",
                sim.steps_done(),
                sim.time(),
                gap,
                tb,
                tn
            );
        });
        let side = N as f64 * 0.5;
        let opts = HeatmapOptions::new()
            .range(0.0, 1.5)
            .title("bacterial colonies: bacteria density b")
            .subtitle(format!(
                "t = {:.1} time units (step {})",
                sim.time(),
                sim.steps_done()
            ))
            .extent(0.0, side, 0.0, side)
            .x_label("x (length units)")
            .y_label("y (length units)")
            .quantity("b (density)");
        let (img, _) = render_heatmap(g.field(0), N, N, &opts)?;
        simkit::output::png::write_png(out.join(format!("b_{:06}.png", sim.steps_done())), &img)?;
        frames.push(img);
    }
    bar.finish();
    csv.finish()?;
    write_gif(out.join("colony.gif"), &frames, 300)?;
    Plot::new("gap between the colonies")
        .x_label("t (time units)")
        .y_label("gap width (length units)")
        .series(Series::line("gap", &ts, &gaps))
        .write(out.join("gap.png"))?;
    let g = sim.state()?;
    let mut vti = ImageData::new_2d(N, N, [0.25, 0.25], [0.5, 0.5])?;
    vti.add_scalar("b", g.field(0))?
        .add_scalar("n", g.field(1))?;
    vti.write(out.join("final.vti"))?;

    let stepped = u64::from(steps).saturating_sub(first);
    let updates = (N * N) as f64 * stepped as f64;
    println!(
        "\nthroughput: {:.3e} cell updates/s ({stepped} steps in {stepping_secs:.2} s of stepping)",
        updates / stepping_secs
    );
    println!("outputs in {}", out.display());
    Ok(())
}
