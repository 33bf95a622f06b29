//! Time integration settings and the stability guard.

use simkit_backend::guard::blow_up;
use simkit_backend::{Error, Real, Result, require_positive};

use crate::grid::Grid;
use crate::model::Model;

/// Explicit time integrator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum Integrator {
    /// Forward Euler (first order; the source's scheme): one stencil pass per step.
    #[default]
    Euler,
    /// Heun's method (explicit trapezoidal, second order): two stencil passes per step.
    Heun,
}

impl Integrator {
    /// Stencil passes per step.
    pub fn stages(self) -> u32 {
        match self {
            Integrator::Euler => 1,
            Integrator::Heun => 2,
        }
    }
}

/// What to do when `dt` exceeds the stability bound.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum Guard {
    /// Refuse with [`Error::Unstable`] (default).
    #[default]
    Enforce,
    /// Run anyway (for experiments on the stability limit itself).
    Override,
}

/// Time-stepping settings.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Stepping {
    /// Time step.
    pub dt: f64,
    /// Integrator.
    pub integrator: Integrator,
    /// Stability guard.
    pub guard: Guard,
}

impl Stepping {
    /// Euler with the guard enforced.
    pub fn euler(dt: f64) -> Self {
        Self {
            dt,
            integrator: Integrator::Euler,
            guard: Guard::Enforce,
        }
    }
    /// Heun with the guard enforced.
    pub fn heun(dt: f64) -> Self {
        Self {
            dt,
            integrator: Integrator::Heun,
            guard: Guard::Enforce,
        }
    }
    /// The same settings with the guard overridden.
    pub fn unguarded(self) -> Self {
        Self {
            guard: Guard::Override,
            ..self
        }
    }
}

/// Largest stable time step for the current fields: `h^2 / (4 D_max)` with the model's
/// largest effective diffusivity (5-point Laplacian, explicit Euler; Heun's real stability
/// interval `[-2, 0]` is the same). `f64::INFINITY` when nothing diffuses; NaN when `D_max`
/// is NaN (fields holding NaN in a model whose diffusivity depends on them).
pub fn stable_dt<T: Real, M: Model>(model: &M, grid: &Grid<T>) -> f64 {
    dt_bound(model.max_diffusivity(grid), grid.h())
}

/// The explicit stability bound of the 5-point Laplacian, `h^2 / (4 d_max)` (forward Euler:
/// the most negative Laplacian eigenvalue is `-8 / h^2`, and `dt * D * 8 / h^2 <= 2`);
/// `f64::INFINITY` when `d_max <= 0` (nothing diffuses); NaN when `d_max` is NaN (never an
/// infinite bound). Every stability check and every `stable_dt` of both backends goes
/// through this one function.
pub(crate) fn dt_bound(d_max: f64, h: f64) -> f64 {
    if d_max.is_nan() {
        f64::NAN
    } else if d_max > 0.0 {
        let (hh, dd) = (h * h, 4.0 * d_max);
        if hh.is_finite() && dd.is_finite() {
            hh / dd
        } else {
            // `h^2` or `4 D_max` overflows (inf / inf would be NaN, a bound that passes
            // every comparison): the same quantity without the overflowing intermediates.
            let r = h / (2.0 * d_max.sqrt());
            r * r
        }
    } else {
        f64::INFINITY
    }
}

/// Checks `dt` against [`stable_dt`] unless the guard is overridden.
pub(crate) fn check_dt<T: Real, M: Model>(model: &M, grid: &Grid<T>, s: &Stepping) -> Result<()> {
    check_dt_with(model.name(), model.max_diffusivity(grid), grid.h(), s)
}

/// [`dt_bound`] for a backend's `stable_dt`: an error if `d_max` is NaN.
pub(crate) fn checked_bound(model: &str, d_max: f64, h: f64) -> Result<f64> {
    if d_max.is_nan() {
        return Err(Error::invalid(
            format!("largest diffusivity D_max of the {model} model"),
            d_max,
            "the fields hold NaN or infinite values (the run has blown up); \
             rebuild the simulation from finite fields with a smaller dt",
        ));
    }
    Ok(dt_bound(d_max, h))
}

/// Checks `dt` against `h^2 / (4 d_max)` unless the guard is overridden; a NaN `d_max`
/// (blown-up fields) is an error even with the guard overridden.
pub(crate) fn check_dt_with(model: &str, d_max: f64, h: f64, s: &Stepping) -> Result<()> {
    require_positive("dt", s.dt)?;
    let bound = checked_bound(model, d_max, h)?;
    if s.guard == Guard::Enforce && s.dt > bound {
        return Err(Error::Unstable {
            dt: s.dt,
            bound,
            reason: format!(
                "{model} model, 5-point Laplacian: D_max dt / h^2 <= 1/4 with D_max = {d_max:e}, h = {h:e}"
            ),
        });
    }
    Ok(())
}

/// The re-check of the bound at a check inside `step(n)` (for models whose diffusivity
/// depends on the fields): with the guard enforced, `dt` must stay within
/// `h^2 / (4 d_max)` of the fields at step `step`, else the run stops there (that state is
/// finite: it passed the finite check) with [`Error::BlowUp`] naming `D_max`, the bound and
/// the fix. A NaN `d_max` fails too. With the guard overridden this check is skipped (the
/// finite check still stops a diverging run).
pub(crate) fn recheck_bound(
    model: &str,
    d_max: f64,
    h: f64,
    s: &Stepping,
    step: u64,
) -> Result<()> {
    let bound = dt_bound(d_max, h);
    if s.guard == Guard::Override || s.dt <= bound {
        return Ok(());
    }
    Err(blow_up(
        step,
        step,
        format!(
            "the largest diffusivity of the current fields, D_max = {d_max:e}, gives the \
             stability bound h^2 / (4 D_max) = {bound:e} (h = {h:e}), now below dt = {:e}",
            s.dt
        ),
        format!(
            "the {model} model's diffusivity grew with the fields during the run, so the \
             explicit step is no longer stable (no step was taken from this state); continue \
             with a smaller dt: set_stepping with dt <= {bound:e}"
        ),
    ))
}

