//! Solver settings: integrator, precision, time step and its guard.

use serde::{Deserialize, Serialize};
use simkit_backend::{Error, Precision, Result};

use crate::{ContactLaw, Scene};

/// Time integration scheme. Both give the damping force a non-lagged velocity.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
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
    /// Interval, in steps, of the blow-up check inside `step(n)` (counted from step 0; see
    /// [`simkit_backend::guard`]): non-finite positions or velocities, a particle more than
    /// its radius outside the box along a non-periodic axis, or a contact deeper than
    /// [`max_overlap`](Self::max_overlap) stop the run with [`Error::BlowUp`], rolled back to
    /// the last state that passed. `0` turns the interval checks off; the check at the end
    /// of every `step(n)` call stays. Default [`simkit_backend::guard::DEFAULT_CHECK_EVERY`].
    pub check_every: u32,
    /// Deepest overlap the blow-up check accepts, as a fraction of the smaller radius of the
    /// contact (the particle's radius against a wall); `f64::INFINITY` turns this guard off.
    /// Default [`DEFAULT_MAX_OVERLAP`] (see there for how it was chosen).
    pub max_overlap: f64,
}

/// Default of [`Config::max_overlap`]: a contact deeper than half the smaller radius is a
/// blow-up.
///
/// How it was chosen: a linear contact with contact time `t_c` and restitution `e` reaches
/// its deepest overlap `delta_max = v t_c / pi * exp(-b t*)` (`b = -ln(e) / t_c`, `t*` the
/// time of the maximum, `<= t_c / 2`), at most `v t_c / pi`, for a head-on impact at
/// relative speed `v`. Half a radius therefore needs `v >= pi R / (2 t_c)`: with the usual
/// choice of `t_c` (overlaps of about 1 % of the radius at the scene's impact speeds, the
/// source's rule) that is 50 times the fastest impact the scene produces, e.g. for `R = 0.5`,
/// `t_c = 0.02`, `g = 1` a fall from 400 times the box height. A stable run never gets
/// there; an unstable step (dt above [`crate::safe_dt`]) or a far too soft contact does, and
/// a deeper contact no longer means anything physical (the source itself drops overlaps
/// beyond half a radius; at `delta = 2 R_min` the normal is undefined).
pub const DEFAULT_MAX_OVERLAP: f64 = 0.5;

impl Default for Config {
    fn default() -> Self {
        Self {
            dt: None,
            integrator: Integrator::default(),
            precision: Precision::default(),
            allow_unstable_dt: false,
            skin: 0.1,
            check_every: simkit_backend::guard::DEFAULT_CHECK_EVERY,
            max_overlap: DEFAULT_MAX_OVERLAP,
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

    /// Settings with another blow-up check interval (0 = only at the end of each call).
    pub fn with_check_every(mut self, every: u32) -> Self {
        self.check_every = every;
        self
    }

    /// Settings with another overlap limit of the blow-up check (fraction of the smaller
    /// radius; `f64::INFINITY` = off).
    pub fn with_max_overlap(mut self, fraction: f64) -> Self {
        self.max_overlap = fraction;
        self
    }

    /// Settings with another Verlet-list skin (fraction of the largest diameter).
    pub fn with_skin(mut self, skin: f64) -> Self {
        self.skin = skin;
        self
    }

    /// Explicitly accepts a time step over the safe bound.
    pub fn allow_unstable_dt(mut self) -> Self {
        self.allow_unstable_dt = true;
        self
    }

    /// Checks the settings that do not depend on a scene ([`Dem::new`](crate::Dem::new)
    /// calls it).
    ///
    /// Errors: a `dt` that is not finite and `> 0`, a skin outside `[0, 100]`, a
    /// `max_overlap` that is NaN or `<= 0`; each naming the value and the fix.
    pub fn validate(&self) -> Result<()> {
        if let Some(dt) = self.dt {
            simkit_backend::require_positive("dt", dt)?;
        }
        if !(self.skin.is_finite() && self.skin >= 0.0 && self.skin <= 100.0) {
            return Err(Error::invalid(
                "skin",
                self.skin,
                "must be finite and in [0, 100] (a fraction of the largest diameter; 0.1 is \
                 usual)",
            ));
        }
        if self.max_overlap.is_nan() || self.max_overlap <= 0.0 {
            return Err(Error::invalid(
                "max_overlap",
                self.max_overlap,
                "must be > 0 (a fraction of the smaller radius; f64::INFINITY turns the guard \
                 off)",
            ));
        }
        Ok(())
    }

    /// Checks the settings ([`Config::validate`]) and returns the time step the solver
    /// will use for `scene`: `dt`, or `t_c / 30` of the shortest contact time in the scene.
    ///
    /// Errors: those of [`Config::validate`]; a scene without particles (the contact time
    /// depends on their masses and radii); [`Error::Unstable`] when the step exceeds
    /// [`safe_dt`] without [`allow_unstable_dt`](Self::allow_unstable_dt).
    pub fn resolve_dt<L: ContactLaw>(&self, scene: &Scene<L>) -> Result<f64> {
        self.validate()?;
        scene.check_ready()?;
        let dt = match self.dt {
            Some(dt) => dt,
            None => scene.min_contact_time() / DEFAULT_STEPS_PER_CONTACT,
        };
        let bound = safe_dt(scene);
        if dt > bound * (1.0 + 1e-12) && !self.allow_unstable_dt {
            return Err(Error::Unstable {
                dt,
                bound,
                reason: "the smallest ContactLaw::safe_dt over all contact materials (linear \
                         law: min(t_c / 5, 1 / omega_0)); set Config::allow_unstable_dt to \
                         override"
                    .into(),
            });
        }
        Ok(dt)
    }
}

/// The safe time-step bound of a scene: the minimum of [`ContactLaw::safe_dt`] over every
/// species pair and wall material, each at its lightest reduced mass and smallest
/// effective radius (for [`crate::Material`]: [`crate::ContactCoefficients::safe_dt`]).
pub fn safe_dt<L: ContactLaw>(scene: &Scene<L>) -> f64 {
    scene
        .contact_scales()
        .map(|(law, m, r)| law.safe_dt(m, r))
        .fold(f64::INFINITY, f64::min)
}
