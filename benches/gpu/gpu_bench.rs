//! Every crate's GPU path at realistic sizes, in one run, with the card's ceilings measured
//! by our own kernels in the same run, a check against the CPU on every row, the CPU paths'
//! scaling over rayon threads, and the ratio to each CUDA peer that `benches/gpu/peers.py`
//! measured on the same card just before (see `benches/gpu/README.md`).
//!
//! ```text
//! cargo run --release --example gpu_bench -- --out DIR [--quick] [--peers DIR/peers.csv]
//! ```
//!
//! Writes `DIR/table.md` (the table, printed last too), `DIR/samples.csv` (every timed
//! sample) and `DIR/adapter.md` (the adapter's name, driver and limits, printed first).
//! `--quick` runs tiny sizes (the CI check on lavapipe that keeps this program working).

mod ceilings;
mod cpu_scaling;
#[path = "../../examples/common/machine.rs"]
mod machine;
mod rows;

use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

use clap::Parser;
use simkit::backend::{Error, GpuContext, Result};

use ceilings::{Ceilings, median};
use rows::{Limit, Row};

/// Command-line options.
#[derive(Parser, Debug)]
#[command(about = "simkit's GPU paths at realistic sizes, one table (see benches/gpu/README.md)")]
struct Args {
    /// Folder for table.md, samples.csv and adapter.md (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// Tiny sizes: checks that every row still runs (CI, lavapipe), measures nothing useful.
    #[arg(long)]
    quick: bool,
    /// CSV of peer rates measured on the same card in the same run (`name,unit,rate`).
    #[arg(long)]
    peers: Option<PathBuf>,
    /// Run only the rows whose name contains one of these (comma separated).
    #[arg(long, value_delimiter = ',')]
    only: Vec<String>,
    /// Seconds for the CPU thread-scaling table (0 skips it).
    #[arg(long, default_value_t = 110.0)]
    cpu_seconds: f64,
    /// Seconds per timed sample of a GPU row.
    #[arg(long, default_value_t = 0.4)]
    sample_seconds: f64,
    /// Timed samples per GPU row.
    #[arg(long, default_value_t = 5)]
    samples: usize,
}

/// Timing settings shared by every row.
#[derive(Clone, Copy, Debug)]
pub struct Timing {
    /// Target seconds of one sample.
    pub sample_seconds: f64,
    /// Samples per row.
    pub samples: usize,
}

impl Timing {
    /// Calibrates `run(k)` (k steps, waited for) to about [`Timing::sample_seconds`] per call
    /// after a warm-up, then times [`Timing::samples`] calls; returns `(k, seconds of each)`.
    pub fn time(&self, mut run: impl FnMut(u32) -> Result<()>) -> Result<(u32, Vec<f64>)> {
        let clock = |run: &mut dyn FnMut(u32) -> Result<()>, k: u32| -> Result<f64> {
            let start = Instant::now();
            run(k)?;
            Ok(start.elapsed().as_secs_f64())
        };
        let t1 = clock(&mut run, 1)?;
        let mut k = ((self.sample_seconds / t1.max(1e-6)) as u32).clamp(1, 10_000);
        if k > 1 {
            let t = clock(&mut run, k)?;
            k = ((f64::from(k) * self.sample_seconds / t.max(1e-6)) as u32).clamp(1, 10_000);
        }
        let mut samples = Vec::with_capacity(self.samples);
        for _ in 0..self.samples {
            samples.push(clock(&mut run, k)?);
        }
        Ok((k, samples))
    }
}

fn main() {
    let args = Args::parse();
    if let Err(e) = run(&args) {
        eprintln!("gpu_bench: {e}");
        std::process::exit(1);
    }
}

fn run(args: &Args) -> Result<()> {
    std::fs::create_dir_all(&args.out).map_err(|e| io(&args.out, e))?;
    let ctx = GpuContext::new()?;
    let adapter = adapter_report(&ctx);
    print!("{adapter}");
    write(&args.out.join("adapter.md"), &adapter)?;
    let timing = if args.quick {
        Timing {
            sample_seconds: 0.02,
            samples: 2,
        }
    } else {
        Timing {
            sample_seconds: args.sample_seconds,
            samples: args.samples.max(1),
        }
    };
    let started = Instant::now();
    let (ceilings, mut done) = measure_ceilings(&ctx, args.quick, timing.samples)?;
    println!("{}", ceilings_line(&ceilings));
    let peers = match &args.peers {
        Some(path) => read_peers(path)?,
        None => Vec::new(),
    };
    for spec in rows::all(args.quick, ctx.has_f64()) {
        if !args.only.is_empty() && !args.only.iter().any(|o| spec.name.contains(o.as_str())) {
            continue;
        }
        let t0 = Instant::now();
        let row = rows::run(&spec, &ctx, timing);
        println!(
            "[{:>5.0} s] {} ({:.1} s): {}",
            started.elapsed().as_secs_f64(),
            row.name,
            t0.elapsed().as_secs_f64(),
            row.outcome()
        );
        done.push(row);
    }
    let scaling = if args.cpu_seconds > 0.0 {
        cpu_scaling::run(args.quick, args.cpu_seconds)
    } else {
        String::new()
    };
    let mut samples = String::from("row,unit,work_per_sample,seconds\n");
    for row in &done {
        for s in &row.samples {
            let _ = writeln!(
                samples,
                "{},{},{},{s}",
                row.name, row.unit, row.work_per_sample
            );
        }
    }
    write(&args.out.join("samples.csv"), &samples)?;
    let table = table(&ctx, &ceilings, &done, &peers, args.quick) + &scaling;
    write(&args.out.join("table.md"), &table)?;
    println!("\n{table}");
    println!("total {:.0} s", started.elapsed().as_secs_f64());
    Ok(())
}

