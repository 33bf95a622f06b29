//! GPU backend (wgpu, `f32`): the whole velocity-Verlet step on the device.
//!
//! Per step, recorded into one command buffer (64 steps per submission) without host
//! round trips: `dem_drift` (half kick,
//! drift, periodic wrap, predicted velocity), `neighbor`'s [`GpuCellList`] build,
//! `dem_force` (one invocation per particle gathering contact forces over the full shell
//! of neighbour cells, walls, gravity, second half kick) and `dem_tick` (device step
//! counter for the wall motion). [`Engine::state`] downloads the state.

use bytemuck::{Pod, Zeroable};

use simkit_neighbor::{CELLS_WGSL, CellGrid, GPU_LOOP_RESERVE, GpuCellList, OutOfBox};

use simkit_backend::gpu::{DISPATCH_WGSL, Uniform};
use simkit_backend::{Error, GpuBuffer, GpuContext, Kernel, KernelDesc, Result};

use crate::State;
use crate::engine::Engine;
use crate::prepared::Prepared;

const PARAMS_WGSL: &str = simkit_backend::wgsl!("params.wgsl");
const DRIFT_WGSL: &str = simkit_backend::wgsl!("drift.wgsl");
const FORCE_WGSL: &str = simkit_backend::wgsl!("force.wgsl");
const TICK_WGSL: &str = simkit_backend::wgsl!("tick.wgsl");
/// The contact law (twin of [`crate::normal_force`], [`crate::friction_force`]).
const CONTACT_WGSL: &str = simkit_backend::wgsl!("contact.wgsl");
/// The wall geometry (twin of [`crate::plane_overlap`], [`crate::cylinder_overlap`],
/// [`crate::wall_motion`]).
const WALLS_WGSL: &str = simkit_backend::wgsl!("walls.wgsl");

/// Steps recorded into one command buffer.
const STEPS_PER_SUBMIT: u32 = 64;
/// Storage buffers the force kernel binds.
const STORAGE_BUFFERS_NEEDED: u32 = 10;

/// Mirror of `DemParams` in `shaders/params.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct GpuParams {
    gravity: [f32; 4],
    dt: f32,
    half_dt: f32,
    omega_dt: f32,
    amplitude: f32,
    omega: f32,
    n: u32,
    n_walls: u32,
    n_species: u32,
    vertical: u32,
    dim: u32,
    _pad0: u32,
    _pad1: u32,
}

/// Mirror of `DemWall` in `shaders/params.wgsl`: one wall record, 4 consecutive entries of
/// the force kernel's coefficient table.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct GpuWall {
    /// Unit normal and offset of a plane wall, relative to the grid origin.
    plane: [f32; 4],
    /// Axis `(x, y)` relative to the grid origin, radius, kind (1 = cylinder, 0 = plane).
    cylinder: [f32; 4],
    /// Contact coefficients `(kappa, 2b, mu_s, mu_k)`.
    coeff: [f32; 4],
    /// `(1, 0, 0, 0)` for a vibrating wall, zero otherwise.
    motion: [f32; 4],
}

/// The cell-list buffers the force kernel reads.
struct CellBuffers<'a> {
    grid: &'a Uniform<simkit_neighbor::GpuGridParams>,
    cell_start: &'a GpuBuffer<u32>,
    sorted_ids: &'a GpuBuffer<u32>,
    sorted_pos: &'a GpuBuffer<[f32; 4]>,
    wrapped: &'a GpuBuffer<[f32; 4]>,
}

enum Cells {
    Two(GpuCellList<2>),
    Three(GpuCellList<3>),
}

impl Cells {
    fn new(ctx: &GpuContext, p: &Prepared, pos: &GpuBuffer<[f32; 4]>) -> Result<Self> {
        fn grid<const D: usize>(p: &Prepared) -> Result<CellGrid<D>> {
            let lo: [f64; D] = std::array::from_fn(|d| p.lo[d]);
            let len: [f64; D] = std::array::from_fn(|d| p.len[d]);
            let per: [bool; D] = std::array::from_fn(|d| p.periodic[d]);
            Ok(CellGrid::new(lo, len, per, p.cutoff)?.with_out_of_box(OutOfBox::Clamp))
        }
        Ok(if p.axes == 2 {
            Cells::Two(GpuCellList::new(ctx, &grid::<2>(p)?, pos)?)
        } else {
            Cells::Three(GpuCellList::new(ctx, &grid::<3>(p)?, pos)?)
        })
    }

