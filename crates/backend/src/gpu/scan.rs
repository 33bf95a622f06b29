//! Multi-level exclusive prefix sum of `u32` arrays on the GPU.
//!
//! Level 0 scans blocks of [`SCAN_BLOCK`] values of the user's buffer in place and writes one
//! total per block; level 1 scans those totals the same way, and so on until one block is
//! left. The scanned totals are then added back level by level. Any length works, including
//! 0 and lengths over the workgroup-grid limit. All buffers and bind groups are made once per
//! [`ScanPlan`], so a plan can be re-encoded every step without allocation.

use bytemuck::{Pod, Zeroable};

use super::{DISPATCH_WGSL, GpuBuffer, GpuContext, Kernel, KernelDesc, Uniform, run_pass};
use crate::Result;

/// Values scanned by one workgroup.
pub const SCAN_BLOCK: u32 = 1024;

const SCAN_WGSL: &str = crate::wgsl!("scan.wgsl");

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct ScanParams {
    n: u32,
    pad: [u32; 3],
}

/// The compiled scan kernels; create once per [`GpuContext`] and make plans from it.
pub struct GpuScan {
    blocks: Kernel,
    add: Kernel,
}

struct Level {
    blocks: u64,
    scan_bind: wgpu::BindGroup,
    add_bind: wgpu::BindGroup,
    // Kept alive for the bind groups' sake and so the next level can bind them.
    _params: Uniform<ScanParams>,
    sums: GpuBuffer<u32>,
}

/// A scan of one particular buffer: its intermediate buffers and bind groups.
pub struct ScanPlan {
    levels: Vec<Level>,
}

impl GpuScan {
    /// Compiles the scan kernels.
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        let sources = [DISPATCH_WGSL, SCAN_WGSL];
        let make = |entry| {
            Kernel::new(
                ctx,
                &KernelDesc {
                    label: entry,
                    sources: &sources,
                    entry,
                    workgroup_size: 256,
                    constants: &[],
                },
            )
        };
        Ok(Self {
            blocks: make("scan_blocks")?,
            add: make("add_offsets")?,
        })
    }

    /// Prepares an in-place exclusive scan of `data`.
    pub fn plan(&self, ctx: &GpuContext, data: &GpuBuffer<u32>) -> Result<ScanPlan> {
        let mut levels: Vec<Level> = Vec::new();
        let mut n = data.len() as u64;
        while n > 0 {
            let blocks = n.div_ceil(u64::from(SCAN_BLOCK));
            let sums = GpuBuffer::<u32>::zeroed(ctx, "scan block sums", blocks as usize)?;
            let params = Uniform::new(
                ctx,
                "scan params",
                &ScanParams {
                    n: n as u32,
                    pad: [0; 3],
                },
            )?;
            let input = levels.last().map_or(data, |l| &l.sums);
            let resources = [input.binding(), sums.binding(), params.binding()];
            let scan_bind = self.blocks.bind(ctx, &resources)?;
            let add_bind = self.add.bind(ctx, &resources)?;
            levels.push(Level {
                blocks,
                scan_bind,
                add_bind,
                _params: params,
                sums,
            });
            if blocks == 1 {
                break;
            }
            n = blocks;
        }
        Ok(ScanPlan { levels })
    }

    /// Records the scan described by `plan` into `pass`.
    pub fn encode(
        &self,
        ctx: &GpuContext,
        pass: &mut wgpu::ComputePass<'_>,
        plan: &ScanPlan,
    ) -> Result<()> {
        for level in &plan.levels {
            self.blocks
                .dispatch_workgroups(ctx, pass, &level.scan_bind, level.blocks)?;
        }
        // The last level is a single block whose offset is zero: nothing to add there.
        for level in plan.levels.iter().rev().skip(1) {
            self.add
                .dispatch_workgroups(ctx, pass, &level.add_bind, level.blocks)?;
        }
        Ok(())
    }

    /// Scans `data` in place (exclusive) and waits for nothing: the result is ready for any
    /// work submitted afterwards. Allocates a plan; hot loops should keep a [`ScanPlan`].
    pub fn scan_in_place(&self, ctx: &GpuContext, data: &GpuBuffer<u32>) -> Result<ScanPlan> {
        let plan = self.plan(ctx, data)?;
        run_pass(ctx, "exclusive scan", |pass| self.encode(ctx, pass, &plan))?;
        Ok(plan)
    }
}

impl ScanPlan {
    /// A one-element buffer that holds the sum of all scanned values after the scan ran
    /// (`None` for an empty input).
    pub fn total(&self) -> Option<&GpuBuffer<u32>> {
        self.levels.last().map(|l| &l.sums)
    }
}
