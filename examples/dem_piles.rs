//! Piles of rolling grains: a heap from a column released onto a floor (2D discs or 3D
//! spheres) and a rotating drum (2D), with static friction (a tangential spring per
//! contact) and rolling resistance, and the angle of their free surface over time.
//!
//! ```text
//! cargo run --release --example dem_piles                           # drum, 400 discs
//! cargo run --release --example dem_piles -- --pile heap            # 2D heap, 1500 discs
//! cargo run --release --example dem_piles -- --pile heap3d --n 4000 # 3D heap
//! cargo run --release --example dem_piles -- --law hertz-mindlin --mu 0.3 --mu-r 0
//! cargo run --release --example dem_piles -- --gpu                  # the drum on the GPU
//! ```
//!
//! Writes to `out/dem_piles/<pile>/`:
//! - `frame_NNN.png` and `pile.gif`: the grains coloured by their angular velocity (the
//!   drum's shell and the fitted surface drawn in), a side view for the 3D heap;
//! - `pile_NNN.vtp` + `pile.pvd` (ParaView: `Velocity`, `AngularVelocity`, `radius`) and
//!   `frames.xyz` (extended XYZ for OVITO and ASE, with `velo`, `radius` and `omega`);
//! - `frames.gsd` (GSD, HOOMD-blue's format, for OVITO, freud and MDAnalysis: positions
//!   relative to the box centre, velocities, diameters, masses, and the angular velocity
//!   as `log/particles/angular_velocity`);
//! - `angle.csv`: time, surface angle (degrees), kinetic and rotational energy per grain.
//!
//! Units: mean grain diameter 1, mass 1 at diameter 1, `g = 1` (time in `sqrt(d / g)`).
//! The drum turns at `Omega = sqrt(Fr g / R)`; its surface angle is the dynamic angle of
//! repose once the flow is steady (after about half a turn), the heap's the static one
//! once it is at rest.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, ValueEnum};
use simkit::backend::{Backend, Precision, Result, Simulation};
use simkit::dem::scenes::{
    DrumParams, HeapParams, column_heap, heap_flank, rotating_drum, surface_angle,
};
use simkit::dem::{Config, ContactLaw, Dem, Dim, HertzMindlin, LinearHistory, Scene, Solid, State};
use simkit::output::colormap::Colormap;
use simkit::output::csv::CsvWriter;
use simkit::output::gif::GifWriter;
use simkit::output::gsd::{GsdFrame, GsdWriter};
use simkit::output::particles::ParticleFrame;
use simkit::output::png::write_png;
use simkit::output::vtk::{Particles, write_pvd};
use simkit::output::xyz::{XyzFrame, XyzWriter};

#[path = "common/progress.rs"]
mod progress;

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Pile {
    /// A 2D rotating drum.
    Drum,
    /// A 2D heap from a column released onto a floor.
    Heap,
    /// A 3D heap from a column released onto a floor.
    Heap3d,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Law {
    /// Linear spring–dashpot with tangential and rolling springs (`t_c = 0.03`, `e = 0.5`).
    LinearHistory,
    /// Hertz–Mindlin (`E = 1e5`, `nu = 0.3`, `e = 0.5`) with an SDS rolling spring.
    HertzMindlin,
}

/// A heap from a released column or a rotating drum, with rolling grains; writes frames
/// (PNG, GIF, VTK, extended XYZ) and the surface angle over time.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    /// Which pile.
    #[arg(long, value_enum, default_value_t = Pile::Drum)]
    pile: Pile,
    /// Contact law.
    #[arg(long, value_enum, default_value_t = Law::LinearHistory)]
    law: Law,
    /// Coulomb friction coefficient (grains and walls).
    #[arg(long, default_value_t = 0.5)]
    mu: f64,
    /// Rolling friction coefficient (0: none).
    #[arg(long, default_value_t = 0.1)]
    mu_r: f64,
    /// Number of grains (default: 400 in the drum, 1500 in the 2D heap, 4000 in 3D).
    #[arg(long)]
    n: Option<usize>,
    /// Froude number `Omega^2 R / g` of the drum.
    #[arg(long, default_value_t = 0.005)]
    froude: f64,
    /// Simulated time (default: one turn of the drum; 150 for a heap).
    #[arg(long)]
    time: Option<f64>,
    /// Number of frames written.
    #[arg(long, default_value_t = 40)]
    frames: u32,
    /// Output folder (a subfolder per pile).
    #[arg(long, default_value = "out/dem_piles")]
    out: PathBuf,
    /// Run on the GPU (f32) instead of the CPU (f64).
    #[arg(long)]
    gpu: bool,
}

