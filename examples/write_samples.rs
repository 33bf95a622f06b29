//! One small file of every kind `simkit::output` writes for other programs (`.vtp` particles
//! in binary and ASCII, a `.pvd` series of `.vtp` files, `.vti` grids in binary and ASCII,
//! extended XYZ, GSD, CSV), with values from simple formulas of the particle or grid index.
//! `scripts/check_readers.py` recomputes the same formulas and checks that VTK, ASE, `gsd`
//! and freud read every file back with the counts, names and values written.
//!
//! ```text
//! cargo run --release --example write_samples -- out/samples
//! ```

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::Parser;
use simkit::backend::{Precision, Result};
use simkit::output::csv::write_csv;
use simkit::output::gsd::{GsdFrame, GsdWriter};
use simkit::output::vtk::{Encoding, ImageData, Particles, write_pvd};
use simkit::output::xyz::{XyzFrame, write_xyz};

/// Writes one sample file of every output kind into a directory, for reader checks.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    /// Directory to write into (created if missing).
    #[arg(default_value = "out/samples")]
    dir: PathBuf,
}

/// Particles per sample.
const N: usize = 6;
/// Species names of the samples; particle `i` has species `i % 3`.
const KINDS: [&str; 3] = ["gas", "liquid", "solid"];

/// Position of particle `i` in frame `f`.
fn position(i: usize, f: usize) -> [f64; 3] {
    let x = i as f64;
    [0.5 * x + f as f64, 0.25 * x * x, -x / 3.0]
}

/// Velocity of particle `i`.
fn velocity(i: usize) -> [f64; 3] {
    let x = i as f64;
    [x, -2.0 * x, 0.5]
}

/// Radius of particle `i`.
fn radius(i: usize) -> f64 {
    0.1 + 0.05 * i as f64
}

/// Particles of frame `f`: radius, species, id and velocity arrays.
fn particles(f: usize, encoding: Encoding) -> Result<Particles> {
    let pos: Vec<[f64; 3]> = (0..N).map(|i| position(i, f)).collect();
    let vel: Vec<[f64; 3]> = (0..N).map(velocity).collect();
    let radii: Vec<f64> = (0..N).map(radius).collect();
    let species: Vec<u32> = (0..N as u32).map(|i| i % 3).collect();
    let ids: Vec<u32> = (0..N as u32).map(|i| 100 + i).collect();
    let mut p = Particles::from_xyz(&pos)?.encoding(encoding);
    p.add_scalar("radius", &radii)?
        .add_ints("species", &species)?
        .add_ints("id", &ids)?
        .add_vector("Velocity", vel.as_flattened(), 3)?;
    Ok(p)
}

/// A 4 x 3 x 2 grid (`rho = i + 10 j + 100 k`, `u = (i / 2, -j, k)`) and a 5 x 4 grid
/// (`phi = i j / 7`, two-component `g = (i, j)`).
fn grids(dir: &Path) -> Result<()> {
    let (nx, ny, nz) = (4, 3, 2);
    let mut rho = Vec::new();
    let mut u = Vec::new();
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let (i, j, k) = (i as f64, j as f64, k as f64);
                rho.push(i + 10.0 * j + 100.0 * k);
                u.extend_from_slice(&[i / 2.0, -j, k]);
            }
        }
    }
    let mut g = ImageData::new([nx, ny, nz], [0.0, -1.0, 0.5], [0.5, 0.25, 1.0])?;
    g.add_scalar("rho", &rho)?.add_vector("u", &u, 3)?;
    g.write(dir.join("grid.vti"))?;

    let (nx, ny) = (5, 4);
    let mut phi = Vec::new();
    let mut grad = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            let (i, j) = (i as f64, j as f64);
            phi.push(i * j / 7.0);
            grad.extend_from_slice(&[i, j]);
        }
    }
    let mut g = ImageData::new_2d(nx, ny, [1.0, 2.0], [0.1, 0.2])?.encoding(Encoding::Ascii);
    g.add_scalar("phi", &phi)?.add_vector("g", &grad, 2)?;
    g.write(dir.join("grid_ascii.vti"))
}

