//! A liquid slab on a solid substrate under a gas, with the three-species table of
//! `simkit::md::scenes::three_phase_table` (solid and liquid attract their own kind with a
//! Lennard-Jones 12-6 potential cut at 5, every other pair only repels).
//!
//! The box is periodic in x and y and closed (reflecting walls) in z, the slab normal.
//! At the start every particle sits on one FCC lattice of density 1 (lattice constant
//! 1.587): the bottom `--solid-cells` cells are solid (every site filled), the next
//! `--liquid-cells` liquid (each site filled with probability 0.8: the 20 % vacancies make
//! the slab melt at once), the rest gas (probability `--gas-fill`); velocities are
//! Maxwell-Boltzmann at `--temperature` with zero total momentum over the moving
//! particles. The run is at constant energy. The solid is a frozen species
//! (`System::set_frozen`): a fixed substrate whose atoms exert forces but never move
//! (`--mobile-substrate` lets it move, as a crystal of mobile atoms on the bottom wall).
//! Since liquid and solid only repel each other (their pair has no attractive term), the
//! liquid does not wet the substrate: it floats on a gap of two to three sigma, and a few
//! liquid particles evaporate into the gas. The species exchange energy only through
//! repulsive contacts, so their temperatures approach each other slowly (after the default
//! 4000 steps, t = 8: gas 1.64, liquid 0.86, the frozen solid 0; 23 s on 2 busy cores).
//!
//! ```text
//! cargo run --release --example three_phase [-- --steps N --frames N --temperature T
//!     --cells XxY --solid-cells N --liquid-cells N --gas-cells N --gas-fill P --dt DT
//!     --seed S --mobile-substrate --gpu] [--checkpoint-every N] [--resume out/three_phase/checkpoint.ckpt]
//! ```
//! Defaults: 4000 steps, 10 frames, T = 1.4, 10 x 7 cells across (15.9 x 11.1), 3 solid,
//! 6 liquid and 14 gas cells up (box height 36.5), gas fill 0.05 (2 391 particles), dt =
//! 0.002 (`--dt 0` takes the library's default from the stiffest pair, the gas-gas core:
//! 0.0007; gas-gas collisions are rare at this gas density, and 0.002 keeps the total
//! energy to 2e-4 relative over the default run), the CPU backend (f64).
//! `--gpu` runs on the GPU backend (f32). `--checkpoint-every N` saves the run every N
//! steps; `--resume FILE` continues a saved run up to `--steps` in total (frames, the
//! trajectory and the averages then cover the resumed part only).
//!
//! Output under `out/three_phase/`:
//! - `side_NNN.png`: side views (x across, z up, looking along y; farther particles drawn
//!   first and paler), coloured by species, with a legend;
//! - `density.png`, `density.csv`: number density of each species along z, averaged over
//!   the second half of the run;
//! - `frame_NNN.vtp` + `frames.pvd` (VTK poly data for ParaView and OVITO, with `species`,
//!   `radius` = sigma / 2 of the species and `Velocity` arrays) and `frames.xyz` (extended XYZ
//!   trajectory: gas, liquid and solid are written as H, He and Li, with the names in the
//!   `kind` column);
//! - `thermo.csv`: total energy and the temperature of each species.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use simkit::backend::{Backend, Error, GpuContext, Result, Simulation};
use simkit::md::scenes::{GAS, LIQUID, SOLID, three_phase_table};
use simkit::md::{Config, Dim, Md, State, System};
use simkit::output::csv::{CsvWriter, write_csv};
use simkit::output::particles::ParticleFrame;
use simkit::output::plot::{Plot, Series};
use simkit::output::vtk::{Particles, write_pvd};
use simkit::output::xyz::{XyzFrame, XyzWriter};

#[path = "common/checkpoint.rs"]
mod checkpoint;
#[path = "common/progress.rs"]
mod progress;

