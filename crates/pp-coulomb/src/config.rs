//! Run configuration: force law, integrator, precision and time step.

use serde::{Deserialize, Serialize};
use simkit_backend::guard::DEFAULT_CHECK_EVERY;
use simkit_backend::{Error, Precision, Result, require_positive};

use crate::laws;

/// Default of [`Config::energy_tolerance`]: the largest relative change of the total energy
/// between two interval checks that the exact law accepts (see [`Config::energy_tolerance`]
/// for how it was chosen).
pub const DEFAULT_ENERGY_TOLERANCE: f64 = 1e-2;

/// How the pair force is evaluated. Each law is a separate compiled kernel: the choice is made
/// once per force evaluation, never per pair.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
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
    /// Checks the parameter: finite and > 0, with a square the kernels can hold (a normal,
    /// finite `f64`: a softening of 1e-170 would square to 0 and run the singular law).
    pub fn validate(&self) -> Result<()> {
        let (name, v) = match *self {
            ForceLaw::Exact => return Ok(()),
            ForceLaw::Exclusion { radius } => ("exclusion radius", radius),
            ForceLaw::Plummer { epsilon } => ("softening epsilon", epsilon),
        };
        require_positive(name, v)?;
        let square = v * v;
        if !(square.is_finite() && square >= f64::MIN_POSITIVE) {
            return Err(Error::invalid(
                name,
                format!("{v:e}"),
                format!(
                    "its square {square:e} is not a normal f64; use a value between {:e} and \
                     {:e}",
                    f64::MIN_POSITIVE.sqrt(),
                    f64::MAX.sqrt()
                ),
            ));
        }
        Ok(())
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
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Integrator {
    /// The source's scheme: `v += a dt; x += v dt` (first order, symplectic).
    SymplecticEuler,
    /// Leapfrog kick–drift–kick (second order, symplectic, time-reversible).
    Leapfrog,
}

/// Everything a run needs besides the particles.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
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
    #[serde(with = "precision_serde")]
    pub precision: Precision,
    /// CPU backend: use the AVX-512 path (`vrsqrt14` plus Newton steps: one in f32, two in
    /// f64) instead of square root and division when the CPU has AVX-512F. Default `true`;
    /// accuracy: about 1e-7 relative per pair in f32, a few ulp in f64.
    pub rsqrt: bool,
    /// Mixed precision (CPU backend only; needs `precision` = [`Precision::F32`]): the pair
    /// terms in f32 with the f32 SIMD kernel, everything else in f64. Default `false`.
    ///
    /// What is f32 and what is f64 in a mixed run:
    /// - positions, velocities, accelerations, `q / m`, the integrator (kick, drift, the
    ///   time step) and the clock: f64, with the f64 code of [`Precision::F64`];
    /// - the coordinates the pair kernel reads: each f64 coordinate `x` is split, once per
    ///   force evaluation, into `hi = x` rounded to f32 and `lo = x - hi` rounded to f32
    ///   (O(N) work); the kernel forms each separation as `(hi_i - hi_j) + (lo_i - lo_j)` in
    ///   f32, which is the f64 separation rounded to f32 within about two f32 ulps however
    ///   far the particles are from the origin (plain f32 coordinates lose
    ///   `|x| / |r_ij|` times more for a pair at distance `r_ij`). This costs three
    ///   subtractions, three additions and three loads per 16 pairs more than the f32
    ///   kernel; forming the separation in f64 per pair would double the traffic and
    ///   convert every pair;
    /// - the pair weight `w(r^2)`, `q_j w r` and the partial sums: f32, with the f32 kernel
    ///   of [`Precision::F32`] (the same law functions, the same AVX-512 or portable path
    ///   chosen by [`Config::rsqrt`]): 16 lanes of partial sums over a block of 1024
    ///   sources, 64 pair terms per lane, the lanes added in f32;
    /// - the per-target sum over the blocks, the field and the acceleration: f64 (one f64
    ///   addition per target and block of 1024 sources, never rounded to f32);
    /// - the energy guard's potential energy and [`crate::Diagnostics`]: f64 from the f64
    ///   positions, as in [`Precision::F64`].
    ///
    /// Accuracy and cost, measured on a neutral plasma of N = 8192 in a sphere of radius 10
    /// (exact law, L2 relative force error against a scalar f64 sum): f32 4.5e-6, mixed
    /// 2.3e-7, f64 4.5e-15; moved to (100, 100, 100), f32 1.1e-4 and mixed unchanged. A
    /// mixed evaluation takes about 1.3x the time of an f32 one and two thirds of an f64 one
    /// (the pp-coulomb guide and its trade-off page have the timings). In leapfrog runs the
    /// mixed energy stays within 1e-7 of K(0) of the f64 run's, where f32 departs by 5e-7
    /// to 3e-6. Inputs must fit f32 where the kernel reads them (positions and charges),
    /// as in f32; velocities and masses f64.
    /// Checkpoints record it (model `PpCoulomb<mixed>`). The GPU backend refuses it
    /// (`Error::Unsupported`); [`crate::DistributedCoulomb`] runs it bit-identically to one
    /// process.
    pub mixed: bool,
    /// Interval, in steps, of the blow-up check inside `step(n)` (default
    /// [`DEFAULT_CHECK_EVERY`] = 100): every `check_every` steps counted from step 0, the
    /// positions and velocities must be finite and, under [`ForceLaw::Exact`], the total
    /// energy must not jump (see [`Config::energy_tolerance`]); the state of each check that
    /// passes is kept, and a failed check puts the run back to it and returns
    /// `Error::BlowUp`. The finite check also runs at the end of every `step` call. `0`
    /// turns the interval checks (and with them the energy check) off; the end-of-call
    /// finite check stays. Cost: one pass over the state and one copy of it per interval, plus
    /// one potential-energy sum (about half a force pass) under the exact law.
    pub check_every: u32,
    /// The exact law's energy-jump guard: at each interval check, the total energy `E` must
    /// satisfy `|E - E_ref| <= tol * max(K_ref + |U_ref|, K + |U|)`, where `E_ref`, `K_ref`,
    /// `U_ref` are those of the previous interval check (or of the start of the run). `None`
    /// turns it off; only [`ForceLaw::Exact`] uses it (the exclusion cut does not conserve
    /// energy, and softened runs cannot collapse).
    ///
    /// Default [`DEFAULT_ENERGY_TOLERANCE`] = 1e-2. Both integrators are symplectic, so a run
    /// that resolves its encounters keeps a bounded energy error that falls as dt^2
    /// (leapfrog) or dt (symplectic Euler); in this crate's tests such runs stay at or below
    /// 2e-3 (leapfrog) and 4e-3 (symplectic Euler) of the energy scale over whole runs, so
    /// 1e-2 leaves a margin of 2.5 to 5. An unresolved close approach of two charges under
    /// the bare 1/r^2 force changes the energy by the pair's potential at its closest
    /// distance, orders of magnitude above that (the reported run with dt = 10: a factor
    /// 1e8). A single bad encounter among very many particles can change the total energy by
    /// less than the tolerance and pass: the guard catches runs whose energy is visibly
    /// wrong, not every unresolved pair.
    pub energy_tolerance: Option<f64>,
    /// The GPU force kernel's tile ([`GpuTile`]); `None` (the default) uses
    /// [`GpuTile::default`]. Every tile gives the same bits (each target sums its
    /// sources in index order), so it is a speed setting: not recorded in checkpoints, and
    /// ignored by the CPU backend.
    #[serde(skip)]
    pub gpu_tile: Option<GpuTile>,
}

