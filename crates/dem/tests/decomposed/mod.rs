//! The cases `DistributedDem` must pass on any communicator (one process in
//! `tests/distributed.rs`, 2-4 MPI ranks in `tests/mpi.rs`): every rank count gives the bits
//! of the one-process run (state, diagnostics and checkpoint bytes), checkpoints move
//! between rank counts, and a blow-up stops every rank with the same error.

use simkit_backend::comm::Comm;
use simkit_backend::testing::check_decomposed;
use simkit_backend::{Error, Simulation};
use simkit_dem::scenes::{BedParams, granular_box, granular_box_history, vibrating_bed};
use simkit_dem::{
    Config, ContactLaw, Dim, DistributedDem, HertzMindlin, Material, Particle, Scene, Solid, State,
};

/// A periodic gas of `n_side^D` grains of radius 0.5 on a lattice of spacing `spacing`,
/// masses 1 and 2, pseudo-random velocities of about `speed`, Coulomb friction.
pub fn gas(dim: Dim, n_side: usize, spacing: f64, speed: f64) -> Scene {
    let m = Material::new(0.8, 0.05).with_friction(0.4, 20.0);
    gas_with(dim, n_side, spacing, speed, m)
}

/// [`gas`] of rotating grains in contact law `law`.
pub fn rough_gas<L: ContactLaw>(
    dim: Dim,
    n_side: usize,
    spacing: f64,
    speed: f64,
    law: L,
) -> Scene<L> {
    let mut s = gas_with(dim, n_side, spacing, speed, law);
    s.set_rotation(true);
    s
}

/// [`gas`] with contact law `law`.
fn gas_with<L: ContactLaw>(dim: Dim, n_side: usize, spacing: f64, speed: f64, law: L) -> Scene<L> {
    let l = n_side as f64 * spacing;
    let three = dim == Dim::Three;
    let hi = [l, l, if three { l } else { 0.0 }];
    let mut s = Scene::new(dim, [0.0; 3], hi, law).unwrap();
    s.set_periodic([true; 3]);
    let nz = if three { n_side } else { 1 };
    let mut k = 0u32;
    for z in 0..nz {
        for y in 0..n_side {
            for x in 0..n_side {
                k += 1;
                let h = |a: u32| speed * (simkit_backend::rng::rng_uniform(11, a, k) as f64 - 0.5);
                let p = [
                    (x as f64 + 0.5) * spacing,
                    (y as f64 + 0.5) * spacing,
                    if three {
                        (z as f64 + 0.5) * spacing
                    } else {
                        0.0
                    },
                ];
                let v = [h(0), h(1), if three { h(2) } else { 0.0 }];
                let mass = if k.is_multiple_of(3) { 2.0 } else { 1.0 };
                s.add_particle(Particle::new(p, 0.5, mass).with_velocity(v))
                    .unwrap();
            }
        }
    }
    s
}

/// The scenes, their settings and step counts: a vibrated 2D bed in a closed box (walls,
/// a vibrating floor, friction), periodic 2D and 3D gases (particles crossing the periodic
/// faces and the region borders), and the 3D pile on a floor of the LAMMPS deck (periodic
/// x and y).
pub fn cases() -> Vec<Case<Material>> {
    let bed = BedParams {
        n: 240,
        width: 24,
        ..BedParams::default()
    };
    let (bed, _) = vibrating_bed(&bed).unwrap();
    let pile = granular_box(10, 9, 3, 5).unwrap();
    let pile_config = Config {
        dt: Some(1e-4),
        ..Config::default()
    };
    vec![
        ("vibrated 2D bed", bed, Config::default(), 1500),
        (
            "periodic 2D gas",
            gas(Dim::Two, 20, 1.1, 4.0),
            Config::default(),
            600,
        ),
        (
            "periodic 3D gas",
            gas(Dim::Three, 9, 1.15, 4.0),
            Config::default(),
            400,
        ),
        ("3D pile on a floor", pile, pile_config, 400),
    ]
}

