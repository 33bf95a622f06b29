//! The cases `DistributedMd` must pass on any communicator (one process in
//! `tests/distributed.rs`, 2-4 MPI ranks in `tests/mpi.rs`): every rank count gives the bits
//! of the one-process run (state, diagnostics, forces and checkpoint bytes), checkpoints
//! move between rank counts, and a blow-up stops every rank with the same error.

use simkit_backend::comm::Comm;
use simkit_backend::rng::rng_uniform;
use simkit_backend::testing::check_decomposed;
use simkit_backend::{Error, Simulation};
use simkit_md::{
    Config, Dim, DistributedMd, Integrator, Langevin, LennardJones, PairTable, State, System,
    scenes,
};

/// A pseudo-random number in `[-0.5, 0.5)` keyed by `(stream, index)`.
fn noise(stream: u32, k: usize) -> f64 {
    f64::from(rng_uniform(23, stream, k as u32)) - 0.5
}

/// Particles on a square (2D) or simple cubic (3D) lattice of spacing `a` filling
/// the box, species by `kind(site)`, velocities of about `speed` (none for `frozen`).
fn lattice(
    system: &mut System,
    a: f64,
    speed: f64,
    kind: impl Fn([usize; 3]) -> u32,
    frozen: &[u32],
) {
    let (lo, len) = (system.lo(), system.lengths());
    let three = system.dim() == Dim::Three;
    let count = |d: usize| (len[d] / a).floor() as usize;
    let nz = if three { count(2) } else { 1 };
    let mut k = 0;
    for z in 0..nz {
        for y in 0..count(1) {
            for x in 0..count(0) {
                k += 1;
                let s = kind([x, y, z]);
                let p = [
                    lo[0] + (x as f64 + 0.5) * a,
                    lo[1] + (y as f64 + 0.5) * a,
                    if three {
                        lo[2] + (z as f64 + 0.5) * a
                    } else {
                        0.0
                    },
                ];
                let v = if frozen.contains(&s) {
                    [0.0; 3]
                } else {
                    [
                        speed * noise(0, k),
                        speed * noise(1, k),
                        if three { speed * noise(2, k) } else { 0.0 },
                    ]
                };
                system.add_particle(s, p, v).unwrap();
            }
        }
    }
}

/// LAMMPS's `in.lj` liquid in a 6 x 4 x 4 FCC box (384 atoms, 10.1 x 6.7 x 6.7, periodic),
/// energy shifted.
pub fn lj_liquid() -> (System, Config) {
    let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5)).unwrap();
    let system = scenes::fcc_lattice([6, 4, 4], 0.8442, 1.44, table, &[0], 5).unwrap();
    let config = Config {
        dt: Some(0.005),
        shift: true,
        ..Config::default()
    };
    (system, config)
}

/// 2D, closed along x and periodic along y, two mobile species (masses 1 and 2, their own
/// table entries) around a frozen column of a third: leapfrog.
pub fn walled_2d() -> (System, Config) {
    let mut t = PairTable::uniform(3, LennardJones::new(1.0, 1.0, 2.5)).unwrap();
    t.set(1, 1, LennardJones::new(1.2, 0.9, 2.2)).unwrap();
    t.set(0, 1, LennardJones::weighted(1.0, 1.0, 1.0, 0.5, 2.0))
        .unwrap();
    t.set(0, 2, LennardJones::repulsive(1.0, 1.0, 1.5)).unwrap();
    t.set(1, 2, LennardJones::new(0.5, 1.0, 2.5)).unwrap();
    t.set(2, 2, LennardJones::repulsive(1.0, 1.0, 1.2)).unwrap();
    let mut s = System::new(
        Dim::Two,
        [0.0; 3],
        [14.3, 9.9, 0.0],
        [false, true, false],
        vec![1.0, 2.0, 1.0],
        t,
    )
    .unwrap();
    s.set_frozen(2, true).unwrap();
    lattice(
        &mut s,
        1.1,
        2.0,
        |c| if c[0] == 6 { 2 } else { (c[1] % 2) as u32 },
        &[2],
    );
    let config = Config {
        integrator: Integrator::Leapfrog,
        ..Config::default()
    };
    (s, config)
}

