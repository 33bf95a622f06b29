//! The vibrated 2D bed (as `examples/vibrating_bed.rs`) on however many MPI ranks `mpirun`
//! starts: `DistributedDem` cuts the box into columns, one per rank (spatial decomposition:
//! ghost grains near the column borders, migration at list builds; the same bits on any
//! rank count). Rank 0 gathers the state for the pictures and the CSV, and the checkpoint
//! written at the end resumes on any number of ranks (or in one process with `Dem`).
//!
//! ```text
//! cargo build --release --features mpi --example distributed_bed
//! RAYON_NUM_THREADS=1 mpirun -np 2 -x RAYON_NUM_THREADS \
//!     target/release/examples/distributed_bed --cycles 4
//! # ... then go on, e.g. on 3 ranks, from the checkpoint the first run wrote:
//! mpirun -np 3 target/release/examples/distributed_bed --cycles 8 \
//!     --resume out/distributed_bed/checkpoint.ckpt
//! ```
//! Options: `--n` (discs, 4096), `--width` (box width in grain diameters, 128), `--gamma`
//! (vibration strength), `--cycles` (total, 4), `--resume FILE`. Writes, from rank 0,
//! `out/distributed_bed/frame_<step>.png` (4 per cycle), `series.csv` (step, time,
//! granular temperature, centre-of-mass height, kinetic energy) and `checkpoint.ckpt`.
//! Also runs as a single process.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use simkit::backend::comm::Comm;
use simkit::backend::{Distributed, Result, Simulation};
use simkit::dem::scenes::{BedParams, vibrating_bed};
use simkit::dem::{Config, DistributedDem};
use simkit::output::csv::CsvWriter;
use simkit::output::png::write_png;

#[path = "common/bed_frame.rs"]
mod bed_frame;
#[path = "common/progress.rs"]
mod progress;

/// The vibrated bed on the MPI ranks mpirun starts; pictures, CSV and a checkpoint from
/// rank 0 under out/distributed_bed/.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    /// Number of discs
    #[arg(long, default_value_t = 4096)]
    n: usize,
    /// Box width in grain diameters
    #[arg(long, value_name = "DIAMETERS", default_value_t = 128)]
    width: usize,
    /// Vibration strength Gamma = A omega^2 / g (dimensionless)
    #[arg(long, default_value_t = BedParams::default().gamma)]
    gamma: f64,
    /// Vibration cycles in total (a resumed run continues up to this many)
    #[arg(long, default_value_t = 4)]
    cycles: u32,
    /// Continue from a checkpoint written by this example (or by `Dem` on the CPU in f64),
    /// on any rank count
    #[arg(long, value_name = "FILE")]
    resume: Option<PathBuf>,
}

fn main() -> ExitCode {
    simkit::cli::exit_code(run(&Args::parse()))
}

fn run(args: &Args) -> Result<()> {
    let comm = Comm::mpi()?;
    let out = PathBuf::from("out/distributed_bed");
    let params = BedParams {
        n: args.n,
        width: args.width,
        gamma: args.gamma,
        ..BedParams::default()
    };
    let (scene, units) = vibrating_bed(&params)?;
    let mut sim = match &args.resume {
        // Rank 0 reads the file and every rank resumes from its bytes.
        Some(path) => DistributedDem::<simkit::dem::Material>::resume_file(path, comm.clone())?,
        None => DistributedDem::new(scene, &Config::default(), comm.clone())?,
    };
    let scene = sim.scene().clone();
    // Four frames per vibration cycle (time unit 1/omega: a cycle is 2 pi).
    let per_frame = (std::f64::consts::FRAC_PI_2 / sim.dt()).round() as u64;
    let total = u64::from(args.cycles) * 4 * per_frame;
    let vmax = 2.0 * units.amplitude(params.gamma);
    let (bar, mut csv) = if comm.is_root() {
        println!(
            "vibrated bed: {} discs, {} ranks ({} columns), {}, steps {} -> {total}",
            sim.len(),
            comm.size(),
            sim.dims()[0],
            sim.backend_name(),
            sim.steps_done()
        );
        let header = [
            "step",
            "time",
            "granular_temperature",
            "com_height",
            "kinetic",
        ];
        (
            Some(progress::bar(
                "bed",
                total.saturating_sub(sim.steps_done()),
                "steps",
            )),
            Some(CsvWriter::create(out.join("series.csv"), &header)?),
        )
    } else {
        (None, None)
    };
    let t = Instant::now();
    let start = sim.steps_done();
    while sim.steps_done() < total {
        let k = per_frame.min(total - sim.steps_done());
        sim.step(k as u32)?;
        // Collective: every rank sends its grains; rank 0 draws and writes.
        let state = sim.state()?;
        if let (Some(csv), Some(bar)) = (csv.as_mut(), &bar) {
            bar.inc(k);
            let d = sim.diagnostics_of(&state)?;
            let zw = sim.wall_displacement(state.time);
            let img = bed_frame::draw(&scene, &state, zw, vmax, params.gamma)?;
            write_png(out.join(format!("frame_{:07}.png", sim.steps_done())), &img)?;
            csv.row(&[
                sim.steps_done() as f64,
                d.time,
                d.granular_temperature,
                d.com_height,
                d.kinetic,
            ])?;
        }
    }
    let path = out.join("checkpoint.ckpt");
    sim.write_checkpoint(&path)?;
    if let (Some(csv), Some(bar)) = (csv, bar) {
        bar.finish();
        csv.finish()?;
        let done = (sim.steps_done() - start) as f64;
        println!(
            "{:.3e} particle-steps/s on {} rank(s); checkpoint {} (resume it on any rank count)",
            sim.len() as f64 * done / t.elapsed().as_secs_f64().max(1e-9),
            comm.size(),
            path.display()
        );
    }
    Ok(())
}
