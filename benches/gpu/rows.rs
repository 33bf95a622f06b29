//! The GPU rows: one per crate, size and kernel variant. Each builds its scene, checks the GPU
//! against the CPU on the same input (a fast wrong kernel cannot pass), then times the GPU
//! path with [`Timing::time`], waiting for the device after every timed call.

use std::panic::{AssertUnwindSafe, catch_unwind};

use rand::{RngExt, SeedableRng};
use simkit::backend::{Backend, Error, GpuBuffer, GpuContext, Precision, Result, Simulation};
use simkit::neighbor::{
    CellGrid, GpuCellList, GpuNeighborList, ListKind, SortedCells, positions_to_f32,
};
use simkit::{dem, lattice_gas, md, pp_coulomb, rd};

use crate::{Timing, rate_of};

/// What bounds a row, per unit of its work: bytes it must move through device memory at
/// least, or flops it must do (see `benches/gpu/README.md` for each count).
#[derive(Clone, Copy, Debug)]
pub enum Limit {
    /// Bytes per unit, against the measured copy bandwidth.
    Bytes(f64),
    /// f32 flops per unit, against the measured f32 FMA rate.
    FlopsF32(f64),
    /// f64 flops per unit, against the measured f64 FMA rate.
    FlopsF64(f64),
    /// No ceiling applies (e.g. a latency).
    None,
}

/// A row's function: checks and times one GPU path.
type RowFn = Box<dyn Fn(&GpuContext, Timing) -> Result<Measured>>;

/// One row to run.
pub struct Spec {
    /// Row name (also the key of `--only`).
    pub name: String,
    /// The peer's name in the peers CSV, if one is compared.
    pub peer: Option<String>,
    run: RowFn,
}

/// What a row's function returns.
pub struct Measured {
    /// Unit of the work (e.g. `atom-steps/s`).
    pub unit: String,
    /// Units of work per step.
    pub work_per_step: f64,
    /// Steps per timed sample.
    pub steps: u32,
    /// Seconds of each sample.
    pub samples: Vec<f64>,
    /// What bounds the row.
    pub limit: Limit,
    /// The check against the CPU: `Ok(summary)` when it passed, `Err(summary)` when not.
    pub check: std::result::Result<String, String>,
}

/// A row after its run.
pub struct Row {
    /// Row name.
    pub name: String,
    /// Rate unit.
    pub unit: String,
    /// Units of work per timed sample.
    pub work_per_sample: f64,
    /// Seconds of each sample (empty when the row failed).
    pub samples: Vec<f64>,
    /// What bounds the row.
    pub limit: Limit,
    /// Peer name in the peers CSV.
    pub peer: Option<String>,
    /// Check summary or the error that stopped the row.
    pub check: std::result::Result<String, String>,
}

impl Row {
    /// The median rate, `None` when the row failed or its check did.
    pub fn rate(&self) -> Option<f64> {
        (self.check.is_ok() && !self.samples.is_empty())
            .then(|| rate_of(self.work_per_sample, &self.samples))
    }

    /// The check cell: `ok (...)` or `FAILED (...)`.
    pub fn outcome(&self) -> String {
        match &self.check {
            Ok(s) => format!("ok ({s})"),
            Err(s) => format!("FAILED ({s})"),
        }
    }
}

/// Runs one row; an error or a panic becomes a failed row, so that the others still run.
pub fn run(spec: &Spec, ctx: &GpuContext, timing: Timing) -> Row {
    let out = catch_unwind(AssertUnwindSafe(|| (spec.run)(ctx, timing)));
    let failed = |why: String| Row {
        name: spec.name.clone(),
        unit: String::new(),
        work_per_sample: 0.0,
        samples: Vec::new(),
        limit: Limit::Bytes(0.0),
        peer: spec.peer.clone(),
        check: Err(why),
    };
    match out {
        Ok(Ok(m)) => Row {
            name: spec.name.clone(),
            unit: m.unit,
            work_per_sample: m.work_per_step * f64::from(m.steps),
            samples: m.samples,
            limit: m.limit,
            peer: spec.peer.clone(),
            check: m.check,
        },
        Ok(Err(e)) => failed(format!("error: {e}")),
        Err(p) => failed(format!(
            "panicked: {}",
            p.downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default()
        )),
    }
}