    fn encode(&self, ctx: &GpuContext, pass: &mut wgpu::ComputePass<'_>) -> Result<()> {
        match self {
            Cells::Two(c) => c.encode(ctx, pass),
            Cells::Three(c) => c.encode(ctx, pass),
        }
    }

    fn check(&self, ctx: &GpuContext) -> Result<()> {
        match self {
            Cells::Two(c) => c.check(ctx),
            Cells::Three(c) => c.check(ctx),
        }
    }

    fn buffers(&self) -> CellBuffers<'_> {
        match self {
            Cells::Two(c) => CellBuffers {
                grid: c.params(),
                cell_start: c.cell_start(),
                sorted_ids: c.sorted_ids(),
                sorted_pos: c.sorted_pos(),
                wrapped: c.wrapped(),
            },
            Cells::Three(c) => CellBuffers {
                grid: c.params(),
                cell_start: c.cell_start(),
                sorted_ids: c.sorted_ids(),
                sorted_pos: c.sorted_pos(),
                wrapped: c.wrapped(),
            },
        }
    }
}

pub(crate) struct GpuEngine {
    ctx: GpuContext,
    prep: Prepared,
    pos: GpuBuffer<[f32; 4]>,
    vel: GpuBuffer<[f32; 4]>,
    cells: Cells,
    drift: (Kernel, wgpu::BindGroup),
    force: (Kernel, wgpu::BindGroup),
    tick: (Kernel, wgpu::BindGroup),
    steps: u64,
    _bound: BoundOnly,
}

/// Buffers only the kernels touch (held so they live as long as the bind groups).
struct BoundOnly {
    _acc: GpuBuffer<[f32; 4]>,
    _vpred: GpuBuffer<[f32; 4]>,
    _species: GpuBuffer<u32>,
    _table: GpuBuffer<[f32; 4]>,
    _clock: GpuBuffer<u32>,
    _params: Uniform<GpuParams>,
}

fn kernel(
    ctx: &GpuContext,
    src: &[&str],
    entry: &str,
    wg: u32,
    consts: &[(&str, f64)],
) -> Result<Kernel> {
    let mut sources = vec![DISPATCH_WGSL, CELLS_WGSL, PARAMS_WGSL];
    sources.extend_from_slice(src);
    Kernel::new(
        ctx,
        &KernelDesc {
            label: entry,
            sources: &sources,
            entry,
            workgroup_size: wg,
            constants: consts,
        },
    )
}

/// Records one compute pass into `encoder`.
fn in_pass(
    encoder: &mut wgpu::CommandEncoder,
    label: &str,
    record: impl FnOnce(&mut wgpu::ComputePass<'_>) -> Result<()>,
) -> Result<()> {
    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some(label),
        timestamp_writes: None,
    });
    record(&mut pass)
}