fn main() -> ExitCode {
    simkit::cli::exit_code(run(&Args::parse()))
}

fn run(args: &Args) -> Result<()> {
    match args.law {
        Law::LinearHistory => pile(
            args,
            LinearHistory::new(0.5, 0.03, args.mu).with_rolling_friction(args.mu_r),
        ),
        Law::HertzMindlin => {
            let solid = Solid::new(1e5, 0.3);
            let law = HertzMindlin::new(solid, solid, 0.5, args.mu)?;
            let law = if args.mu_r > 0.0 {
                law.with_rolling(args.mu_r, 2000.0, 20.0)
            } else {
                law
            };
            pile(args, law)
        }
    }
}

fn pile<L: ContactLaw>(args: &Args, law: L) -> Result<()> {
    let drum = DrumParams {
        n: args.n.unwrap_or(400),
        froude: args.froude,
        ..DrumParams::default()
    };
    let (scene, time, name) = match args.pile {
        Pile::Drum => (
            rotating_drum(law, None, &drum)?,
            args.time
                .unwrap_or(2.0 * std::f64::consts::PI / drum.spin()),
            "drum",
        ),
        Pile::Heap | Pile::Heap3d => {
            let three = args.pile == Pile::Heap3d;
            let p = HeapParams {
                dim: if three { Dim::Three } else { Dim::Two },
                n: args.n.unwrap_or(if three { 4000 } else { 1500 }),
                column: if three { 16 } else { 40 },
                floor: if three { 40.0 } else { 80.0 },
                ..HeapParams::default()
            };
            (
                column_heap(law, None, &p)?,
                args.time.unwrap_or(150.0),
                if three { "heap3d" } else { "heap" },
            )
        }
    };
    let out = args.out.join(name);
    std::fs::create_dir_all(&out).map_err(|e| simkit::output::atomic::io_error(&out, &e))?;
    let radii: Vec<f64> = scene.particles().iter().map(|p| p.radius).collect();
    let ctx = if args.gpu {
        Some(simkit::backend::GpuContext::new()?)
    } else {
        None
    };
    let backend = ctx.as_ref().map_or(Backend::Cpu, Backend::Gpu);
    let mut sim = Dem::new(scene.clone(), &Config::default(), backend)?;
    let frames = args.frames.max(1);
    let per_frame = ((time / sim.dt()) as u32 / frames).max(1);
    println!(
        "{name}: {} grains, {} law, dt = {:.3e}, {} steps, a frame every {per_frame}",
        radii.len(),
        L::NAME,
        sim.dt(),
        u64::from(per_frame) * u64::from(frames)
    );
    let mut csv = CsvWriter::create(
        out.join("angle.csv"),
        &["time", "angle_deg", "kinetic", "rotational"],
    )?;
    let mut gif = GifWriter::create(out.join("pile.gif"), 100)?;
    let mut xyz = XyzWriter::create(out.join("frames.xyz"))?;
    let mut gsd = GsdWriter::create(out.join("frames.gsd"), Precision::F32)?;
    let mut pvd: Vec<(f64, String)> = Vec::new();
    let bar = progress::bar(name, u64::from(frames), "frames");
    let mut last = f64::NAN;
    for k in 0..=frames {
        if k > 0 {
            sim.step(per_frame)?;
            bar.inc(1);
        }
        let s = sim.state()?;
        let d = sim.diagnostics()?;
        let fit = angle(&scene, &s, &radii);
        let n = radii.len() as f64;
        last = fit.map_or(f64::NAN, |f| f.angle);
        csv.row(&[s.time, last, d.kinetic / n, d.rotational / n])?;
        let image = draw(&scene, &s, &radii, fit, name)?;
        write_png(out.join(format!("frame_{k:03}.png")), &image)?;
        gif.push(&image)?;
        let file = format!("pile_{k:03}.vtp");
        vtk(&s, &radii, &out.join(&file))?;
        pvd.push((s.time, file));
        xyz.push(&xyz_frame(&scene, &s, &radii)?)?;
        gsd.push(&gsd_frame(&scene, u64::from(per_frame) * u64::from(k), &s)?)?;
    }
    bar.finish();
    csv.finish()?;
    gif.finish()?;
    xyz.finish()?;
    write_pvd(out.join("pile.pvd"), &pvd)?;
    let d = sim.diagnostics()?;
    println!(
        "t = {:.1}: surface angle {last:.1}°, kinetic energy per grain {:.2e}; wrote {}/",
        d.time,
        (d.kinetic + d.rotational) / radii.len() as f64,
        out.display()
    );
    Ok(())
}

