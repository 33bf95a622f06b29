//! The source's 2D vibrated bed (chapter 1) from physical inputs: discs of 0.6 cm and 0.2 g
//! in a box whose floor and lid vibrate as `z_w(t) = -A cos(omega t)` with strength
//! `Gamma = A omega^2 / g` at frequency `f`, restitutions `e_pp`, `e_pw` and friction `mu`.
//!
//! ```text
//! cargo run --release --example vibrating_bed                              # 512 discs, 3 cycles
//! cargo run --release --example vibrating_bed -- --n 2048 --width 64 --cycles 10
//! cargo run --release --example vibrating_bed -- --gamma 4 --freq 25 --mu 0.5 --gpu
//! cargo run --release --example vibrating_bed -- --cycles 10 --checkpoint-every 5000
//! cargo run --release --example vibrating_bed -- --cycles 20 --resume out/vibrating_bed/checkpoint.ckpt
//! ```
//! Writes `out/vibrating_bed/frame_NNN.png`, `bed.gif`, `bed_NNN.vtp` + `bed.pvd`, and prints
//! the centre-of-mass height against the vibration phase over the last cycle.
//! `--checkpoint-every N` saves the run every N steps to `out/vibrating_bed/checkpoint.ckpt`;
//! `--resume FILE` continues it (with the same scene options) up to `--cycles` in total, bit
//! for bit as the uninterrupted run, the wall phase included. Scene options (defaults from
//! `BedParams::default()` except `--n 512 --width 32`): `--n`, `--width` (grain diameters),
//! `--gamma`, `--freq` (Hz), `--e-pp`, `--e-pw`, `--mu`, `--tc` (contact time, s);
//! `--cycles` (3), `--gpu`. `--help` lists them with their units and defaults.

use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use simkit::backend::{Backend, GpuContext, Result, Simulation};
use simkit::dem::scenes::{BedParams, vibrating_bed};
use simkit::dem::{Config, Dem};
use simkit::output::gif::GifWriter;
use simkit::output::png::write_png;
use simkit::output::vtk::{Particles, write_pvd};

#[path = "common/bed_frame.rs"]
mod bed_frame;
#[path = "common/checkpoint.rs"]
mod checkpoint;
#[path = "common/progress.rs"]
mod progress;

