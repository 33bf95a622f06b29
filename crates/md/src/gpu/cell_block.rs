//! The cell-block scheme ([`crate::GpuKernel::CellBlock`]): fixed-capacity slot lists per
//! cell, updated locally on the device after every drift, and a force kernel with one
//! workgroup per cell that stages the neighbour cells in workgroup memory.
//!
//! The slot lists are ping-ponged between two sets: the state at step `t` uses set
//! `t % 2`; a step reads it in the update kernel and writes set `(t + 1) % 2`, which its
//! force kernel then reads. A full rebuild (construction, resume, rollback) sorts the
//! particles into cells with neighbor's [`AnyGpuCellList`] and copies its cells (ascending
//! ids) into the set of the current step. Because the local update also keeps the ids of
//! each cell ascending, both give the same lists, so a resumed run sums its forces in the
//! order of the uninterrupted one (bit-exact restart).

use simkit_backend::gpu::{DISPATCH_WGSL, Uniform, run_pass};
use simkit_backend::{Error, GpuBuffer, GpuContext, Kernel, KernelDesc, Result};
use simkit_neighbor::{AnyGpuCellList, CELLS_WGSL};

use super::{GpuParams, PARAMS_WGSL};

const BLOCK_WGSL: &str = simkit_backend::wgsl!("block.wgsl");
const FILL_WGSL: &str = simkit_backend::wgsl!("block_fill.wgsl");
const UPDATE_WGSL: &str = simkit_backend::wgsl!("block_update.wgsl");
const FORCE_WGSL: &str = simkit_backend::wgsl!("block_force.wgsl");

/// Label of the two-value health buffer (`[overflow, jump]`, NaN when set) that the guard
/// checks; its report names it.
pub(super) const HEALTH_LABEL: &str = "md cells";

/// The smallest automatic capacity, and the granule capacities are rounded up to.
const SLOT_GRANULE: u32 = 8;

/// Bytes of workgroup memory per slot in the force kernel (a position and an id).
const STAGE_BYTES_PER_SLOT: u32 = 20;

/// The engine's buffers the force kernel binds, and the law's WGSL.
pub(super) struct ForceInputs<'a, C: bytemuck::Pod> {
    /// The pair law (`struct MdCoeff`, `md_pair_force_energy`).
    pub law: &'static str,
    /// Run parameters.
    pub params: &'a Uniform<GpuParams>,
    /// Positions (`w`: species).
    pub pos: &'a GpuBuffer<[f32; 4]>,
    /// Pair coefficients, entry `si * n_species + sj`.
    pub coeff: &'a GpuBuffer<C>,
    /// Per species: `(1 / mass, c1, amplitude, 0)`.
    pub species: &'a GpuBuffer<[f32; 4]>,
    /// Accelerations (`w`: pair energy sum).
    pub acc: &'a GpuBuffer<[f32; 4]>,
    /// Velocities.
    pub vel: &'a GpuBuffer<[f32; 4]>,
    /// Virial sums.
    pub vir: &'a GpuBuffer<f32>,
}

/// Slot lists, their kernels and the full-rebuild cell list.
pub(super) struct CellBlock {
    slots: u32,
    n_cells: u64,
    full: AnyGpuCellList,
    health: GpuBuffer<f32>,
    fill: Kernel,
    fill_bind: [wgpu::BindGroup; 2],
    update: Kernel,
    /// `update_bind[s]` reads set `s` and writes set `1 - s`.
    update_bind: [wgpu::BindGroup; 2],
    force: Kernel,
    force_bind: [wgpu::BindGroup; 2],
    // Bound only.
    _counts: [GpuBuffer<u32>; 2],
    _lists: [GpuBuffer<u32>; 2],
}

/// The automatic capacity: the larger of twice the mean and 1.5 times the largest
/// population, rounded up to a multiple of [`SLOT_GRANULE`].
fn auto_slots(particles: usize, cells: usize, fullest: u32) -> u32 {
    let mean = particles as f64 / cells.max(1) as f64;
    let want = (2.0 * mean).max(1.5 * f64::from(fullest)).ceil() as u32;
    want.max(1).div_ceil(SLOT_GRANULE) * SLOT_GRANULE
}

