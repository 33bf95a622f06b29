//! GPU plumbing shared by every simkit GPU backend (wgpu, WGSL).

mod buffer;
mod context;
mod kernel;
pub mod scan;

pub use buffer::{GpuBuffer, Staging, Uniform, check_storage_size};
pub use context::{ADAPTER_ENV, AdapterSummary, GpuContext, LLVMPIPE_LOOP_LIMIT};
pub use kernel::{DISPATCH_WGSL, Kernel, KernelDesc, run_pass, workgroup_grid};
pub use scan::{GpuScan, ScanPlan};
