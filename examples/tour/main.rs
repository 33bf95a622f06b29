//! The simkit tour: lists the adapters, runs each crate's flagship scene at a small size on
//! the best backend available, writes pictures and data under `out/`, and prints a summary.
//!
//! ```text
//! cargo run --release --example tour            # best backend (GPU if any, else CPU)
//! cargo run --release --example tour -- --cpu   # force the CPU backends
//! ```
//! Options: `--cpu` (run every scene on the CPU backends). Exits non-zero if a scene fails.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use simkit::backend::{Backend, GpuContext, Result};

// The scenes that can run longer than a second show a progress bar.
#[path = "../common/progress.rs"]
mod progress;

// Scene modules: one per crate, each `pub fn run(backend: Backend<'_>, out: &Path) -> Result<Row>`.
// TOUR-MODULES (keep this marker: crate work adds `mod <crate>;` lines below it)
mod dem;
mod lattice_gas;
mod md;
mod neighbor;
mod pp_coulomb;
mod rd;

/// The simkit tour: every crate's flagship scene at a small size on the best backend found
/// (a GPU if any, else the CPU), with pictures and data under out/tour/ and a summary table.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    /// Run every scene on the CPU backends, even when a GPU is available
    #[arg(long)]
    cpu: bool,
}

/// One line of the summary table.
pub struct Row {
    /// Scene name.
    pub scene: String,
    /// Backend that ran it.
    pub backend: String,
    /// Steps taken.
    pub steps: u64,
    /// Throughput in the field's unit.
    pub throughput: f64,
    /// The unit of `throughput` (e.g. "pair evaluations/s").
    pub unit: &'static str,
    /// One validation figure, as text (e.g. "restitution 0.899 (want 0.9)").
    pub check: String,
}

type Scene = fn(Backend<'_>, &Path) -> Result<Row>;

fn scenes() -> Vec<(&'static str, Scene)> {
    vec![
        // TOUR-SCENES (keep this marker: crate work adds `("name", module::run),` lines below it)
        ("dem", dem::run),
        ("neighbor", neighbor::run),
        ("lattice_gas", lattice_gas::run),
        ("rd", rd::run),
        ("pp_coulomb", pp_coulomb::run),
        ("md", md::run),
    ]
}

fn main() -> ExitCode {
    let force_cpu = Args::parse().cpu;
    let out = PathBuf::from("out/tour");
    println!("simkit tour\n===========\n");
    let adapters = GpuContext::list_adapters();
    if adapters.is_empty() {
        println!("GPU adapters: none found (install a Vulkan driver, e.g. mesa-vulkan-drivers).");
    } else {
        println!("GPU adapters (best first):");
        for a in &adapters {
            println!("  - {a}");
        }
    }
    let ctx = if force_cpu {
        println!("--cpu given: running every scene on the CPU backend.\n");
        None
    } else {
        match GpuContext::new() {
            Ok(ctx) => {
                println!("Using GPU adapter: {}\n", ctx.summary());
                Some(ctx)
            }
            Err(e) => {
                println!("No usable GPU ({e}).\nRunning every scene on the CPU backend.\n");
                None
            }
        }
    };
    let backend = ctx.as_ref().map_or(Backend::Cpu, Backend::Gpu);
    let mut rows = Vec::new();
    let mut failures = 0;
    for (name, scene) in scenes() {
        let t = Instant::now();
        print!("running {name} ... ");
        match scene(backend, &out.join(name)) {
            Ok(row) => {
                println!("done in {:.2} s", t.elapsed().as_secs_f64());
                rows.push(row);
            }
            Err(e) => {
                println!("FAILED: {e}");
                failures += 1;
            }
        }
    }
    print_table(&rows);
    println!("\nOutputs under {}/", out.display());
    if failures > 0 {
        eprintln!("{failures} scene(s) failed");
        return ExitCode::FAILURE;
    }
    ExitCode::SUCCESS
}

fn print_table(rows: &[Row]) {
    let width = |title: &str, f: &dyn Fn(&Row) -> usize| {
        rows.iter().map(f).max().unwrap_or(0).max(title.len())
    };
    let ws = width("scene", &|r| r.scene.chars().count());
    let wb = width("backend", &|r| r.backend.chars().count());
    let wu = width("unit", &|r| r.unit.chars().count());
    println!(
        "\n{:<ws$}  {:<wb$}  {:>8}  {:>10}  {:<wu$}  validation",
        "scene", "backend", "steps", "throughput", "unit"
    );
    println!("{}", "-".repeat(ws + wb + wu + 44));
    for r in rows {
        println!(
            "{:<ws$}  {:<wb$}  {:>8}  {:>10.3e}  {:<wu$}  {}",
            r.scene, r.backend, r.steps, r.throughput, r.unit, r.check
        );
    }
}