fn kernel(
    ctx: &GpuContext,
    law: &str,
    cap: &str,
    src: &str,
    entry: &str,
    wg: u32,
    kick: f64,
) -> Result<Kernel> {
    let consts = [("KICK", kick)];
    Kernel::new(
        ctx,
        &KernelDesc {
            label: entry,
            sources: &[
                DISPATCH_WGSL,
                CELLS_WGSL,
                PARAMS_WGSL,
                law,
                cap,
                BLOCK_WGSL,
                src,
            ],
            entry,
            workgroup_size: wg,
            constants: if src == FORCE_WGSL { &consts } else { &[] },
        },
    )
}

impl CellBlock {
    /// Builds the slot lists of the current positions into set `steps % 2` and computes the
    /// initial forces with closing kick `start_kick` (see `force.wgsl`); later steps kick
    /// with `kick`. `kicks` is `[kick, start_kick]`.
    ///
    /// Errors: a requested capacity of 0, below the fullest initial cell or over the
    /// device's workgroup limits; an automatic capacity over those limits.
    pub fn new<C: bytemuck::Pod>(
        ctx: &GpuContext,
        full: AnyGpuCellList,
        n: usize,
        requested: Option<u32>,
        inputs: &ForceInputs<'_, C>,
        steps: u64,
        kicks: [f64; 2],
    ) -> Result<Self> {
        let [kick, start_kick] = kicks;
        run_pass(ctx, "md cell-block full rebuild", |pass| {
            full.encode(ctx, pass)
        })?;
        full.check(ctx)?;
        let starts = full.buffers().cell_start.download(ctx)?;
        let n_cells = starts.len() - 1;
        let fullest = starts.windows(2).map(|w| w[1] - w[0]).max().unwrap_or(0);
        let limits = ctx.limits();
        let max_slots = limits
            .max_compute_invocations_per_workgroup
            .min(limits.max_compute_workgroup_size_x)
            .min(limits.max_compute_workgroup_storage_size / STAGE_BYTES_PER_SLOT);
        let slots = match requested {
            Some(s) if s == 0 || s < fullest => {
                return Err(Error::invalid(
                    "GpuKernel::CellBlock slots",
                    s,
                    format!(
                        "the fullest cell of the initial state holds {fullest} particles; give \
                         at least that (e.g. {}), or None for the automatic capacity",
                        auto_slots(n, n_cells, fullest)
                    ),
                ));
            }
            Some(s) => s,
            None => auto_slots(n, n_cells, fullest),
        };
        if slots > max_slots {
            return Err(Error::Unsupported(format!(
                "the cell-block kernel needs {slots} slots per cell (one invocation and \
                 {STAGE_BYTES_PER_SLOT} bytes of workgroup memory each; {n} particles in \
                 {n_cells} cells, the fullest holding {fullest}) and '{}' allows {max_slots} \
                 per workgroup; use GpuKernel::PerParticle",
                ctx.adapter_info().name
            )));
        }
        let cap = format!("const CAP: u32 = {slots}u;");
        let len = n_cells * slots as usize;
        let counts = [
            GpuBuffer::zeroed(ctx, "md cell counts a", n_cells)?,
            GpuBuffer::zeroed(ctx, "md cell counts b", n_cells)?,
        ];
        let lists = [
            GpuBuffer::zeroed(ctx, "md cell slots a", len)?,
            GpuBuffer::zeroed(ctx, "md cell slots b", len)?,
        ];
        let health = GpuBuffer::<f32>::zeroed(ctx, HEALTH_LABEL, 2)?;
        let cells = full.buffers();
        let fill = kernel(ctx, inputs.law, &cap, FILL_WGSL, "md_block_fill", 64, 0.0)?;
        let fill_set = |s: usize| {
            fill.bind(
                ctx,
                &[
                    cells.grid.binding(),
                    cells.cell_start.binding(),
                    cells.sorted_ids.binding(),
                    counts[s].binding(),
                    lists[s].binding(),
                    health.binding(),
                ],
            )
        };
        let fill_bind = [fill_set(0)?, fill_set(1)?];
        let update = kernel(
            ctx,
            inputs.law,
            &cap,
            UPDATE_WGSL,
            "md_block_update",
            slots,
            0.0,
        )?;
        let update_set = |s: usize| {
            update.bind(
                ctx,
                &[
                    cells.grid.binding(),
                    inputs.pos.binding(),
                    counts[s].binding(),
                    lists[s].binding(),
                    counts[1 - s].binding(),
                    lists[1 - s].binding(),
                    health.binding(),
                ],
            )
        };
        let update_bind = [update_set(0)?, update_set(1)?];
        let force_set = |k: &Kernel, s: usize| {
            k.bind(
                ctx,
                &[
                    cells.grid.binding(),
                    inputs.params.binding(),
                    counts[s].binding(),
                    lists[s].binding(),
                    inputs.pos.binding(),
                    inputs.coeff.binding(),
                    inputs.species.binding(),
                    inputs.acc.binding(),
                    inputs.vel.binding(),
                    inputs.vir.binding(),
                ],
            )
        };
        let force = kernel(
            ctx,
            inputs.law,
            &cap,
            FORCE_WGSL,
            "md_block_force",
            slots,
            kick,
        )?;
        let force_bind = [force_set(&force, 0)?, force_set(&force, 1)?];
        let set = (steps % 2) as usize;
        let init = kernel(
            ctx,
            inputs.law,
            &cap,
            FORCE_WGSL,
            "md_block_force",
            slots,
            start_kick,
        )?;
        let init_bind = force_set(&init, set)?;
        run_pass(ctx, "md cell-block initial forces", |pass| {
            fill.dispatch_items(ctx, pass, &fill_bind[set], n_cells as u64)?;
            init.dispatch_workgroups(ctx, pass, &init_bind, n_cells as u64)
        })?;
        Ok(Self {
            slots,
            n_cells: n_cells as u64,
            full,
            health,
            fill,
            fill_bind,
            update,
            update_bind,
            force,
            force_bind,
            _counts: counts,
            _lists: lists,
        })
    }

