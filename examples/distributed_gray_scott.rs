//! Gray–Scott spots (Pearson 1993 set-up, as `examples/gray_scott.rs`) on however many MPI
//! ranks `mpirun` starts: the grid is block-decomposed over the ranks (`DistributedRd`, CPU,
//! bit-identical to one process), every rank gets the grid, rank 0 writes the pictures and the CSV, and
//! the checkpoint written at the end resumes on any number of ranks.
//!
//! ```text
//! cargo build --release --features mpi --example distributed_gray_scott
//! RAYON_NUM_THREADS=1 mpirun -np 2 -x RAYON_NUM_THREADS \
//!     target/release/examples/distributed_gray_scott --steps 4000
//! # ... then go on, e.g. on 3 ranks, from the checkpoint the first run wrote:
//! mpirun -np 3 target/release/examples/distributed_gray_scott --steps 8000 \
//!     --resume out/distributed_gray_scott/checkpoint.ckpt
//! ```
//! Options: `--size N` (cells per side, 256), `--steps N` (total steps, 10,000), `--every N`
//! (a picture and a CSV row every N steps, 1,000), `--resume FILE`. Writes, from rank 0,
//! `out/distributed_gray_scott/v_<step>.png`, `series.csv` (this run's rows: step, time, variance of v,
//! regions with v > 0.2) and `checkpoint.ckpt`. Also runs as a single process.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use simkit::backend::comm::Comm;
use simkit::backend::{Distributed, Result, Simulation};
use simkit::output::csv::CsvWriter;
use simkit::output::heatmap::{HeatmapOptions, write_heatmap};
use simkit::rd::scenes::{count_spots, gray_scott_square, variance};
use simkit::rd::{Config, DistributedRd, GrayScott, Grid, Stepping};

#[path = "common/progress.rs"]
mod progress;

/// Gray–Scott spots on the MPI ranks mpirun starts; pictures, CSV and a checkpoint from
/// rank 0 under out/distributed_gray_scott/.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    /// Cells per side of the periodic grid
    #[arg(long, value_name = "N", default_value_t = 256)]
    size: usize,
    /// Total steps (a resumed run continues up to this many)
    #[arg(long, value_name = "N", default_value_t = 10_000)]
    steps: u64,
    /// A picture and a CSV row every N steps
    #[arg(long, value_name = "N", default_value_t = 1000)]
    every: u32,
    /// Continue from a checkpoint written by this example (or by `Rd`), on any rank count
    #[arg(long, value_name = "FILE")]
    resume: Option<PathBuf>,
}

fn main() -> ExitCode {
    simkit::cli::exit_code(run(&Args::parse()))
}

fn run(args: &Args) -> Result<()> {
    let comm = Comm::mpi()?;
    let out = PathBuf::from("out/distributed_gray_scott");
    let mut sim = match &args.resume {
        // Rank 0 reads the file and every rank resumes from its bytes.
        Some(path) => DistributedRd::resume_file(path, comm.clone())?,
        None => {
            let n = args.size;
            let grid = gray_scott_square::<f64>(n, GrayScott::PEARSON_H, n / 8, 1)?;
            let config = Config::new(Stepping::euler(1.0));
            DistributedRd::new(grid, GrayScott::spots(), &config, comm.clone())?
        }
    };
    let [nx, ny] = sim.decomposition().global();
    let dims = sim.decomposition().dims();
    let mut csv = None;
    let bar = comm.is_root().then(|| {
        println!(
            "Gray–Scott spots {nx} x {ny} on {} rank(s) ({} x {} blocks), steps {} -> {}",
            comm.size(),
            dims[0],
            dims[1],
            sim.steps_done(),
            args.steps
        );
        progress::bar(
            "gray-scott",
            args.steps.saturating_sub(sim.steps_done()),
            "steps",
        )
    });
    if comm.is_root() {
        csv = Some(CsvWriter::create(
            out.join("series.csv"),
            &["step", "time", "variance_v", "regions_v_above_0.2"],
        )?);
    }
    let t = Instant::now();
    let start = sim.steps_done();
    while sim.steps_done() < args.steps {
        let k = u64::from(args.every.max(1)).min(args.steps - sim.steps_done());
        sim.step(k as u32)?;
        if let Some(bar) = &bar {
            bar.inc(k);
        }
        // Collective: every rank sends its block and gets the grid; rank 0 writes.
        let grid = sim.state()?;
        if let Some(csv) = csv.as_mut() {
            frame(&out, &grid, sim.steps_done(), csv)?;
        }
    }
    if let Some(bar) = &bar {
        bar.finish();
    }
    let path = out.join("checkpoint.ckpt");
    sim.write_checkpoint(&path)?;
    if let Some(csv) = csv {
        csv.finish()?;
        let secs = t.elapsed().as_secs_f64();
        let done = (sim.steps_done() - start) as f64;
        println!(
            "{:.3e} cell updates/s on {} rank(s); checkpoint {} (resume it on any rank count)",
            (nx * ny) as f64 * done / secs.max(1e-9),
            comm.size(),
            path.display()
        );
    }
    Ok(())
}

/// Rank 0's picture of v and CSV row at `step` (dt = 1, so the time is the step).
fn frame(out: &Path, grid: &Grid<f64>, step: u64, csv: &mut CsvWriter) -> Result<()> {
    let (nx, ny) = (grid.nx(), grid.ny());
    let side = nx as f64 * GrayScott::PEARSON_H;
    let opts = HeatmapOptions::new()
        .upscale(2)
        .title("Gray–Scott spots (distributed run)")
        .subtitle(format!("t = {step} (dt = 1, {nx} x {ny} cells)"))
        .extent(0.0, side, 0.0, ny as f64 * GrayScott::PEARSON_H)
        .x_label("x (dimensionless length)")
        .y_label("y (dimensionless length)")
        .quantity("v (dimensionless concentration)");
    write_heatmap(
        out.join(format!("v_{step:06}.png")),
        grid.field(1),
        nx,
        ny,
        &opts,
    )?;
    csv.row(&[
        step as f64,
        step as f64,
        variance(grid, 1),
        count_spots(grid, 1, 0.2) as f64,
    ])
}
