//! Body-force-driven channel (plane Poiseuille flow): walls on the top and bottom rows,
//! periodic in x, a force that turns west-movers into east-movers with probability p. Fits
//! the time-averaged velocity profile and prints the viscosity it implies, with the
//! acceleration measured in a periodic box at rest and with the local acceleration of each
//! row (see `simkit::lattice_gas::poiseuille`), against the FHP-I theory.
//!
//! ```text
//! cargo run --release --example poiseuille [-- --density D --force P --height H]
//! ```
//! Options (defaults): `--density` d = 0.2 (particles per link), `--force` p = 0.0005
//! (probability per site and step), `--height` 64 rows (4096 x 64 sites; other heights keep
//! ~2^18 sites); writes out/poiseuille/profile.csv. The in-suite check is
//! `crates/lattice-gas/tests/viscosity.rs::poiseuille_profile_gives_the_fhp_viscosity`.

use std::process::ExitCode;
use std::time::Duration;

use clap::Parser;
use indicatif::{ProgressBar, ProgressStyle};
use simkit::backend::Result;
use simkit::lattice_gas::PoiseuilleChannel;
use simkit::output::csv::write_csv;

/// Plane Poiseuille flow of the FHP lattice gas: fits the velocity profile and compares the
/// viscosity it implies with the FHP-I theory; writes out/poiseuille/profile.csv.
#[derive(Parser, Debug)]
#[command(version, allow_negative_numbers = true)]
struct Args {
    /// Reduced density d (mean occupation per link, in (0, 1))
    #[arg(long, value_name = "D", default_value_t = 0.2)]
    density: f64,
    /// Body force p: probability per site and step that a west-mover turns east (in (0, 1))
    #[arg(long, value_name = "P", default_value_t = 0.0005)]
    force: f64,
    /// Channel height in rows (even, at least 8); the width keeps about 2^18 sites
    #[arg(long, value_name = "ROWS", default_value_t = 64)]
    height: usize,
}

fn main() -> ExitCode {
    simkit::cli::exit_code(run(&Args::parse()))
}

fn run(args: &Args) -> Result<()> {
    let (d, p, h) = (args.density, args.force, args.height);
    // About 2^18 sites, the width a multiple of 64.
    let w = ((1usize << 18) / h.max(1)).div_ceil(64) * 64;
    let channel = PoiseuilleChannel::new(w, h, d, p);
    // One library call without a progress hook: a spinner with the elapsed time (drawn only
    // when stderr is a terminal).
    let style = ProgressStyle::with_template("{spinner} {msg} ({elapsed})")
        .expect("the spinner template is valid");
    let spinner = ProgressBar::new_spinner()
        .with_style(style)
        .with_message(format!(
            "measuring: {} steps of {w} x {h} sites",
            channel.relax + channel.average
        ));
    spinner.enable_steady_tick(Duration::from_millis(200));
    let t = std::time::Instant::now();
    let r = channel.measure();
    spinner.finish_and_clear();
    let r = r?;
    let elapsed = t.elapsed().as_secs_f64();
    println!(
        "Poiseuille channel {w} x {h}, d = {d}, p = {p}, {} steps ({elapsed:.1} s)",
        channel.relax + channel.average
    );
    println!(
        "acceleration g = {:.4e} per step (measured in a periodic box)",
        r.acceleration
    );
    println!("centre-line velocity {:.4}", r.centre_velocity);
    println!(
        "viscosity from the parabola and the at-rest g: {:.4}; FHP-I theory {:.4} ({:+.1} %)",
        r.nu_at_rest,
        r.theory,
        100.0 * (r.nu_at_rest / r.theory - 1.0)
    );
    println!(
        "viscosity with the local, velocity-dependent g(y): {:.4} ({:+.1} %)",
        r.nu_local,
        100.0 * (r.nu_local / r.theory - 1.0)
    );
    let rows: Vec<[f64; 2]> = r.profile.iter().map(|&(y, u)| [y, u]).collect();
    write_csv("out/poiseuille/profile.csv", &["y", "u_x"], &rows)?;
    Ok(())
}
