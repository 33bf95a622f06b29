//! GPU plumbing shared by every simkit GPU backend (wgpu, WGSL): the `gpu` cargo feature.
//!
//! ```no_run
//! use simkit_backend::{GpuBuffer, GpuContext, GpuScan};
//! # fn main() -> simkit_backend::Result<()> {
//! let ctx = GpuContext::new()?; // Err(Error::NoAdapter) with advice when there is no GPU
//! let counts = GpuBuffer::from_slice(&ctx, "counts", &[3u32, 1, 4, 1, 5])?;
//! GpuScan::new(&ctx)?.scan_in_place(&ctx, &counts)?;
//! assert_eq!(counts.download(&ctx)?, vec![0, 3, 4, 8, 9]);
//! # Ok(())
//! # }
//! ```

mod buffer;
mod context;
mod guard;
mod kernel;
pub mod scan;

pub use buffer::{GpuBuffer, Staging, Uniform, check_storage_size};
pub use context::{
    ADAPTER_ENV, AdapterSummary, DEFAULT_WAIT_LIMIT, GpuContext, LLVMPIPE_LOOP_LIMIT,
};
pub use guard::{GUARD_WGSL, GpuGuard, GuardReport, GuardedRun, Watch};
pub use kernel::{DISPATCH_WGSL, Kernel, KernelDesc, record_pass, run_pass, workgroup_grid};
pub use scan::{GpuScan, ScanPlan};