impl GpuEngine {
    pub fn new(ctx: &GpuContext, prep: Prepared) -> Result<Self> {
        let have = ctx.limits().max_storage_buffers_per_shader_stage;
        if have < STORAGE_BUFFERS_NEEDED {
            return Err(Error::Unsupported(format!(
                "the dem GPU force kernel binds {STORAGE_BUFFERS_NEEDED} storage buffers, this \
                 device allows {have} per stage; use the CPU backend"
            )));
        }
        let n = prep.n;
        if n >= u32::MAX as usize / 2 {
            return Err(Error::invalid(
                "particle count",
                n,
                "too large for the GPU backend",
            ));
        }
        // The force kernel's wall loop runs beside its shell walk; the cell list leaves
        // GPU_LOOP_RESERVE iterations for such loops on adapters that end shader loops early.
        let max_walls = GPU_LOOP_RESERVE as usize / 2;
        if ctx.shader_loop_limit().is_some() && prep.walls.len() > max_walls {
            return Err(Error::Unsupported(format!(
                "{} walls on adapter '{}', which ends shader loops after {} iterations per \
                 invocation: at most {max_walls} walls fit beside the neighbour walk; use the \
                 CPU backend",
                prep.walls.len(),
                ctx.adapter_info().name,
                ctx.shader_loop_limit().unwrap_or(0)
            )));
        }
        let origin = prep.lo;
        let pos_h: Vec<[f32; 4]> = (0..n)
            .map(|i| {
                let x = prep.positions[i];
                [x[0] as f32, x[1] as f32, x[2] as f32, prep.radius[i] as f32]
            })
            .collect();
        let vel_h: Vec<[f32; 4]> = (0..n)
            .map(|i| {
                let v = prep.velocities[i];
                [v[0] as f32, v[1] as f32, v[2] as f32, prep.mass[i] as f32]
            })
            .collect();
        let pos = GpuBuffer::from_slice(ctx, "dem pos", &pos_h)?;
        let vel = GpuBuffer::from_slice(ctx, "dem vel", &vel_h)?;
        let acc = GpuBuffer::<[f32; 4]>::zeroed(ctx, "dem acc", n)?;
        let vpred = GpuBuffer::from_slice(ctx, "dem vpred", &vel_h)?;
        let species = GpuBuffer::from_slice(ctx, "dem species", &prep.species)?;
        let mut table: Vec<[f32; 4]> = prep
            .coeff
            .iter()
            .map(|c| [c.kappa as f32, c.two_b as f32, c.mu_s as f32, c.mu_k as f32])
            .collect();
        for w in &prep.walls {
            // Walls in wrapped coordinates (relative to the grid origin), as the kernel sees them.
            let n_dot_o: f64 = (0..3).map(|d| w.normal[d] * origin[d]).sum();
            let record = GpuWall {
                plane: [
                    w.normal[0] as f32,
                    w.normal[1] as f32,
                    w.normal[2] as f32,
                    (w.offset - n_dot_o) as f32,
                ],
                cylinder: [
                    (w.center[0] - origin[0]) as f32,
                    (w.center[1] - origin[1]) as f32,
                    w.radius as f32,
                    if w.cylinder { 1.0 } else { 0.0 },
                ],
                coeff: [
                    w.coeff.kappa as f32,
                    w.coeff.two_b as f32,
                    w.coeff.mu_s as f32,
                    w.coeff.mu_k as f32,
                ],
                motion: [if w.vibrating { 1.0 } else { 0.0 }, 0.0, 0.0, 0.0],
            };
            table.extend_from_slice(&bytemuck::cast::<GpuWall, [[f32; 4]; 4]>(record));
        }
        let table = GpuBuffer::from_slice(ctx, "dem table", &table)?;
        let clock = GpuBuffer::<u32>::zeroed(ctx, "dem clock", 1)?;
        let (amp, omega) = prep
            .vibration
            .map_or((0.0, 0.0), |v| (v.amplitude, v.omega));
        let mut gravity = [0.0f32; 4];
        gravity[prep.vertical] = -prep.gravity as f32;
        let pv = GpuParams {
            gravity,
            dt: prep.dt as f32,
            half_dt: (0.5 * prep.dt) as f32,
            omega_dt: (omega * prep.dt) as f32,
            amplitude: amp as f32,
            omega: omega as f32,
            n: n as u32,
            n_walls: prep.walls.len() as u32,
            n_species: prep.n_species as u32,
            vertical: prep.vertical as u32,
            dim: prep.axes as u32,
            _pad0: 0,
            _pad1: 0,
        };
        let params = Uniform::new(ctx, "dem params", &pv);
        let cells = Cells::new(ctx, &prep, &pos)?;
        let CellBuffers {
            grid,
            cell_start,
            sorted_ids,
            sorted_pos,
            wrapped,
        } = cells.buffers();
        let k = kernel(ctx, &[DRIFT_WGSL], "dem_drift", 64, &[])?;
        let b = k.bind(
            ctx,
            &[
                grid.binding(),
                params.binding(),
                pos.binding(),
                vel.binding(),
                acc.binding(),
                vpred.binding(),
            ],
        )?;
        let drift = (k, b);
        let friction = if prep.friction { 1.0 } else { 0.0 };
        let force_resources = [
            grid.binding(),
            params.binding(),
            cell_start.binding(),
            sorted_ids.binding(),
            sorted_pos.binding(),
            wrapped.binding(),
            vpred.binding(),
            species.binding(),
            table.binding(),
            acc.binding(),
            vel.binding(),
            clock.binding(),
        ];
        let k = kernel(
            ctx,
            &[CONTACT_WGSL, WALLS_WGSL, FORCE_WGSL],
            "dem_force",
            64,
            &[("FRICTION", friction), ("INIT", 0.0)],
        )?;
        let b = k.bind(ctx, &force_resources)?;
        let force = (k, b);
        let init = kernel(
            ctx,
            &[CONTACT_WGSL, WALLS_WGSL, FORCE_WGSL],
            "dem_force",
            64,
            &[("FRICTION", friction), ("INIT", 1.0)],
        )?;
        let init_bind = init.bind(ctx, &force_resources)?;
        let k = kernel(ctx, &[TICK_WGSL], "dem_tick", 1, &[])?;
        let b = k.bind(ctx, &[clock.binding()])?;
        let tick = (k, b);
        // Initial accelerations a(0) with the initial velocities.
        let mut encoder = ctx.encoder("dem init");
        in_pass(&mut encoder, "dem init forces", |pass| {
            cells.encode(ctx, pass)?;
            init.dispatch_items(ctx, pass, &init_bind, n as u64)
        })?;
        ctx.submit(encoder);
        cells.check(ctx)?;
        Ok(Self {
            ctx: ctx.clone(),
            prep,
            pos,
            vel,
            cells,
            drift,
            force,
            tick,
            steps: 0,
            _bound: BoundOnly {
                _acc: acc,
                _vpred: vpred,
                _species: species,
                _table: table,
                _clock: clock,
                _params: params,
            },
        })
    }
}

