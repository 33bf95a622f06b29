//! What every simkit simulation crate shares.
//!
//! - [`GpuContext`]: adapter choice (a real GPU first, else a CPU Vulkan driver such as
//!   lavapipe; `SIMKIT_ADAPTER=<name substring>` overrides), device limits and features.
//! - [`GpuBuffer`]: typed storage buffers with size checks against the device limits, upload
//!   and download.
//! - [`Kernel`]: WGSL from `shaders/` (embedded with `include_str!`), pipelines, bind groups and
//!   dispatch of any number of items.
//! - [`GpuScan`]: multi-level exclusive prefix sum on the GPU; [`prefix`] has the CPU twins.
//! - [`rng`]: the counter-based random numbers that CPU and WGSL draw bit for bit alike.
//! - [`Simulation`], [`Backend`], [`Error`]: the common trait, backend selector and error type.
//! - [`pool::on_pool`]: runs a stepping loop on the rayon pool (no thread hand-over per pass).
//!
//! ```no_run
//! use backend::{GpuBuffer, GpuContext, GpuScan};
//! # fn main() -> backend::Result<()> {
//! let ctx = GpuContext::new()?; // Err(Error::NoAdapter) with advice when there is no GPU
//! let counts = GpuBuffer::from_slice(&ctx, "counts", &[3u32, 1, 4, 1, 5])?;
//! GpuScan::new(&ctx)?.scan_in_place(&ctx, &counts)?;
//! assert_eq!(counts.download(&ctx)?, vec![0, 3, 4, 8, 9]);
//! # Ok(())
//! # }
//! ```

pub mod error;
pub mod gpu;
pub mod pool;
pub mod prefix;
pub mod rng;
mod simulation;
pub mod testing;

pub use error::{Error, Result, require_finite, require_non_negative, require_positive};
pub use gpu::{GpuBuffer, GpuContext, GpuScan, Kernel, KernelDesc};
pub use simulation::{Backend, Simulation};
