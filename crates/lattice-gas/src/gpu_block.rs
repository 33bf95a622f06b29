//! The GPU stepper of one rank's block of a [`crate::DistributedLatticeGas`]: the byte rule
//! of the single-process GPU kernel (the same site update, `shaders/site.wgsl`) on the
//! block padded with one ghost layer, one site per `u32`. The halo goes through the host
//! once per step: the block's edge sites are packed on the device and downloaded, the host
//! exchanges them with the neighbouring ranks, and the ghosts are uploaded and unpacked.

use bytemuck::{Pod, Zeroable};
use simkit_backend::comm::Block;
use simkit_backend::gpu::{DISPATCH_WGSL, Staging, Uniform, record_pass, run_pass};
use simkit_backend::rng::RNG_WGSL;
use simkit_backend::{GpuBuffer, GpuContext, Kernel, KernelDesc, Result};

use crate::gpu::SITE_WGSL;
use crate::random::{FORCE_STREAM, RANDOM_WGSL, force_threshold};
use crate::{CollisionTable, Config};

const BLOCK_WGSL: &str = simkit_backend::wgsl!("block.wgsl");
const HALO_WGSL: &str = simkit_backend::wgsl!("halo.wgsl");

/// The Rust mirror of `BlockParams` in `shaders/block.wgsl` (field meanings there).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct BlockParams {
    nx: u32,
    ny: u32,
    x0: u32,
    y0: u32,
    width: u32,
    seed: u32,
    force_seed: u32,
    threshold: u32,
    step: u32,
    pad: [u32; 3],
}

/// One rank's padded block on its GPU (see the module docs).
pub(crate) struct GpuBlock {
    ctx: GpuContext,
    /// Padded block, ping-pong.
    buffers: [GpuBuffer<u32>; 2],
    /// Bind groups stepping buffer 0 -> 1 and 1 -> 0.
    step_binds: [wgpu::BindGroup; 2],
    /// Per buffer: packing its edge sites, unpacking ghosts into it.
    pack_binds: [wgpu::BindGroup; 2],
    unpack_binds: [wgpu::BindGroup; 2],
    step_kernel: Kernel,
    pack_kernel: Kernel,
    unpack_kernel: Kernel,
    params: Uniform<BlockParams>,
    gp: BlockParams,
    /// Padded indices of the block's edge sites (rows 1 and `ny`, columns 1 and `nx`) and of
    /// its ghosts (rows 0 and `ny + 1`, columns 0 and `nx + 1`).
    edge_idx: Vec<u32>,
    ghost_idx: Vec<u32>,
    edge_vals: GpuBuffer<u32>,
    /// The host-readable copy of `edge_vals`, made once (one download every step).
    edge_staging: Staging<u32>,
    ghost_vals: GpuBuffer<u32>,
    /// The buffer holding the current state.
    current: usize,
    // Kept alive for the bind groups.
    _buffers: [GpuBuffer<u32>; 3],
}

