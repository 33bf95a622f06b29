//! neighbor: all pairs within the cutoff among 20 000 random points (number density 1,
//! periodic cube, cutoff 2.5), found by sorted cells + half shell (CPU, rayon) or by the GPU
//! cell list + CSR list, and cross-checked against linked cells.

use std::path::Path;
use std::time::Instant;

use rand::{RngExt, SeedableRng};
use simkit::backend::{Backend, Result};
use simkit::neighbor::{CellGrid, GpuNeighborSearch, LinkedCells, NeighborSearch, SortedCells};
use simkit::output::plot::{Plot, Series};

use crate::Row;

/// Builds and enumerates the pairs 5 times on the chosen backend, checks the pair count and
/// the per-particle neighbour counts against linked cells (CPU), compares the mean number of
/// neighbours with `4/3 pi rc^3` (density 1), and plots the neighbour-count histogram.
pub fn run(backend: Backend<'_>, out: &Path) -> Result<Row> {
    let n = 20_000usize;
    let rc = 2.5;
    let side = (n as f64).cbrt();
    let mut rng = rand_pcg::Pcg64::seed_from_u64(3);
    let p: Vec<[f64; 3]> = (0..n)
        .map(|_| std::array::from_fn(|_| rng.random::<f64>() * side))
        .collect();
    let grid = CellGrid::new([0.0; 3], [side; 3], [true; 3], rc)?;
    let repeats = 5u64;
    let t = Instant::now();
    let (name, pairs, counts) = match backend {
        Backend::Gpu(ctx) => {
            let mut s = GpuNeighborSearch::new(ctx, &grid)?;
            for _ in 0..repeats {
                s.build(&p)?;
            }
            let name = s.name();
            (name, s.half_list().neighbors.len(), s.neighbor_counts()?)
        }
        Backend::Cpu => {
            let mut s = SortedCells::new(&grid);
            let mut pairs = 0;
            for _ in 0..repeats {
                s.build(&p)?;
                pairs = s.par_pair_count();
            }
            let name = format!("CPU {} (rayon)", NeighborSearch::name(&s));
            (name, pairs, s.neighbor_counts()?)
        }
    };
    let secs = t.elapsed().as_secs_f64();
    let mut linked = LinkedCells::new(&grid);
    linked.build(&p)?;
    let want = linked.neighbor_counts()?;
    let same = counts == want;
    let mean = 2.0 * pairs as f64 / n as f64;
    let ideal = 4.0 / 3.0 * std::f64::consts::PI * rc * rc * rc;
    let max = counts.iter().copied().max().unwrap_or(0) as usize;
    let mut hist = vec![0.0f64; max + 1];
    for &c in &counts {
        hist[c as usize] += 1.0;
    }
    let x: Vec<f64> = (0..=max).map(|k| k as f64).collect();
    Plot::new(format!("neighbours within {rc} (N = {n}, density 1)"))
        .x_label("neighbours within r_c (count)")
        .y_label("particles (count)")
        .series(Series::line("count", &x, &hist))
        .write(out.join("neighbor_counts.png"))?;
    Ok(Row {
        scene: "neighbor: 20k points, rc 2.5".into(),
        backend: name,
        steps: repeats,
        throughput: pairs as f64 * repeats as f64 / secs,
        unit: "pairs/s (build + enumerate)",
        check: format!(
            "{pairs} pairs, mean {mean:.2} neighbours (ideal gas {ideal:.2}); counts equal to \
             linked cells: {}",
            if same { "yes" } else { "NO" }
        ),
    })
}
