//! What each opt-in piece of the granular contact costs per particle-step, and what it
//! changes in a result: a 2D heap. `N` discs (radius 0.5, mass 1, `g = 1`) stand in a
//! column on a floor of the same material and collapse into a heap, under
//!
//! - the linear spring–dashpot with viscous Coulomb-capped friction (`Material`), without
//!   and with rotation,
//! - the linear law with a tangential spring per contact (`LinearHistory`), without and
//!   with rolling resistance,
//! - Hertz–Mindlin (`HertzMindlin`), without and with rolling resistance,
//!
//! on the CPU in `f64` and `f32`, all at the same time step and `mu = 0.5`. For each: the
//! wall time per particle-step over the whole run (2 threads on the machine of the table),
//! the kinetic energy left at the end (static friction brings a heap to rest; viscous
//! friction lets it creep on; without rolling resistance lone discs roll away) and the
//! deposit's height and runout (the distance from the centre line within which 95 % of the
//! discs lie).
//!
//! ```text
//! cargo run --release --example dem_contact_models                  # N = 1500
//! cargo run --release --example dem_contact_models -- --update-docs
//! ```
//! Prints a Markdown table; `--update-docs` also writes it to
//! `docs/tradeoffs/dem_contact_models.md` (else `out/dem_contact_models/`).

use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use simkit::backend::{Backend, Result, Simulation};
use simkit::dem::Solid;
use simkit::dem::{
    Config, ContactLaw, Dem, Dim, HertzMindlin, LinearHistory, Material, Particle, Precision, Scene,
};

#[path = "common/progress.rs"]
mod progress;
#[path = "common/tradeoffs.rs"]
mod tradeoffs;

/// Cost and effect of rotation, tangential history, Hertz–Mindlin and rolling resistance
/// on a 2D heap of discs; prints a Markdown table.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    /// Number of discs.
    #[arg(long, default_value_t = 1500)]
    n: usize,
    /// Simulated time of the collapse (time units of `sqrt(d / g)`).
    #[arg(long, default_value_t = 80.0)]
    time: f64,
    #[command(flatten)]
    out: tradeoffs::TradeoffArgs,
}

/// Time step of every run: 1/30 of the linear laws' contact time.
const DT: f64 = 1e-3;
const TC: f64 = 0.03;
/// Width of the column the heap falls from, in discs.
const COLUMN: usize = 40;
/// Width of the floor.
const WIDTH: f64 = 300.0;

/// The column: `n` discs in rows 1.02 apart, `COLUMN` per row at spacing 1.12 with a
/// random offset of up to 0.05 each (so that no two rows line up), centred on a floor
/// `WIDTH` long (walls at both ends).
fn column<L: ContactLaw>(law: L, n: usize, rotation: bool) -> Result<Scene<L>> {
    let rows = n.div_ceil(COLUMN);
    let height = 1.02 * rows as f64 + 2.0;
    let mut s = Scene::new(Dim::Two, [0.0; 3], [WIDTH, height, 0.0], law)?;
    s.set_gravity(1.0)?
        .set_rotation(rotation)
        .add_box_walls(law, false)?;
    let x0 = 0.5 * WIDTH - 0.56 * COLUMN as f64;
    for k in 0..n {
        let (i, j) = (k % COLUMN, k / COLUMN);
        let jitter = 0.1 * (simkit::backend::rng::rng_uniform(5, 0, k as u32) as f64 - 0.5);
        let p = [
            x0 + 0.56 + 1.12 * i as f64 + jitter,
            0.51 + 1.02 * j as f64,
            0.0,
        ];
        s.add_particle(Particle::new(p, 0.5, 1.0))?;
    }
    Ok(s)
}

/// The deposit's height (highest disc top) and runout: the distance from the centre line
/// within which 95 % of the discs lie (lone discs that roll away do not count).
fn deposit(positions: &[[f64; 3]]) -> (f64, f64) {
    let height = positions.iter().map(|x| x[1] + 0.5).fold(0.0, f64::max);
    let mut reach: Vec<f64> = positions
        .iter()
        .map(|x| (x[0] - 0.5 * WIDTH).abs() + 0.5)
        .collect();
    reach.sort_by(f64::total_cmp);
    let runout = reach[(0.95 * (reach.len() - 1) as f64).round() as usize];
    (height, runout)
}

