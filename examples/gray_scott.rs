//! A gallery of Gray–Scott patterns (Pearson 1993 set-up: Du = 2e-5, Dv = 1e-5, domain 2.5 on
//! 256 x 256 periodic cells, dt = 1, seeded centre square) written as PNGs of v.
//!
//! ```text
//! cargo run --release --example gray_scott                  # CPU, f64, 20,000 steps
//! cargo run --release --example gray_scott -- --gpu --steps 5000
//! ```
//! Options: `--steps N` (steps per pattern, 20,000), `--gpu` (GPU backend instead of the
//! CPU). Writes `out/gray_scott/{spots,stripes,worms}.png`.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use simkit::backend::{Backend, GpuContext, Result, Simulation};
use simkit::output::heatmap::{HeatmapOptions, write_heatmap};
use simkit::rd::scenes::{count_spots, gray_scott_square, variance};
use simkit::rd::{Config, GrayScott, Rd, Stepping};

#[path = "common/progress.rs"]
mod progress;

/// Gray-Scott pattern gallery (Pearson 1993): spots, stripes and worms as PNGs of v under
/// out/gray_scott/.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    /// Euler steps per pattern (dt = 1, in the model's time units)
    #[arg(long, value_name = "N", default_value_t = 20_000)]
    steps: u32,
    /// Run on the GPU backend instead of the CPU
    #[arg(long)]
    gpu: bool,
}

fn main() -> ExitCode {
    simkit::cli::exit_code(run(&Args::parse()))
}

fn run(args: &Args) -> Result<()> {
    let steps = args.steps;
    let n = 256;
    let ctx = if args.gpu {
        Some(GpuContext::new()?)
    } else {
        None
    };
    let backend = ctx.as_ref().map_or(Backend::Cpu, Backend::Gpu);
    let out = PathBuf::from("out/gray_scott");
    println!(
        "Gray-Scott gallery: {n} x {n}, {steps} steps, backend {}",
        backend.name()
    );
    let bar = progress::bar("gray-scott", 3 * u64::from(steps), "steps");
    // Progress in about 200 pieces per pattern; splitting `step` does not change the result.
    let chunk = (steps / 200).max(1);
    for (name, model) in [
        ("spots", GrayScott::spots()),
        ("stripes", GrayScott::stripes()),
        ("worms", GrayScott::worms()),
    ] {
        let grid = gray_scott_square::<f64>(n, GrayScott::PEARSON_H, n / 8, 1)?;
        let config = Config::new(Stepping::euler(1.0));
        let mut sim = Rd::new(grid, model.clone(), &config, backend)?;
        let t = Instant::now();
        let mut done = 0;
        while done < steps {
            let k = chunk.min(steps - done);
            sim.step(k)?;
            done += k;
            bar.inc(u64::from(k));
        }
        let g = sim.state()?;
        let secs = t.elapsed().as_secs_f64();
        let path = out.join(format!("{name}.png"));
        let title = format!("Gray–Scott {name}: F = {}, k = {}", model.feed, model.kill);
        let side = n as f64 * GrayScott::PEARSON_H;
        let opts = HeatmapOptions::new()
            .upscale(2)
            .title(title)
            .subtitle(format!("t = {steps} (dt = 1, {n} x {n} cells)"))
            .extent(0.0, side, 0.0, side)
            .x_label("x (dimensionless length)")
            .y_label("y (dimensionless length)")
            .quantity("v (dimensionless concentration)");
        write_heatmap(&path, g.field(1), n, n, &opts)?;
        bar.suspend(|| {
            println!(
            "{name:8} F = {:.4} k = {:.4}: var(v) = {:.3e}, regions with v > 0.2: {:4}, {:.3e} cell updates/s -> {}",
            model.feed,
            model.kill,
            variance(&g, 1),
            count_spots(&g, 1, 0.2),
            (n * n) as f64 * f64::from(steps) / secs,
            path.display()
        )
        });
    }
    bar.finish();
    Ok(())
}
