//! Builds a cell grid, enumerates every pair within the cutoff with each method of the
//! `neighbor` crate on the CPU and on the GPU, and prints pair counts and timings.
//!
//! Workload: N uniform random points at number density 1 in a periodic cube, cutoff 2.5
//! (about 65 neighbours each).
//!
//! ```text
//! cargo run --release --example neighbor_pairs [-- --n N]
//! ```
//! Options: `--n N` (points, 100,000; brute force runs too for N <= 20,000).

use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use indicatif::ProgressBar;
use rand::{RngExt, SeedableRng};
use simkit::backend::{GpuContext, Result};
use simkit::neighbor::{
    BruteForce, CellGrid, GpuNeighborSearch, LinkedCells, ListKind, NeighborSearch, SortedCells,
    VerletList,
};

#[path = "common/progress.rs"]
mod progress;

const CUTOFF: f64 = 2.5;

/// Every neighbour-search method of the `neighbor` crate, on the CPU and on the GPU: pair
/// counts and timings for N random points at density 1, cutoff 2.5.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    /// Number of points (uniform, number density 1, periodic cube)
    #[arg(long, value_name = "N", default_value_t = 100_000)]
    n: usize,
}

/// Runs `f` (build + enumerate, returning the pair count) 3 times; returns the best time.
fn best_of_3(mut f: impl FnMut() -> Result<usize>) -> Result<(f64, usize)> {
    let mut best = f64::INFINITY;
    let mut pairs = 0;
    for _ in 0..3 {
        let t = Instant::now();
        pairs = f()?;
        best = best.min(t.elapsed().as_secs_f64());
    }
    Ok((best, pairs))
}

/// Prints one result line (above the progress bar) and counts the method as done.
fn report(bar: &ProgressBar, name: &str, secs: f64, pairs: usize, reference: usize) {
    bar.inc(1);
    bar.suspend(|| {
        println!(
            "{name:<34} {pairs:>11} pairs  {:>9.2} ms  {:>9.3e} pairs/s  {}",
            secs * 1e3,
            pairs as f64 / secs,
            if pairs == reference { "ok" } else { "MISMATCH" }
        );
    });
}

fn main() -> ExitCode {
    simkit::cli::exit_code(run(&Args::parse()))
}

fn run(args: &Args) -> Result<()> {
    let n = args.n;
    let side = (n as f64).cbrt();
    let mut rng = rand_pcg::Pcg64::seed_from_u64(1);
    let p: Vec<[f64; 3]> = (0..n)
        .map(|_| std::array::from_fn(|_| rng.random::<f64>() * side))
        .collect();
    let grid = CellGrid::new([0.0; 3], [side; 3], [true; 3], CUTOFF)?;
    println!(
        "N = {n}, periodic cube of side {side:.2}, cutoff {CUTOFF}, {:?} cells, rayon threads {}",
        grid.cells_per_axis(),
        rayon::current_num_threads()
    );

    let mut sorted = SortedCells::new(&grid);
    sorted.build(&p)?;
    let reference = sorted.par_pair_count();
    println!(
        "{reference} pairs: {:.2} neighbours per particle (ideal gas 4/3 pi rc^3 = {:.2})\n",
        2.0 * reference as f64 / n as f64,
        4.0 / 3.0 * std::f64::consts::PI * CUTOFF.powi(3)
    );
    println!("method (build + all pairs)          pairs         time          rate");

    // Brute force (small N), 6 CPU methods and the GPU.
    let bar = progress::bar("methods", 7 + u64::from(n <= 20_000), "methods");
    if n <= 20_000 {
        let mut brute = BruteForce::new(&grid);
        let t = Instant::now();
        brute.build(&p)?;
        let k = brute.pair_count()?;
        let t = t.elapsed().as_secs_f64();
        report(&bar, "brute force O(N^2)", t, k, reference);
    }
    let mut linked = LinkedCells::new(&grid);
    let (t, k) = best_of_3(|| {
        linked.build(&p)?;
        linked.pair_count()
    })?;
    report(&bar, "linked cells, serial", t, k, reference);
    let (t, k) = best_of_3(|| {
        sorted.build(&p)?;
        sorted.pair_count()
    })?;
    report(&bar, "sorted cells half shell, serial", t, k, reference);
    let (t, k) = best_of_3(|| {
        sorted.build(&p)?;
        Ok(sorted.par_pair_count())
    })?;
    report(&bar, "sorted cells half shell, rayon", t, k, reference);
    let mut counts = vec![0u32; n];
    let (t, k) = best_of_3(|| {
        sorted.build(&p)?;
        counts.fill(0);
        sorted.par_for_each_particle(&mut counts, |c, _, _, _, _| *c += 1)?;
        Ok(counts.iter().map(|&c| c as usize).sum::<usize>() / 2)
    })?;
    report(&bar, "sorted cells full shell, rayon", t, k, reference);
    let mut verlet = VerletList::new(&grid, 0.3, ListKind::Half)?;
    let (t, k) = best_of_3(|| {
        verlet.build(&p)?;
        Ok(verlet
            .par_fold_pairs(|| 0usize, |k, _, _, _, _| *k += 1)
            .into_iter()
            .sum())
    })?;
    report(&bar, "Verlet half list (skin 0.3), build", t, k, reference);
    let (t, k) = best_of_3(|| {
        Ok(verlet
            .par_fold_pairs(|| 0usize, |k, _, _, _, _| *k += 1)
            .into_iter()
            .sum())
    })?;
    report(&bar, "Verlet half list, reuse only", t, k, reference);

    match GpuContext::new() {
        Ok(ctx) => {
            let mut gpu = GpuNeighborSearch::new(&ctx, &grid)?;
            gpu.build(&p)?;
            let (t, k) = best_of_3(|| {
                gpu.build(&p)?;
                Ok(gpu.half_list().neighbors.len())
            })?;
            report(
                &bar,
                "GPU cells + CSR half list + download",
                t,
                k,
                reference,
            );
            if k != reference {
                bar.suspend(|| println!(
                    "  GPU differs by {} pair(s): f32 cannot decide pairs at r2 within ~1e-7 of \
                     rc^2 (the tests check that every difference is such a pair)",
                    k.abs_diff(reference)
                ));
            }
            bar.suspend(|| println!("  (GPU: {})", ctx.summary()));
        }
        Err(e) => {
            bar.inc(1);
            bar.suspend(|| println!("GPU skipped: {e}"));
        }
    }
    bar.finish();
    Ok(())
}
