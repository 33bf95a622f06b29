//! The contact-law trait: what a contact model must provide to run on every backend.

use std::fmt::Debug;

use bytemuck::Pod;
use serde::Serialize;
use serde::de::DeserializeOwned;
use simkit_backend::{Real, Result};

/// The geometry and kinematics of one contact, as the force loops hand them to a
/// [`ContactLaw`]: particle `i` touches `j` (another particle, or a wall of infinite mass).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contact<T, const D: usize> {
    /// Reduced mass `m_i m_j / (m_i + m_j)` (against a wall: `m_i`).
    pub m_ij: T,
    /// Overlap `delta = R_i + R_j - |r_i - r_j| > 0` (against a wall: the wall's overlap).
    pub delta: T,
    /// Unit normal from `j` to `i`.
    pub n: [T; D],
    /// Relative velocity `v_i - v_j` at the centres.
    pub v_rel: [T; D],
    /// Normal relative velocity `v_rel . n` (negative when approaching).
    pub v_n: T,
    /// Effective radius `R_i R_j / (R_i + R_j)` (against a wall: `R_i`).
    pub r_eff: T,
    /// Relative angular velocity `omega_i - omega_j` (against a wall: `omega_i`; zero in a
    /// scene without rotation). 2D discs spin about z only.
    pub w_rel: [T; 3],
    /// The time step (laws with a per-contact history integrate it over one step).
    pub dt: T,
}

/// What a [`ContactLaw`] returns for one contact: the force on `i` and the torque on `i`
/// beyond the lever arm of that force (a rolling-resistance couple; `j` receives minus
/// it). The engines add the torque `(-R_i n) x F` of the force itself.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactForce<T, const D: usize> {
    /// Force on particle `i`.
    pub force: [T; D],
    /// Couple on particle `i` (3 components; 2D discs use z only).
    pub torque: [T; 3],
}

impl<T: Real, const D: usize> ContactForce<T, D> {
    /// A force without a couple.
    #[inline(always)]
    pub fn force(force: [T; D]) -> Self {
        Self {
            force,
            torque: [T::ZERO; 3],
        }
    }
}

