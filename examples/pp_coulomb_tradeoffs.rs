//! Trade-off sweep for `pp-coulomb`: precision (f64, f32 and the mixed mode), force law
//! (exclusion radius, softening) and time step, each as error against a reference versus
//! cost.
//!
//! ```text
//! cargo run --release --example pp_coulomb_tradeoffs                    # out/pp_coulomb_tradeoffs/
//! cargo run --release --example pp_coulomb_tradeoffs -- --update-docs   # docs/tradeoffs/
//! ```
//! Writes `pp-coulomb.md`, `pp-coulomb-energy.png` and `pp-coulomb-force.png` under
//! `out/pp_coulomb_tradeoffs/`; with `--update-docs`, under `docs/tradeoffs/` (the tracked
//! documentation) instead.

use std::fmt::Write as _;
use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use simkit::backend::{Backend, GpuContext, Result, Simulation};
use simkit::output::plot::{Plot, Scale, Series, Style};
use simkit::output::write_atomic;
use simkit::pp_coulomb::{
    Config, ForceLaw, Integrator, Particles, PpCoulomb, Precision, Region, Species, Velocities,
    reference_accelerations,
};

#[path = "common/machine.rs"]
mod machine;
#[path = "common/progress.rs"]
mod progress;
#[path = "common/tradeoffs.rs"]
mod tradeoffs;

/// pp-coulomb trade-off sweep: precision, force law and time step, each as error versus
/// cost; writes pp-coulomb.md and two plots under out/pp_coulomb_tradeoffs/.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    #[command(flatten)]
    out: tradeoffs::TradeoffArgs,
}

/// A neutral plasma: `n / 2` electrons (q = -1, m = 1) and `n / 2` ions (q = 1, m = 100),
/// uniform in a sphere of radius 10, Maxwellian (electrons 0.3, ions 0.03).
fn plasma(n: usize) -> Result<(Particles, f64)> {
    let radius = 10.0;
    let mut p = Particles::new();
    let e = p.add_species(Species::new("electron", -1.0, 1.0))?;
    let ion = p.add_species(Species::new("ion", 1.0, 100.0))?;
    let sphere = Region::Sphere {
        center: [0.0; 3],
        radius,
    };
    p.fill(
        e,
        n / 2,
        sphere,
        Velocities::Maxwellian { thermal_speed: 0.3 },
        1,
    )?;
    p.fill(
        ion,
        n - n / 2,
        sphere,
        Velocities::Maxwellian {
            thermal_speed: 0.03,
        },
        2,
    )?;
    // Mean interparticle spacing.
    let spacing = radius * (4.0 * std::f64::consts::PI / (3.0 * n as f64)).cbrt();
    Ok((p, spacing))
}

fn l2_relative(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        for k in 0..3 {
            num += (x[k] - y[k]).powi(2);
            den += y[k] * y[k];
        }
    }
    (num / den).sqrt()
}

/// Median over particles of |a_i - b_i| / |b_i|.
fn median_relative(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let norm = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let mut r: Vec<f64> = a
        .iter()
        .zip(b)
        .map(|(x, y)| norm([x[0] - y[0], x[1] - y[1], x[2] - y[2]]) / norm(*y))
        .collect();
    r.sort_by(f64::total_cmp);
    r[r.len() / 2]
}

/// Seconds per force evaluation (median of `reps` symplectic-Euler steps).
fn time_per_eval(p: &Particles, config: Config, b: Backend<'_>, reps: usize) -> Result<f64> {
    let config = config.with_integrator(Integrator::SymplecticEuler);
    let mut sim = PpCoulomb::new(p.clone(), &config, b)?;
    sim.step(1)?;
    sim.state()?;
    let mut times = Vec::new();
    for _ in 0..reps {
        let t = Instant::now();
        sim.step(1)?;
        sim.state()?; // waits for GPU work
        times.push(t.elapsed().as_secs_f64());
    }
    times.sort_by(f64::total_cmp);
    Ok(times[times.len() / 2])
}

struct EnergyRun {
    label: String,
    error: f64,
    seconds_per_unit_time: f64,
}

