//! md trade-off sweep on a Lennard-Jones liquid (2048 atoms: `8^3` FCC cells at density
//! 0.8442, T = 1.44, cutoff 2.5, energies shifted at the cutoff so that the total energy
//! is a smooth function of the positions), melted for 400 steps in `f64` and then run from
//! that same liquid state by every mode:
//!
//! - **precision**: CPU `f64`, CPU `f32` and (with `--gpu`) the GPU backend (`f32`);
//! - **time step** `dt` in {0.001, 0.002, 0.005, 0.01}, each run to t = 5 (5000 to 500
//!   steps);
//! - **Verlet-list skin** in {0.1, 0.2, 0.3, 0.5, 0.8} (CPU `f64`, dt = 0.005).
//!
//! Measured per row: the force error against CPU `f64` on the liquid state (max and rms of
//! `|F - F_f64|` over all atoms, relative to the rms force), the energy error (max over the
//! run of `|E(t) - E(0)| / |E(0)|`, sampled every 0.1 time units through
//! `Simulation::step_observed`) and the throughput (atom-steps/s over the whole run, 2
//! rayon threads unless `RAYON_NUM_THREADS` says otherwise).
//!
//! ```text
//! cargo run --release --example md_tradeoffs                    # writes out/md_tradeoffs/
//! cargo run --release --example md_tradeoffs -- --gpu           # adds the GPU backend
//! cargo run --release --example md_tradeoffs -- --update-docs   # writes docs/tradeoffs/
//! ```
//! Prints the Markdown tables of `docs/tradeoffs/md.md` and writes `md.png` (energy error
//! against dt per mode, with a dt^2 guide) and `md.csv` (every row; `mode` 0 = CPU f64,
//! 1 = CPU f32, 2 = GPU; `sweep` 0 = time step, 1 = skin).

use std::ops::ControlFlow;
use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use simkit::backend::{Backend, GpuContext, Precision, Result, Simulation};
use simkit::md::{Config, LennardJones, Md, PairTable, System, scenes};
use simkit::output::csv::write_csv;
use simkit::output::plot::{Plot, Scale, Series, Style};

#[path = "common/progress.rs"]
mod progress;
#[path = "common/tradeoffs.rs"]
mod tradeoffs;

/// md trade-off sweep (precision, time step, Verlet skin) on a Lennard-Jones liquid:
/// force and energy errors and throughput; prints Markdown tables and writes md.png and
/// md.csv under out/md_tradeoffs/.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    /// Also run the GPU backend (f32) on the best adapter found
    #[arg(long)]
    gpu: bool,
    #[command(flatten)]
    out: tradeoffs::TradeoffArgs,
}

/// Time steps of the sweep (reduced units).
const DTS: [f64; 4] = [0.001, 0.002, 0.005, 0.01];
/// Skins of the sweep (absolute length, sigma units).
const SKINS: [f64; 5] = [0.1, 0.2, 0.3, 0.5, 0.8];
/// Simulated time of each run.
const DURATION: f64 = 5.0;
/// Energy samples per unit time.
const SAMPLES_PER_TIME: f64 = 10.0;

/// One run's figures.
struct Row {
    mode: String,
    dt: f64,
    skin: f64,
    force_max: f64,
    force_rms: f64,
    energy: f64,
    rate: f64,
}

/// The melted liquid every mode starts from.
fn liquid() -> Result<System> {
    let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5))?;
    let mut system = scenes::fcc_lattice([8; 3], 0.8442, 1.44, table, &[0], 87287)?;
    let mut melt = Md::new(
        system.clone(),
        &config(0.005, 0.3, Precision::F64),
        Backend::Cpu,
    )?;
    melt.step(400)?;
    let s = melt.state()?;
    system.set_particles(&s.species, &s.positions, &s.velocities)?;
    Ok(system)
}

fn config(dt: f64, skin: f64, precision: Precision) -> Config {
    let mut c = Config::default().with_dt(dt);
    c.skin = skin;
    c.precision = precision;
    c.shift = true;
    c
}

/// Max and rms of `|F - F_ref|` relative to the rms reference force.
fn force_error(reference: &[[f64; 3]], forces: &[[f64; 3]]) -> (f64, f64) {
    let n = reference.len() as f64;
    let norm = (reference.iter().flatten().map(|f| f * f).sum::<f64>() / n).sqrt();
    let diffs: Vec<f64> = reference
        .iter()
        .zip(forces)
        .map(|(a, b)| (0..3).map(|d| (a[d] - b[d]).powi(2)).sum::<f64>().sqrt())
        .collect();
    let max = diffs.iter().copied().fold(0.0, f64::max);
    let rms = (diffs.iter().map(|d| d * d).sum::<f64>() / n).sqrt();
    (max / norm, rms / norm)
}

/// Runs `system` to t = DURATION: (max relative energy error, atom-steps/s).
fn energy_run(system: &System, cfg: &Config, backend: Backend<'_>) -> Result<(f64, f64)> {
    let mut md = Md::new(system.clone(), cfg, backend)?;
    let e0 = md.diagnostics()?.total;
    let dt = md.dt();
    let steps = (DURATION / dt).round() as u64;
    let every = ((1.0 / SAMPLES_PER_TIME / dt).round() as u32).max(1);
    let mut worst = 0.0f64;
    let mut stepping = 0.0;
    let mut t = Instant::now();
    md.step_observed(steps, every, |md| {
        stepping += t.elapsed().as_secs_f64();
        let e = md.diagnostics()?.total;
        // A non-finite energy is the largest error there is (f64::max would skip a NaN).
        worst = if e.is_finite() {
            worst.max(((e - e0) / e0).abs())
        } else {
            f64::INFINITY
        };
        t = Instant::now();
        Ok(ControlFlow::Continue(()))
    })?;
    let atoms = system.particle_count() as f64;
    Ok((worst, atoms * steps as f64 / stepping))
}