fn io(path: &std::path::Path, e: std::io::Error) -> Error {
    Error::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

fn write(path: &std::path::Path, text: &str) -> Result<()> {
    std::fs::write(path, text).map_err(|e| io(path, e))
}

/// The adapter's name, driver and the limits the kernels are sized from.
fn adapter_report(ctx: &GpuContext) -> String {
    let info = ctx.adapter_info();
    let l = ctx.limits();
    let mut s = String::from("## Adapter\n\n");
    let _ = writeln!(
        s,
        "- name: {} ({:?}, {:?})",
        info.name, info.device_type, info.backend
    );
    let _ = writeln!(s, "- driver: {} {}", info.driver, info.driver_info);
    let _ = writeln!(
        s,
        "- vendor 0x{:04x}, device 0x{:04x}",
        info.vendor, info.device
    );
    let _ = writeln!(s, "- SHADER_F64: {}", ctx.has_f64());
    let _ = writeln!(
        s,
        "- subgroups: {}..{} lanes (SUBGROUP feature: {})",
        info.subgroup_min_size,
        info.subgroup_max_size,
        ctx.adapter().features().contains(wgpu::Features::SUBGROUP)
    );
    let _ = writeln!(
        s,
        "- max storage binding {} MiB, max buffer {} MiB, workgroup storage {} KiB",
        l.max_storage_buffer_binding_size >> 20,
        l.max_buffer_size >> 20,
        l.max_compute_workgroup_storage_size >> 10
    );
    let _ = writeln!(
        s,
        "- invocations per workgroup {}, workgroup size x {}, workgroups per dimension {}",
        l.max_compute_invocations_per_workgroup,
        l.max_compute_workgroup_size_x,
        l.max_compute_workgroups_per_dimension
    );
    let _ = writeln!(
        s,
        "- host: {} ({} threads)\n",
        cpu_scaling::cpu_model(),
        std::thread::available_parallelism().map_or(1, |n| n.get())
    );
    s
}

/// The ceilings, and their rows for the table (the copy compared with the peers' copy).
fn measure_ceilings(ctx: &GpuContext, quick: bool, samples: usize) -> Result<(Ceilings, Vec<Row>)> {
    let limit = ctx.limits().max_storage_buffer_binding_size;
    // 512 MiB per buffer: ten times the largest L2 of current cards.
    let bytes = if quick {
        1 << 22
    } else {
        (512u64 << 20).min(limit)
    };
    let row =
        |name: String, unit: &str, limit: Limit, peer: Option<&str>, (rate, t): (f64, Vec<f64>)| {
            Row {
                name,
                unit: unit.into(),
                work_per_sample: rate * median(&t),
                samples: t,
                limit,
                peer: peer.map(str::to_string),
                check: Ok("output checked".into()),
            }
        };
    let copy = ceilings::copy_bandwidth(ctx, bytes, samples)?;
    let items = if quick { 1 << 12 } else { 1 << 22 };
    let fma_f32 = ceilings::fma_rate(ctx, false, items, samples)?;
    let fma_f64 = if ctx.has_f64() {
        Some(ceilings::fma_rate(ctx, true, items / 4, samples)?)
    } else {
        None
    };
    let c = Ceilings {
        copy_bytes_per_s: copy.0,
        fma_f32: fma_f32.0,
        fma_f64: fma_f64.as_ref().map(|r| r.0),
    };
    let mut rows = vec![
        row(
            format!("ceiling: copy 2 x {} MiB (WGSL)", bytes >> 20),
            "B/s",
            Limit::Bytes(1.0),
            Some("cupy copy"),
            copy,
        ),
        row(
            "ceiling: FMA f32 (WGSL)".into(),
            "FLOP/s",
            Limit::FlopsF32(1.0),
            None,
            fma_f32,
        ),
    ];
    // What one dependent dispatch costs: the floor under a step made of many small kernels.
    let cost = ceilings::dispatch_cost(ctx, if quick { 100 } else { 2000 }, samples)?;
    for (what, pick) in [("recorded on the host", 0), ("executed on the device", 1)] {
        let t: Vec<f64> = cost
            .iter()
            .map(|c| if pick == 0 { c.0 } else { c.1 })
            .collect();
        rows.push(Row {
            name: format!("dependent dispatch, {what}"),
            unit: "dispatches/s".into(),
            work_per_sample: 1.0,
            samples: t,
            limit: Limit::None,
            peer: None,
            check: Ok("every dispatch counted, in order".into()),
        });
    }
    if let Some(r) = fma_f64 {
        rows.push(row(
            "ceiling: FMA f64 (WGSL)".into(),
            "FLOP/s",
            Limit::FlopsF64(1.0),
            None,
            r,
        ));
    }
    Ok((c, rows))
}

/// `name,unit,rate` lines (a header line and `#` comments skipped).
fn read_peers(path: &std::path::Path) -> Result<Vec<(String, f64)>> {
    let text = std::fs::read_to_string(path).map_err(|e| io(path, e))?;
    Ok(text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("name,"))
        .filter_map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f.len() >= 3)
                .then(|| {
                    f[2].trim()
                        .parse::<f64>()
                        .ok()
                        .map(|r| (f[0].trim().to_string(), r))
                })
                .flatten()
        })
        .collect())
}