/// An energy run's result.
struct Energies {
    /// Max |E(t) - E(0)| / K(0) over the samples.
    worst: f64,
    /// Wall seconds of stepping per unit simulated time.
    cost: f64,
    /// E(t) at the 21 samples (t = 0 and after each of 20 chunks), and K(0).
    samples: Vec<f64>,
    k0: f64,
}

/// Runs `p` under `config` on the CPU to `t_end` in 20 chunks, sampling the energy.
fn energy_run(p: &Particles, config: Config, t_end: f64) -> Result<Energies> {
    let mut sim = PpCoulomb::new(p.clone(), &config, Backend::Cpu)?;
    let d0 = sim.diagnostics()?;
    let steps = (t_end / config.dt).round() as u32;
    let chunks = 20;
    let mut worst: f64 = 0.0;
    let mut stepping = 0.0;
    let mut samples = vec![d0.total];
    for _ in 0..chunks {
        let t = Instant::now();
        sim.step(steps / chunks)?;
        stepping += t.elapsed().as_secs_f64();
        let d = sim.diagnostics()?;
        worst = worst.max((d.total - d0.total).abs() / d0.kinetic);
        samples.push(d.total);
    }
    Ok(Energies {
        worst,
        cost: stepping / sim.time(),
        samples,
        k0: d0.kinetic,
    })
}

/// The precision column: `F64`, `F32` or `mixed` (f32 pairs, f64 sums and state).
fn mode_name(prec: Precision, mixed: bool) -> String {
    if mixed {
        "mixed".into()
    } else {
        format!("{prec:?}")
    }
}

fn main() -> ExitCode {
    simkit::cli::exit_code(run(&Args::parse()))
}