/// A fitted surface: its angle (degrees) and the line drawn over the picture.
#[derive(Clone, Copy)]
struct Fit {
    angle: f64,
    from: (f64, f64),
    to: (f64, f64),
}

/// The surface angle: in the drum, the middle half of the surface (its chord through the
/// axis, rising to the right); on a heap, its flanks between 15 % and 85 % of the runout
/// (the distance from the axis within which 95 % of the grains lie), both flanks folded
/// onto one (a positive angle: the flank falls away from the axis).
fn angle<L: ContactLaw>(scene: &Scene<L>, s: &State, radii: &[f64]) -> Option<Fit> {
    let up = scene.dim().vertical();
    let tops = |x: &dyn Fn(&[f64; 3]) -> f64| -> Vec<(f64, f64)> {
        s.positions
            .iter()
            .zip(radii)
            .map(|(p, r)| (x(p), p[up] + r))
            .collect()
    };
    if let Some(w) = scene.walls().iter().find(|w| w.spin != 0.0) {
        let simkit::dem::WallShape::Cylinder { center, radius } = w.shape else {
            return None;
        };
        let (a, b) = (center[0] - 0.5 * radius, center[0] + 0.5 * radius);
        let grains = tops(&|p| p[0]);
        let angle = surface_angle(&grains, a, b, 1.0).ok()?;
        let mid = grains
            .iter()
            .filter(|g| (g.0 - center[0]).abs() < 1.0)
            .map(|g| g.1)
            .fold(f64::NEG_INFINITY, f64::max);
        let slope = angle.to_radians().tan();
        return Some(Fit {
            angle,
            from: (a, mid - slope * (center[0] - a)),
            to: (b, mid + slope * (b - center[0])),
        });
    }
    let flank = heap_flank(scene.dim(), &s.positions, radii).ok()?;
    let (angle, a, b) = (flank.angle, flank.from, flank.to);
    let crest = flank
        .grains
        .iter()
        .filter(|g| g.0 < a)
        .map(|g| g.1)
        .fold(f64::NEG_INFINITY, f64::max);
    let slope = angle.to_radians().tan();
    Some(Fit {
        angle,
        from: (a, crest),
        to: (b, crest - slope * (b - a)),
    })
}

