//! What every simkit simulation crate shares.
//!
//! - [`GpuContext`]: adapter choice (a real GPU first, else a CPU Vulkan driver such as
//!   lavapipe; `SIMKIT_ADAPTER=<name substring>` overrides), device limits and features.
//! - [`GpuBuffer`]: typed storage buffers with size checks against the device limits, upload
//!   and download.
//! - [`Kernel`]: WGSL from each crate's `shaders/` (embedded with [`wgsl!`]), pipelines, bind groups and
//!   dispatch of any number of items.
//! - [`GpuScan`]: multi-level exclusive prefix sum on the GPU; [`prefix`] has the CPU twins.
//! - [`rng`]: the counter-based random numbers that CPU and WGSL draw bit for bit alike.
//! - [`Real`], [`Precision`]: the `f32`/`f64` scalar every CPU law is generic over.
//! - [`Simulation`], [`Backend`], [`Error`]: the common trait, backend selector and error type.
//! - [`pool::on_pool`]: runs a stepping loop on the rayon pool (no thread hand-over per pass).
//! - [`guard`]: the blow-up check every `step(n)` runs (finite state at an interval, rollback
//!   to the last good state); [`checkpoint`]: the versioned, checksummed checkpoint format
//!   and the [`Restart`] trait; [`atomic`]: atomic file writes.
//! - [`comm`]: the communicator of a distributed run ([`comm::Comm`]: serial always, MPI with
//!   the `mpi` feature), Cartesian block decomposition, halo exchange, gather and reductions;
//!   [`Distributed`]: the common trait of every distributed simulation.
//! - [`vector`]: positions and velocities at the public API as `glam` vectors or arrays.
//!
//! The GPU half (everything wgpu) is the `gpu` cargo feature, on by default; without it the
//! crate, and every simkit crate, builds its CPU side only. An example is in [`gpu`].

// Links to the GPU items resolve when they are compiled (the `gpu` feature, on by default).
#![cfg_attr(not(feature = "gpu"), allow(rustdoc::broken_intra_doc_links))]

/// The WGSL source `shaders/<file>` of the crate that invokes it, embedded at compile time.
///
/// This is how every simkit crate loads its shaders: each crate keeps its WGSL in its own
/// `shaders/` folder (so a packaged crate carries its kernels), and a kernel is composed by
/// listing pieces in [`KernelDesc::sources`], shared pieces from this crate first
/// ([`rng::RNG_WGSL`], [`gpu::DISPATCH_WGSL`]), then the crate's own:
///
/// ```ignore
/// const FORCE_WGSL: &str = simkit_backend::wgsl!("force.wgsl"); // <crate>/shaders/force.wgsl
/// ```
#[macro_export]
macro_rules! wgsl {
    ($file:literal) => {
        include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/shaders/", $file))
    };
}

pub mod atomic;
pub mod checkpoint;
pub mod comm;
mod distributed;
pub mod error;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod guard;
pub mod particles;
pub mod pool;
pub mod prefix;
mod real;
pub mod rng;
mod simulation;
pub mod testing;
pub mod vector;

pub use checkpoint::Restart;
pub use distributed::Distributed;
pub use error::{Error, Result, require_finite, require_non_negative, require_positive};
#[cfg(feature = "gpu")]
pub use gpu::{GpuBuffer, GpuContext, GpuScan, Kernel, KernelDesc};
pub use real::{Precision, Real, max_or_nan};
pub use simulation::{Backend, Simulation};
