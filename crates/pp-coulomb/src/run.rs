//! [`Run`]: what a run keeps besides its backend's particle arrays (the particles' static
//! properties, configuration, step counter, clock and energy reference), its step-call
//! bookkeeping and its checkpoint format. [`crate::PpCoulomb`] and
//! [`crate::DistributedCoulomb`] both hold one, so both validate, count, time and save alike.

use serde::{Deserialize, Serialize};
use simkit_backend::{Error, Precision, Result, checkpoint};

use crate::config::{Config, ForceLaw, Mode};
use crate::guard::{Checks, Energy};
use crate::particles::Particles;
use crate::particles::PositionsVelocities;

/// The bookkeeping of a run.
pub(crate) struct Run {
    /// The particles as built or resumed (positions and velocities of that moment; the
    /// backend holds the current ones).
    pub particles: Particles,
    pub config: Config,
    pub steps: u64,
    /// The step and simulated time at which the current `dt` took over: the time is
    /// `origin.1 + dt * (steps - origin.0)`, whatever the split into `step` calls.
    pub origin: (u64, f64),
    /// The energy at the last interval check that passed (exact law's energy guard).
    pub energy_ref: Option<Energy>,
}

/// Everything a checkpoint holds.
#[derive(Serialize, Deserialize)]
struct Saved {
    config: Config,
    particles: Particles,
    accelerations: Option<Vec<[f64; 3]>>,
    steps: u64,
    origin: (u64, f64),
    energy_ref: Option<Energy>,
}

/// A run restored from a checkpoint (its energy reference not yet set), the
/// accelerations leapfrog kept and the saved energy reference.
pub(crate) struct Resumed {
    pub run: Run,
    pub accelerations: Option<Vec<[f64; 3]>>,
    pub energy_ref: Option<Energy>,
}