/// Lattice constant of the starting FCC lattice (density 1: `4^(1/3)`).
const LATTICE: f64 = 1.587_401_051_968_199_4;
/// Atoms of an FCC unit cell, in units of the lattice constant.
const FCC: [[f64; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [0.5, 0.5, 0.0],
    [0.5, 0.0, 0.5],
    [0.0, 0.5, 0.5],
];
/// Species names, indexed by species.
const NAMES: [&str; 3] = ["gas", "liquid", "solid"];
/// Picture colours, indexed by species.
const COLORS: [[u8; 3]; 3] = [[240, 150, 40], [30, 100, 210], [105, 85, 75]];
/// Bin width of the density profiles.
const BIN: f64 = 0.2;

/// A liquid slab on a solid substrate under a gas (three-species pair table): side views,
/// density profiles, VTK/XYZ frames under out/three_phase/.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    /// Total steps of the run (a resumed run continues up to this many)
    #[arg(long, value_name = "N", default_value_t = 4000)]
    steps: u32,
    /// Frames (pictures, VTK, XYZ) after the initial one, evenly spaced
    #[arg(long, value_name = "N", default_value_t = 10)]
    frames: u32,
    /// Initial temperature (reduced units)
    #[arg(long, value_name = "T", default_value_t = 1.4)]
    temperature: f64,
    /// FCC cells across the slab, XxY (each at least 7: periodic lengths >= 10)
    #[arg(long, value_name = "XxY", default_value = "10x7", value_parser = parse_cells)]
    cells: (usize, usize),
    /// FCC cells of solid at the bottom
    #[arg(long, value_name = "N", default_value_t = 3)]
    solid_cells: usize,
    /// FCC cells of liquid on the solid
    #[arg(long, value_name = "N", default_value_t = 6)]
    liquid_cells: usize,
    /// FCC cells of gas above the liquid
    #[arg(long, value_name = "N", default_value_t = 14)]
    gas_cells: usize,
    /// Fraction of the gas region's lattice sites holding a gas particle
    #[arg(long, value_name = "P", default_value_t = 0.05)]
    gas_fill: f64,
    /// Time step (0: the library's default from the stiffest pair, `time_step_guide`,
    /// 0.0007 here, set by the rarely met gas-gas core)
    #[arg(long, value_name = "DT", default_value_t = 0.002)]
    dt: f64,
    /// Seed of the site filling and the velocities
    #[arg(long, default_value_t = 7)]
    seed: u64,
    /// Let the solid move (by default it is a frozen species: a fixed substrate)
    #[arg(long)]
    mobile_substrate: bool,
    /// Run on the GPU backend (f32) instead of the CPU
    #[arg(long)]
    gpu: bool,
    #[command(flatten)]
    checkpoint: checkpoint::CheckpointArgs,
}

/// `XxY`, e.g. `10x7`.
fn parse_cells(s: &str) -> std::result::Result<(usize, usize), String> {
    let (x, y) = s
        .split_once('x')
        .ok_or_else(|| format!("`{s}` is not XxY (e.g. 10x7)"))?;
    let parse = |v: &str| {
        v.parse::<usize>()
            .map_err(|e| format!("`{v}` in `{s}` is not a cell count: {e}"))
    };
    Ok((parse(x)?, parse(y)?))
}

fn main() -> ExitCode {
    simkit::cli::exit_code(run(&Args::parse()))
}

