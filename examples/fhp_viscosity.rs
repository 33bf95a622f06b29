//! FHP shear viscosity from the decay of a sinusoidal shear wave, against the FHP-I theory
//! `nu(d) = 1/(12 d (1-d)^3) - 1/8`, for FHP-I and the full collision table.
//!
//! ```text
//! cargo run --release --example fhp_viscosity [-- WIDTH HEIGHT RUNS]
//! ```
//! Defaults: 8192 x 80 sites (wavelength 69 lattice units), 8 runs (seeds) per density,
//! averaged. Environment overrides: `SKIP` (steps before the fit, 30), `STOP` (fit until the
//! amplitude falls to this fraction, 0.3), `AMP` (velocity amplitude, 0.1). The measured
//! viscosity grows slowly with the wavelength (the logarithmic long-time-tail renormalisation
//! of 2D lattice gases), so compare at several heights: see docs/lattice-gas.md.

use std::time::Instant;

use simkit::lattice_gas::RuleSet;
use simkit::lattice_gas::viscosity::{ShearWave, fhp1_viscosity};

fn main() -> simkit::backend::Result<()> {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let width = args.first().copied().unwrap_or(8192);
    let height = args.get(1).copied().unwrap_or(80);
    let runs = args.get(2).copied().unwrap_or(8).max(1);
    println!(
        "shear-wave viscosity, {width} x {height} sites, {runs} runs per point (multi-spin CPU)\n"
    );
    println!(
        "{:<8} {:>6} {:>12} {:>10} {:>12} {:>9} {:>8}",
        "rules", "d", "nu measured", "+- (sem)", "nu FHP-I th", "error %", "time s"
    );
    for rules in [RuleSet::FhpI, RuleSet::Full] {
        for d in [0.15, 0.2, 0.3, 0.4, 0.5] {
            let t = Instant::now();
            let mut values = Vec::new();
            for seed in 0..runs as u32 {
                let wave = ShearWave {
                    rules,
                    seed: seed + 1,
                    skip: env_or("SKIP", 30.0) as u32,
                    stop_fraction: env_or("STOP", 0.3),
                    amplitude: env_or("AMP", 0.1),
                    ..ShearWave::new(width, height, d)
                };
                values.push(wave.measure()?.viscosity);
            }
            let n = values.len() as f64;
            let mean = values.iter().sum::<f64>() / n;
            let sem = if values.len() > 1 {
                (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0) / n).sqrt()
            } else {
                f64::NAN
            };
            let theory = fhp1_viscosity(d);
            let label = match rules {
                RuleSet::FhpI => "FHP-I",
                RuleSet::Full => "full",
            };
            println!(
                "{label:<8} {d:>6.2} {mean:>12.4} {sem:>10.4} {theory:>12.4} {:>9.2} {:>8.2}",
                100.0 * (mean / theory - 1.0),
                t.elapsed().as_secs_f64()
            );
        }
    }
    Ok(())
}

fn env_or(name: &str, default: f64) -> f64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}