fn main() -> ExitCode {
    simkit::cli::exit_code(run(&Args::parse()))
}

fn run(args: &Args) -> Result<()> {
    let system = liquid()?;
    let gpu = if args.gpu {
        Some(GpuContext::new()?)
    } else {
        None
    };
    let mut modes: Vec<(String, Precision, Backend<'_>)> = vec![
        ("CPU f64".into(), Precision::F64, Backend::Cpu),
        ("CPU f32".into(), Precision::F32, Backend::Cpu),
    ];
    if let Some(ctx) = &gpu {
        modes.push((
            format!("GPU f32 ({})", ctx.adapter_info().name),
            Precision::F32,
            Backend::Gpu(ctx),
        ));
    }
    let reference = Md::new(
        system.clone(),
        &config(0.005, 0.3, Precision::F64),
        Backend::Cpu,
    )?
    .forces()?;

    let runs = (modes.len() * DTS.len() + SKINS.len()) as u64;
    let bar = progress::bar("md sweep", runs, "runs");
    let mut rows = Vec::new();
    for (mode, precision, backend) in &modes {
        let forces =
            Md::new(system.clone(), &config(0.005, 0.3, *precision), *backend)?.forces()?;
        let (force_max, force_rms) = force_error(&reference, &forces);
        for &dt in &DTS {
            let (energy, rate) = energy_run(&system, &config(dt, 0.3, *precision), *backend)?;
            rows.push(Row {
                mode: mode.clone(),
                dt,
                skin: 0.3,
                force_max,
                force_rms,
                energy,
                rate,
            });
            bar.inc(1);
        }
    }
    let mut skins = Vec::new();
    for &skin in &SKINS {
        let (energy, rate) =
            energy_run(&system, &config(0.005, skin, Precision::F64), Backend::Cpu)?;
        skins.push(Row {
            mode: "CPU f64".into(),
            dt: 0.005,
            skin,
            force_max: 0.0,
            force_rms: 0.0,
            energy,
            rate,
        });
        bar.inc(1);
    }
    bar.finish_and_clear();

    println!(
        "| mode | dt | force error max | force error rms | energy error (t = 5) | atom-steps/s |"
    );
    println!("|---|---|---|---|---|---|");
    for r in &rows {
        println!(
            "| {} | {} | {:.2e} | {:.2e} | {:.2e} | {:.3e} |",
            r.mode, r.dt, r.force_max, r.force_rms, r.energy, r.rate
        );
    }
    println!("\n| skin | energy error (t = 5, dt = 0.005) | atom-steps/s (CPU f64) |");
    println!("|---|---|---|");
    for r in &skins {
        println!("| {} | {:.2e} | {:.3e} |", r.skin, r.energy, r.rate);
    }

    let dir = args.out.dir("md_tradeoffs");
    // mode: index into the printed mode list (0 CPU f64, 1 CPU f32, 2 GPU f32); sweep: 0
    // for the time-step rows, 1 for the skin rows.
    let mut csv = Vec::new();
    for (sweep, list) in [(0.0, &rows), (1.0, &skins)] {
        for r in list {
            let mode = modes.iter().position(|m| m.0 == r.mode).unwrap_or(0) as f64;
            csv.push([
                sweep,
                mode,
                r.dt,
                r.skin,
                r.force_max,
                r.force_rms,
                r.energy,
                r.rate,
            ]);
        }
    }
    let columns = [
        "sweep",
        "mode",
        "dt",
        "skin",
        "force_err_max",
        "force_err_rms",
        "energy_err",
        "atom_steps_per_s",
    ];
    write_csv(dir.join("md.csv"), &columns, &csv)?;

    let mut plot = Plot::new("md: energy error at t = 5 vs time step")
        .x_label("dt (LJ time units)")
        .y_label("max |E(t) - E(0)| / |E(0)|")
        .x_scale(Scale::Log10)
        .y_scale(Scale::Log10)
        .size(900, 560);
    for (mode, _, _) in &modes {
        let (xs, ys): (Vec<f64>, Vec<f64>) = rows
            .iter()
            .filter(|r| &r.mode == mode)
            .map(|r| (r.dt, r.energy.max(1e-12)))
            .unzip();
        plot = plot.series(Series::line(mode.clone(), &xs, &ys).style(Style::LinePoints));
    }
    // dt^2 guide through the CPU f64 point at dt = 0.005.
    if let Some(r) = rows.iter().find(|r| r.mode == "CPU f64" && r.dt == 0.005) {
        let ys: Vec<f64> = DTS
            .iter()
            .map(|dt| r.energy * (dt / 0.005).powi(2))
            .collect();
        plot = plot.series(Series::line("dt^2 guide", &DTS, &ys));
    }
    let path = dir.join("md.png");
    plot.write(&path)?;
    println!(
        "wrote {} and {}",
        path.display(),
        dir.join("md.csv").display()
    );
    Ok(())
}