/// The picture: grains (x against height; a side view in 3D) coloured by the angular
/// velocity about the axis normal to the picture, the fitted surface, the drum's shell.
fn draw<L: ContactLaw>(
    scene: &Scene<L>,
    s: &State,
    radii: &[f64],
    fit: Option<Fit>,
    name: &str,
) -> Result<simkit::output::RgbImage> {
    let up = scene.dim().vertical();
    let (lo, hi) = (scene.lo(), scene.hi());
    let xy: Vec<[f64; 2]> = s.positions.iter().map(|p| [p[0], p[up]]).collect();
    // About z in 2D; about -y in 3D (the axis pointing out of an x-z side view).
    let spin: Vec<f64> = s
        .angular_velocities
        .iter()
        .map(|w| if up == 1 { w[2] } else { -w[1] })
        .collect();
    let wmax = spin.iter().fold(0.05f64, |m, w| m.max(w.abs()));
    let mut frame = ParticleFrame::new(&xy, radii)
        .by_value(&spin, "angular velocity")
        .colormap(Colormap::Viridis)
        .range(-wmax, wmax)
        .x_label("x (d)")
        .y_label(if up == 1 { "y (d)" } else { "z (d)" })
        .title(format!("{name}, t = {:.1}", s.time));
    if let Some(f) = fit {
        frame = frame.subtitle(format!("surface angle {:.1}°", f.angle));
        if scene.walls().iter().any(|w| w.spin != 0.0) {
            frame = frame.line(f.from, f.to);
        } else {
            frame = frame
                .line(f.from, f.to)
                .line((-f.from.0, f.from.1), (-f.to.0, f.to.1));
        }
    }
    for w in scene.walls() {
        if let simkit::dem::WallShape::Cylinder { center, radius } = w.shape {
            frame = frame
                .circle((center[0], center[1]), radius)
                .bounds(lo[0], hi[0], lo[1], hi[1]);
        }
    }
    if !scene.walls().iter().any(|w| w.spin != 0.0) {
        // A heap: its floor, from the highest grain down.
        let top = xy
            .iter()
            .zip(radii)
            .map(|(p, r)| p[1] + r)
            .fold(0.0, f64::max);
        frame = frame.bounds(lo[0], hi[0], 0.0, (top + 2.0).max(0.25 * (hi[0] - lo[0])));
    }
    frame.render()
}

/// A VTK poly-data frame: `Velocity`, `AngularVelocity`, `radius`.
fn vtk(s: &State, radii: &[f64], path: &Path) -> Result<()> {
    let mut v = Particles::from_xyz(&s.positions)?;
    v.add_scalar("radius", radii)?
        .add_vector("Velocity", s.velocities.as_flattened(), 3)?
        .add_vector("AngularVelocity", s.angular_velocities.as_flattened(), 3)?;
    v.write(path)
}

/// A GSD frame at time step `step`: positions, velocities, one type `grain`, diameters,
/// masses, angular velocities; the box of the scene.
fn gsd_frame<L: ContactLaw>(scene: &Scene<L>, step: u64, s: &State) -> Result<GsdFrame> {
    let axes = scene.dim().axes();
    let (lo, hi) = (scene.lo(), scene.hi());
    let mut f = GsdFrame::from_state(step, s, &lo[..axes], &hi[..axes])?;
    let grains = scene.particles();
    let diameters: Vec<f64> = grains.iter().map(|p| 2.0 * p.radius).collect();
    let masses: Vec<f64> = grains.iter().map(|p| p.mass).collect();
    f.types(&vec![0u32; grains.len()], &["grain"])?
        .diameters(&diameters)?
        .masses(&masses)?;
    Ok(f)
}

/// An extended XYZ frame: positions, `velo`, `radius`, `omega`, the box.
fn xyz_frame<L: ContactLaw>(scene: &Scene<L>, s: &State, radii: &[f64]) -> Result<XyzFrame> {
    let (lo, hi) = (scene.lo(), scene.hi());
    let mut f = XyzFrame::from_xyz(&s.positions)?;
    f.uniform_species("X")?
        .lattice([
            [hi[0] - lo[0], 0.0, 0.0],
            [0.0, hi[1] - lo[1], 0.0],
            [0.0, 0.0, (hi[2] - lo[2]).max(1.0)],
        ])?
        .pbc([false; 3])
        .time(s.time)?;
    f.velocities(s.velocities.as_flattened(), 3)?
        .radii(radii)?
        .add_vector("omega", s.angular_velocities.as_flattened(), 3)?;
    Ok(f)
}
