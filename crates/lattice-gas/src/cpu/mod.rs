//! The CPU backends: [`lut`] (one byte per site, table lookup; a 64-site AVX-512 VBMI path)
//! and [`multispin`] (64-site bit-planes, boolean collisions). Both are bit-identical to each
//! other and to the GPU backend.

pub(crate) mod lut;
#[cfg(target_arch = "x86_64")]
mod lut_vbmi;
pub(crate) mod multispin;