/// The starting slab: solid, liquid and gas layers of one FCC lattice (see the top comment).
fn slab(args: &Args) -> Result<System> {
    let (nx, ny) = args.cells;
    let nz = args.solid_cells + args.liquid_cells + args.gas_cells;
    if !(0.0..=1.0).contains(&args.gas_fill) {
        return Err(Error::invalid(
            "--gas-fill",
            args.gas_fill,
            "must be in [0, 1]",
        ));
    }
    if !(args.temperature.is_finite() && args.temperature >= 0.0) {
        return Err(Error::invalid(
            "--temperature",
            args.temperature,
            "must be finite and >= 0",
        ));
    }
    if nz == 0 {
        return Err(Error::invalid("layer cells", 0, "give at least one layer"));
    }
    let len = [nx, ny, nz].map(|n| n as f64 * LATTICE);
    let mut sys = System::new(
        Dim::Three,
        [0.0; 3],
        len,
        [true, true, false],
        vec![1.0; 3],
        three_phase_table()?,
    )?;
    let mut rng = Pcg64::seed_from_u64(args.seed);
    let (mut kinds, mut pos, mut vel) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..nz {
        let (species, fill) = if k < args.solid_cells {
            (SOLID, 1.0)
        } else if k < args.solid_cells + args.liquid_cells {
            (LIQUID, 0.8)
        } else {
            (GAS, args.gas_fill)
        };
        for j in 0..ny {
            for i in 0..nx {
                for b in FCC {
                    if rng.random::<f64>() >= fill {
                        continue;
                    }
                    kinds.push(species);
                    // A quarter cell up in z keeps the bottom layer off the wall.
                    pos.push([
                        (i as f64 + b[0]) * LATTICE,
                        (j as f64 + b[1]) * LATTICE,
                        (k as f64 + b[2] + 0.25) * LATTICE,
                    ]);
                    let frozen = species == SOLID && !args.mobile_substrate;
                    vel.push([0.0; 3].map(|_: f64| {
                        let g = gaussian(&mut rng);
                        if frozen { 0.0 } else { g }
                    }));
                }
            }
        }
    }
    // Maxwell-Boltzmann over the particles that move, with zero total momentum.
    if !args.mobile_substrate {
        sys.set_frozen(SOLID, true)?;
    }
    let moving: Vec<usize> = (0..kinds.len())
        .filter(|&i| kinds[i] != SOLID || args.mobile_substrate)
        .collect();
    let n = moving.len();
    if n < 2 {
        return Err(Error::invalid(
            "moving particle count",
            n,
            "add liquid or gas",
        ));
    }
    let mean: [f64; 3] =
        std::array::from_fn(|d| moving.iter().map(|&i| vel[i][d]).sum::<f64>() / n as f64);
    let twice_k: f64 = moving
        .iter()
        .map(|&i| (0..3).map(|d| (vel[i][d] - mean[d]).powi(2)).sum::<f64>())
        .sum();
    let scale = (args.temperature * (3 * n - 3) as f64 / twice_k).sqrt();
    for &i in &moving {
        for d in 0..3 {
            vel[i][d] = (vel[i][d] - mean[d]) * scale;
        }
    }
    sys.set_particles(&kinds, &pos, &vel)?;
    Ok(sys)
}