/// A case: its name, scene, settings and step count.
pub type Case<L> = (&'static str, Scene<L>, Config, u32);

/// Hertz–Mindlin with sliding and rolling friction (`E = 1e5`, `nu = 0.3`, `e = 0.7`,
/// `mu = 0.4`, rolling `mu_r = 0.05`).
pub fn rough_law() -> HertzMindlin {
    let solid = Solid::new(1e5, 0.3);
    HertzMindlin::new(solid, solid, 0.7, 0.4)
        .unwrap()
        .with_rolling(0.05, 2000.0, 20.0)
}

/// The cases with rotation and contact history: a rough periodic 2D gas (Hertz–Mindlin with
/// rolling resistance) and the 3D box of the LAMMPS comparison with `hooke/history`
/// physics (a floor, periodic sides).
pub fn history_cases() -> (Case<HertzMindlin>, Case<simkit_dem::LinearHistory>) {
    let box_config = Config {
        dt: Some(1e-4),
        ..Config::default()
    };
    (
        (
            "rough 2D gas (Hertz–Mindlin, rolling)",
            rough_gas(Dim::Two, 16, 1.1, 3.0, rough_law()),
            Config::default(),
            600,
        ),
        (
            "3D box with history (hooke/history)",
            granular_box_history(8, 8, 3, 5).unwrap(),
            box_config,
            400,
        ),
    )
}

/// The bits of positions, velocities and angular velocities (so -0.0 differs from 0.0).
pub fn state_bits(s: &State) -> Vec<u64> {
    s.positions
        .iter()
        .chain(&s.velocities)
        .chain(&s.angular_velocities)
        .flatten()
        .chain([&s.time])
        .map(|c| c.to_bits())
        .collect()
}

/// `Err` naming `what` when `a != b`.
fn same<T: PartialEq>(a: T, b: T, what: &str) -> Result<(), String> {
    if a == b {
        Ok(())
    } else {
        Err(format!("{what} differs from the one-process run"))
    }
}

fn err(e: Error) -> String {
    e.to_string()
}

/// Every case on `comm` against one process (`Comm::serial`, run on every rank), bit for
/// bit: the state after a first stretch, the checkpoint bytes, the state after a second
/// stretch, a one-process checkpoint resumed on `comm` and a `comm` checkpoint resumed on
/// one process. Returns the number of checks.
pub fn check_all(comm: &Comm) -> Result<usize, String> {
    let mut checks = 0;
    for (name, scene, config, steps) in cases() {
        checks += check_case(comm, name, scene, config, steps)?;
    }
    let (rough, boxed) = history_cases();
    checks += check_case(comm, rough.0, rough.1, rough.2, rough.3)?;
    checks += check_case(comm, boxed.0, boxed.1, boxed.2, boxed.3)?;
    checks += blow_up(comm)?;
    Ok(checks)
}

/// One case of [`check_all`] (`testing::check_decomposed`, then the diagnostics and the
/// ownership): 6 checks.
fn check_case<L: ContactLaw>(
    comm: &Comm,
    name: &str,
    scene: Scene<L>,
    config: Config,
    steps: u32,
) -> Result<usize, String> {
    let make = |c: Comm| DistributedDem::new(scene.clone(), &config, c);
    let same_state = |a: &State, b: &State, what: &str| same(state_bits(a), state_bits(b), what);
    let (mut one, mut many) = check_decomposed(comm, name, steps, make, same_state)?;
    let end = one.state().map_err(err)?;
    if scene.rotation() && !end.angular_velocities.iter().flatten().any(|&w| w != 0.0) {
        return Err(format!("{name}: nothing spins after {steps} steps"));
    }
    let (d1, dm) = (
        one.diagnostics().map_err(err)?,
        many.diagnostics().map_err(err)?,
    );
    same(
        format!("{d1:?}"),
        format!("{dm:?}"),
        &format!("{name}: diagnostics"),
    )?;
    // Every rank owns its share: the owned counts add up to all particles.
    let owned = comm.all_sum(many.owned() as f64).map_err(err)?;
    same(
        owned,
        scene.particles().len() as f64,
        &format!("{name}: owned total"),
    )?;
    Ok(6)
}

/// Two grains thrown at each other far too fast for their contact time: the overlap check
/// stops the run on every rank with the one-process error, rolled back to the same step.
pub fn blow_up(comm: &Comm) -> Result<usize, String> {
    let m = Material::new(0.9, 0.5);
    let mut scene = Scene::new(Dim::Two, [0.0; 3], [12.0, 4.0, 0.0], m).unwrap();
    scene.set_periodic([true, false, false]);
    for k in 0..6 {
        let x = 1.0 + 2.0 * k as f64;
        let v = if k % 2 == 0 { 40.0 } else { -40.0 };
        scene
            .add_particle(Particle::new([x, 2.0, 0.0], 0.4, 1.0).with_velocity([v, 0.0, 0.0]))
            .unwrap();
    }
    let config = Config {
        check_every: 10,
        ..Config::default()
    };
    let run = |c: Comm| -> Result<(String, u64, Vec<u64>), String> {
        let mut sim = DistributedDem::new(scene.clone(), &config, c).map_err(err)?;
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
    if !one.0.contains("overlaps") {
        return Err(format!("the blow-up names no overlap: {}", one.0));
    }
    Ok(1)
}
