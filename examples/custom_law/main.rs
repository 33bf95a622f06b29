//! A pair law of your own, end to end: the Gaussian core model
//! (`examples/custom_law/gaussian_core.rs`, defined outside `simkit-md`) run as any
//! built-in law on the CPU and the GPU.
//!
//! ```text
//! cargo run --release --example custom_law [-- --cells N --steps N --cpu]
//! ```
//!
//! The run: a Gaussian-core fluid (`eps = 1`, `sigma = 1`, `r_c = 3.5`) of `4 N^3`
//! particles on an FCC lattice at density 0.5 and temperature 0.02 (a dense, soft fluid;
//! Stillinger's phase diagram puts it above the freezing line at this density), at constant
//! energy with the time step the library derives from the law's stiffness. It prints the
//! law-level GPU test (the law's WGSL against its Rust function, `check_law_on_gpu`), the
//! energy drift on each backend and the distance between the CPU's `f32` trajectory and the
//! GPU's; `out/custom_law/energy.csv` holds the energies per particle over time. With
//! `--cpu`, or without a GPU adapter, only the CPU runs.

mod gaussian_core;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;
use gaussian_core::GaussianCore;
use simkit::backend::{Backend, Error, GpuContext, Precision, Result, Simulation};
use simkit::md::{Config, Md, PairTable, System, check_law_on_gpu, scenes};
use simkit::output::csv::write_csv;

#[path = "../common/progress.rs"]
mod progress;

/// The Gaussian core model, a pair law defined outside simkit-md, on the CPU and the GPU.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    /// FCC unit cells per side (4 N^3 particles; at least 5: the periodic box must be twice
    /// the cutoff 3.5)
    #[arg(long, value_name = "N", default_value_t = 8)]
    cells: usize,
    /// Steps of each run
    #[arg(long, value_name = "N", default_value_t = 2000)]
    steps: u32,
    /// Run on the CPU only
    #[arg(long)]
    cpu: bool,
}

/// Energies per particle every this many steps.
const EVERY: u32 = 50;

fn main() -> ExitCode {
    simkit::cli::exit_code(run(&Args::parse()))
}

fn system(cells: usize) -> Result<System<GaussianCore>> {
    if cells < 5 {
        return Err(Error::invalid(
            "--cells",
            cells,
            "need at least 5 (the periodic box must be twice the cutoff 3.5 long)",
        ));
    }
    let law = GaussianCore {
        eps: 1.0,
        sigma: 1.0,
        r_c: 3.5,
    };
    scenes::fcc_lattice([cells; 3], 0.5, 0.02, PairTable::uniform(1, law)?, &[0], 11)
}

/// Energies per particle `(time, kinetic, potential, total)` every [`EVERY`] steps, and
/// the final positions.
type Run = (Vec<[f64; 4]>, Vec<[f64; 3]>);

/// Runs `steps` steps on `backend`.
fn run_on(
    system: &System<GaussianCore>,
    config: &Config,
    backend: Backend<'_>,
    steps: u32,
) -> Result<Run> {
    let mut md = Md::new(system.clone(), config, backend)?;
    let n = system.particle_count() as f64;
    let bar = progress::bar(&md.backend_name(), u64::from(steps), "steps");
    let mut rows = Vec::new();
    let mut record = |md: &mut Md<GaussianCore>| -> Result<()> {
        let d = md.diagnostics()?;
        rows.push([d.time, d.kinetic / n, d.potential / n, d.total / n]);
        Ok(())
    };
    record(&mut md)?;
    md.step_observed(u64::from(steps), EVERY, |md| {
        bar.set_position(md.steps_done());
        record(md)?;
        Ok(std::ops::ControlFlow::Continue(()))
    })?;
    bar.finish_and_clear();
    Ok((rows, md.state()?.positions))
}

/// The largest `|E(t) - E(0)|` per particle.
fn drift(rows: &[[f64; 4]]) -> f64 {
    rows.iter()
        .map(|r| (r[3] - rows[0][3]).abs())
        .fold(0.0, f64::max)
}

fn run(args: &Args) -> Result<()> {
    let system = system(args.cells)?;
    let config = Config::default();
    let dt = Md::new(system.clone(), &config, Backend::Cpu)?.dt();
    println!(
        "Gaussian core fluid: {} particles, density 0.5, T 0.02, dt {dt:.4} (from the law's \
         stiffness), {} steps",
        system.particle_count(),
        args.steps
    );
    let out = PathBuf::from("out/custom_law");
    let (cpu, cpu_x) = run_on(&system, &config, Backend::Cpu, args.steps)?;
    println!("cpu f64: energy drift {:.2e} per particle", drift(&cpu));
    let ctx = if args.cpu {
        None
    } else {
        match GpuContext::new() {
            Ok(ctx) => Some(ctx),
            Err(e) => {
                println!("no GPU ({e}): the CPU run only");
                None
            }
        }
    };
    let mut columns = vec!["time", "kinetic_cpu", "potential_cpu", "total_cpu"];
    let mut rows: Vec<Vec<f64>> = cpu.iter().map(|r| r.to_vec()).collect();
    if let Some(ctx) = &ctx {
        let law = system.table().as_slice()[0];
        let check = check_law_on_gpu(ctx, &[law], 64.0)?;
        println!(
            "law-level GPU test: {} evaluations, worst {:.1} f32 ulps of the term size",
            check.cases, check.worst_ulps
        );
        let f32_config = Config {
            precision: Precision::F32,
            ..config
        };
        let (_, cpu32_x) = run_on(&system, &f32_config, Backend::Cpu, args.steps)?;
        let (gpu, gpu_x) = run_on(&system, &config, Backend::Gpu(ctx), args.steps)?;
        // The largest distance between two runs' positions of a particle (minimum image:
        // the box is periodic).
        let len = system.lengths();
        let apart = |a: &[[f64; 3]], b: &[[f64; 3]]| {
            a.iter()
                .zip(b)
                .flat_map(|(p, q)| {
                    (0..3).map(move |d| {
                        let s = p[d] - q[d];
                        (s - len[d] * (s / len[d]).round()).abs()
                    })
                })
                .fold(0.0, f64::max)
        };
        println!(
            "gpu f32 ({}): energy drift {:.2e} per particle; after {} steps the GPU is {:.2e} \
             from the CPU in f32 and {:.2e} from the CPU in f64 (rounding, grown along a \
             chaotic trajectory)",
            ctx.adapter_info().name,
            drift(&gpu),
            args.steps,
            apart(&gpu_x, &cpu32_x),
            apart(&gpu_x, &cpu_x),
        );
        columns.extend(["kinetic_gpu", "potential_gpu", "total_gpu"]);
        for (row, g) in rows.iter_mut().zip(&gpu) {
            row.extend_from_slice(&g[1..]);
        }
    }
    write_csv(out.join("energy.csv"), &columns, &rows)?;
    println!(
        "energies per particle: {}",
        out.join("energy.csv").display()
    );
    Ok(())
}
