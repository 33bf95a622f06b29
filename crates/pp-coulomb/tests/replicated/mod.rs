//! The cases `DistributedCoulomb` must pass on any communicator (one process in
//! `tests/distributed.rs`, 2-4 MPI ranks in `tests/mpi.rs`): against `PpCoulomb` on the
//! CPU, bit for bit, in f64, f32 and the mixed mode, with 203 particles (203 = 12 x 16 + 11: no rank count 2-4 and no SIMD
//! width divides it).

use simkit_backend::Distributed;
use simkit_backend::comm::Comm;
use simkit_backend::{Backend, Restart, Simulation};
use simkit_pp_coulomb::{
    Config, Diagnostics, DistributedCoulomb, ForceLaw, Integrator, Particles, PpCoulomb, Precision,
    Region, Species, Velocities,
};

/// Particles in the cases.
pub const N: usize = 203;

/// Electrons and heavier ions in a cube: opposite charges, so the bare law can blow up.
pub fn plasma(seed: u64) -> Particles {
    let mut p = Particles::new();
    let e = p.add_species(Species::new("electron", -1.0, 1.0)).unwrap();
    let ion = p.add_species(Species::new("ion", 2.0, 40.0)).unwrap();
    let cube = Region::Cube {
        min: [-6.0; 3],
        length: 12.0,
    };
    let v = Velocities::Maxwellian { thermal_speed: 0.2 };
    p.fill(e, N - 68, cube, v, seed).unwrap();
    p.fill(ion, 68, cube, v, seed + 1).unwrap();
    p
}

/// The bits of positions and velocities (so -0.0 differs from 0.0).
pub fn state_bits(p: &Particles) -> Vec<u64> {
    p.position
        .iter()
        .chain(&p.velocity)
        .flatten()
        .map(|c| c.to_bits())
        .collect()
}

fn vec_bits(a: &[[f64; 3]]) -> Vec<u64> {
    a.iter().flatten().map(|c| c.to_bits()).collect()
}

fn diagnostics_bits(d: &Diagnostics) -> Vec<u64> {
    [d.kinetic, d.potential, d.total, d.force_magnitude_sum]
        .iter()
        .chain(&d.momentum)
        .chain(&d.angular_momentum)
        .chain(&d.force_sum)
        .map(|c| c.to_bits())
        .collect()
}

/// `Err` naming `what` when `a != b`.
fn same<T: PartialEq>(a: T, b: T, what: &str) -> Result<(), String> {
    if a == b {
        Ok(())
    } else {
        Err(format!("{what} differs from the single-process CPU run"))
    }
}

/// Everything observable of the two runs, bit for bit: state, accelerations, diagnostics,
/// steps, time, and the checkpoint bytes.
fn compare(d: &mut DistributedCoulomb, one: &mut PpCoulomb, case: &str) -> Result<(), String> {
    let e = |err: simkit_backend::Error| format!("{case}: {err}");
    same(
        state_bits(&d.state().map_err(e)?),
        state_bits(&one.state().map_err(e)?),
        &format!("{case}: state"),
    )?;
    same(
        vec_bits(&d.accelerations().map_err(e)?),
        vec_bits(&one.accelerations().map_err(e)?),
        &format!("{case}: accelerations"),
    )?;
    same(
        diagnostics_bits(&d.diagnostics().map_err(e)?),
        diagnostics_bits(&one.diagnostics().map_err(e)?),
        &format!("{case}: diagnostics"),
    )?;
    same(
        (d.steps_done(), d.time().to_bits()),
        (one.steps_done(), one.time().to_bits()),
        &format!("{case}: steps and time"),
    )?;
    same(
        d.checkpoint().map_err(e)?,
        one.checkpoint().map_err(e)?,
        &format!("{case}: checkpoint"),
    )
}