/// The tile of the GPU force kernel: `workgroup` invocations stage that many source
/// particles at a time in workgroup memory, and each invocation sums the field on
/// `targets` particles, so that one read of a source serves `targets` of them (the scheme
/// of the CUDA `nbody` sample and its successors).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GpuTile {
    /// Invocations per workgroup = sources per tile: 32, 64, 128 or 256.
    pub workgroup: u32,
    /// Target particles per invocation: 1, 2, 4 or 8.
    pub targets: u32,
}

impl Default for GpuTile {
    /// 128 x 4, the tile used where [`Config::gpu_tile`] is `None`: at N = 10^6 (f32) on an
    /// NVIDIA H200 1.44e12 interactions/s against 0.96e12 for 128 x 1, within 5 % of the
    /// fastest of twelve tiles (32 x 8; 2026-11-28, `benches/gpu/`, docs/gpu.md), and on
    /// lavapipe 3.3x the rate of 128 x 1 at N = 2048.
    /// The targets add no loop iterations, so the loop limit of software drivers
    /// ([`crate::gpu_max_particles`]) does not depend on them.
    fn default() -> Self {
        Self {
            workgroup: 128,
            targets: 4,
        }
    }
}

impl GpuTile {
    /// Checks the workgroup size (32, 64, 128 or 256) and the targets (1, 2, 4 or 8).
    pub fn validate(&self) -> Result<()> {
        if ![32, 64, 128, 256].contains(&self.workgroup) {
            return Err(Error::invalid(
                "gpu_tile.workgroup",
                self.workgroup,
                "must be 32, 64, 128 or 256",
            ));
        }
        if ![1, 2, 4, 8].contains(&self.targets) {
            return Err(Error::invalid(
                "gpu_tile.targets",
                self.targets,
                "must be 1, 2, 4 or 8",
            ));
        }
        Ok(())
    }
}

