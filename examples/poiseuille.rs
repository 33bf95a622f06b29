//! Body-force-driven channel (plane Poiseuille flow): walls on the top and bottom rows,
//! periodic in x, a force that turns west-movers into east-movers with probability p. Fits
//! the time-averaged velocity profile and prints the viscosity it implies, with the
//! acceleration measured in a periodic box at rest and with the local acceleration of each
//! row (see `simkit::lattice_gas::poiseuille`), against the FHP-I theory.
//!
//! ```text
//! cargo run --release --example poiseuille [-- DENSITY P HEIGHT]
//! ```
//! Defaults: d = 0.2, p = 0.0005, 64 rows (4096 x 64 sites; other heights keep ~2^18
//! sites); writes out/poiseuille/profile.csv. The in-suite check is
//! `crates/lattice-gas/tests/viscosity.rs::poiseuille_profile_gives_the_fhp_viscosity`.

use simkit::backend::Result;
use simkit::lattice_gas::poiseuille::PoiseuilleChannel;
use simkit::output::csv::write_csv;

fn main() -> Result<()> {
    let args: Vec<f64> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let d = args.first().copied().unwrap_or(0.2);
    let p = args.get(1).copied().unwrap_or(0.0005);
    let h = args.get(2).map_or(64, |&x| x as usize);
    // About 2^18 sites, the width a multiple of 64.
    let w = ((1usize << 18) / h.max(1)).div_ceil(64) * 64;
    let channel = PoiseuilleChannel::new(w, h, d, p);
    let t = std::time::Instant::now();
    let r = channel.measure()?;
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