    /// Slots per cell.
    pub fn slots(&self) -> u32 {
        self.slots
    }

    /// The health flags the guard checks (`[overflow, jump]`, NaN when set).
    pub fn health(&self) -> &GpuBuffer<f32> {
        &self.health
    }

    /// Records one step's cell-list update and forces, from the state at step `from`.
    pub fn record_step(
        &self,
        ctx: &GpuContext,
        pass: &mut wgpu::ComputePass<'_>,
        from: u64,
    ) -> Result<()> {
        let s = (from % 2) as usize;
        self.update
            .dispatch_workgroups(ctx, pass, &self.update_bind[s], self.n_cells)?;
        self.force
            .dispatch_workgroups(ctx, pass, &self.force_bind[1 - s], self.n_cells)
    }

    /// Rebuilds the slot lists of the state at step `steps` from scratch (after a rollback).
    pub fn rebuild(&self, ctx: &GpuContext, steps: u64) -> Result<()> {
        let set = (steps % 2) as usize;
        run_pass(ctx, "md cell-block full rebuild", |pass| {
            self.full.encode(ctx, pass)?;
            self.fill
                .dispatch_items(ctx, pass, &self.fill_bind[set], self.n_cells)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::auto_slots;

    #[test]
    fn the_automatic_capacity_covers_twice_the_mean_and_half_again_the_fullest_cell() {
        // The LJ liquid of in.lj: 32,000 atoms in 13^3 cells, 14.6 per cell on average.
        assert_eq!(auto_slots(32_000, 2197, 20), 32);
        assert_eq!(auto_slots(32_000, 2197, 22), 40);
        assert_eq!(auto_slots(0, 1, 0), 8);
        assert_eq!(auto_slots(100, 1, 100), 200);
    }
}