fn spec(
    name: impl Into<String>,
    peer: Option<String>,
    run: impl Fn(&GpuContext, Timing) -> Result<Measured> + 'static,
) -> Spec {
    Spec {
        name: name.into(),
        peer,
        run: Box::new(run),
    }
}

/// Every row, at full or `quick` sizes; the f64 rows only where the adapter has f64.
pub fn all(quick: bool, f64_ok: bool) -> Vec<Spec> {
    let pick = |full: usize, small: usize| if quick { small } else { full };
    let mut v = Vec::new();
    for cells in [pick(20, 6), pick(63, 8)] {
        let atoms = 4 * cells * cells * cells;
        for (label, kernel) in [
            ("per-particle", md::GpuKernel::PerParticle),
            ("cell-block", md::GpuKernel::cell_block()),
        ] {
            v.push(spec(
                format!("md in.lj {atoms} f32 {label}"),
                Some(format!("jax-md lj {atoms}")),
                move |ctx, t| {
                    md_row(
                        ctx,
                        t,
                        cells,
                        kernel,
                        simkit::backend::guard::DEFAULT_CHECK_EVERY,
                    )
                },
            ));
        }
    }
    // The blow-up guard's cost: the same run checked only at the end of each call.
    let cells = pick(20, 6);
    v.push(spec(
        format!(
            "md in.lj {} f32 per-particle, check_every 0",
            4 * cells * cells * cells
        ),
        None,
        move |ctx, t| md_row(ctx, t, cells, md::GpuKernel::PerParticle, 0),
    ));
    let side = pick(100, 12);
    v.push(spec(
        format!("dem settling box {} f32", side * side * side),
        None,
        move |ctx, t| {
            let scene = dem::scenes::granular_box(side, side, side, 4_928_459)?;
            // Position, velocity, force (12 bytes each, read and written), the radius read.
            dem_row(ctx, t, scene, 76.0)
        },
    ));
    // The same box with rotation and the tangential spring per contact (LAMMPS
    // gran/hooke/history + nve/sphere): what rotation and contact history cost on a GPU.
    v.push(spec(
        format!(
            "dem settling box {} f32, rotation + history",
            side * side * side
        ),
        None,
        move |ctx, t| {
            let scene = dem::scenes::granular_box_history(side, side, side, 4_928_459)?;
            // The plain box's 76 bytes, the spin records (48 bytes read, 32 written), and a
            // history slot (32 bytes) read and written per contact, about 6 per sphere.
            dem_row(ctx, t, scene, 76.0 + 80.0 + 6.0 * 64.0)
        },
    ));
    let n = pick(16384, 256);
    for layout in [
        lattice_gas::GpuLayout::BitPlanes,
        lattice_gas::GpuLayout::Bytes,
    ] {
        v.push(spec(
            format!("lattice-gas {n}^2 {layout:?}"),
            None,
            move |ctx, t| lattice_gas_row(ctx, t, n, layout),
        ));
    }
    for n in [pick(4096, 128), pick(8192, 256)] {
        for kernel in [rd::GpuKernel::Tiled, rd::GpuKernel::Global] {
            v.push(spec(
                format!("rd gray-scott {n}^2 f32 {kernel:?}"),
                Some(format!("cupy gray-scott {n}")),
                move |ctx, t| rd_row(ctx, t, n, kernel, false),
            ));
        }
    }
    let n = pick(4096, 128);
    for kernel in [rd::GpuKernel::Tiled, rd::GpuKernel::Global] {
        v.push(spec(
            format!("rd colony {n}^2 f32 {kernel:?}"),
            None,
            move |ctx, t| rd_row(ctx, t, n, kernel, true),
        ));
    }
    for n in [pick(100_000, 1024), pick(1_000_000, 2048)] {
        v.push(spec(
            format!("pp-coulomb {n} f32"),
            Some(format!("cupy nbody {n}")),
            move |ctx, t| pp_row(ctx, t, n, Precision::F32, None),
        ));
        if f64_ok {
            v.push(spec(format!("pp-coulomb {n} f64"), None, move |ctx, t| {
                pp_row(ctx, t, n, Precision::F64, None)
            }));
        }
    }
    // The force kernel's tiles, to choose the default per adapter.
    let n = pick(1_000_000, 2048);
    for (workgroup, targets) in [
        (64, 1),
        (128, 1),
        (256, 1),
        (64, 2),
        (128, 2),
        (256, 2),
        (64, 4),
        (128, 4),
        (256, 4),
        (32, 8),
        (64, 8),
        (128, 8),
    ] {
        let tile = pp_coulomb::GpuTile { workgroup, targets };
        v.push(spec(
            format!("pp-coulomb {n} f32 tile {workgroup}x{targets}"),
            Some(format!("cupy nbody {n}")),
            move |ctx, t| pp_row(ctx, t, n, Precision::F32, Some(tile)),
        ));
    }
    let n = pick(10_000_000, 10_000);
    v.push(spec(
        format!("neighbor {n} build + half list"),
        None,
        move |ctx, t| neighbor_row(ctx, t, n),
    ));
    v
}