/// A standard normal deviate (Box-Muller).
fn gaussian(rng: &mut Pcg64) -> f64 {
    let u: f64 = 1.0 - rng.random::<f64>(); // (0, 1]
    let v: f64 = rng.random();
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

fn run(args: &Args) -> Result<()> {
    let ctx = if args.gpu {
        Some(GpuContext::new()?)
    } else {
        None
    };
    let backend = ctx.as_ref().map_or(Backend::Cpu, Backend::Gpu);
    let out = PathBuf::from("out/three_phase");
    let checkpoints = args.checkpoint.checkpoints(&out);
    let config = Config {
        dt: (args.dt != 0.0).then_some(args.dt),
        ..Config::default()
    };
    let mut md = checkpoints.start(backend, |backend| Md::new(slab(args)?, &config, backend))?;
    let system = md.system().clone();
    let counts = NAMES
        .iter()
        .enumerate()
        .map(|(s, name)| {
            let c = system
                .species()
                .iter()
                .filter(|&&k| k as usize == s)
                .count();
            format!("{c} {name}")
        })
        .collect::<Vec<_>>()
        .join(", ");
    let len = system.lengths();
    let steps = args.steps;
    println!(
        "three-phase slab: {counts} in {:.2} x {:.2} x {:.2} (x, y periodic; z walls), \
         dt {:.4}, {steps} steps on {}; output in {}/",
        len[0],
        len[1],
        len[2],
        md.dt(),
        md.backend_name(),
        out.display()
    );
    let frames = args.frames.clamp(1, steps.max(1));
    let frame_every = (steps / frames).max(1);
    let sample_every = (frame_every / 4).max(1);
    let bins = (len[2] / BIN).ceil() as usize;
    let mut profile = vec![vec![0.0; bins]; 3];
    let mut samples = 0u32;
    let mut xyz = XyzWriter::create(out.join("frames.xyz"))?;
    let mut pvd: Vec<(f64, String)> = Vec::new();
    let mut thermo = CsvWriter::create(
        out.join("thermo.csv"),
        &[
            "step",
            "time",
            "total_energy",
            "t_gas",
            "t_liquid",
            "t_solid",
        ],
    )?;
    let mut done = u32::try_from(md.steps_done())
        .unwrap_or(u32::MAX)
        .min(steps);
    let first = done;
    let d0 = md.diagnostics()?;
    let t = &d0.species_temperature;
    thermo.row(&[f64::from(done), d0.time, d0.total, t[0], t[1], t[2]])?;
    let frame = |done: u32| done.div_ceil(frame_every);
    write_frame(
        &md.state()?,
        &system,
        (done, frame(done)),
        &out,
        &mut xyz,
        &mut pvd,
    )?;
    let bar = progress::bar("three_phase", u64::from(steps), "steps");
    bar.set_position(u64::from(done));
    bar.reset_eta();
    let mut stepping = 0.0;
    while done < steps {
        let n = (sample_every - done % sample_every).min(steps - done);
        let clock = Instant::now();
        checkpoints.step(&mut md, n)?;
        stepping += clock.elapsed().as_secs_f64();
        done += n;
        bar.inc(u64::from(n));
        let state = md.state()?;
        if 2 * done > steps {
            add_profile(&state, &mut profile);
            samples += 1;
        }
        if done.is_multiple_of(frame_every) || done == steps {
            let d = md.diagnostics()?;
            let t = &d.species_temperature;
            thermo.row(&[f64::from(done), d.time, d.total, t[0], t[1], t[2]])?;
            write_frame(
                &state,
                &system,
                (done, frame(done)),
                &out,
                &mut xyz,
                &mut pvd,
            )?;
        }
    }
    bar.finish();
    xyz.finish()?;
    thermo.finish()?;
    write_pvd(out.join("frames.pvd"), &pvd)?;
    let d1 = md.diagnostics()?;
    println!(
        "energy: {:.6} -> {:.6} (relative drift {:.2e}); temperatures gas {:.3}, liquid {:.3}, \
         solid {:.3}",
        d0.total,
        d1.total,
        (d1.total - d0.total) / d0.total.abs(),
        d1.species_temperature[0],
        d1.species_temperature[1],
        d1.species_temperature[2]
    );
    if done > first {
        println!(
            "{:.3e} atom-steps/s ({} steps, {stepping:.2} s of stepping)",
            system.particle_count() as f64 * f64::from(done - first) / stepping,
            done - first
        );
    }
    if samples > 0 {
        write_profile(&mut profile, samples, len, &out)?;
    }
    println!(
        "wrote {} frames (side_*.png, frame_*.vtp, frames.pvd, frames.xyz), density.png, \
         density.csv, thermo.csv",
        pvd.len()
    );
    Ok(())
}

/// Adds one sample of the number of particles of each species per bin along z.
fn add_profile(state: &State, profile: &mut [Vec<f64>]) {
    let bins = profile[0].len();
    for (x, &s) in state.positions.iter().zip(&state.species) {
        let b = ((x[2] / BIN) as usize).min(bins - 1);
        profile[s as usize][b] += 1.0;
    }
}

/// Turns the counts into number densities and writes the plot and the CSV.
fn write_profile(profile: &mut [Vec<f64>], samples: u32, len: [f64; 3], out: &Path) -> Result<()> {
    let volume = len[0] * len[1] * BIN;
    for p in profile.iter_mut() {
        for v in p.iter_mut() {
            *v /= f64::from(samples) * volume;
        }
    }
    let z: Vec<f64> = (0..profile[0].len())
        .map(|b| (b as f64 + 0.5) * BIN)
        .collect();
    let mut plot = Plot::new(format!("density along z, mean of {samples} states"))
        .x_label("z (σ)")
        .y_label("number density (σ⁻³)")
        .legend(true);
    for s in [SOLID, LIQUID, GAS] {
        let s = s as usize;
        plot = plot.series(Series::line(NAMES[s], &z, &profile[s]).color(COLORS[s]));
    }
    plot.write(out.join("density.png"))?;
    let rows: Vec<[f64; 4]> = (0..z.len())
        .map(|b| [z[b], profile[0][b], profile[1][b], profile[2][b]])
        .collect();
    write_csv(
        out.join("density.csv"),
        &["z", "gas", "liquid", "solid"],
        &rows,
    )
}

/// The side view, the VTK file and the XYZ frame of one state at `(step, frame index)`
/// (the index counts frames of the whole run, so a resumed run goes on numbering).
fn write_frame(
    state: &State,
    system: &System,
    (step, index): (u32, u32),
    out: &Path,
    xyz: &mut XyzWriter,
    pvd: &mut Vec<(f64, String)>,
) -> Result<()> {
    side_view(state, system, step).write(out.join(format!("side_{index:03}.png")))?;
    // Each particle's radius is half its like-pair sigma (the contact distance).
    let radii: Vec<f64> = state
        .species
        .iter()
        .map(|&s| {
            let s = s as usize;
            system.table().get(s, s).map_or(0.5, |p| 0.5 * p.sigma)
        })
        .collect();
    let mut vtp = Particles::from_xyz(&state.positions)?;
    vtp.add_ints("species", &state.species)?
        .add_scalar("radius", &radii)?
        .add_vector("Velocity", state.velocities.as_flattened(), 3)?;
    let name = format!("frame_{index:03}.vtp");
    vtp.write(out.join(&name))?;
    pvd.push((state.time, name));
    let len = system.lengths();
    let mut frame = XyzFrame::from_xyz(&state.positions)?;
    frame
        .kinds(&state.species, &NAMES)?
        .lattice([[len[0], 0.0, 0.0], [0.0, len[1], 0.0], [0.0, 0.0, len[2]]])?
        .pbc(system.periodic())
        .time(state.time)?;
    frame
        .velocities(state.velocities.as_flattened(), 3)?
        .radii(&radii)?;
    xyz.push(&frame)
}

/// Side view: x across, z up, looking along +y; far particles first (hidden behind near
/// ones), discs of half the like-pair contact distance, coloured by species with a legend.
fn side_view(state: &State, system: &System, step: u32) -> ParticleFrame {
    let len = system.lengths();
    let mut order: Vec<usize> = (0..state.positions.len()).collect();
    order.sort_by(|&a, &b| state.positions[b][1].total_cmp(&state.positions[a][1]));
    let pos: Vec<[f64; 2]> = order
        .iter()
        .map(|&i| [state.positions[i][0], state.positions[i][2]])
        .collect();
    let ids: Vec<usize> = order.iter().map(|&i| state.species[i] as usize).collect();
    let radii: Vec<f64> = ids
        .iter()
        .map(|&s| if s == GAS as usize { 0.3 } else { 0.5 })
        .collect();
    ParticleFrame::new(&pos, &radii)
        .bounds(0.0, len[0], 0.0, len[2])
        .by_species(&ids, &NAMES)
        .species_colors(&COLORS)
        .size_px(640)
        .title("solid, liquid and gas in one box (side view along y)")
        .subtitle(format!("step {step}, t = {:.2} τ", state.time))
        .x_label("x (σ)")
        .y_label("z (σ)")
}