/// 3D, periodic along x and z, closed along y, three species with their own cutoffs,
/// the Langevin thermostat with a per-species target for species 2; velocity Verlet.
pub fn langevin_3d() -> (System, Config) {
    let mut t = PairTable::uniform(3, LennardJones::new(1.0, 1.0, 2.5)).unwrap();
    t.set(0, 0, LennardJones::repulsive(1.0, 0.8, 1.6)).unwrap();
    t.set(0, 1, LennardJones::repulsive(1.0, 1.0, 2.0)).unwrap();
    t.set(1, 2, LennardJones::new(0.7, 1.05, 2.4)).unwrap();
    let mut s = System::new(
        Dim::Three,
        [-1.0, 2.0, 0.5],
        [10.0, 9.0, 7.0],
        [true, false, true],
        vec![1.0, 1.5, 3.0],
        t,
    )
    .unwrap();
    s.set_species_langevin(2, Some([0.8, 2.0])).unwrap();
    lattice(
        &mut s,
        1.25,
        1.5,
        |c| ((c[0] + c[1] + c[2]) % 3) as u32,
        &[],
    );
    let config = Config {
        shift: true,
        thermostat: Some(Langevin::new(1.5, 1.0, 7)),
        ..Config::default()
    };
    (s, config)
}

/// A hot 2D Lennard-Jones gas, periodic along both axes (particles cross the periodic
/// faces and the region corners); velocity Verlet.
pub fn hot_gas_2d() -> (System, Config) {
    let t = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5)).unwrap();
    let mut s = System::new(
        Dim::Two,
        [0.0; 3],
        [12.0, 12.0, 0.0],
        [true, true, false],
        vec![1.0],
        t,
    )
    .unwrap();
    lattice(&mut s, 1.3, 5.0, |_| 0, &[]);
    (s, Config::default())
}

/// The systems, their settings and step counts.
pub fn cases() -> Vec<(&'static str, System, Config, u32)> {
    let (a, ca) = lj_liquid();
    let (b, cb) = walled_2d();
    let (c, cc) = langevin_3d();
    let (d, cd) = hot_gas_2d();
    vec![
        ("3D Lennard-Jones liquid", a, ca, 200),
        ("2D walls, frozen column, leapfrog", b, cb, 300),
        ("3D three species, Langevin", c, cc, 200),
        ("2D periodic hot gas", d, cd, 300),
    ]
}

/// The bits of positions and velocities (so -0.0 differs from 0.0).
pub fn state_bits(s: &State) -> Vec<u64> {
    s.positions
        .iter()
        .chain(&s.velocities)
        .flatten()
        .chain([&s.time])
        .map(|c| c.to_bits())
        .collect()
}

/// `Err` naming `what` when `a != b`.
fn same<T: PartialEq + std::fmt::Debug>(a: T, b: T, what: &str) -> Result<(), String> {
    if a == b {
        Ok(())
    } else {
        Err(format!("{what} differs from the one-process run"))
    }
}

/// The first particle whose state bits differ, for the error message.
fn first_difference(a: &State, b: &State) -> String {
    let n = a.positions.len();
    (0..n)
        .find(|&i| {
            a.positions[i].map(f64::to_bits) != b.positions[i].map(f64::to_bits)
                || a.velocities[i].map(f64::to_bits) != b.velocities[i].map(f64::to_bits)
        })
        .map_or("none".into(), |i| {
            format!(
                "particle {i}: {:?} {:?} against {:?} {:?}",
                a.positions[i], a.velocities[i], b.positions[i], b.velocities[i]
            )
        })
}

