//! The models: linear diffusion, Gray–Scott and the bacterial colony model.

mod colony;
mod diffusion;
mod gray_scott;

pub use colony::Colony;
pub use diffusion::Diffusion;
pub use gray_scott::GrayScott;

use simkit_backend::Real;

/// Writes `v` into `out`, or the Heun average `(out + v) / 2` when `AVG`.
#[inline(always)]
pub(crate) fn store<T: Real, const AVG: bool>(out: &mut T, v: T) {
    if AVG {
        *out = T::from_f64(0.5) * (*out + v);
    } else {
        *out = v;
    }
}
