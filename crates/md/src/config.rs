//! Run settings and the time-step guidance.

use serde::{Deserialize, Serialize};
use simkit_backend::{Error, Precision, Result};

use crate::{Langevin, PairLaw, System};

/// Time integration scheme (both second order, symplectic and time reversible; one force
/// evaluation per step).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Integrator {
    /// Velocity Verlet: `v += a dt/2`, `x += v dt`, forces, `v += a dt/2`; the stored
    /// velocities are those at the step (default).
    #[default]
    VelocityVerlet,
    /// Leapfrog in kick–drift–kick form with the two half kicks of consecutive steps fused:
    /// the stored velocities are the half-step ones `v(t + dt/2)`, advanced by one full kick
    /// `v += a dt` per step; `Md::state` (the [`simkit_backend::Simulation`] method) reports `v(t) = v(t + dt/2) - a(t) dt/2`.
    Leapfrog,
}

/// Default time step as a fraction of the shortest pair period: `dt = T_min / 120` (about
/// `0.0049` for Lennard-Jones with `sigma = eps = m = 1`, the usual `0.005`).
pub const DEFAULT_STEPS_PER_PERIOD: f64 = 120.0;

/// The safe bound: a time step above `T_min / 20` is refused unless
/// [`Config::allow_unstable_dt`] is set.
pub const MIN_STEPS_PER_PERIOD: f64 = 20.0;

/// Default Verlet-list skin (absolute length; LAMMPS's `neighbor 0.3 bin` in LJ units).
pub const DEFAULT_SKIN: f64 = 0.3;

/// The GPU backend's force kernel (the CPU ignores this setting). Both give the same forces
/// up to `f32` rounding and the same guarantees (blow-up guard, bit-exact restart); they
/// differ in speed, which depends on the device: `benches/md.rs` times both.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum GpuKernel {
    /// One invocation per particle gathering its pair terms over the full shell of
    /// neighbour cells of a cell list sorted from scratch every step (default: the faster
    /// of the two on lavapipe and on an NVIDIA H200, where it runs `in.lj` at 7.4e7
    /// atom-steps/s with 32,000 atoms and 2.75e8 with 10^6; docs/gpu.md).
    #[default]
    PerParticle,
    /// One workgroup per cell, one invocation per slot of the cell: the positions of each
    /// neighbour cell are staged in workgroup memory, and the per-cell slot lists are
    /// updated locally after every drift (each cell drops its leavers and picks up the
    /// arrivals from its neighbours). `slots` is the fixed capacity of a cell; `None`
    /// derives it from the density: the larger of twice the mean and 1.5 times the largest
    /// initial cell population, rounded up to a multiple of 8. A cell that would overflow
    /// is an error, never a dropped particle.
    CellBlock {
        /// Slots per cell (= invocations per workgroup, at most the device's
        /// `max_compute_invocations_per_workgroup`); `None`: automatic.
        slots: Option<u32>,
    },
}

impl GpuKernel {
    /// [`GpuKernel::CellBlock`] with the automatic capacity.
    pub const fn cell_block() -> Self {
        Self::CellBlock { slots: None }
    }
}

/// Run settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config {
    /// Time step; `None` picks `T_min / DEFAULT_STEPS_PER_PERIOD` (see [`time_step_guide`]).
    pub dt: Option<f64>,
    /// Integrator.
    pub integrator: Integrator,
    /// CPU precision (`f64` default; the GPU backend computes in `f32` whatever this says).
    pub precision: Precision,
    /// GPU only: the force kernel and cell-list scheme ([`GpuKernel`]).
    pub gpu_kernel: GpuKernel,
    /// Verlet-list skin (absolute length, `>= 0`): the list holds pairs within
    /// `r_c + skin` and is rebuilt when a particle has moved more than `skin / 2` since the
    /// last build.
    pub skin: f64,
    /// Interval, in steps, of the blow-up check inside `step(n)` (counted from step 0; see
    /// [`simkit_backend::guard`]): non-finite positions, velocities or forces, or a particle
    /// that left a closed box, stop the run with [`Error::BlowUp`], rolled back to the last
    /// state that passed. `0` turns the interval checks off; the check at the end of every
    /// `step(n)` call stays. Default [`simkit_backend::guard::DEFAULT_CHECK_EVERY`].
    pub check_every: u32,
    /// Shift every pair's energy by `phi(r_c)` so that it is continuous at the cutoff
    /// (forces unchanged). Off by default.
    pub shift: bool,
    /// Accept a time step above the safe bound `T_min / 20` (for studies of instability).
    pub allow_unstable_dt: bool,
    /// Langevin thermostat (BAOAB splitting), off (`None`) by default: an NVE run does no
    /// thermostat work at all. Per-species targets: [`System::set_species_langevin`].
    pub thermostat: Option<Langevin>,
}