fn same_state(a: &State, b: &State, what: &str) -> Result<(), String> {
    if state_bits(a) == state_bits(b) {
        Ok(())
    } else {
        Err(format!(
            "{what} differs from the one-process run; first difference: {}",
            first_difference(a, b)
        ))
    }
}

fn err(e: Error) -> String {
    e.to_string()
}

/// Every case on `comm` against one process (`Comm::serial`, run on every rank), bit for
/// bit: the state after a first stretch, the checkpoint bytes, the state after a second
/// stretch, a one-process checkpoint resumed on `comm` and a `comm` checkpoint resumed on
/// one process, diagnostics and forces. Returns the number of checks.
pub fn check_all(comm: &Comm) -> Result<usize, String> {
    let mut checks = 0;
    for (name, system, config, steps) in cases() {
        let make = |c: Comm| DistributedMd::new(system.clone(), &config, c);
        let (mut one, mut many) = check_decomposed(comm, name, steps, make, same_state)?;
        let (d1, dm) = (
            one.diagnostics().map_err(err)?,
            many.diagnostics().map_err(err)?,
        );
        same(
            format!("{d1:?}"),
            format!("{dm:?}"),
            &format!("{name}: diagnostics"),
        )?;
        let bits =
            |f: Vec<[f64; 3]>| -> Vec<u64> { f.iter().flatten().map(|x| x.to_bits()).collect() };
        same(
            bits(one.forces().map_err(err)?),
            bits(many.forces().map_err(err)?),
            &format!("{name}: forces"),
        )?;
        // The run is decomposed: with several ranks no rank owns every particle.
        if comm.size() > 1 && many.owned() == system.particle_count() {
            return Err(format!(
                "{name}: rank {} owns all particles on {} ranks (regions {:?})",
                comm.rank(),
                comm.size(),
                many.dims()
            ));
        }
        // Every rank owns its share: the owned counts add up to all particles.
        let owned = comm.all_sum(many.owned() as f64).map_err(err)?;
        same(
            owned,
            system.particle_count() as f64,
            &format!("{name}: owned total"),
        )?;
        if !d1.total.is_finite() {
            return Err(format!("{name}: energy {}", d1.total));
        }
        checks += 7;
    }
    checks += blow_up(comm)?;
    Ok(checks)
}

/// Pairs of atoms thrown at each other far too fast for the time step: the run stops on
/// every rank with the one-process error, rolled back to the same step.
pub fn blow_up(comm: &Comm) -> Result<usize, String> {
    let t = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5)).unwrap();
    let mut system = System::new(
        Dim::Two,
        [0.0; 3],
        [24.0, 6.0, 0.0],
        [true, false, false],
        vec![1.0],
        t,
    )
    .unwrap();
    for k in 0..12 {
        let x = 1.0 + 2.0 * k as f64;
        let v = if k % 2 == 0 { 60.0 } else { -60.0 };
        system
            .add_particle(0, [x, 3.0, 0.0], [v, 0.0, 0.0])
            .unwrap();
    }
    let config = Config {
        dt: Some(0.005),
        check_every: 10,
        ..Config::default()
    };
    let run = |c: Comm| -> Result<(String, u64, Vec<u64>), String> {
        let mut sim = DistributedMd::new(system.clone(), &config, c).map_err(err)?;
        let e = match sim.step(2000) {
            Err(e @ Error::BlowUp { .. }) => e.to_string(),
            other => return Err(format!("expected a blow-up, got {other:?}")),
        };
        let s = sim.state().map_err(err)?;
        Ok((e, sim.steps_done(), state_bits(&s)))
    };
    let one = run(Comm::serial())?;
    let many = run(comm.clone())?;
    same(
        &one,
        &many,
        "the blow-up (message, step rolled back to, state)",
    )?;
    if one.1 % 10 != 0 {
        return Err(format!("rolled back to step {}, not a checked step", one.1));
    }
    Ok(1)
}