/// Times `sim`'s steps with [`Timing::time`], waiting for the device after each call.
fn time_gpu<S: Simulation>(
    timing: Timing,
    ctx: &GpuContext,
    sim: &mut S,
) -> Result<(u32, Vec<f64>)> {
    timing.time(|k| {
        sim.step(k)?;
        ctx.wait()
    })
}

/// `Ok(text)` when `error <= tolerance`, else `Err(text)`.
fn verdict(what: &str, error: f64, tolerance: f64) -> std::result::Result<String, String> {
    let text = format!("{what} {error:.1e}, tolerance {tolerance:.0e}");
    if error <= tolerance {
        Ok(text)
    } else {
        Err(text)
    }
}

/// `sqrt(sum |a - b|^2 / sum |b|^2)` over 3-vectors.
fn relative_l2(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    if a.len() != b.len() {
        return f64::INFINITY;
    }
    let (mut num, mut den) = (0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        for k in 0..3 {
            num += (x[k] - y[k]).powi(2);
            den += y[k] * y[k];
        }
    }
    (num / den).sqrt()
}

/// LAMMPS's `in.lj` state on `cells^3` FCC cells: forces after 10 steps against the CPU's,
/// both in f32 (relative L2 error: the two sum in different orders; against f64 the f32
/// rounding of the positions alone gives 4e-5 at 32,000 atoms and 1.1e-4 at 10^6, growing
/// with the box), then the GPU timed with `kernel`.
fn md_row(
    ctx: &GpuContext,
    timing: Timing,
    cells: usize,
    kernel: md::GpuKernel,
    check_every: u32,
) -> Result<Measured> {
    let table = md::PairTable::uniform(1, md::LennardJones::new(1.0, 1.0, 2.5))?;
    let system = md::scenes::fcc_lattice([cells; 3], 0.8442, 1.44, table, &[0], 87287)?;
    let base = md::Config::default()
        .with_dt(0.005)
        .with_precision(Precision::F32);
    let mut cpu = md::Md::new(system.clone(), &base, Backend::Cpu)?;
    let config = base.with_gpu_kernel(kernel).with_check_every(check_every);
    let mut gpu = md::Md::new(system.clone(), &config, Backend::Gpu(ctx))?;
    let e0 = cpu.diagnostics()?.total / system.particle_count() as f64;
    // The lattice's forces vanish by symmetry: compare once the atoms have moved.
    cpu.step(10)?;
    gpu.step(10)?;
    let error = relative_l2(&gpu.forces()?, &cpu.forces()?);
    let (steps, samples) = time_gpu(timing, ctx, &mut gpu)?;
    let e1 = gpu.diagnostics()?.total / system.particle_count() as f64;
    let check = verdict("forces rel. L2", error, 1e-4).map(|s| {
        format!(
            "{s}; E/N {e0:.4} -> {e1:.4} after {} steps",
            gpu.steps_done()
        )
    });
    let n = system.particle_count() as f64;
    Ok(Measured {
        unit: "atom-steps/s".into(),
        work_per_step: n,
        steps,
        samples,
        // Positions, velocities and forces read and written once per step (3 x 12 bytes
        // each way): the least a step moves.
        limit: Limit::Bytes(72.0),
        check,
    })
}