/// `Precision` as a string in checkpoints (`"f32"`, `"f64"`).
mod precision_serde {
    use serde::{Deserialize, Deserializer, Serializer};
    use simkit_backend::Precision;

    pub(super) fn serialize<S: Serializer>(p: &Precision, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(match p {
            Precision::F32 => "f32",
            Precision::F64 => "f64",
        })
    }

    pub(super) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Precision, D::Error> {
        match String::deserialize(d)?.as_str() {
            "f32" => Ok(Precision::F32),
            "f64" => Ok(Precision::F64),
            other => Err(serde::de::Error::custom(format!(
                "unknown precision '{other}'"
            ))),
        }
    }
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
            mixed: false,
            check_every: DEFAULT_CHECK_EVERY,
            energy_tolerance: Some(DEFAULT_ENERGY_TOLERANCE),
            gpu_tile: None,
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

    /// Turns the mixed-precision mode on or off (see [`Config::mixed`]; needs
    /// `with_precision(Precision::F32)`).
    ///
    /// ```
    /// use simkit_pp_coulomb::{Config, ForceLaw, Precision};
    /// let mixed = Config::new(0.05, ForceLaw::Plummer { epsilon: 0.5 })
    ///     .with_precision(Precision::F32)
    ///     .with_mixed(true);
    /// assert!(mixed.validate().is_ok());
    /// // The pair terms of a mixed run are f32: with f64 it is an error naming the fix.
    /// assert!(mixed.with_precision(Precision::F64).validate().is_err());
    /// ```
    pub fn with_mixed(mut self, mixed: bool) -> Self {
        self.mixed = mixed;
        self
    }

    /// Sets the blow-up check interval (see [`Config::check_every`]; 0 = end of call only).
    pub fn with_check_every(mut self, check_every: u32) -> Self {
        self.check_every = check_every;
        self
    }

    /// Sets the exact law's energy-jump tolerance (see [`Config::energy_tolerance`]; `None`
    /// turns the energy check off).
    pub fn with_energy_tolerance(mut self, tolerance: Option<f64>) -> Self {
        self.energy_tolerance = tolerance;
        self
    }

    /// Sets the GPU force kernel's tile (see [`Config::gpu_tile`]).
    pub fn with_gpu_tile(mut self, tile: GpuTile) -> Self {
        self.gpu_tile = Some(tile);
        self
    }

    /// Checks the time step, the force-law parameter, the energy tolerance, the GPU tile and
    /// that [`Config::mixed`] comes with [`Precision::F32`].
    pub fn validate(&self) -> Result<()> {
        require_positive("dt", self.dt)?;
        if let Some(tile) = self.gpu_tile {
            tile.validate()?;
        }
        if self.mixed && self.precision != Precision::F32 {
            return Err(Error::invalid(
                "mixed",
                "true with precision F64",
                "the mixed mode computes the pair terms in f32 and the rest in f64; set \
                 with_precision(Precision::F32) with it, or with_mixed(false) for pure f64",
            ));
        }
        if let Some(tol) = self.energy_tolerance {
            require_positive("energy_tolerance", tol)?;
        }
        self.force.validate()
    }
}

/// How a run stores its state and evaluates its pairs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Mode {
    /// Everything in f64.
    F64,
    /// Everything in f32 (block sums in f64).
    F32,
    /// Pair terms in f32, the state and the sums in f64 ([`Config::mixed`]).
    Mixed,
}

impl Mode {
    /// Every mode.
    pub(crate) const ALL: [Mode; 3] = [Mode::F64, Mode::F32, Mode::Mixed];

    /// The precision of the particle state (positions, velocities, accelerations).
    pub(crate) fn state(self) -> Precision {
        match self {
            Mode::F32 => Precision::F32,
            Mode::F64 | Mode::Mixed => Precision::F64,
        }
    }

    /// The name in checkpoint models and messages: `f64`, `f32` or `mixed`.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Mode::F64 => "f64",
            Mode::F32 => "f32",
            Mode::Mixed => "mixed",
        }
    }
}

impl Config {
    /// The run's mode (a mixed run with f64 pairs is refused by [`Config::validate`]; it
    /// counts as mixed here).
    pub(crate) fn mode(&self) -> Mode {
        match (self.mixed, self.precision) {
            (true, _) => Mode::Mixed,
            (false, Precision::F32) => Mode::F32,
            (false, Precision::F64) => Mode::F64,
        }
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