/// Checks that every position, velocity, charge, mass and charge-to-mass ratio stays finite
/// where the run's mode stores or reads it (f32 ends at 3.4e38; `q / m` can overflow in
/// either): all in f32 for [`Mode::F32`]; the positions and charges (the pair kernel's
/// inputs) in f32 and the rest in f64 for [`Mode::Mixed`].
fn representable(p: &Particles, mode: Mode) -> Result<()> {
    let fits = |v: f64, precision: Precision| match precision {
        Precision::F32 => (v as f32).is_finite(),
        Precision::F64 => v.is_finite(),
    };
    let kernel = match mode {
        Mode::F64 => Precision::F64,
        Mode::F32 | Mode::Mixed => Precision::F32,
    };
    let state = mode.state();
    let name = |precision| match precision {
        Precision::F32 => "f32",
        Precision::F64 => "f64",
    };
    for i in 0..p.len() {
        let values = [
            ("position", p.position[i].to_vec(), kernel),
            ("velocity", p.velocity[i].to_vec(), state),
            ("charge", vec![p.charge[i]], kernel),
            ("mass", vec![p.mass[i]], state),
            ("charge / mass", vec![p.charge[i] / p.mass[i]], state),
        ];
        for (what, v, precision) in values {
            if let Some(bad) = v.iter().find(|v| !fits(**v, precision)) {
                return Err(Error::invalid(
                    format!("{what} of particle {i}"),
                    bad,
                    format!(
                        "overflows the run's precision ({} in the {} mode); use values of \
                         physical magnitude, or Precision::F64",
                        name(precision),
                        mode.name()
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// The checkpoint model string of a mode: `PpCoulomb<f64>`, `PpCoulomb<f32>` or
/// `PpCoulomb<mixed>`.
fn model(mode: Mode) -> String {
    format!("PpCoulomb<{}>", mode.name())
}

impl Run {
    /// Validates the particles and the configuration (see [`crate::PpCoulomb::new`]) and
    /// starts the bookkeeping at step 0 (the energy reference is set by the caller).
    pub fn new(particles: Particles, config: &Config) -> Result<Self> {
        particles.validate()?;
        config.validate()?;
        representable(&particles, config.mode())?;
        Ok(Self {
            particles,
            config: *config,
            steps: 0,
            origin: (0, 0.0),
            energy_ref: None,
        })
    }

    /// The energy tolerance in force: `Some` only under the exact law with interval checks
    /// on and particles to check.
    pub fn energy_tolerance(&self) -> Option<f64> {
        let on = self.config.force == ForceLaw::Exact
            && self.config.check_every > 0
            && !self.particles.is_empty();
        self.config.energy_tolerance.filter(|_| on)
    }

    /// Sets the energy guard's reference when the guard is on: `saved` (a checkpoint's),
    /// or else the energy `now` measures.
    pub fn set_energy_ref(
        &mut self,
        saved: Option<Option<Energy>>,
        now: impl FnOnce() -> Result<Energy>,
    ) -> Result<()> {
        if self.energy_tolerance().is_some() {
            self.energy_ref = match saved {
                Some(kept) => kept,
                None => Some(now()?),
            };
        }
        Ok(())
    }

    /// The simulated time after `steps` steps at the current `dt`.
    fn time_at(&self, steps: u64) -> f64 {
        self.origin.1 + self.config.dt * steps.saturating_sub(self.origin.0) as f64
    }

    /// The simulated time now.
    pub fn time(&self) -> f64 {
        self.time_at(self.steps)
    }

    /// `N (N - 1)`.
    pub fn interactions_per_step(&self) -> f64 {
        let n = self.particles.len() as f64;
        n * (n - 1.0).max(0.0)
    }

    /// Checks `dt` and moves the clock's origin to now (the backend's step is the caller's).
    pub fn set_dt(&mut self, dt: f64) -> Result<()> {
        simkit_backend::require_positive("dt", dt)?;
        self.origin = (self.steps, self.time());
        self.config.dt = dt;
        Ok(())
    }

    /// Advances `steps` steps through `advance` (the backend's stepping loop, given the
    /// call's checks): refuses a step count that would overflow the counter or the clock,
    /// skips the backend when there is nothing to do, and adopts the step of a blow-up's
    /// rollback.
    pub fn step(
        &mut self,
        steps: u32,
        advance: impl FnOnce(&mut Checks<'_>) -> Result<()>,
    ) -> Result<()> {
        // Room for one more check interval after the end, too.
        let end = simkit_backend::guard::end_step(self.steps, steps)?;
        simkit_backend::guard::end_step(end, self.config.check_every)?;
        if !self.time_at(end).is_finite() {
            return Err(Error::invalid(
                "steps",
                steps,
                format!(
                    "the simulated time would overflow (time {:e}, dt {:e}); use a smaller dt",
                    self.time(),
                    self.config.dt
                ),
            ));
        }
        if self.particles.is_empty() || steps == 0 {
            self.steps = end;
            return Ok(());
        }
        let energy_tolerance = self.energy_tolerance();
        let mut checks = Checks {
            done: self.steps,
            every: self.config.check_every,
            energy_tolerance,
            energy_ref: &mut self.energy_ref,
            charge: &self.particles.charge,
            mass: &self.particles.mass,
            dt: self.config.dt,
            integrator: self.config.integrator,
        };
        match advance(&mut checks) {
            Ok(()) => {
                self.steps = end;
                Ok(())
            }
            Err(e) => {
                if let Error::BlowUp { rolled_back_to, .. } = e {
                    self.steps = rolled_back_to;
                }
                Err(e)
            }
        }
    }

    /// The particles with the backend's current positions and velocities.
    pub fn particles_at(&self, (position, velocity): PositionsVelocities) -> Particles {
        let mut p = self.particles.clone();
        p.position = position;
        p.velocity = velocity;
        p
    }

    /// The checkpoint of this run in state `now` with the kept `accelerations`.
    pub fn checkpoint(
        &self,
        now: Particles,
        accelerations: Option<Vec<[f64; 3]>>,
    ) -> Result<Vec<u8>> {
        let saved = Saved {
            config: self.config,
            particles: now,
            accelerations,
            steps: self.steps,
            origin: self.origin,
            energy_ref: self.energy_ref,
        };
        checkpoint::encode(
            env!("CARGO_PKG_NAME"),
            env!("CARGO_PKG_VERSION"),
            &model(self.config.mode()),
            &saved,
        )
    }

    /// Decodes and validates a checkpoint (see [`crate::PpCoulomb::resume`]); the particles
    /// and configuration are validated as by [`Run::new`].
    pub fn resume(bytes: &[u8]) -> Result<Resumed> {
        let header = checkpoint::header(bytes)?;
        let mode = Mode::ALL
            .into_iter()
            .find(|m| model(*m) == header.model)
            .unwrap_or(Mode::F64);
        let saved: Saved = checkpoint::decode(
            bytes,
            env!("CARGO_PKG_NAME"),
            env!("CARGO_PKG_VERSION"),
            &model(mode),
        )?;
        if saved.config.mode() != mode {
            return Err(Error::checkpoint(format!(
                "the header says {} but the state is {}; the file is \
                     inconsistent",
                model(mode),
                model(saved.config.mode())
            )));
        }
        let n = saved.particles.len();
        if let Some(a) = &saved.accelerations
            && (a.len() != n || a.iter().flatten().any(|c| !c.is_finite()))
        {
            return Err(Error::checkpoint(format!(
                "{} kept accelerations for {n} particles, or non-finite ones; the file is \
                 inconsistent",
                a.len()
            )));
        }
        let (origin_step, origin_time) = saved.origin;
        let energy_ok = saved.energy_ref.is_none_or(|e| e.is_finite());
        if origin_step > saved.steps || !origin_time.is_finite() || !energy_ok {
            return Err(Error::checkpoint(format!(
                "step {} with time origin ({origin_step}, {origin_time}) and energy reference                  {:?}; the file is \
                     inconsistent",
                saved.steps, saved.energy_ref
            )));
        }
        let mut run = Run::new(saved.particles, &saved.config)?;
        run.steps = saved.steps;
        run.origin = saved.origin;
        if !run.time().is_finite() {
            return Err(Error::checkpoint(format!(
                "step {} at dt {:e} gives a non-finite time",
                saved.steps, saved.config.dt
            )));
        }
        Ok(Resumed {
            run,
            accelerations: saved.accelerations,
            energy_ref: saved.energy_ref,
        })
    }
}
