//! neighbor trade-off sweep: Verlet skin vs rebuild frequency vs time per step, for
//! particles on a random walk. Writes `docs/tradeoffs/neighbor.md` and
//! `docs/tradeoffs/neighbor.png`.
//!
//! N = 20000 points at number density 1 in a periodic cube, cutoff rc = 2.5; every step each
//! particle moves by `delta` (0.01, 0.03, 0.1 rc) in a random diagonal direction, then the
//! list is updated (rebuilt only when `needs_rebuild`) and every pair within rc is
//! enumerated (rayon). Baseline: sorted cells rebuilt every step (no list).
//! `cargo run --release --example neighbor_tradeoffs`

use std::fmt::Write as _;
use std::time::Instant;

use output::plot::{Plot, Scale, Series};
use rand::{RngExt, SeedableRng};
use simkit::backend::{Error, Result};
use simkit::neighbor::{CellGrid, ListKind, SortedCells, VerletList};

const N: usize = 20_000;
const RC: f64 = 2.5;
const STEPS: usize = 100;
const DELTAS: [f64; 3] = [0.01, 0.03, 0.1];
const SKINS: [f64; 7] = [0.02, 0.05, 0.1, 0.2, 0.3, 0.5, 0.8];

fn walk(rng: &mut rand_pcg::Pcg64, p: &mut [[f64; 3]], delta: f64) {
    let a = delta / 3f64.sqrt();
    for q in p.iter_mut() {
        for x in q.iter_mut() {
            *x += if rng.random::<bool>() { a } else { -a };
        }
    }
}

/// Runs the walk with a Verlet list of skin `skin` (or sorted cells every step for `None`);
/// returns (seconds per step, rebuilds, pairs at the last step).
fn run(
    grid: &CellGrid<3>,
    start: &[[f64; 3]],
    delta: f64,
    skin: Option<f64>,
) -> Result<(f64, u64, usize)> {
    let mut rng = rand_pcg::Pcg64::seed_from_u64(9);
    let mut p = start.to_vec();
    let mut pairs = 0;
    let t = Instant::now();
    let rebuilds = match skin {
        Some(skin) => {
            let mut v = VerletList::new(grid, skin, ListKind::Half)?;
            v.build(&p)?;
            for _ in 0..STEPS {
                walk(&mut rng, &mut p, delta);
                v.update(&p)?;
                pairs = v
                    .par_fold_pairs(|| 0usize, |k, _, _, _, _| *k += 1)
                    .into_iter()
                    .sum();
            }
            v.builds() - 1
        }
        None => {
            let mut s = SortedCells::new(grid);
            for _ in 0..STEPS {
                walk(&mut rng, &mut p, delta);
                s.build(&p)?;
                pairs = s.par_pair_count();
            }
            STEPS as u64
        }
    };
    Ok((t.elapsed().as_secs_f64() / STEPS as f64, rebuilds, pairs))
}

fn main() -> Result<()> {
    let side = (N as f64).cbrt();
    let grid = CellGrid::new([0.0; 3], [side; 3], [true; 3], RC)?;
    let mut rng = rand_pcg::Pcg64::seed_from_u64(4);
    let start: Vec<[f64; 3]> = (0..N)
        .map(|_| std::array::from_fn(|_| rng.random::<f64>() * side))
        .collect();
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# neighbor: Verlet skin vs rebuild frequency vs time per step\n\n\
         Regenerate: `cargo run --release --example neighbor_tradeoffs` (writes this file and \
         `neighbor.png`).\n\n\
         N = {N} random points, number density 1, periodic cube, cutoff rc = {RC}; each step \
         every particle moves by delta in a random diagonal direction, the half Verlet list is \
         updated (rebuilt when a particle moved more than skin/2 since the last build) and all \
         pairs within rc are enumerated with rayon ({} threads). {STEPS} steps per row. \
         \"cells\" = sorted cells rebuilt and traversed every step (no list).\n",
        rayon::current_num_threads()
    );
    let _ = writeln!(
        md,
        "| delta / rc | skin / rc | rebuilds / {STEPS} steps | ms per step | vs cells |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|");
    let mut plot = Plot::new("Verlet list: time per step vs skin (N = 20000, rc = 2.5)")
        .x_label("skin / rc")
        .y_label("ms per step")
        .x_scale(Scale::Log10)
        .size(900, 600);
    for &d in &DELTAS {
        let delta = d * RC;
        let (tc, _, pc) = run(&grid, &start, delta, None)?;
        let _ = writeln!(md, "| {d} | cells | {STEPS} | {:.2} | 1.00 |", tc * 1e3);
        let (mut x, mut y) = (Vec::new(), Vec::new());
        for &s in &SKINS {
            let (t, rebuilds, pairs) = run(&grid, &start, delta, Some(s * RC))?;
            if pairs != pc {
                return Err(Error::invalid(
                    "Verlet pair count",
                    pairs,
                    format!("differs from sorted cells ({pc}) at skin {s} rc, delta {d} rc"),
                ));
            }
            let _ = writeln!(
                md,
                "| {d} | {s} | {rebuilds} | {:.2} | {:.2} |",
                t * 1e3,
                t / tc
            );
            x.push(s);
            y.push(t * 1e3);
        }
        plot.push(Series::line(format!("delta = {d} rc"), &x, &y));
        plot.push(Series::line(
            format!("cells every step, delta = {d} rc"),
            &[SKINS[0], SKINS[6]],
            &[tc * 1e3, tc * 1e3],
        ));
        println!("delta {d} rc done");
    }
    plot.write("docs/tradeoffs/neighbor.png")?;
    output::write_atomic("docs/tradeoffs/neighbor.md", |w| w.write_all(md.as_bytes()))?;
    print!("{md}");
    Ok(())
}