/// Seconds per particle-step, kinetic energy per particle, deposit height and runout.
type Measured = (f64, f64, (f64, f64));

/// (seconds per particle-step, kinetic energy per particle, deposit height and runout).
fn measure<L: ContactLaw>(
    law: L,
    rotation: bool,
    precision: Precision,
    args: &Args,
) -> Result<Measured> {
    let config = Config::default().with_dt(DT).with_precision(precision);
    let mut sim = Dem::new(column(law, args.n, rotation)?, &config, Backend::Cpu)?;
    let steps = (args.time / DT) as u32;
    let t = Instant::now();
    sim.step(steps)?;
    let secs = t.elapsed().as_secs_f64() / (f64::from(steps) * args.n as f64);
    let d = sim.diagnostics()?;
    let s = sim.state()?;
    Ok((
        secs,
        (d.kinetic + d.rotational) / args.n as f64,
        deposit(&s.positions),
    ))
}

fn main() -> ExitCode {
    simkit::cli::exit_code(run(&Args::parse()))
}

fn run(args: &Args) -> Result<()> {
    let solid = Solid::new(1e5, 0.3);
    let hertz = HertzMindlin::new(solid, solid, 0.5, 0.5)?;
    let linear = LinearHistory::new(0.5, TC, 0.5);
    let viscous = Material::new(0.5, TC).with_friction(0.5, 40.0);
    let mut lines = vec![
        format!(
            "| contact model | rotation | precision | ns / particle-step | kinetic energy / particle at t = {} | deposit height | runout (95 %) |",
            args.time
        ),
        "|---|---|---|---|---|---|---|".to_string(),
    ];
    let bar = progress::bar("contact models", 12, "runs");
    for precision in [Precision::F64, Precision::F32] {
        let rows: Vec<(&str, bool, Measured)> = vec![
            (
                "linear, viscous friction",
                false,
                measure(viscous, false, precision, args)?,
            ),
            (
                "linear, viscous friction",
                true,
                measure(viscous, true, precision, args)?,
            ),
            (
                "linear + tangential spring",
                true,
                measure(linear, true, precision, args)?,
            ),
            (
                "linear + tangential spring + rolling (mu_r = 0.05)",
                true,
                measure(linear.with_rolling_friction(0.05), true, precision, args)?,
            ),
            (
                "Hertz–Mindlin",
                true,
                measure(hertz, true, precision, args)?,
            ),
            (
                "Hertz–Mindlin + rolling (mu_r = 0.05)",
                true,
                measure(
                    hertz.with_rolling(0.05, 2000.0, 20.0),
                    true,
                    precision,
                    args,
                )?,
            ),
        ];
        for (name, rotation, (secs, ke, heap)) in rows {
            bar.inc(1);
            lines.push(format!(
                "| {name} | {} | {precision:?} | {:.0} | {ke:.2e} | {:.1} | {:.1} |",
                if rotation { "yes" } else { "no" },
                secs * 1e9,
                heap.0,
                heap.1
            ));
        }
    }
    bar.finish();
    let table = lines.join("\n");
    println!("{table}");
    let dir = args.out.dir("dem_contact_models");
    std::fs::create_dir_all(&dir).map_err(|e| simkit::output::atomic::io_error(&dir, &e))?;
    let path = dir.join("dem_contact_models.md");
    let text = format!(
        "N = {} spheres, dt = {DT}, {} threads (`cargo run --release --example \
             dem_contact_models -- --n {}`)\n\n{table}\n",
        args.n,
        rayon::current_num_threads(),
        args.n
    );
    simkit::output::write_atomic(&path, |w| w.write_all(text.as_bytes()))?;
    println!("\nwrote {}", path.display());
    Ok(())
}
