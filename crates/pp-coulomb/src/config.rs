//! Run configuration: force law, integrator, precision and time step.

use simkit_backend::{Error, Precision, Result, require_positive};

use crate::laws;

/// How the pair force is evaluated. Each law is a separate compiled kernel: the choice is made
/// once per force evaluation, never per pair.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ForceLaw {
    /// Bare Coulomb `q_i q_j r / |r|^3`. Two particles at the same position are an error.
    Exact,
    /// Bare Coulomb, but pairs with `|r| <= radius` are skipped (the source's near-field
    /// exclusion, radius = Debye length). The matching potential is `q_i q_j / r` for
    /// `r > radius` and 0 inside.
    Exclusion {
        /// Exclusion radius (> 0).
        radius: f64,
    },
    /// Plummer softening: force `q_i q_j r / (r^2 + eps^2)^(3/2)`, potential
    /// `q_i q_j / sqrt(r^2 + eps^2)`.
    Plummer {
        /// Softening length (> 0).
        epsilon: f64,
    },
}

impl ForceLaw {
    /// Checks the parameter (finite and > 0).
    pub fn validate(&self) -> Result<()> {
        match *self {
            ForceLaw::Exact => Ok(()),
            ForceLaw::Exclusion { radius } => {
                require_positive("exclusion radius", radius).map(|_| ())
            }
            ForceLaw::Plummer { epsilon } => {
                require_positive("softening epsilon", epsilon).map(|_| ())
            }
        }
    }

    /// The kernel parameter: `radius^2`, `epsilon^2`, or 0 for the exact law.
    pub(crate) fn squared_parameter(&self) -> f64 {
        match *self {
            ForceLaw::Exact => 0.0,
            ForceLaw::Exclusion { radius } => radius * radius,
            ForceLaw::Plummer { epsilon } => epsilon * epsilon,
        }
    }

    /// Pair force weight `w(r^2)` (the pair field is `q_j w r`): [`laws::exact_weight`],
    /// [`laws::exclusion_weight`] or [`laws::plummer_weight`] with this law's parameter.
    pub(crate) fn weight(&self, r2: f64) -> f64 {
        match *self {
            ForceLaw::Exact => laws::exact_weight(r2),
            ForceLaw::Exclusion { .. } => laws::exclusion_weight(r2, self.squared_parameter()),
            ForceLaw::Plummer { .. } => laws::plummer_weight(r2, self.squared_parameter()),
        }
    }

    /// Pair potential per unit `q_i q_j` at distance `r` (consistent with the force law):
    /// [`laws::exact_potential`], [`laws::exclusion_potential`] or
    /// [`laws::plummer_potential`].
    pub fn potential(&self, r: f64) -> f64 {
        match *self {
            ForceLaw::Exact => laws::exact_potential(r),
            ForceLaw::Exclusion { radius } => laws::exclusion_potential(r, radius),
            ForceLaw::Plummer { .. } => laws::plummer_potential(r, self.squared_parameter()),
        }
    }
}

/// Time integrator.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Integrator {
    /// The source's scheme: `v += a dt; x += v dt` (first order, symplectic).
    SymplecticEuler,
    /// Leapfrog kick–drift–kick (second order, symplectic, time-reversible).
    Leapfrog,
}

/// Everything a run needs besides the particles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config {
    /// Time step in normalised units (the source uses 1).
    pub dt: f64,
    /// Force law.
    pub force: ForceLaw,
    /// Integrator.
    pub integrator: Integrator,
    /// Floating-point precision of the force evaluation and the particle state on the
    /// backend: f64 (the default of [`Config::new`]) or f32 (fastest; about 1e-6 relative
    /// force error). On the GPU, f64 needs `SHADER_F64`.
    pub precision: Precision,
    /// CPU backend: use the AVX-512 path (`vrsqrt14` plus Newton steps: one in f32, two in
    /// f64) instead of square root and division when the CPU has AVX-512F. Default `true`;
    /// accuracy: about 1e-7 relative per pair in f32, a few ulp in f64.
    pub rsqrt: bool,
}

impl Config {
    /// Leapfrog, double precision, with the given time step and force law.
    pub fn new(dt: f64, force: ForceLaw) -> Self {
        Self {
            dt,
            force,
            integrator: Integrator::Leapfrog,
            precision: Precision::F64,
            rsqrt: true,
        }
    }

    /// Sets the integrator.
    pub fn with_integrator(mut self, integrator: Integrator) -> Self {
        self.integrator = integrator;
        self
    }

    /// Sets the precision.
    pub fn with_precision(mut self, precision: Precision) -> Self {
        self.precision = precision;
        self
    }

    /// Enables or disables the CPU's AVX-512 rsqrt path (see [`Config::rsqrt`]).
    pub fn with_rsqrt(mut self, rsqrt: bool) -> Self {
        self.rsqrt = rsqrt;
        self
    }

    /// Checks the time step and the force-law parameter.
    pub fn validate(&self) -> Result<()> {
        require_positive("dt", self.dt)?;
        self.force.validate()
    }
}

/// The error for two coincident particles under the exact law.
pub(crate) fn coincident_error(i: usize, j: usize, at: [f64; 3]) -> Error {
    Error::invalid(
        format!("positions of particles {i} and {j}"),
        format!("both ({}, {}, {})", at[0], at[1], at[2]),
        "coincident particles make the exact Coulomb force infinite; \
         separate them or use ForceLaw::Plummer or ForceLaw::Exclusion",
    )
}