/// The source's 2D vibrated bed from physical inputs (discs of 0.6 cm and 0.2 g): frames,
/// GIF and VTK under out/vibrating_bed/, and the centre-of-mass height against the phase.
#[derive(Parser, Debug)]
#[command(version, allow_negative_numbers = true)]
struct Args {
    /// Number of discs
    #[arg(long, default_value_t = 512)]
    n: usize,
    /// Box width in grain diameters
    #[arg(long, value_name = "DIAMETERS", default_value_t = 32)]
    width: usize,
    /// Vibration strength Gamma = A omega^2 / g (dimensionless)
    #[arg(long, default_value_t = BedParams::default().gamma)]
    gamma: f64,
    /// Vibration frequency f in Hz
    #[arg(long, value_name = "HZ", default_value_t = BedParams::default().freq_hz)]
    freq: f64,
    /// Particle-particle restitution e_pp
    #[arg(long, value_name = "E", default_value_t = BedParams::default().e_pp)]
    e_pp: f64,
    /// Particle-wall restitution e_pw
    #[arg(long, value_name = "E", default_value_t = BedParams::default().e_pw)]
    e_pw: f64,
    /// Coulomb friction coefficient mu (0 = frictionless)
    #[arg(long, default_value_t = BedParams::default().mu)]
    mu: f64,
    /// Contact time t_c in seconds (dt = t_c / 30)
    #[arg(long, value_name = "SECONDS", default_value_t = BedParams::default().contact_time_s)]
    tc: f64,
    /// Vibration cycles in total (a resumed run continues up to this many)
    #[arg(long, default_value_t = 3)]
    cycles: u32,
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
    let params = BedParams {
        n: args.n,
        width: args.width,
        gamma: args.gamma,
        freq_hz: args.freq,
        e_pp: args.e_pp,
        e_pw: args.e_pw,
        mu: args.mu,
        contact_time_s: args.tc,
    };
    let cycles = args.cycles;
    let frames_per_cycle: u32 = 16;
    let ctx = if args.gpu {
        Some(GpuContext::new()?)
    } else {
        None
    };
    let backend = ctx.as_ref().map_or(Backend::Cpu, Backend::Gpu);
    let (scene, units) = vibrating_bed(&params)?;
    println!("physical inputs: {params:?}");
    println!(
        "reduced units: d0 = {} cm, m0 = {} g, time 1/omega = {:.4e} s; g' = {:.5}, A' = {:.5}, t_c = {:.5}",
        units.d0_cm,
        units.m0_g,
        units.time_unit_s(),
        units.gravity(),
        units.amplitude(params.gamma),
        units.time(params.contact_time_s)
    );
    let out = Path::new("out/vibrating_bed");
    let checkpoints = args.checkpoint.checkpoints(out);
    let mut sim = checkpoints.start(backend, |b| Dem::new(scene.clone(), &Config::default(), b))?;
    let period = 2.0 * std::f64::consts::PI;
    let per_frame = (period / f64::from(frames_per_cycle) / sim.dt()).round() as u32;
    println!(
        "backend {}, dt = {:.4e} (t_c / 30), {} steps per cycle",
        sim.backend_name(),
        sim.dt(),
        per_frame * frames_per_cycle
    );
    std::fs::create_dir_all(out).map_err(|e| simkit::output::atomic::io_error(out, &e))?;
    let mut gif = GifWriter::create(out.join("bed.gif"), 60)?;
    let mut pvd = Vec::new();
    let radii: Vec<f64> = scene.particles().iter().map(|p| p.radius).collect();
    let vmax = 2.0 * units.amplitude(params.gamma);
    let mut last_cycle = Vec::new();
    let t0 = Instant::now();
    let first = sim.steps_done();
    let first_frame = u32::try_from(first / u64::from(per_frame)).unwrap_or(u32::MAX);
    let total = u64::from(cycles * frames_per_cycle) * u64::from(per_frame);
    let bar = progress::bar("vibrated bed", total, "steps");
    bar.set_position(first.min(total));
    bar.reset_eta();
    for frame in first_frame..cycles * frames_per_cycle {
        // A blow-up is an error from `step` (the run is checked every 100 steps).
        // Frames at multiples of `per_frame` steps of the whole run (a resumed run too).
        let target = u64::from(frame + 1) * u64::from(per_frame);
        let n = (target - sim.steps_done()) as u32;
        checkpoints.step(&mut sim, n)?;
        bar.inc(u64::from(n));
        let s = sim.state()?;
        let d = sim.diagnostics_of(&s)?;
        let zw = sim.wall_displacement(s.time);
        let img = bed_frame::draw(&scene, &s, zw, vmax, params.gamma)?;
        write_png(out.join(format!("frame_{frame:03}.png")), &img)?;
        gif.push(&img)?;
        let name = format!("bed_{frame:03}.vtp");
        let mut vtp = Particles::from_xyz(&s.positions)?;
        vtp.add_scalar("radius", &radii)?
            .add_vector("Velocity", s.velocities.as_flattened(), 3)?;
        vtp.write(out.join(&name))?;
        pvd.push((s.time, name));
        if frame >= (cycles - 1) * frames_per_cycle {
            last_cycle.push((s.time % period / period, d.com_height, zw, d.kinetic));
        }
    }
    let secs = t0.elapsed().as_secs_f64();
    bar.finish();
    gif.finish()?;
    write_pvd(out.join("bed.pvd"), &pvd)?;
    println!(
        "\nlast cycle: phase (omega t / 2 pi), plate z_w, centre-of-mass height, kinetic energy"
    );
    for (phase, com, zw, ke) in &last_cycle {
        println!("  {phase:5.3}  {zw:+8.4}  {com:8.4}  {ke:10.4}");
    }
    let steps = sim.steps_done() - first;
    let d = sim.diagnostics()?;
    println!(
        "\nsummary: {} discs, {} cycles, {steps} steps in {secs:.1} s = {:.3e} particle-steps/s ({}); \
         max overlap {:.2e} d, {} contacts; pictures in {}",
        params.n,
        cycles,
        params.n as f64 * steps as f64 / secs,
        sim.backend_name(),
        d.max_overlap,
        d.contacts,
        out.display()
    );
    Ok(())
}
