//! The pair-law trait: what a potential must provide to run on every backend.

use std::fmt::Debug;

use bytemuck::Pod;
use serde::Serialize;
use serde::de::DeserializeOwned;
use simkit_backend::{Real, Result};

/// A pair potential `phi(r)` cut at `r_c`: its parameters for one species pair (the
/// implementing type itself), the coefficients the force loops read, the force and energy
/// as one Rust function generic over [`Real`] with its WGSL twin, the cutoff, and the
/// curvature that the time-step guidance needs.
///
/// A [`PairTable`](crate::PairTable) holds one law type for every species pair, and every
/// backend is compiled for that type: the CPU kernels (the AVX-512, AVX2 and portable
/// builds of the half-list kernel, the distributed full-list kernel) call
/// [`force_energy`](PairLaw::force_energy) inlined, and the GPU kernels are built from
/// [`WGSL`](PairLaw::WGSL). A law defined outside this crate therefore runs at the speed
/// of a built-in one. Mixing laws per species pair is a law of its own (an enum whose
/// coefficients name the form), which costs a branch per pair only where it is used.
///
/// # Contract
///
/// - [`force_energy`](PairLaw::force_energy) returns `(f / r, phi(r) - shift)` for the
///   squared distance `r2 > 0`, where `f = -phi'(r)` is the force on the first particle
///   along the separation (positive: repulsive), and exactly `(0, 0)` when `r2 >= r_c^2`
///   (the CPU kernels feed a separation beyond every cutoff to unused vector lanes and
///   rely on it). It must not branch on anything but `r2` and the coefficients.
/// - The WGSL twin declares `struct MdCoeff` (the layout of [`PairLaw::Gpu`]) and
///   `fn md_pair_force_energy(c: MdCoeff, r2: f32) -> vec2<f32>` returning the same pair
///   in `f32`; [`check_law_on_gpu`](crate::check_law_on_gpu) tests the two against each
///   other.
/// - [`validate`](PairLaw::validate) refuses parameters whose coefficients would not be
///   finite in `f32` (the GPU and the `f32` CPU backend compute in it).
///
/// A complete law from outside the crate, with its GPU test, is `examples/custom_law/`;
/// the guide `docs/md.md` walks through it.
pub trait PairLaw:
    Copy + Debug + PartialEq + Send + Sync + Serialize + DeserializeOwned + 'static
{
    /// The coefficients of one species pair as the force loops read them, in precision
    /// `T` (derived from the parameters once, at construction).
    type Coeff<T: Real>: Copy + Debug + PartialEq + Send + Sync + 'static;

    /// `Coeff<f32>` laid out as the WGSL struct `MdCoeff` of [`PairLaw::WGSL`].
    type Gpu: Pod + Send + Sync;

    /// Short name of the law (checkpoints record it, so a run resumes only with the law
    /// that wrote it), e.g. `"lj"`, `"morse"`: letters, digits, `-` and `_`, different
    /// from every other law's (a table refuses a law named as the built-in default).
    const NAME: &'static str;

    /// WGSL declaring `struct MdCoeff` and `fn md_pair_force_energy(c: MdCoeff, r2: f32)
    /// -> vec2<f32>`, the twin of [`force_energy`](PairLaw::force_energy).
    const WGSL: &'static str;

    /// Whether the law is one of `simkit-md`'s own: their engines (the CPU engine of each
    /// dimension and precision, the GPU engine) are compiled once, in `simkit-md`, instead
    /// of again in every crate, test and example that runs them (Rust compiles generic
    /// code where it is used). Leave it `false`: a law of your own has its engines
    /// compiled in your crate, and one that claims to be built in is refused.
    #[doc(hidden)]
    const BUILT_IN: bool = false;

    /// Checks the parameters; `pair` names the species pair for the error message (e.g.
    /// `"pair (0, 1)"`).
    ///
    /// Errors: [`simkit_backend::Error::InvalidParameter`] naming `pair`, the parameter,
    /// its value and the fix.
    fn validate(&self, pair: &str) -> Result<()>;

    /// The cutoff `r_c > 0`: the pair does not interact at `r >= r_c`.
    fn cutoff(&self) -> f64;

    /// `phi(r)` without the cutoff or the shift, in `f64` (the energy shift at the cutoff
    /// is `energy(cutoff())`).
    fn energy(&self, r: f64) -> f64;

    /// The coefficients in precision `T`, with the energy shift `shift` (`phi(r_c)` when
    /// the run shifts energies, else 0) subtracted from every energy.
    fn coefficients<T: Real>(&self, shift: f64) -> Self::Coeff<T>;

    /// The `f32` coefficients in the GPU layout.
    fn gpu(c: &Self::Coeff<f32>) -> Self::Gpu;

    /// `(f / r, phi - shift)` at squared distance `r2`; `(0, 0)` at `r2 >= r_c^2` (see the
    /// contract above).
    fn force_energy<T: Real>(c: &Self::Coeff<T>, r2: T) -> (T, T);

    /// Where the time-step guidance measures the pair's stiffness, `r*`, and the
    /// curvature `phi''(r*) > 0` there: the minimum of `phi` for a law with a well, else a
    /// distance the law documents. `None` (the default) when the pair does not interact
    /// or the law has no such distance: a system whose pairs all give `None` needs an
    /// explicit [`Config::dt`](crate::Config::dt).
    fn stiffness(&self) -> Option<(f64, f64)> {
        None
    }

    /// The size of the largest term that the force `f / r` and the energy `phi` at
    /// distance `r` are summed from (in `f64`): the scale of their rounding errors, which
    /// [`check_law_on_gpu`](crate::check_law_on_gpu) measures the GPU against. The
    /// default, `|f / r|` and `|phi|`, suits laws without cancelling terms; a law that
    /// subtracts terms (attraction from repulsion) returns the larger of them.
    fn term_sizes(&self, r: f64) -> (f64, f64) {
        let c = self.coefficients::<f64>(0.0);
        let (f, e) = Self::force_energy(&c, r * r);
        (f.abs(), e.abs())
    }
}