fn run(args: &Args) -> Result<()> {
    let dir = args.out.dir("pp_coulomb_tradeoffs");
    let gpu = GpuContext::new().ok();
    let mut md = String::new();
    let cpu_name = machine::cpu_model().unwrap_or_else(|| "unknown CPU".into());
    let threads = rayon::current_num_threads();
    writeln!(md, "# pp-coulomb trade-offs\n").ok();
    writeln!(
        md,
        "Generated by `cargo run --release --example pp_coulomb_tradeoffs -- --update-docs` on {cpu_name} \
         ({threads} rayon threads){}. Scene: a neutral plasma of electrons (q = -1, m = 1) and \
         ions (q = 1, m = 100), uniform in a sphere of radius 10, Maxwellian velocities \
         (electrons 0.3, ions 0.03), normalised units (k_e = 1). Timings are wall-clock on a \
         shared machine: expect 10-40 % noise.\n",
        gpu.as_ref()
            .map(|c| format!("; GPU adapter: {}", c.adapter_info().name))
            .unwrap_or_default()
    )
    .ok();

    // 1. Precision and force law: force error against exact f64 versus time per evaluation.
    let n_force = 8192;
    let (p, spacing) = plasma(n_force)?;
    let exact = reference_accelerations(&p, ForceLaw::Exact)?;
    writeln!(
        md,
        "## Force error versus cost (N = {n_force}, mean spacing a = {spacing:.3})\n"
    )
    .ok();
    writeln!(
        md,
        "Force error: L2 relative difference of all accelerations against the exact law summed by a plain scalar f64 loop. \
        The exclusion and softening rows measure the model error of the law itself. Precision `mixed` is the CPU's mixed mode \
        (`Config::with_mixed(true)` with `Precision::F32`): pair terms in f32 from the f64 separations rounded to f32, \
        sums, accelerations and the particle state in f64.\n"
    )
    .ok();
    writeln!(md, "| backend | precision | force law | force error (L2) | median per-particle error | ms per evaluation | pair interactions/s |").ok();
    writeln!(md, "|---|---|---|---|---|---|---|").ok();
    let mut laws = vec![("exact".to_string(), ForceLaw::Exact)];
    for f in [0.1, 0.3, 1.0] {
        laws.push((
            format!("Plummer eps = {f} a"),
            ForceLaw::Plummer {
                epsilon: f * spacing,
            },
        ));
    }
    for f in [0.3, 1.0] {
        laws.push((
            format!("exclusion c = {f} a"),
            ForceLaw::Exclusion {
                radius: f * spacing,
            },
        ));
    }
    // (name, backend, precision, rsqrt, mixed)
    let mut variants: Vec<(String, Backend<'_>, Precision, bool, bool)> = Vec::new();
    for (name, rsqrt) in [("cpu avx512-rsqrt", true), ("cpu sqrt+div", false)] {
        for (prec, mixed) in [
            (Precision::F64, false),
            (Precision::F32, false),
            (Precision::F32, true),
        ] {
            variants.push((name.into(), Backend::Cpu, prec, rsqrt, mixed));
        }
    }
    if let Some(ctx) = &gpu {
        variants.push((
            "gpu".into(),
            Backend::Gpu(ctx),
            Precision::F32,
            false,
            false,
        ));
        if ctx.has_f64() {
            variants.push((
                "gpu".into(),
                Backend::Gpu(ctx),
                Precision::F64,
                false,
                false,
            ));
        }
    }
    let mut force_series: Vec<Series> = Vec::new();
    let interactions = (n_force * (n_force - 1)) as f64;
    let bar = progress::bar(
        "force laws",
        (variants.len() * laws.len()) as u64,
        "configurations",
    );
    for (name, backend, prec, rsqrt, mixed) in &variants {
        let (mut xs, mut ys) = (Vec::new(), Vec::new());
        let mode = mode_name(*prec, *mixed);
        for (label, law) in &laws {
            let config = Config::new(1e-9, *law)
                .with_precision(*prec)
                .with_rsqrt(*rsqrt)
                .with_mixed(*mixed);
            let acc = PpCoulomb::new(p.clone(), &config, *backend)?.accelerations()?;
            let err = l2_relative(&acc, &exact).max(1e-17);
            let med = median_relative(&acc, &exact);
            let reps = if matches!(backend, Backend::Gpu(_)) {
                3
            } else {
                5
            };
            let t = time_per_eval(&p, config, *backend, reps)?;
            writeln!(
                md,
                "| {name} | {mode} | {label} | {err:.2e} | {med:.2e} | {:.1} | {:.2e} |",
                t * 1e3,
                interactions / t
            )
            .ok();
            bar.inc(1);
            bar.suspend(|| {
                println!("{name} {mode} {label}: error {err:.2e}, {:.1} ms", t * 1e3);
            });
            if label == "exact" || label.starts_with("Plummer") {
                xs.push(t * 1e3);
                ys.push(err);
            }
        }
        force_series.push(
            Series::points(
                format!("{name} {mode} (exact, Plummer 0.1/0.3/1 a)"),
                &xs,
                &ys,
            )
            .style(Style::LinePoints),
        );
    }
    let mut plot = Plot::new(format!("Force error vs cost, N = {n_force}"))
        .x_label("ms per force evaluation")
        .y_label("L2 relative force error vs exact f64")
        .x_scale(Scale::Log10)
        .y_scale(Scale::Log10);
    for s in force_series {
        plot.push(s);
    }
    bar.finish();
    plot.write(dir.join("pp-coulomb-force.png"))?;

    // 2. Time step, integrator and force law: energy error versus cost.
    let n_energy = 1024;
    let (p, spacing) = plasma(n_energy)?;
    let t_end = 8.0;
    let omega_pe = (4.0 * std::f64::consts::PI * (n_energy as f64 / 2.0)
        / (4.0 / 3.0 * std::f64::consts::PI * 1000.0))
        .sqrt();
    writeln!(md, "\n## Energy error versus cost (N = {n_energy}, CPU f64, t = 0..{t_end}, omega_pe = {omega_pe:.2}, a = {spacing:.3})\n").ok();
    writeln!(md, "Energy error: max over 20 samples of |E(t) - E(0)| / K(0). Cost: wall seconds of stepping per unit of simulated time. \
        The runs have the energy guard off (`Config::with_energy_tolerance(None)`): with it on (the default), the exact-law runs \
        stop with `Error::BlowUp` at their first unresolved close approach.\n").ok();
    writeln!(
        md,
        "| integrator | force law | dt | omega_pe dt | energy error | s per unit time |"
    )
    .ok();
    writeln!(md, "|---|---|---|---|---|---|").ok();
    let mut runs: Vec<EnergyRun> = Vec::new();
    let cases = [
        (
            "leapfrog",
            Integrator::Leapfrog,
            "Plummer eps = 0.3 a",
            ForceLaw::Plummer {
                epsilon: 0.3 * spacing,
            },
        ),
        (
            "leapfrog",
            Integrator::Leapfrog,
            "Plummer eps = 0.1 a",
            ForceLaw::Plummer {
                epsilon: 0.1 * spacing,
            },
        ),
        ("leapfrog", Integrator::Leapfrog, "exact", ForceLaw::Exact),
        (
            "symplectic Euler",
            Integrator::SymplecticEuler,
            "Plummer eps = 0.3 a",
            ForceLaw::Plummer {
                epsilon: 0.3 * spacing,
            },
        ),
        (
            "leapfrog",
            Integrator::Leapfrog,
            "exclusion c = 0.3 a",
            ForceLaw::Exclusion {
                radius: 0.3 * spacing,
            },
        ),
    ];
    let bar = progress::bar("energy", 4 * cases.len() as u64, "runs");
    for (iname, integ, lname, law) in cases {
        for dt in [0.1, 0.05, 0.025, 0.0125] {
            // The energy guard off: it would stop the exact-law runs at their first
            // unresolved close approach, and these rows measure how far the energy goes.
            let config = Config::new(dt, law)
                .with_integrator(integ)
                .with_energy_tolerance(None);
            let Energies {
                worst: err, cost, ..
            } = energy_run(&p, config, t_end)?;
            writeln!(
                md,
                "| {iname} | {lname} | {dt} | {:.3} | {err:.2e} | {cost:.3} |",
                omega_pe * dt
            )
            .ok();
            bar.inc(1);
            bar.suspend(|| {
                println!(
                    "{iname} {lname} dt {dt}: energy error {err:.2e}, {cost:.3} s per unit time"
                );
            });
            runs.push(EnergyRun {
                label: format!("{iname}, {lname}"),
                error: err.max(1e-16),
                seconds_per_unit_time: cost,
            });
        }
    }
    let mut plot = Plot::new(format!("Energy error vs cost, N = {n_energy}"))
        .x_label("wall seconds per unit simulated time")
        .y_label("max |E(t) - E(0)| / K(0)")
        .x_scale(Scale::Log10)
        .y_scale(Scale::Log10);
    let mut labels: Vec<String> = runs.iter().map(|r| r.label.clone()).collect();
    labels.dedup();
    for label in labels {
        let sel: Vec<&EnergyRun> = runs.iter().filter(|r| r.label == label).collect();
        let x: Vec<f64> = sel.iter().map(|r| r.seconds_per_unit_time).collect();
        let y: Vec<f64> = sel.iter().map(|r| r.error).collect();
        plot.push(Series::points(label, &x, &y).style(Style::LinePoints));
    }
    bar.finish();
    plot.write(dir.join("pp-coulomb-energy.png"))?;

    // 3. Precision and energy: the same leapfrog runs in f64, f32 and the mixed mode.
    let eps = 0.3 * spacing;
    writeln!(
        md,
        "\n## Energy error versus precision (N = {n_energy}, CPU, leapfrog, Plummer eps = 0.3 a, t = 0..{t_end})\n"
    )
    .ok();
    writeln!(
        md,
        "The scene, samples and cost of the table above, one run per precision and dt. Energy error: \
         max |E(t) - E(0)| / K(0) (the integrator's error plus rounding). Deviation from f64: \
         max |E(t) - E_f64(t)| / K(0) against the f64 run with the same dt, at the same 20 samples \
         (the part of the error that the precision adds).\n"
    )
    .ok();
    writeln!(
        md,
        "| precision | dt | energy error | deviation from f64 | s per unit time |"
    )
    .ok();
    writeln!(md, "|---|---|---|---|---|").ok();
    let modes = [
        (Precision::F64, false),
        (Precision::F32, false),
        (Precision::F32, true),
    ];
    let dts = [0.025, 0.0125];
    let bar = progress::bar("precision", (modes.len() * dts.len()) as u64, "runs");
    for dt in dts {
        let mut f64_samples: Vec<f64> = Vec::new();
        for (prec, mixed) in modes {
            let config = Config::new(dt, ForceLaw::Plummer { epsilon: eps })
                .with_precision(prec)
                .with_mixed(mixed);
            let run = energy_run(&p, config, t_end)?;
            if f64_samples.is_empty() {
                f64_samples = run.samples.clone();
            }
            let deviation = run
                .samples
                .iter()
                .zip(&f64_samples)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max)
                / run.k0;
            let mode = mode_name(prec, mixed);
            writeln!(
                md,
                "| {mode} | {dt} | {:.3e} | {deviation:.2e} | {:.4} |",
                run.worst, run.cost
            )
            .ok();
            bar.inc(1);
            bar.suspend(|| {
                println!(
                    "{mode} dt {dt}: energy error {:.3e}, deviation from f64 {deviation:.2e}, \
                     {:.4} s per unit time",
                    run.worst, run.cost
                );
            });
        }
    }
    bar.finish();

    writeln!(md, "\n![force error vs cost](pp-coulomb-force.png)\n\n![energy error vs cost](pp-coulomb-energy.png)\n").ok();
    writeln!(md, "## Reading the tables\n").ok();
    let notes = [
        "Precision: CPU f32 runs about 2.4x the f64 rate and adds a force error of about 5e-6 \
         (L2) / 7e-7 (median per particle), far below the model error of any softening. Use \
         f64 for conservation checks. The GPU f32 median error is higher (4e-6) because WGSL \
         `inverseSqrt` is allowed 2 ulp; GPU f64 matches the CPU to 1e-15.",
        "Mixed mode (`Config::with_mixed(true)` with `Precision::F32`, CPU only): the f32 pair \
         kernel runs on separations formed from the f64 positions (each coordinate split into an \
         f32 high and an f32 low part), and the sums over blocks, the accelerations, positions, \
         velocities and the integrator are f64. Its force error is about 20x below f32's and, \
         unlike f32's, does not depend on how far the particles are from the origin (f32 \
         coordinates lose |x| / r times the rounding on a pair at distance r); an evaluation \
         takes about 1.3x the time of f32 and two thirds of f64's. Over a run its energy stays \
         within 1e-7 of K(0) of the f64 run's, where f32 departs by 5e-7 to 2e-6 (the \
         precision table). Pick it for long runs, conservation checks or systems far from the origin when \
         f64 is too slow; pure f32 when a 5e-6 force error is affordable.",
        "Accumulation: the CPU f32 mode already adds its sums over blocks of 1024 sources in \
         f64 (16 lanes of f32 partial sums within a block), so its summation error does not \
         grow with N; its force error grows with N through ever closer pairs, whose separations \
         carry the rounding of the coordinates. The GPU sums in f32 and has no mixed mode.",
        "CPU paths: the AVX-512 rsqrt + Newton path has the accuracy of sqrt + divide (same \
         errors in the table). On this AMD EPYC, whose vector square root and division are fast, \
         it gains up to ~10 % in f32 and is within the noise in f64; on CPUs with slow 512-bit sqrt/div (Skylake/Cascade Lake) the \
         gain should be larger (not measured here).",
        "Force laws: the L2 force error is dominated by the few closest electron-ion pairs, whose \
         forces are the largest; the median per-particle error shows the typical particle. \
         Plummer eps = 0.1 a changes the typical force by ~4 %, eps = a by ~80 %.",
        "Exact law with attracting species: electron-ion pairs fall into tight orbits (the bare \
         1/r potential has no floor), and the energy error exceeds K(0) at every step size \
         tried. Use softening whenever opposite charges meet; keep the exact law for \
         same-sign systems (Coulomb explosion, Rutherford scattering).",
        "Softening + leapfrog: the energy error falls as dt^2 (4x per halving) once dt resolves \
         the softened encounters (omega dt < ~0.06 for eps = 0.1 a).",
        "The exclusion radius (the source's choice) makes the force discontinuous at r = c: \
         pairs crossing c jump in potential energy, and the energy error (~1.5 K(0) here) does \
         not shrink with dt.",
        "Symplectic Euler (the source's scheme) has a first-order energy error (2x per \
         halving): at equal cost it is 10-100x less accurate than leapfrog.",
    ];
    for note in notes {
        writeln!(md, "- {note}").ok();
    }
    write_atomic(dir.join("pp-coulomb.md"), |w| w.write_all(md.as_bytes()))?;
    println!(
        "wrote {}/pp-coulomb.md, pp-coulomb-force.png and pp-coulomb-energy.png",
        dir.display()
    );
    Ok(())
}
