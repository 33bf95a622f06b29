//! The Rust side of the Python package's equality tests (crates/python/tests): runs the
//! scenes that `tests/test_same_bits.py` runs through Python, on the CPU in f64, and writes
//! their final states as raw little-endian arrays (`<scene>_<array>.bin`: f64, or u8 cells,
//! or u32 pairs) into the folder given, for the tests to compare bit for bit.
//!
//! ```text
//! cargo run --release -p simkit-python --example reference -- <folder>
//! ```

use std::path::{Path, PathBuf};

use simkit::backend::{Backend, Result, Simulation};
use simkit::neighbor::{CellGrid, NeighborSearch, SortedCells};

fn write(dir: &Path, name: &str, bytes: &[u8]) -> Result<()> {
    let path = dir.join(format!("{name}.bin"));
    std::fs::write(&path, bytes).map_err(|e| simkit::output::atomic::io_error(&path, &e))
}

fn write_f64(dir: &Path, name: &str, rows: &[[f64; 3]], dim: usize) -> Result<()> {
    let bytes: Vec<u8> = rows
        .iter()
        .flat_map(|r| r[..dim].iter().flat_map(|x| x.to_le_bytes()))
        .collect();
    write(dir, name, &bytes)
}

fn main() -> Result<()> {
    let dir = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| ".".into()));
    std::fs::create_dir_all(&dir).map_err(|e| simkit::output::atomic::io_error(&dir, &e))?;

    // md: Md.fcc(4, 0.8442, 1.44, 87287, dt=0.005), 100 steps.
    {
        use simkit::md::{Config, LennardJones, Md, PairTable, scenes};
        let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5))?;
        let system = scenes::fcc_lattice([4; 3], 0.8442, 1.44, table, &[0], 87287)?;
        let mut sim = Md::new(system, &Config::default().with_dt(0.005), Backend::Cpu)?;
        sim.step(100)?;
        let s = sim.state()?;
        write_f64(&dir, "md_positions", &s.positions, 3)?;
        write_f64(&dir, "md_velocities", &s.velocities, 3)?;
    }
    // dem: Dem.vibrating_bed(64, 8, contact_time_s=5e-4), 500 steps.
    {
        use simkit::dem::scenes::{BedParams, vibrating_bed};
        use simkit::dem::{Config, Dem};
        let params = BedParams {
            n: 64,
            width: 8,
            contact_time_s: 5e-4,
            ..BedParams::default()
        };
        let (scene, _) = vibrating_bed(&params)?;
        let mut sim = Dem::new(scene, &Config::default(), Backend::Cpu)?;
        sim.step(500)?;
        let s = sim.state()?;
        write_f64(&dir, "dem_positions", &s.positions, 2)?;
        write_f64(&dir, "dem_velocities", &s.velocities, 2)?;
    }
    // rd: Rd.gray_scott_square(64) (Pearson's start and rates, dt = 1), 200 steps.
    {
        use simkit::rd::scenes::gray_scott_square;
        use simkit::rd::{Config, GrayScott, Rd, Stepping};
        let grid = gray_scott_square::<f64>(64, GrayScott::PEARSON_H, 8, 1)?;
        let model = GrayScott::new(2e-5, 1e-5, 0.04, 0.06)?;
        let mut sim = Rd::new(
            grid,
            model,
            &Config::new(Stepping::euler(1.0)),
            Backend::Cpu,
        )?;
        sim.step(200)?;
        let g = sim.state()?;
        let bytes: Vec<u8> = g
            .fields()
            .iter()
            .flatten()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        write(&dir, "rd_fields", &bytes)?;
    }
    // lattice gas: LatticeGas.random(64, 32, 0.3, 1), FHP-I, seed 1, 100 steps.
    {
        use simkit::lattice_gas::{Config, Lattice, LatticeGas};
        let mut lattice = Lattice::new(64, 32)?;
        lattice.fill_random(0.3, 1)?;
        let mut sim = LatticeGas::new(lattice, &Config::default(), Backend::Cpu)?;
        sim.step(100)?;
        write(&dir, "lattice_gas_cells", sim.state()?.cells())?;
    }
    // pp-coulomb: PpCoulomb.cold_sphere(300, 1.0, 7, dt=0.01), 50 steps.
    {
        use simkit::pp_coulomb::scenes::cold_sphere;
        use simkit::pp_coulomb::{Config, ForceLaw, PpCoulomb};
        let p = cold_sphere(300, 1.0, 7)?;
        let mut sim = PpCoulomb::new(p, &Config::new(0.01, ForceLaw::Exact), Backend::Cpu)?;
        sim.step(50)?;
        let s = sim.state()?;
        write_f64(&dir, "pp_coulomb_positions", &s.position, 3)?;
        write_f64(&dir, "pp_coulomb_velocities", &s.velocity, 3)?;
    }
    // neighbor: 2000 points x_k = frac(k a_d) * side (a = 0.618..., 0.414..., 0.732...) in a
    // periodic cube of side 12, cutoff 1.5; the pairs (i < j) sorted.
    {
        let (n, side) = (2000usize, 12.0);
        let a = [
            0.618_033_988_749_894_9,
            0.414_213_562_373_095_1,
            0.732_050_807_568_877_2,
        ];
        let points: Vec<[f64; 3]> = (0..n)
            .map(|k| std::array::from_fn(|d| ((k as f64 * a[d]) % 1.0) * side))
            .collect();
        let grid = CellGrid::new([0.0; 3], [side; 3], [true; 3], 1.5)?;
        let mut search = SortedCells::new(&grid);
        NeighborSearch::build(&mut search, &points)?;
        let mut pairs = Vec::new();
        NeighborSearch::for_each_pair(&mut search, |i, j, _, _| {
            pairs.push([i.min(j) as u32, i.max(j) as u32]);
        })?;
        pairs.sort_unstable();
        let bytes: Vec<u8> = pairs
            .iter()
            .flatten()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        write(&dir, "neighbor_pairs", &bytes)?;
    }
    println!("wrote the reference states to {}", dir.display());
    Ok(())
}