impl Default for Config {
    fn default() -> Self {
        Self {
            dt: None,
            integrator: Integrator::default(),
            precision: Precision::default(),
            gpu_kernel: GpuKernel::PerParticle,
            skin: DEFAULT_SKIN,
            check_every: simkit_backend::guard::DEFAULT_CHECK_EVERY,
            shift: false,
            allow_unstable_dt: false,
            thermostat: None,
        }
    }
}

impl Config {
    /// Settings with an explicit time step.
    pub fn with_dt(mut self, dt: f64) -> Self {
        self.dt = Some(dt);
        self
    }

    /// Settings with another integrator.
    pub fn with_integrator(mut self, integrator: Integrator) -> Self {
        self.integrator = integrator;
        self
    }

    /// Settings with another CPU precision.
    pub fn with_precision(mut self, precision: Precision) -> Self {
        self.precision = precision;
        self
    }

    /// Settings with another GPU force kernel.
    pub fn with_gpu_kernel(mut self, kernel: GpuKernel) -> Self {
        self.gpu_kernel = kernel;
        self
    }

    /// Settings with another Verlet-list skin (absolute length).
    pub fn with_skin(mut self, skin: f64) -> Self {
        self.skin = skin;
        self
    }

    /// Settings with another blow-up check interval (0 = only at the end of each call).
    pub fn with_check_every(mut self, every: u32) -> Self {
        self.check_every = every;
        self
    }

    /// Settings with energies shifted (`true`) or not at the cutoff.
    pub fn with_shift(mut self, shift: bool) -> Self {
        self.shift = shift;
        self
    }

    /// Settings with a Langevin thermostat.
    pub fn with_thermostat(mut self, thermostat: Langevin) -> Self {
        self.thermostat = Some(thermostat);
        self
    }

    /// Explicitly accepts a time step over the safe bound.
    pub fn allow_unstable_dt(mut self) -> Self {
        self.allow_unstable_dt = true;
        self
    }

    /// Checks the settings that do not depend on a system ([`Md::new`](crate::Md::new)
    /// calls it).
    ///
    /// Errors: a `dt` that is not finite and `> 0`, a negative or non-finite skin, a
    /// thermostat with a negative or non-finite temperature or friction; each naming the
    /// value and the fix.
    pub fn validate(&self) -> Result<()> {
        if let Some(l) = &self.thermostat {
            crate::input::check_target("thermostat", l.temperature, l.gamma)?;
        }
        if !(self.skin.is_finite() && self.skin >= 0.0) {
            return Err(Error::invalid(
                "skin",
                self.skin,
                "must be finite and >= 0 (e.g. 0.3 sigma)",
            ));
        }
        if let Some(dt) = self.dt
            && !(dt.is_finite() && dt > 0.0)
        {
            return Err(Error::invalid("dt", dt, "must be finite and > 0"));
        }
        Ok(())
    }

