//! The source's channel flow past an obstacle: walls on the top and bottom rows,
//! a disc obstacle, an inflow column re-filled with east-movers and an emptied outflow
//! column. Writes PNG frames of the time- and block-averaged velocity field, an animated GIF
//! and a VTK file, and prints the throughput.
//!
//! ```text
//! cargo run --release --example obstacle_flow [-- --gpu --steps N --size WxH]
//!     [--checkpoint-every N] [--resume out/obstacle_flow/checkpoint.ckpt]
//! ```
//! Output under `out/obstacle_flow/`. Defaults: 1024 x 512 sites, 6000 steps, the CPU method
//! `CpuMethod::Auto` picks. `--checkpoint-every N` saves the run every N steps;
//! `--resume FILE` continues a saved run up to `--steps` in total, bit for bit as the
//! uninterrupted run (frames are written from the resumed step on). `--help` lists them.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use simkit::backend::{Backend, GpuContext, Result, Simulation};
use simkit::lattice_gas::{BlockField, TimeAverage};
use simkit::lattice_gas::{Config, Lattice, LatticeGas, Obstacle, ROW_SPACING, RuleSet};
use simkit::output::gif::GifWriter;
use simkit::output::vector_field::render_vector_field;

#[path = "common/checkpoint.rs"]
mod checkpoint;
#[path = "common/progress.rs"]
mod progress;

/// FHP channel flow past a disc: velocity frames, GIF and VTK under out/obstacle_flow/.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    /// Total steps of the run (a resumed run continues up to this many)
    #[arg(long, value_name = "N", default_value_t = 6000)]
    steps: u32,
    /// Lattice size in sites, WIDTHxHEIGHT
    #[arg(long, value_name = "WxH", default_value = "1024x512", value_parser = parse_size)]
    size: (usize, usize),
    /// Run on the GPU backend instead of the CPU
    #[arg(long)]
    gpu: bool,
    #[command(flatten)]
    checkpoint: checkpoint::CheckpointArgs,
}

/// `WIDTHxHEIGHT`, e.g. `1024x512`.
fn parse_size(s: &str) -> std::result::Result<(usize, usize), String> {
    let (w, h) = s
        .split_once('x')
        .ok_or_else(|| format!("`{s}` is not WIDTHxHEIGHT (e.g. 1024x512)"))?;
    let parse = |v: &str| {
        v.parse::<usize>()
            .map_err(|e| format!("`{v}` in `{s}` is not a size in sites: {e}"))
    };
    Ok((parse(w)?, parse(h)?))
}

fn main() -> ExitCode {
    simkit::cli::exit_code(run(&Args::parse()))
}

fn run(args: &Args) -> Result<()> {
    let (steps, (w, h)) = (args.steps, args.size);
    let ctx = if args.gpu {
        Some(GpuContext::new()?)
    } else {
        None
    };
    let backend = ctx.as_ref().map_or(Backend::Cpu, Backend::Gpu);
    let out = PathBuf::from("out/obstacle_flow");
    let checkpoints = args.checkpoint.checkpoints(&out);
    let config = Config {
        periodic_x: false,
        periodic_y: false,
        inflow: true,
        outflow: true,
        seed: 2026,
        // The source's collision table.
        rules: RuleSet::Full,
        ..Config::default()
    };
    let mut sim = checkpoints.start(backend, |backend| {
        let mut lattice = channel_lattice(w, h)?;
        lattice.fill_with(3, |_, _, k| if k == 0 { 0.5 } else { 0.15 })?;
        LatticeGas::new(lattice, &config, backend)
    })?;
    println!(
        "channel {w} x {h}, {steps} steps on {}; output in {}/",
        sim.backend_name(),
        out.display()
    );
    let block = (w / 64).max(4);
    let frame_every = (steps / 30).max(20);
    let sample_every = (frame_every / 10).max(1);
    let mut gif = GifWriter::create(out.join("flow.gif"), 120)?;
    let mut avg = TimeAverage::new();
    let mut stepping = 0.0;
    let mut done = u32::try_from(sim.steps_done())
        .unwrap_or(u32::MAX)
        .min(steps);
    let mut frame = done / frame_every;
    let first = done;
    let first_frame = frame;
    let bar = progress::bar("channel", u64::from(steps), "steps");
    bar.set_position(u64::from(done));
    bar.reset_eta();
    while done < steps {
        // Samples at multiples of `sample_every` of the whole run (a resumed run too).
        let n = (sample_every - done % sample_every).min(steps - done);
        let t = Instant::now();
        checkpoints.step(&mut sim, n)?;
        let state = sim.state()?;
        stepping += t.elapsed().as_secs_f64();
        done += n;
        bar.inc(u64::from(n));
        avg.add(&BlockField::from_lattice(&state, block)?)?;
        if done.is_multiple_of(frame_every) || done == steps {
            let field = avg.field().expect("at least one sample");
            let title = format!("FHP channel, step {done}, {block}x{block} blocks");
            simkit::files::write_block_velocity_png(
                field,
                &out.join(format!("frame_{frame:03}.png")),
                &title,
            )?;
            let (ux, uy, cols, rows) = field.velocity_square_cells();
            let mut opts = simkit::files::block_velocity_options(field, &title);
            opts.background = opts.background.upscale(8).range(0.0, 0.8);
            let (img, _) = render_vector_field(&ux, &uy, cols, rows, &opts)?;
            gif.push(&img)?;
            if done == steps {
                simkit::files::write_block_field_vti(field, &out.join("final.vti"))?;
            }
            avg.reset();
            frame += 1;
        }
    }
    bar.finish();
    gif.finish()?;
    let updates = (w * h) as f64 * f64::from(steps - first);
    println!(
        "{} frames; {:.3e} site updates/s (stepping and snapshots, {stepping:.2} s)",
        frame - first_frame,
        updates / stepping
    );
    Ok(())
}

fn channel_lattice(w: usize, h: usize) -> Result<Lattice> {
    let mut lattice = Lattice::new(w, h)?;
    lattice.add_wall_rows();
    let channel_height = h as f64 * ROW_SPACING;
    lattice.add_obstacle(&Obstacle::Disc {
        cx: w as f64 * 0.25,
        cy: 0.5 * channel_height,
        radius: channel_height / 12.0,
    })?;
    Ok(lattice)
}