/// A 3D settling box of `dem::scenes` (spheres of diameter 1 on a lattice, gravity,
/// frictional floor): 20 steps on the CPU (f64) and the GPU (f32) from the same start, largest
/// position difference in diameters, then the GPU timed; `bytes`: the least memory traffic
/// of a particle-step.
fn dem_row<L: dem::ContactLaw>(
    ctx: &GpuContext,
    timing: Timing,
    scene: dem::Scene<L>,
    bytes: f64,
) -> Result<Measured> {
    let config = dem::Config::default().with_dt(1e-4);
    let mut cpu = dem::Dem::new(scene.clone(), &config, Backend::Cpu)?;
    let mut gpu = dem::Dem::new(scene.clone(), &config, Backend::Gpu(ctx))?;
    cpu.step(20)?;
    gpu.step(20)?;
    let (a, b) = (gpu.state()?, cpu.state()?);
    let error = a
        .positions
        .iter()
        .zip(&b.positions)
        .map(|(x, y)| (0..3).map(|k| (x[k] - y[k]).abs()).fold(0.0, f64::max))
        .fold(0.0, f64::max);
    let (steps, samples) = time_gpu(timing, ctx, &mut gpu)?;
    Ok(Measured {
        unit: "particle-steps/s".into(),
        work_per_step: scene.particles().len() as f64,
        steps,
        samples,
        limit: Limit::Bytes(bytes),
        check: verdict(
            "max |x_gpu - x_cpu| after 20 steps (diameters)",
            error,
            1e-3,
        ),
    })
}

/// FHP-I at density 0.3 on a periodic `n x n` lattice: 4 steps on the CPU and the GPU must
/// give the same lattice bit for bit, then the GPU timed.
fn lattice_gas_row(
    ctx: &GpuContext,
    timing: Timing,
    n: usize,
    layout: lattice_gas::GpuLayout,
) -> Result<Measured> {
    let mut lattice = lattice_gas::Lattice::new(n, n)?;
    lattice.fill_random(0.3, 1)?;
    let config = lattice_gas::Config {
        gpu_layout: Some(layout),
        ..lattice_gas::Config::default()
    };
    let mut cpu = lattice_gas::LatticeGas::new(lattice.clone(), &config, Backend::Cpu)?;
    let mut gpu = lattice_gas::LatticeGas::new(lattice, &config, Backend::Gpu(ctx))?;
    cpu.step(4)?;
    gpu.step(4)?;
    let same = cpu.state()? == gpu.state()?;
    let (steps, samples) = time_gpu(timing, ctx, &mut gpu)?;
    Ok(Measured {
        unit: "site-updates/s".into(),
        work_per_step: (n * n) as f64,
        steps,
        samples,
        // Six channel bits read and written per site (bit-planes); one byte each way (bytes).
        limit: Limit::Bytes(match layout {
            lattice_gas::GpuLayout::BitPlanes => 1.5,
            _ => 2.0,
        }),
        check: if same {
            Ok("lattice after 4 steps equal to the CPU's".into())
        } else {
            Err("lattice after 4 steps differs from the CPU's".into())
        },
    })
}