    /// Checks the settings ([`Config::validate`]) and returns the time step to use for
    /// `system`: `dt`, or the default of the system's [`time_step_guide`].
    ///
    /// Errors: those of [`Config::validate`]; a time step over the safe bound without
    /// [`allow_unstable_dt`](Self::allow_unstable_dt); no `dt` for a system without
    /// interacting pairs (no guidance exists then).
    pub fn resolve_dt<L: PairLaw>(&self, system: &System<L>) -> Result<f64> {
        self.validate()?;
        let guide = time_step_guide(system);
        let dt = match (self.dt, guide) {
            (Some(dt), _) => dt,
            (None, Some(g)) => g.default_dt,
            (None, None) => {
                return Err(Error::invalid(
                    "dt",
                    "None",
                    "no pair of the table gives a stiffness (no pair interacts, or the \
                     law has no well, e.g. Yukawa), so no time step can be derived; give \
                     Config::dt",
                ));
            }
        };
        if let Some(g) = guide
            && dt > g.bound
            && !self.allow_unstable_dt
        {
            return Err(Error::Unstable {
                dt,
                bound: g.bound,
                reason: format!(
                    "dt <= T / {MIN_STEPS_PER_PERIOD} with T = 2 pi / omega = {:e} the \
                     oscillation period of species pair ({}, {}) at r = {:e}",
                    g.period, g.pair.0, g.pair.1, g.distance
                ),
            });
        }
        Ok(dt)
    }
}

/// The time-step guidance of a system: the stiffest pair and the steps it implies.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepGuide {
    /// The species pair with the shortest period.
    pub pair: (usize, usize),
    /// Where its stiffness was measured ([`crate::PairLaw::stiffness`]).
    pub distance: f64,
    /// Its period `T = 2 pi sqrt(mu / phi''(r*))`, `mu = m_i m_j / (m_i + m_j)`.
    pub period: f64,
    /// `T / DEFAULT_STEPS_PER_PERIOD`.
    pub default_dt: f64,
    /// `T / MIN_STEPS_PER_PERIOD`: larger steps are refused by default.
    pub bound: f64,
}

/// Time-step guidance from the stiffest species pair.
///
/// For every pair whose law gives a stiffness ([`crate::PairLaw::stiffness`]) the
/// curvature `k = phi''(r*)` is taken at the distance `r*` the law names: for
/// [`crate::LennardJones`] with `eps > 0`, `r* = sigma (2a/b)^(1/6)` (the minimum of
/// `phi`) when `a, b > 0`, and `r* = sigma a^(1/12)` (where the repulsion equals `4 eps`)
/// for a purely repulsive pair; the minimum for [`crate::Morse`], [`crate::Mie`] and
/// [`crate::Buckingham`] (when inside the cutoff), the cutoff for [`crate::Wca`]. The pair
/// then oscillates with `omega = sqrt(k / mu)`, `mu` the reduced mass, period
/// `T = 2 pi / omega`. For Lennard-Jones `k = 72 eps / (2^(1/3) sigma^2) = 57.15 eps /
/// sigma^2`, so with `m = 1` (`mu = 1/2`) `T = 0.588 sigma sqrt(m / eps)`: the default
/// `T / 120` is `0.0049`, the bound `T / 20` is `0.0294`. Velocity Verlet is linearly stable for
/// `omega dt < 2` (`dt < T / pi`); the bound keeps a margin of six for the stiffer
/// repulsive core that hot collisions reach. `None` when no pair gives a stiffness.
pub fn time_step_guide<L: PairLaw>(system: &System<L>) -> Option<StepGuide> {
    let table = system.table();
    let masses = system.masses();
    let n = table.n_species();
    let mut best: Option<StepGuide> = None;
    for si in 0..n {
        for sj in si..n {
            let Some((r, k)) = table.get(si, sj).and_then(|p| p.stiffness()) else {
                continue;
            };
            let mu = masses[si] * masses[sj] / (masses[si] + masses[sj]);
            if !(k > 0.0 && k.is_finite()) {
                continue;
            }
            let period = 2.0 * std::f64::consts::PI * (mu / k).sqrt();
            if best.is_none_or(|b| period < b.period) {
                best = Some(StepGuide {
                    pair: (si, sj),
                    distance: r,
                    period,
                    default_dt: period / DEFAULT_STEPS_PER_PERIOD,
                    bound: period / MIN_STEPS_PER_PERIOD,
                });
            }
        }
    }
    best
}