impl Engine for GpuEngine {
    fn step(&mut self, steps: u32) -> Result<()> {
        let ctx = &self.ctx;
        let n = self.prep.n as u64;
        let mut left = steps;
        while left > 0 {
            let batch = left.min(STEPS_PER_SUBMIT);
            let mut encoder = ctx.encoder("dem steps");
            for _ in 0..batch {
                in_pass(&mut encoder, "dem step", |pass| {
                    self.drift.0.dispatch_items(ctx, pass, &self.drift.1, n)?;
                    self.cells.encode(ctx, pass)?;
                    self.force.0.dispatch_items(ctx, pass, &self.force.1, n)?;
                    self.tick.0.dispatch_workgroups(ctx, pass, &self.tick.1, 1)
                })?;
            }
            ctx.submit(encoder);
            left -= batch;
            self.steps += u64::from(batch);
        }
        Ok(())
    }

    fn state(&mut self) -> Result<State> {
        self.cells.check(&self.ctx)?;
        let pos = self.pos.download(&self.ctx)?;
        let vel = self.vel.download(&self.ctx)?;
        let axes = self.prep.axes;
        let c = |a: &[f32; 4]| -> [f64; 3] {
            let mut o = [0.0; 3];
            for d in 0..axes {
                o[d] = f64::from(a[d]);
            }
            o
        };
        Ok(State {
            time: self.steps as f64 * self.prep.dt,
            positions: pos.iter().map(c).collect(),
            velocities: vel.iter().map(c).collect(),
        })
    }

    fn prepared(&self) -> &Prepared {
        &self.prep
    }

    fn name(&self) -> String {
        format!("gpu f32 ({})", self.ctx.adapter_info().name)
    }
}

#[cfg(test)]
mod tests {
    use std::mem::offset_of;

    use simkit_backend::testing::assert_mirrors;

    use super::*;

    #[test]
    fn gpu_params_mirror_dem_params() {
        assert_mirrors::<GpuParams>(
            PARAMS_WGSL,
            "DemParams",
            &[
                ("gravity", offset_of!(GpuParams, gravity)),
                ("dt", offset_of!(GpuParams, dt)),
                ("half_dt", offset_of!(GpuParams, half_dt)),
                ("omega_dt", offset_of!(GpuParams, omega_dt)),
                ("amplitude", offset_of!(GpuParams, amplitude)),
                ("omega", offset_of!(GpuParams, omega)),
                ("n", offset_of!(GpuParams, n)),
                ("n_walls", offset_of!(GpuParams, n_walls)),
                ("n_species", offset_of!(GpuParams, n_species)),
                ("vertical", offset_of!(GpuParams, vertical)),
                ("dim", offset_of!(GpuParams, dim)),
                ("_pad0", offset_of!(GpuParams, _pad0)),
                ("_pad1", offset_of!(GpuParams, _pad1)),
            ],
        );
    }

    #[test]
    fn gpu_wall_mirrors_dem_wall() {
        assert_mirrors::<GpuWall>(
            PARAMS_WGSL,
            "DemWall",
            &[
                ("plane", offset_of!(GpuWall, plane)),
                ("cylinder", offset_of!(GpuWall, cylinder)),
                ("coeff", offset_of!(GpuWall, coeff)),
                ("motion", offset_of!(GpuWall, motion)),
            ],
        );
        // The kernel reads a record as 4 consecutive table entries.
        assert_eq!(
            std::mem::size_of::<GpuWall>(),
            4 * std::mem::size_of::<[f32; 4]>()
        );
    }
}
