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
//! run (frames, CSV rows and the GIF then cover the resumed part).

use std::path::PathBuf;
use std::time::Instant;

use simkit::backend::{Backend, Error, GpuContext, Result, Simulation};
use simkit::output::csv::CsvWriter;
use simkit::output::gif::write_gif;
use simkit::output::heatmap::{HeatmapOptions, render_heatmap};
use simkit::output::plot::{Plot, Series};
use simkit::output::progress::Progress;
use simkit::output::vtk::ImageData;
use simkit::rd::scenes::{colony_scene, gap_width};
use simkit::rd::{Config, Rd, Stepping};

const N: usize = 512;
const FRAMES: u32 = 16;
/// b below this counts as empty space when measuring the gap.
const GAP_THRESHOLD: f64 = 0.05;

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let steps: u32 = match args.iter().position(|a| a == "--steps") {
        Some(i) => args
            .get(i + 1)
            .and_then(|s| s.parse().ok())
            .filter(|&s: &u32| s >= FRAMES)
            .ok_or_else(|| {
                Error::invalid(
                    "--steps",
                    args.get(i + 1).map_or("", |s| s),
                    "give an integer >= 16",
                )
            })?,
        None => 40_000,
    };
    let ctx = if args.iter().any(|a| a == "--gpu") {
        Some(GpuContext::new()?)
    } else {
        None
    };
    let backend = ctx.as_ref().map_or(Backend::Cpu, Backend::Gpu);
    let out = PathBuf::from("out/bacterial_colony");

    let (grid, model) = colony_scene::<f32>(N, N, 2026)?;
    let (cy, left, right) = (N * 127 / 512, N * 103 / 512, N * 151 / 512);
    let checkpoints = simkit::cli::Checkpoints::from_args(&out)?;
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
    let mut progress = Progress::new("colony", u64::from(steps).saturating_sub(first));
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
            let n = (end - sim.steps_done()) as u32;
            let t = Instant::now();
            checkpoints.step(&mut sim, n)?;
            stepping_secs += t.elapsed().as_secs_f64();
            progress.inc(u64::from(n));
        }
        let g = sim.state()?;
        let gap = gap_width(&g, cy, left, right, GAP_THRESHOLD);
        let (tb, tn) = (g.total(0), g.total(1));
        csv.row(&[sim.steps_done() as f64, sim.time(), gap, tb, tn])?;
        ts.push(sim.time());
        gaps.push(gap);
        println!(
            "{:>7} {:>8.1} {:>9.2} {:>10.2} {:>10.2}",
            sim.steps_done(),
            sim.time(),
            gap,
            tb,
            tn
        );
        let opts = HeatmapOptions::new().range(0.0, 1.5).title(format!(
            "b at t = {:.1} (step {})",
            sim.time(),
            sim.steps_done()
        ));
        let (img, _) = render_heatmap(g.field(0), N, N, &opts)?;
        simkit::output::png::write_png(out.join(format!("b_{:06}.png", sim.steps_done())), &img)?;
        frames.push(img);
    }
    progress.finish();
    csv.finish()?;
    write_gif(out.join("colony.gif"), &frames, 300)?;
    Plot::new("gap between the colonies")
        .x_label("time")
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