/// Gray–Scott (`D_u = 1, D_v = 0.5, F = 0.04, k = 0.06`, dt 0.1) or the bacterial colony model
/// (dt 0.005) in f32 on `n x n`: 20 steps on the CPU and the GPU, largest difference over the
/// largest value, then the GPU timed with `kernel`.
fn rd_row(
    ctx: &GpuContext,
    timing: Timing,
    n: usize,
    kernel: rd::GpuKernel,
    colony: bool,
) -> Result<Measured> {
    let gpu_options = rd::GpuOptions {
        kernel,
        ..rd::GpuOptions::default()
    };
    if colony {
        let (grid, model) = rd::scenes::colony_scene::<f32>(n, n, 1)?;
        let config = rd::Config::new(rd::Stepping::euler(0.005)).with_gpu(gpu_options);
        rd_measure(ctx, timing, grid, model, &config)
    } else {
        let grid = rd::scenes::gray_scott_square::<f32>(n, 1.0, n / 8, 1)?;
        let model = rd::GrayScott::new(1.0, 0.5, 0.04, 0.06)?;
        let config = rd::Config::new(rd::Stepping::euler(0.1)).with_gpu(gpu_options);
        rd_measure(ctx, timing, grid, model, &config)
    }
}

fn rd_measure<M: rd::Model + Clone>(
    ctx: &GpuContext,
    timing: Timing,
    grid: rd::Grid<f32>,
    model: M,
    config: &rd::Config,
) -> Result<Measured> {
    let cells = (grid.nx() * grid.ny()) as f64;
    let species = grid.species() as f64;
    let mut cpu = rd::Rd::new(grid.clone(), model.clone(), config, Backend::Cpu)?;
    let mut gpu = rd::Rd::new(grid, model, config, Backend::Gpu(ctx))?;
    cpu.step(20)?;
    gpu.step(20)?;
    let (a, b) = (gpu.state()?, cpu.state()?);
    let (mut diff, mut scale) = (0.0f64, 0.0f64);
    for (fa, fb) in a.fields().iter().zip(b.fields()) {
        for (x, y) in fa.iter().zip(fb) {
            diff = diff.max((f64::from(*x) - f64::from(*y)).abs());
            scale = scale.max(f64::from(*y).abs());
        }
    }
    let (steps, samples) = time_gpu(timing, ctx, &mut gpu)?;
    Ok(Measured {
        unit: "cell-updates/s".into(),
        work_per_step: cells,
        steps,
        samples,
        // Every species read and written once per step in f32.
        limit: Limit::Bytes(8.0 * species),
        check: verdict(
            "max |gpu - cpu| / max after 20 steps",
            diff / scale.max(f64::MIN_POSITIVE),
            1e-4,
        ),
    })
}

/// The source's plasma box (normalised units, electrons, the exclusion-radius law) with `n`
/// particles.
pub fn plasma(n: usize) -> Result<(pp_coulomb::Particles, pp_coulomb::ForceLaw)> {
    let inputs = pp_coulomb::units::PhysicalInputs {
        particles: n,
        ..pp_coulomb::units::PhysicalInputs::source_plasma()
    };
    let (p, law, _) = pp_coulomb::scenes::plasma_box(&inputs, 1)?;
    Ok((p, law))
}