/// A contact law between two materials (a species pair, or a species and a wall): its
/// parameters (the implementing type itself), the coefficients the force loops read, the
/// contact force as one Rust function generic over [`Real`] with its WGSL twin, the elastic
/// energy, and the time scales the time-step guidance needs.
///
/// A [`Scene`](crate::Scene) holds one law type for every species pair and wall, and every
/// backend is compiled for it: the CPU force loops (the blocked half list of
/// [`Dem`](crate::Dem), the full lists of [`DistributedDem`](crate::DistributedDem)) call
/// [`force`](ContactLaw::force) inlined, the GPU force kernel is built from
/// [`WGSL`](ContactLaw::WGSL). The linear spring–dashpot of [`Material`](crate::Material) is
/// the built-in law.
///
/// # Contract
///
/// - [`force`](ContactLaw::force) returns the force on `i` of a contact with overlap
///   `delta > 0`; the tangential part only when `FRICTION` (the scene has a material with
///   friction, [`ContactLaw::has_friction`]); it depends on the contact's geometry and
///   kinematics and on the contact's history (see below) only.
/// - A law with [`HISTORY`](ContactLaw::HISTORY) `> 0` values per contact (a tangential
///   spring, a rolling spring) reads and updates them in `force`; the CPU engine keeps them
///   per contact from the step the contact closes (all zero) until it opens (reset to
///   zero), carries them through neighbour-list rebuilds, particle reorderings, rollbacks
///   and checkpoints, and, when a contact is listed the other way round (`j` first), hands
///   them over through [`swap_history`](ContactLaw::swap_history).
/// - The WGSL twin declares `struct DemCoeff` (the layout of [`ContactLaw::Gpu`]) and
///   `fn dem_contact_force(c: DemCoeff, k: DemContact, h: ptr<function, DemHistory>,
///   friction: bool) -> DemForce`, the twin of [`force`](ContactLaw::force) in `f32`. The
///   GPU force kernel puts [`LAW_PRELUDE_WGSL`] before it: `DemContact` (the twin of
///   [`Contact`], 3-vectors with `z = 0` in 2D), `DemForce` (of [`ContactForce`]),
///   `DemHistory` (`array<f32, 7>`: a law keeps at most 7 values per contact on the GPU)
///   and the helpers a law may call (`dem_spring_dashpot`, `dem_contact_point_velocity`,
///   `dem_coulomb_spring`, `dem_springs_add`, twins of [`crate::normal_force`],
///   [`crate::coulomb_spring`] and the springs of the history laws).
///
/// Both backends of [`Dem`](crate::Dem) run every law: the CPU backend keeps a law's history
/// per contact of its lists, the GPU backend per particle and contact partner
/// (`docs/dem.md`, "Contact history on the GPU").
/// [`DistributedDem`](crate::DistributedDem) keeps it per particle and partner too, and
/// migrates it with the particles (at most 12 values per contact there).
pub trait ContactLaw:
    Copy + Debug + PartialEq + Send + Sync + Serialize + DeserializeOwned + 'static
{
    /// The coefficients of one material pair as the force loops read them, in precision
    /// `T` (derived from the parameters once, at construction).
    type Coeff<T: Real>: Copy + Debug + PartialEq + Send + Sync + 'static;

    /// `Coeff<f32>` laid out as the WGSL struct `DemCoeff` of [`ContactLaw::WGSL`].
    type Gpu: Pod + Send + Sync;

    /// Short name of the law (checkpoints record it, so a run resumes only with the law
    /// that wrote it), e.g. `"linear"`: letters, digits, `-` and `_`, different from every
    /// other law's (a scene refuses a law named as the built-in default).
    const NAME: &'static str;

    /// WGSL declaring `struct DemCoeff` and `fn dem_contact_force` (see the contract).
    const WGSL: &'static str;

    /// Whether the law is one of `simkit-dem`'s own: their engines (the CPU engine of each
    /// dimension and precision, the GPU engine) are compiled once, in `simkit-dem`, instead
    /// of again in every crate, test and example that runs them (Rust compiles generic
    /// code where it is used). Leave it `false`: a law of your own has its engines
    /// compiled in your crate, and one that claims to be built in is refused.
    #[doc(hidden)]
    const BUILT_IN: bool = false;

    /// Values the law keeps per contact (0: a memoryless law).
    const HISTORY: usize = 0;

    /// Turns the history of a contact listed as `(i, j)` into that of `(j, i)` (e.g. a
    /// tangential displacement changes sign). Only called when `HISTORY > 0`.
    fn swap_history<T: Real>(history: &mut [T]) {
        let _ = history;
    }

    /// Checks the parameters; `what` names the material for the error message (e.g.
    /// `"species pair (0, 1)"`, `"wall 2"`).
    ///
    /// Errors: [`simkit_backend::Error::InvalidParameter`] naming `what`, the parameter,
    /// its value and the fix.
    fn validate(&self, what: &str) -> Result<()>;

    /// The coefficients in precision `T`.
    fn coefficients<T: Real>(&self) -> Self::Coeff<T>;

    /// The `f32` coefficients in the GPU layout.
    fn gpu(c: &Self::Coeff<f32>) -> Self::Gpu;

    /// The magnitudes the precision must hold, `(name, value, must be positive)`: each
    /// must lie below the precision's limit, and the positive ones above its inverse (the
    /// engines refuse a scene otherwise, naming the value).
    fn scales(&self) -> Vec<(&'static str, f64, bool)>;

    /// Whether the law has a tangential force with these parameters.
    fn has_friction(&self) -> bool;

    /// The duration of a binary contact of reduced mass `m_ij` and effective radius
    /// `r_eff` (the scene asks for its lightest and smallest pairs): the default time step
    /// is the shortest over the scene divided by
    /// [`DEFAULT_STEPS_PER_CONTACT`](crate::DEFAULT_STEPS_PER_CONTACT).
    fn contact_time(&self, m_ij: f64, r_eff: f64) -> f64;

    /// The largest stable time step for this material at reduced mass `m_ij` and effective
    /// radius `r_eff` (larger steps are refused unless
    /// [`Config::allow_unstable_dt`](crate::Config::allow_unstable_dt) is set).
    fn safe_dt(&self, m_ij: f64, r_eff: f64) -> f64;

    /// The force (and couple) on particle `i` of `contact`, updating the contact's
    /// `history` ([`HISTORY`](ContactLaw::HISTORY) values; see the contract).
    fn force<T: Real, const D: usize, const FRICTION: bool>(
        c: &Self::Coeff<T>,
        contact: &Contact<T, D>,
        history: &mut [T],
    ) -> ContactForce<T, D>;

    /// The elastic energy stored in a contact of reduced mass `m_ij`, effective radius
    /// `r_eff` and overlap `delta` (the normal spring's).
    fn elastic_energy<T: Real>(c: &Self::Coeff<T>, m_ij: T, r_eff: T, delta: T) -> T;
}

/// The WGSL the GPU force kernel puts before a law's [`ContactLaw::WGSL`]: the structs
/// `DemContact`, `DemForce`, the alias `DemHistory` and the helper functions of the
/// built-in laws (see the trait's contract). Prepend it to test a law's WGSL on its own.
pub const LAW_PRELUDE_WGSL: &str = concat!(
    include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/shaders/law.wgsl")),
    include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/shaders/spin.wgsl")),
);