/// The markdown table of every row.
fn table(
    ctx: &GpuContext,
    c: &Ceilings,
    rows: &[Row],
    peers: &[(String, f64)],
    quick: bool,
) -> String {
    let info = ctx.adapter_info();
    let mut s = String::new();
    let _ = writeln!(
        s,
        "## {} ({}){}\n",
        info.name,
        info.driver_info,
        if quick {
            " — quick sizes, not a measurement"
        } else {
            ""
        }
    );
    let _ = writeln!(s, "{}\n", ceilings_line(c));
    s.push_str(
        "| row | rate (median) | spread | of the limit | check vs CPU | peer (same run) | ratio |\n\
         |---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let rate = r.rate();
        let limit = match (r.limit, rate) {
            (Limit::Bytes(b), Some(x)) => {
                format!("{:.0} % of copy BW", 100.0 * x * b / c.copy_bytes_per_s)
            }
            (Limit::FlopsF32(f), Some(x)) => {
                format!("{:.0} % of FMA f32", 100.0 * x * f / c.fma_f32)
            }
            (Limit::FlopsF64(f), Some(x)) => c.fma_f64.map_or("n/a".into(), |p| {
                format!("{:.0} % of FMA f64", 100.0 * x * f / p)
            }),
            (Limit::None, _) | (_, None) => "n/a".into(),
        };
        let peer = r.peer.as_ref().and_then(|p| {
            peers
                .iter()
                .find(|(n, _)| n == p)
                .map(|(n, v)| (n.clone(), *v))
        });
        let (peer_cell, ratio) = match (&peer, rate) {
            (Some((n, v)), Some(x)) => (
                format!("{n}: {}", si(*v, &r.unit)),
                format!("{:.2}x", x / v),
            ),
            (None, _) if r.peer.is_some() => ("not run".into(), String::new()),
            _ => (String::new(), String::new()),
        };
        let (rate_cell, spread) = match rate {
            Some(x) => {
                let rates: Vec<f64> = r.samples.iter().map(|t| r.work_per_sample / t).collect();
                let lo = rates.iter().copied().fold(f64::INFINITY, f64::min);
                let hi = rates.iter().copied().fold(0.0, f64::max);
                (si(x, &r.unit), format!("{:.0} %", 100.0 * (hi - lo) / x))
            }
            None => ("—".into(), String::new()),
        };
        let _ = writeln!(
            s,
            "| {} | {rate_cell} | {spread} | {limit} | {} | {peer_cell} | {ratio} |",
            r.name,
            r.outcome()
        );
    }
    s.push('\n');
    s
}

/// The ceilings in one sentence.
fn ceilings_line(c: &Ceilings) -> String {
    format!(
        "Ceilings measured in this run: copy {} (read + write), FMA f32 {}{}.",
        si(c.copy_bytes_per_s, "B/s"),
        si(c.fma_f32, "FLOP/s"),
        c.fma_f64
            .map_or(String::new(), |r| format!(", FMA f64 {}", si(r, "FLOP/s")))
    )
}

/// `x` with an SI prefix and `unit`.
pub fn si(x: f64, unit: &str) -> String {
    let (v, p) = [(1e12, "T"), (1e9, "G"), (1e6, "M"), (1e3, "k")]
        .into_iter()
        .find(|(f, _)| x.abs() >= *f)
        .map_or((x, ""), |(f, p)| (x / f, p));
    format!("{v:.3} {p}{unit}")
}

/// The median rate of `samples` for `work` units per sample.
pub fn rate_of(work: f64, samples: &[f64]) -> f64 {
    work / median(samples)
}