/// Steps both runs by `steps` and compares the results (`Ok` or the same error) and then
/// everything [`compare`] sees.
fn step_both(
    d: &mut DistributedCoulomb,
    one: &mut PpCoulomb,
    steps: u32,
    case: &str,
) -> Result<(), String> {
    let (a, b) = (
        format!("{:?}", d.step(steps)),
        format!("{:?}", one.step(steps)),
    );
    if a != b {
        return Err(format!("{case}: step({steps}) gave {a}, one process {b}"));
    }
    compare(d, one, case)
}

/// Runs every case on `comm`; returns how many ran. Collective.
pub fn check_all(comm: &Comm) -> Result<usize, String> {
    let cases = [
        (
            "exact leapfrog",
            ForceLaw::Exact,
            Integrator::Leapfrog,
            0.002,
        ),
        (
            "plummer euler",
            ForceLaw::Plummer { epsilon: 0.3 },
            Integrator::SymplecticEuler,
            0.02,
        ),
        (
            "exclusion leapfrog",
            ForceLaw::Exclusion { radius: 0.8 },
            Integrator::Leapfrog,
            0.02,
        ),
    ];
    let mut count = 0;
    let modes = [
        ("f64", Precision::F64, false),
        ("f32", Precision::F32, false),
        ("mixed", Precision::F32, true),
    ];
    for (mode, precision, mixed) in modes {
        for (name, law, integrator, dt) in cases {
            let case = format!("{name} {mode}");
            let c = Config::new(dt, law)
                .with_integrator(integrator)
                .with_precision(precision)
                .with_mixed(mixed)
                .with_check_every(10);
            let e = |err: simkit_backend::Error| format!("{case}: {err}");
            let p = plasma(5);
            let mut d = DistributedCoulomb::new(p.clone(), &c, comm.clone()).map_err(e)?;
            let mut one = PpCoulomb::new(p, &c, Backend::Cpu).map_err(e)?;
            compare(&mut d, &mut one, &case)?;
            // Two calls: interval checks inside the first, end-of-call checks after both.
            step_both(&mut d, &mut one, 13, &case)?;
            step_both(&mut d, &mut one, 12, &case)?;
            // The single-process checkpoint resumes on this communicator and goes on with
            // the same bits (leapfrog: the kept accelerations come back too).
            let bytes = one.checkpoint().map_err(e)?;
            let mut resumed = DistributedCoulomb::resume(&bytes, comm.clone()).map_err(e)?;
            d.set_dt(dt * 0.5).map_err(e)?;
            resumed.set_dt(dt * 0.5).map_err(e)?;
            one.set_dt(dt * 0.5).map_err(e)?;
            step_both(&mut d, &mut one, 7, &case)?;
            same(
                state_bits(&resumed.state().map_err(e)?),
                state_bits(
                    &PpCoulomb::resume(&bytes, Backend::Cpu)
                        .map_err(e)?
                        .state()
                        .map_err(e)?,
                ),
                &format!("{case}: resumed state"),
            )?;
            resumed.step(7).map_err(e)?;
            compare(&mut resumed, &mut one, &format!("{case}, resumed"))?;
            count += 1;
        }
        // The bare law with a step far too large: the energy guard stops every rank at the
        // same check with the error of one process, and all roll back alike.
        let c = Config::new(0.05, ForceLaw::Exact)
            .with_precision(precision)
            .with_mixed(mixed)
            .with_check_every(5);
        let case = format!("exact blow-up {mode}");
        let e = |err: simkit_backend::Error| format!("{case}: {err}");
        let mut d = DistributedCoulomb::new(plasma(5), &c, comm.clone()).map_err(e)?;
        let mut one = PpCoulomb::new(plasma(5), &c, Backend::Cpu).map_err(e)?;
        let got = one.step(200);
        if !matches!(got, Err(simkit_backend::Error::BlowUp { .. })) {
            return Err(format!("{case}: expected a blow-up, got {got:?}"));
        }
        let mut one = PpCoulomb::new(plasma(5), &c, Backend::Cpu).map_err(e)?;
        step_both(&mut d, &mut one, 200, &case)?;
        count += 1;
    }
    Ok(count)
}