/// Two extended XYZ frames with species kinds, box, velocities and radii; one frame of
/// argon (`elements.xyz`).
fn xyz(dir: &Path) -> Result<()> {
    let kinds: Vec<u32> = (0..N as u32).map(|i| i % 3).collect();
    let vel: Vec<[f64; 3]> = (0..N).map(velocity).collect();
    let radii: Vec<f64> = (0..N).map(radius).collect();
    let mut frames = Vec::new();
    for f in 0..2 {
        let pos: Vec<[f64; 3]> = (0..N).map(|i| position(i, f)).collect();
        let mut frame = XyzFrame::from_xyz(&pos)?;
        frame
            .kinds(&kinds, &KINDS)?
            .lattice([[10.0, 0.0, 0.0], [0.0, 8.0, 0.0], [0.0, 0.0, 6.0]])?
            .pbc([true, true, false])
            .time(0.5 * f as f64)?;
        frame.velocities(vel.as_flattened(), 3)?.radii(&radii)?;
        frames.push(frame);
    }
    write_xyz(dir.join("traj.xyz"), &frames)?;
    let pos: Vec<[f64; 3]> = (0..N).map(|i| position(i, 0)).collect();
    let mut argon = XyzFrame::from_xyz(&pos)?;
    argon.uniform_species("Ar")?;
    write_xyz(dir.join("elements.xyz"), &[argon])
}

/// Box of the GSD samples: `[lo, hi]` holds every sample position (3D; the first two axes
/// in 2D).
const GSD_LO: [f64; 3] = [-1.0, -1.0, -2.0];
const GSD_HI: [f64; 3] = [5.0, 7.0, 1.0];

/// GSD trajectories: `traj.gsd` in f32 and `traj64.gsd` in f64 (3D, two frames at steps 0 and 100: positions, velocities,
/// species, diameters `2 radius`, masses `1 + i`, `log/particles/angular_velocity =
/// (i, 0, -i)` and `log/energy/kinetic = 0.5 f`) and `flat.gsd` (2D, one frame: the first
/// two coordinates and velocity components).
fn gsd(dir: &Path) -> Result<()> {
    let kinds: Vec<u32> = (0..N as u32).map(|i| i % 3).collect();
    let vel: Vec<[f64; 3]> = (0..N).map(velocity).collect();
    let diameters: Vec<f64> = (0..N).map(|i| 2.0 * radius(i)).collect();
    let masses: Vec<f64> = (0..N).map(|i| 1.0 + i as f64).collect();
    let spin: Vec<f64> = (0..N).flat_map(|i| [i as f64, 0.0, -(i as f64)]).collect();
    let mut traj = GsdWriter::create(dir.join("traj.gsd"), Precision::F32)?;
    let mut exact = GsdWriter::create(dir.join("traj64.gsd"), Precision::F64)?;
    for f in 0..2 {
        let pos: Vec<[f64; 3]> = (0..N).map(|i| position(i, f)).collect();
        let mut frame = GsdFrame::new(100 * f as u64, pos.as_flattened(), 3, &GSD_LO, &GSD_HI)?;
        frame
            .velocities(vel.as_flattened(), 3)?
            .types(&kinds, &KINDS)?
            .diameters(&diameters)?
            .masses(&masses)?
            .log("particles/angular_velocity", &spin, 3)?
            .log("energy/kinetic", &[0.5 * f as f64], 1)?;
        traj.push(&frame)?;
        exact.push(&frame)?;
    }
    let xy: Vec<f64> = (0..N).flat_map(|i| position(i, 0)[..2].to_vec()).collect();
    let vxy: Vec<f64> = (0..N).flat_map(|i| velocity(i)[..2].to_vec()).collect();
    let mut flat = GsdFrame::new(7, &xy, 2, &GSD_LO[..2], &GSD_HI[..2])?;
    flat.velocities(&vxy, 2)?.types(&kinds, &KINDS)?;
    GsdWriter::create(dir.join("flat.gsd"), Precision::F32)?.push(&flat)
}

fn run(dir: &Path) -> Result<()> {
    particles(0, Encoding::Binary)?.write(dir.join("particles.vtp"))?;
    particles(0, Encoding::Ascii)?.write(dir.join("particles_ascii.vtp"))?;
    let mut series = Vec::new();
    for f in 0..2 {
        let name = format!("series_{f}.vtp");
        particles(f, Encoding::Binary)?.write(dir.join(&name))?;
        series.push((0.5 * f as f64, name));
    }
    write_pvd(dir.join("series.pvd"), &series)?;
    grids(dir)?;
    xyz(dir)?;
    gsd(dir)?;
    let rows: Vec<[f64; 2]> = (0..5).map(|k| [0.1 * k as f64, -1.5 * k as f64]).collect();
    write_csv(dir.join("series.csv"), &["t", "energy"], &rows)
}

fn main() -> ExitCode {
    let args = Args::parse();
    match run(&args.dir) {
        Ok(()) => {
            println!("wrote samples to {}", args.dir.display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
