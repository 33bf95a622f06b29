//! A gallery of Gray–Scott patterns (Pearson 1993 set-up: Du = 2e-5, Dv = 1e-5, domain 2.5 on
//! 256 x 256 periodic cells, dt = 1, seeded centre square) written as PNGs of v.
//!
//! ```text
//! cargo run --release --example gray_scott                  # CPU, f64, 20,000 steps
//! cargo run --release --example gray_scott -- --gpu --steps 5000
//! ```

use std::path::PathBuf;
use std::time::Instant;

use simkit::backend::{Backend, GpuContext, Result, Simulation};
use simkit::output::heatmap::{HeatmapOptions, write_heatmap};
use simkit::rd::scenes::{count_spots, gray_scott_square, variance};
use simkit::rd::{Config, GrayScott, Rd, Stepping};

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let steps: u32 = match args.iter().position(|a| a == "--steps") {
        Some(i) => {
            let value = args.get(i + 1).map_or("", |s| s.as_str());
            value.parse().map_err(|e| {
                simkit::backend::Error::invalid(
                    "--steps",
                    value,
                    format!("give a step count ({e})"),
                )
            })?
        }
        None => 20_000,
    };
    let n = 256;
    let ctx = if args.iter().any(|a| a == "--gpu") {
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
    for (name, model) in [
        ("spots", GrayScott::spots()),
        ("stripes", GrayScott::stripes()),
        ("worms", GrayScott::worms()),
    ] {
        let grid = gray_scott_square::<f64>(n, GrayScott::PEARSON_H, n / 8, 1)?;
        let config = Config::new(Stepping::euler(1.0));
        let mut sim = Rd::new(grid, model.clone(), &config, backend)?;
        let t = Instant::now();
        sim.step(steps)?;
        let secs = t.elapsed().as_secs_f64();
        let g = sim.state()?;
        let path = out.join(format!("{name}.png"));
        let title = format!(
            "{name}: F = {}, k = {}, v after {steps} steps",
            model.feed, model.kill
        );
        write_heatmap(
            &path,
            g.field(1),
            n,
            n,
            &HeatmapOptions::new().upscale(2).title(title),
        )?;
        println!(
            "{name:8} F = {:.4} k = {:.4}: var(v) = {:.3e}, regions with v > 0.2: {:4}, {:.3e} cell updates/s -> {}",
            model.feed,
            model.kill,
            variance(&g, 1),
            count_spots(&g, 1, 0.2),
            (n * n) as f64 * f64::from(steps) / secs,
            path.display()
        );
    }
    Ok(())
}