/// The likely cause of fields that turned non-finite, for [`Error::BlowUp`]: `bound` is
/// the stability bound of the rolled-back state.
pub(crate) fn divergence_cause(model: &str, s: &Stepping, bound: f64) -> String {
    let guard = match s.guard {
        Guard::Override => " with the stability guard overridden",
        Guard::Enforce => "",
    };
    format!(
        "the explicit {:?} scheme diverged at dt = {:e}{guard} ({model} model; the stability \
         bound h^2 / (4 D_max) of the rolled-back state is {bound:e}), or the reaction terms \
         are too stiff for this dt; use a smaller dt (set_stepping) and step again",
        s.integrator, s.dt
    )
}

/// Checks the model against the grid (species count, parameters, coefficient sizes).
pub(crate) fn check_model<T: Real, M: Model>(model: &M, grid: &Grid<T>) -> Result<()> {
    model.validate(grid.nx(), grid.ny())?;
    if model.species() != grid.species() {
        return Err(Error::invalid(
            "number of species fields",
            grid.species(),
            format!("the {} model needs {}", model.name(), model.species()),
        ));
    }
    // The coefficient fields, whatever the model's own validation checked: the backends
    // pad them as `nx x ny` planes.
    let cells = grid.nx() * grid.ny();
    for (k, c) in model.coefficients().iter().enumerate() {
        if c.len() != cells {
            return Err(Error::invalid(
                format!("{} model: coefficient field {k} length", model.name()),
                c.len(),
                format!(
                    "must equal nx * ny = {} * {} = {cells} (one value per cell, row-major)",
                    grid.nx(),
                    grid.ny()
                ),
            ));
        }
        if let Some(i) = c.iter().position(|v| !v.is_finite()) {
            return Err(Error::invalid(
                format!(
                    "{} model: coefficient field {k} at cell ({}, {})",
                    model.name(),
                    i % grid.nx(),
                    i / grid.nx()
                ),
                c[i],
                "every value must be finite",
            ));
        }
    }
    // Fields may have been edited through `Grid::field_mut`: re-check them.
    for s in 0..grid.species() {
        if let Some(k) = grid.field(s).iter().position(|v| !v.to_f64().is_finite()) {
            return Err(Error::invalid(
                format!("field {s} at cell ({}, {})", k % grid.nx(), k / grid.nx()),
                grid.field(s)[k],
                "every value must be finite",
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use simkit_backend::max_or_nan;

    #[test]
    fn the_bound_is_h2_over_4d_and_infinite_without_diffusion() {
        assert_eq!(dt_bound(2.0, 0.5), 0.5 * 0.5 / 8.0);
        assert_eq!(dt_bound(0.0, 1.0), f64::INFINITY);
        assert_eq!(dt_bound(-1.0, 1.0), f64::INFINITY);
        // Overflowing intermediates: h^2 = inf and 4 D = inf used to give inf / inf = NaN.
        let b = dt_bound(f64::MAX, 1e300); // 1e600 / 7.19e308
        assert!((b / 1.390_671_161_567e291 - 1.0).abs() < 1e-12, "{b}");
        assert_eq!(dt_bound(f64::INFINITY, 1e300), 0.0);
        assert_eq!(dt_bound(1e308, 1e154), 0.25);
        assert_eq!(dt_bound(f64::INFINITY, 1.0), 0.0);
        let s = Stepping::euler(0.2);
        assert!(check_dt_with("diffusion", 1.0, 1.0, &s).is_ok());
        assert!(check_dt_with("diffusion", 1.0, 1.0, &Stepping::euler(0.25)).is_ok());
        let err = check_dt_with("diffusion", 1.0, 1.0, &Stepping::euler(0.3)).unwrap_err();
        assert!(
            matches!(err, Error::Unstable { bound, .. } if bound == 0.25),
            "{err}"
        );
        assert!(check_dt_with("diffusion", 1.0, 1.0, &Stepping::euler(0.3).unguarded()).is_ok());
    }

    #[test]
    fn a_nan_diffusivity_is_an_error_never_an_infinite_bound() {
        assert!(dt_bound(f64::NAN, 1.0).is_nan());
        assert!(max_or_nan(f64::NAN, 1.0).is_nan());
        assert!(max_or_nan(1.0, f64::NAN).is_nan());
        assert_eq!(max_or_nan(1.0, 2.0), 2.0);
        assert_eq!(max_or_nan(2.0, 1.0), 2.0);
        assert!(
            [1.0, f64::NAN, 3.0]
                .into_iter()
                .fold(0.0, max_or_nan)
                .is_nan()
        );
        for s in [Stepping::euler(0.1), Stepping::euler(0.1).unguarded()] {
            let e = check_dt_with("colony", f64::NAN, 1.0, &s)
                .unwrap_err()
                .to_string();
            assert!(e.contains("D_max of the colony model: NaN"), "{e}");
        }
    }
}