impl GpuBlock {
    /// Uploads `padded` (the block with its ghosts, one byte per site, row-major
    /// `(nx + 2) x (ny + 2)`) of `block` of a lattice `width` sites wide, and compiles the
    /// kernels for the rules and boundaries of `config` (validated by the caller).
    pub fn new(
        ctx: &GpuContext,
        config: &Config,
        block: Block,
        width: usize,
        padded: &[u8],
    ) -> Result<Self> {
        let [nx, ny] = block.len;
        let pw = nx + 2;
        let sites: Vec<u32> = padded.iter().map(|&c| u32::from(c)).collect();
        let a = GpuBuffer::from_slice(ctx, "fhp block A", &sites)?;
        let b = GpuBuffer::<u32>::zeroed(ctx, "fhp block B", sites.len())?;
        let table: Vec<u32> = CollisionTable::new(config.rules)
            .entries
            .iter()
            .map(|&e| u32::from(e))
            .collect();
        let table = GpuBuffer::from_slice(ctx, "fhp collision table", &table)?;
        let at = |i: usize, j: usize| (j * pw + i) as u32;
        let mut edge_idx: Vec<u32> = Vec::new();
        let mut ghost_idx: Vec<u32> = Vec::new();
        for i in 1..=nx {
            edge_idx.extend([at(i, 1), at(i, ny)]);
        }
        for j in 1..=ny {
            edge_idx.extend([at(1, j), at(nx, j)]);
        }
        for i in 0..pw {
            ghost_idx.extend([at(i, 0), at(i, ny + 1)]);
        }
        for j in 1..=ny {
            ghost_idx.extend([at(0, j), at(nx + 1, j)]);
        }
        let edge_buf = GpuBuffer::from_slice(ctx, "fhp block edge indices", &edge_idx)?;
        let ghost_buf = GpuBuffer::from_slice(ctx, "fhp block ghost indices", &ghost_idx)?;
        let edge_vals = GpuBuffer::<u32>::zeroed(ctx, "fhp block edge sites", edge_idx.len())?;
        let ghost_vals = GpuBuffer::<u32>::zeroed(ctx, "fhp block ghosts", ghost_idx.len())?;
        let gp = BlockParams {
            nx: nx as u32,
            ny: ny as u32,
            x0: block.start[0] as u32,
            y0: block.start[1] as u32,
            width: width as u32,
            seed: config.seed,
            force_seed: config.seed ^ FORCE_STREAM,
            threshold: force_threshold(config.body_force),
            step: 0,
            pad: [0; 3],
        };
        let params = Uniform::new(ctx, "fhp block params", &gp)?;
        let step_kernel = Kernel::new(
            ctx,
            &KernelDesc {
                label: "fhp_block",
                sources: &[RNG_WGSL, DISPATCH_WGSL, RANDOM_WGSL, SITE_WGSL, BLOCK_WGSL],
                entry: "fhp_block",
                workgroup_size: 64,
                constants: &[("FLAGS", f64::from(config.flags()))],
            },
        )?;
        let halo = |entry: &'static str| {
            Kernel::new(
                ctx,
                &KernelDesc {
                    label: entry,
                    sources: &[DISPATCH_WGSL, HALO_WGSL],
                    entry,
                    workgroup_size: 64,
                    constants: &[],
                },
            )
        };
        let (pack_kernel, unpack_kernel) = (halo("pack")?, halo("unpack")?);
        let step_bind = |s: &GpuBuffer<u32>, d: &GpuBuffer<u32>| {
            step_kernel.bind(
                ctx,
                &[s.binding(), d.binding(), table.binding(), params.binding()],
            )
        };
        let step_binds = [step_bind(&a, &b)?, step_bind(&b, &a)?];
        let pack_binds = [
            pack_kernel.bind(ctx, &[a.binding(), edge_buf.binding(), edge_vals.binding()])?,
            pack_kernel.bind(ctx, &[b.binding(), edge_buf.binding(), edge_vals.binding()])?,
        ];
        let unpack_binds = [
            unpack_kernel.bind(
                ctx,
                &[a.binding(), ghost_buf.binding(), ghost_vals.binding()],
            )?,
            unpack_kernel.bind(
                ctx,
                &[b.binding(), ghost_buf.binding(), ghost_vals.binding()],
            )?,
        ];
        Ok(Self {
            ctx: ctx.clone(),
            buffers: [a, b],
            step_binds,
            pack_binds,
            unpack_binds,
            step_kernel,
            pack_kernel,
            unpack_kernel,
            params,
            gp,
            edge_staging: Staging::new(ctx, edge_idx.len())?,
            edge_idx,
            ghost_idx,
            edge_vals,
            ghost_vals,
            current: 0,
            _buffers: [table, edge_buf, ghost_buf],
        })
    }

    /// Steps the block on the device (random bits keyed by `step`) and copies the new edge
    /// sites into `padded`, the host's copy of the block (whose other sites are not kept
    /// current).
    pub fn step_and_read_edges(&mut self, padded: &mut [u8], step: u32) -> Result<()> {
        self.gp.step = step;
        self.params.set(&self.ctx, &self.gp);
        let (cur, next) = (self.current, self.current ^ 1);
        let sites = u64::from(self.gp.nx) * u64::from(self.gp.ny);
        let ctx = self.ctx.clone();
        ctx.checked("stepping an FHP block", || -> Result<()> {
            let mut encoder = ctx.encoder("fhp block step");
            record_pass(&mut encoder, "fhp block step", |pass| {
                self.step_kernel
                    .dispatch_items(&ctx, pass, &self.step_binds[cur], sites)?;
                self.pack_kernel.dispatch_items(
                    &ctx,
                    pass,
                    &self.pack_binds[next],
                    self.edge_idx.len() as u64,
                )
            })?;
            self.edge_vals
                .encode_copy_to(&mut encoder, &self.edge_staging)?;
            ctx.submit(encoder);
            Ok(())
        })??;
        let vals = self.edge_staging.read_kept(&ctx)?;
        for (&k, &v) in self.edge_idx.iter().zip(&vals) {
            padded[k as usize] = v as u8;
        }
        self.current = next;
        Ok(())
    }

    /// Uploads the ghosts of `padded` (after the host's halo exchange) into the current
    /// state.
    pub fn write_ghosts(&mut self, padded: &[u8]) -> Result<()> {
        let vals: Vec<u32> = self
            .ghost_idx
            .iter()
            .map(|&k| u32::from(padded[k as usize]))
            .collect();
        self.ghost_vals.upload(&self.ctx, &vals)?;
        let ctx = self.ctx.clone();
        let n = self.ghost_idx.len() as u64;
        ctx.checked("writing the ghosts of an FHP block", || {
            run_pass(&ctx, "fhp block ghosts", |pass| {
                self.unpack_kernel
                    .dispatch_items(&ctx, pass, &self.unpack_binds[self.current], n)
            })
        })?
    }

    /// The current padded block, one byte per site.
    pub fn padded(&self) -> Result<Vec<u8>> {
        let sites = self.buffers[self.current].download(&self.ctx)?;
        Ok(sites.into_iter().map(|v| v as u8).collect())
    }

    /// The adapter's name.
    pub fn adapter(&self) -> String {
        self.ctx.adapter_info().name.clone()
    }
}

#[cfg(test)]
mod tests {
    use std::mem::offset_of;

    use simkit_backend::testing::assert_mirrors;

    use super::*;

    #[test]
    fn block_params_mirror_the_wgsl_struct() {
        let module = [RNG_WGSL, DISPATCH_WGSL, RANDOM_WGSL, SITE_WGSL, BLOCK_WGSL].concat();
        assert_mirrors::<BlockParams>(
            &module,
            "BlockParams",
            &[
                ("nx", offset_of!(BlockParams, nx)),
                ("ny", offset_of!(BlockParams, ny)),
                ("x0", offset_of!(BlockParams, x0)),
                ("y0", offset_of!(BlockParams, y0)),
                ("width", offset_of!(BlockParams, width)),
                ("seed", offset_of!(BlockParams, seed)),
                ("force_seed", offset_of!(BlockParams, force_seed)),
                ("threshold", offset_of!(BlockParams, threshold)),
                ("step", offset_of!(BlockParams, step)),
                ("pad0", offset_of!(BlockParams, pad)),
                ("pad1", offset_of!(BlockParams, pad) + 4),
                ("pad2", offset_of!(BlockParams, pad) + 8),
            ],
        );
    }
}
