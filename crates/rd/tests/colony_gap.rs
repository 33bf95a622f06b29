//! The colony gap (docs/rd.md, "Scenes"): two colonies inoculated 48 cells apart grow towards
//! each other, eat the nutrient between them and stop, leaving a thin gap, while they keep
//! growing outwards. A fast-sized version of the `bacterial_colony` example's 512 x 512 scene:
//! the same model, parameters, inoculation squares and distance, on a 128 x 64 grid.

use simkit_backend::rng::rng_uniform;
use simkit_backend::{Backend, Simulation};
use simkit_rd::scenes::gap_width;
use simkit_rd::{Boundaries, Colony, Config, Grid, Rd, Stepping};

const NX: usize = 128;
const NY: usize = 64;
/// Centres of the two 17 x 17 inoculated squares (48 cells apart, as 103 and 151 on 512^2)
/// and their row.
const LEFT: usize = 40;
const RIGHT: usize = 88;
const ROW: usize = 32;
/// `b` below this counts as empty space (the example's threshold).
const THRESHOLD: f64 = 0.05;

/// The example's scene on [`NX`] x [`NY`]: h = 0.5, gamma = 0.5, `d = 0.75 (1 + 0.4 U(-1, 1))`,
/// `n = 1 + 0.1 U(-1, 1)`, `b = 0.7` on the two squares, no-flux edges.
fn scene(seed: u32) -> (Grid<f32>, Colony) {
    let d = Colony::random_d(NX, NY, 0.75, 0.4, seed).unwrap();
    let model = Colony::new(0.5, NX, NY, d).unwrap();
    let n = (0..NX * NY)
        .map(|k| 1.0 + 0.1 * (2.0 * rng_uniform(seed, 1, k as u32) - 1.0))
        .collect();
    let mut b = vec![0.0f32; NX * NY];
    for cx in [LEFT, RIGHT] {
        for j in ROW - 8..=ROW + 8 {
            for i in cx - 8..=cx + 8 {
                b[j * NX + i] = 0.7;
            }
        }
    }
    let grid = Grid::new(NX, NY, 0.5, Boundaries::no_flux(), vec![b, n]).unwrap();
    (grid, model)
}

/// Cells of `b >= THRESHOLD` on [`ROW`] going outwards (to the west) from the left colony's
/// centre: how far that colony has spread away from the gap.
fn outward_reach(g: &Grid<f32>) -> usize {
    (0..LEFT)
        .rev()
        .take_while(|&i| g.get(0, i, ROW).is_some_and(|b| f64::from(b) >= THRESHOLD))
        .count()
}

/// Measured (CPU f32, `--nocapture` prints the table), seeds 2026 and 7 alike: the gap
/// (widest run of `b < 0.05` on the row through both centres) is 15.5 at t = 0, 9.5 at t = 5,
/// 2.5 at t = 20 and 2.0 (4 cells) from t = 30 to t = 60, while the outward reach of the left colony grows from 25 to 33 (seed 2026) or
/// 31 (seed 7) cells and total b from 1558 to 2107. Asserted: the initial 15.5; at most 2.5 at
/// t = 20; from t = 30 on the gap stays the same, at 2.0 +- 0.5 (one cell), never 0 (the
/// colonies do not merge); meanwhile the colony grows outwards by at least 4 cells (half the
/// measured 6–8) and total b by at least 20 % (measured 35 %).
#[test]
fn colonies_close_the_gap_and_stop() {
    for seed in [2026, 7] {
        let (grid, model) = scene(seed);
        let config = Config::new(Stepping::euler(0.005));
        let mut sim = Rd::new(grid, model, &config, Backend::Cpu).unwrap();
        // (time, gap, total b, outward reach) every t = 5 (1000 steps) up to t = 60.
        let mut rows = Vec::new();
        for k in 0..=12 {
            if k > 0 {
                sim.step(1000).unwrap();
            }
            let g = sim.state().unwrap();
            let gap = gap_width(&g, ROW, LEFT, RIGHT, THRESHOLD);
            let (tb, reach) = (g.total(0), outward_reach(&g));
            println!(
                "seed {seed}: t = {:4.1}, gap {gap:5.2}, total b {tb:8.2}, outward reach {reach} cells",
                sim.time()
            );
            rows.push((sim.time(), gap, tb, reach));
        }
        let at = |t: f64| {
            rows.iter()
                .find(|r| (r.0 - t).abs() < 1e-9)
                .copied()
                .unwrap()
        };
        assert_eq!(
            at(0.0).1,
            15.5,
            "seed {seed}: 31 empty cells between the squares"
        );
        assert!(
            at(20.0).1 <= 2.5,
            "seed {seed}: not closed by t = 20: {:?}",
            at(20.0)
        );
        let stopped = at(30.0).1;
        assert!(
            (1.5..=2.5).contains(&stopped),
            "seed {seed}: gap {stopped} at t = 30"
        );
        for r in rows.iter().filter(|r| r.0 >= 30.0) {
            assert_eq!(
                r.1, stopped,
                "seed {seed}: the gap moved after t = 30: {r:?}"
            );
        }
        let (early, late) = (at(30.0), at(60.0));
        assert!(
            late.3 >= early.3 + 4,
            "seed {seed}: no outward growth {} -> {} cells",
            early.3,
            late.3
        );
        assert!(
            late.2 > 1.2 * early.2,
            "seed {seed}: total b {} -> {}",
            early.2,
            late.2
        );
    }
}