/// The plasma of [`plasma`] with `n` particles: the GPU's accelerations of 256 particles against an f64 reference over all
/// sources, then one symplectic-Euler step per force evaluation timed (N (N - 1)
/// interactions each, 20 flops per interaction as the CUDA `nbody` sample counts them), with
/// the force kernel's `tile` (`None`: the adapter's default).
fn pp_row(
    ctx: &GpuContext,
    timing: Timing,
    n: usize,
    precision: Precision,
    tile: Option<pp_coulomb::GpuTile>,
) -> Result<Measured> {
    use pp_coulomb::{Config, Integrator};
    let (p, law) = plasma(n)?;
    let mut config = Config::new(1.0, law)
        .with_integrator(Integrator::SymplecticEuler)
        .with_precision(precision);
    config.gpu_tile = tile;
    let mut rng = rand_pcg::Pcg64::seed_from_u64(5);
    let targets: Vec<usize> = (0..256.min(n)).map(|_| rng.random_range(0..n)).collect();
    let reference = pp_coulomb::reference_accelerations_of(&p, law, &targets)?;
    let mut gpu = pp_coulomb::PpCoulomb::new(p, &config, Backend::Gpu(ctx))?;
    let acc = gpu.accelerations()?;
    let ours: Vec<[f64; 3]> = targets.iter().map(|&i| acc[i]).collect();
    let error = relative_l2(&ours, &reference);
    let tolerance = match precision {
        Precision::F32 => 1e-3,
        Precision::F64 => 1e-9,
    };
    let timing = Timing {
        samples: timing.samples.min(3),
        ..timing
    };
    let (steps, samples) = time_gpu(timing, ctx, &mut gpu)?;
    Ok(Measured {
        unit: "interactions/s".into(),
        work_per_step: n as f64 * (n as f64 - 1.0),
        steps,
        samples,
        limit: match precision {
            Precision::F32 => Limit::FlopsF32(20.0),
            Precision::F64 => Limit::FlopsF64(20.0),
        },
        check: verdict("accelerations of 256 rel. L2", error, tolerance),
    })
}

/// `n` uniform random points at density 1 in a closed cube, cutoff 2.5: the GPU's cell list
/// and half list built, its pair count against the CPU's sorted cells on the same f32
/// positions, then cells + list timed (pairs per second; the list's count is read back
/// every build).
fn neighbor_row(ctx: &GpuContext, timing: Timing, n: usize) -> Result<Measured> {
    let side = (n as f64).cbrt();
    let mut rng = rand_pcg::Pcg64::seed_from_u64(42);
    let p: Vec<[f64; 3]> = (0..n)
        .map(|_| std::array::from_fn(|_| rng.random::<f64>() * side))
        .collect();
    // The GPU compares f32 distances: count on the CPU from the same f32 positions, within
    // a band of cutoffs 2.5 -+ 1e-5 that covers the f32 rounding of the distance.
    let rounded: Vec<[f64; 3]> = p.iter().map(|x| x.map(|c| f64::from(c as f32))).collect();
    let count = |cutoff: f64| -> Result<usize> {
        let grid = CellGrid::new([0.0; 3], [side; 3], [false; 3], cutoff)?;
        let mut sorted = SortedCells::new(&grid);
        sorted.build(&rounded)?;
        Ok(sorted.par_pair_count())
    };
    let (lo, hi) = (count(2.5 - 1e-5)?, count(2.5 + 1e-5)?);
    let grid = CellGrid::new([0.0; 3], [side; 3], [false; 3], 2.5)?;
    let buf = GpuBuffer::from_slice(ctx, "positions", &positions_to_f32(&p))?;
    let cells = GpuCellList::new(ctx, &grid, &buf)?;
    let mut list = GpuNeighborList::new(ctx, &cells, ListKind::Half)?;
    cells.build(ctx)?;
    let pairs = list.build(ctx, &cells)?;
    let (steps, samples) = timing.time(|k| {
        for _ in 0..k {
            cells.build(ctx)?;
            list.build(ctx, &cells)?;
        }
        ctx.wait()
    })?;
    let text = format!("{pairs} pairs, the CPU {lo}..={hi} within 2.5 -+ 1e-5");
    let check = if (lo..=hi).contains(&pairs) {
        Ok(text)
    } else {
        Err(text)
    };
    if pairs == 0 {
        return Err(Error::invalid(
            "pairs",
            0,
            "no pairs found: the scene is wrong",
        ));
    }
    Ok(Measured {
        unit: "pairs/s".into(),
        work_per_step: pairs as f64,
        steps,
        samples,
        // One 4-byte entry written per pair.
        limit: Limit::Bytes(4.0),
        check,
    })
}
