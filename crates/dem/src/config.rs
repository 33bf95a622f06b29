//! Solver settings: integrator, precision, time step and its guard.

use simkit_backend::{Error, Precision, Result};

use crate::{ContactCoefficients, Scene};

/// Time integration scheme. Both give the damping force a non-lagged velocity.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Integrator {
    /// Velocity Verlet: drift with `v + a dt / 2`, forces at `t + dt` with the predicted
    /// velocity `v(t) + a(t) dt`, then the second half kick (default).
    #[default]
    VelocityVerlet,
    /// Position (Störmer) Verlet as in the source, `r(t+dt) = 2 r(t) - r(t-dt) + a(t) dt^2`;
    /// the damping uses the second-order estimate `v(t) = (r(t) - r(t-dt)) / dt + a(t-dt) dt / 2`
    /// instead of the source's lagged velocity. CPU backend only.
    PositionVerlet,
}

/// Divisor of the default time step: `dt = t_c / 30` (the source's chapter 1 choice).
pub const DEFAULT_STEPS_PER_CONTACT: f64 = 30.0;

/// Solver settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config {
    /// Time step; `None` = `t_c / 30` of the shortest contact time in the scene.
    pub dt: Option<f64>,
    /// Integrator.
    pub integrator: Integrator,
    /// CPU precision.
    pub precision: Precision,
    /// Accept a time step above the safe bound (for studies of the unstable regime).
    pub allow_unstable_dt: bool,
    /// Verlet-list skin as a fraction of the largest particle diameter (CPU backend).
    pub skin: f64,
}

impl Default for Config {
    fn default() -> Self {
        Self {
            dt: None,
            integrator: Integrator::default(),
            precision: Precision::default(),
            allow_unstable_dt: false,
            skin: 0.1,
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

    /// Explicitly accepts a time step over the safe bound.
    pub fn allow_unstable_dt(mut self) -> Self {
        self.allow_unstable_dt = true;
        self
    }
}

/// The safe time-step bound of a scene: the minimum of
/// [`ContactCoefficients::safe_dt`] over every species pair and wall material.
pub fn safe_dt(scene: &Scene) -> f64 {
    scene
        .pair_table()
        .iter()
        .chain(scene.walls().iter().map(|w| &w.material))
        .map(|m| ContactCoefficients::new(m).safe_dt(m))
        .fold(f64::INFINITY, f64::min)
}

/// The time step the solver will use for `scene` with `config`, or an
/// [`Error::Unstable`] when it exceeds [`safe_dt`] without the explicit override.
pub fn resolve_dt(scene: &Scene, config: &Config) -> Result<f64> {
    let dt = match config.dt {
        Some(dt) => simkit_backend::require_positive("dt", dt)?,
        None => scene.min_contact_time() / DEFAULT_STEPS_PER_CONTACT,
    };
    let bound = safe_dt(scene);
    if dt > bound * (1.0 + 1e-12) && !config.allow_unstable_dt {
        return Err(Error::Unstable {
            dt,
            bound,
            reason: "min(t_c / 5, 1 / omega_0) over all contact materials; \
                     set Config::allow_unstable_dt to override"
                .into(),
        });
    }
    if !(config.skin.is_finite() && config.skin >= 0.0) {
        return Err(Error::invalid(
            "skin",
            config.skin,
            "must be finite and >= 0",
        ));
    }
    Ok(dt)
}
