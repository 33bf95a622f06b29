//! GPU backend (wgpu, `f32`): the whole step on the device.
//!
//! Per step, recorded into one command buffer (64 steps per submission) without host round
//! trips: `md_drift` (velocity Verlet: opening half kick; drift; periodic wrap or
//! reflection), then the forces and the closing kick with one of two schemes
//! ([`crate::GpuKernel`]), both over cells at least `max r_c` wide and the full shell of
//! `3^D` neighbour cells (periodic images by the minimum image of the wrapped positions):
//!
//! - **Per particle** (default): `neighbor`'s [`GpuCellList`] is rebuilt from scratch
//!   (counting sort, ids ascending in each cell) and `md_force` runs one invocation per
//!   particle, reading the neighbour cells' positions from global memory. Particle `i` only
//!   writes its own entries, so there are no write conflicts.
//! - **Cell block** (`cell_block`): every cell has a fixed number of slots; after the drift
//!   `md_block_update` (one workgroup per cell) rebuilds each cell's slot list locally, from
//!   its own and its neighbours' previous lists (leavers dropped, arrivals picked up, ids
//!   kept ascending), and `md_block_force` (one workgroup per cell, one invocation per
//!   slot) stages each neighbour cell's positions in workgroup memory and sums every
//!   slot's pair terms from there in a fixed cell and slot order. A cell that would exceed
//!   its slots, or a particle that moved more than one cell in a step, sets a health flag
//!   that the guard checks: the run is rolled back and the call returns an error.
//!
//! Which is faster depends on the device (bandwidth saved by the staging against idle
//! slots of the cell blocks): `benches/md.rs` and `benches/gpu/` time both. The per-particle
//! kernel is the faster on lavapipe (a CPU driver) and on an NVIDIA H200 (1.5x at 32,000
//! atoms, 4x at 10^6: docs/gpu.md).
//!
//! Blow-up check: at every check step (`Config::check_every`, and at the end of a call) a
//! [`GpuGuard`] checks positions, velocities, accelerations (with the energies) and
//! virials (and the cell-block health flags) for non-finite values and snapshots them
//! while all is well; the drift kernel turns a coordinate that left the box into NaN, so
//! that case is caught too. One small download per `step(n)` call reads the outcome; after
//! a failure the snapshots are copied back (and cell-block slot lists rebuilt from scratch).

use bytemuck::{Pod, Zeroable};

use simkit_neighbor::{
    AnyGpuCellList, CELLS_WGSL, CellGrid, GpuCellBuffers, GpuCellList, OutOfBox,
};

use simkit_backend::gpu::{DISPATCH_WGSL, GpuGuard, GuardedRun, Uniform, Watch, record_pass};

mod cell_block;
use cell_block::{CellBlock, ForceInputs, HEALTH_LABEL};
use simkit_backend::guard::blow_up;
use simkit_backend::rng::RNG_WGSL;
use simkit_backend::{Error, GpuBuffer, GpuContext, Kernel, KernelDesc, Precision, Result};

use crate::config::{GpuKernel, Integrator};
use crate::diagnostics::assemble;
use crate::engine::Engine;
use crate::{Config, Diagnostics, Dim, PairLaw, State, System};
use simkit_backend::particles::Dynamics;

pub(crate) const PARAMS_WGSL: &str = simkit_backend::wgsl!("params.wgsl");
const DRIFT_WGSL: &str = simkit_backend::wgsl!("drift.wgsl");
const FORCE_WGSL: &str = simkit_backend::wgsl!("force.wgsl");
/// The Gaussian numbers of the thermostat (twin of `crate::thermostat::gaussians`).
pub(crate) const NOISE_WGSL: &str = simkit_backend::wgsl!("noise.wgsl");
const LANGEVIN_WGSL: &str = simkit_backend::wgsl!("langevin.wgsl");
const TICK_WGSL: &str = simkit_backend::wgsl!("tick.wgsl");

/// Steps recorded into one command buffer.
const STEPS_PER_SUBMIT: u32 = 64;
/// Storage buffers the force kernel binds.
const STORAGE_BUFFERS_NEEDED: u32 = 9;

/// Mirror of `MdParams` in `shaders/params.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct GpuParams {
    pub lo: [f32; 4],
    pub hi: [f32; 4],
    pub len: [f32; 4],
    pub periodic: [u32; 4],
    pub dt: f32,
    pub half_dt: f32,
    pub n: u32,
    pub n_species: u32,
    pub leapfrog: u32,
    pub dim: u32,
    pub seed: u32,
    pub _pad1: u32,
}

/// The device cell list of the system's dimension, cells one largest cutoff wide.
fn cell_list<L: PairLaw>(
    ctx: &GpuContext,
    sys: &System<L>,
    pos: &GpuBuffer<[f32; 4]>,
    n: usize,
) -> Result<AnyGpuCellList> {
    fn grid<const D: usize, L: PairLaw>(sys: &System<L>) -> Result<CellGrid<D>> {
        let (lo, len, per) = (sys.lo(), sys.lengths(), sys.periodic());
        Ok(CellGrid::new(
            std::array::from_fn(|d| lo[d]),
            std::array::from_fn(|d| len[d]),
            std::array::from_fn(|d| per[d]),
            sys.table().max_cutoff(),
        )?
        .with_out_of_box(OutOfBox::Clamp))
    }
    Ok(match sys.dim() {
        Dim::Two => AnyGpuCellList::Two(GpuCellList::with_count(ctx, &grid::<2, L>(sys)?, pos, n)?),
        Dim::Three => {
            AnyGpuCellList::Three(GpuCellList::with_count(ctx, &grid::<3, L>(sys)?, pos, n)?)
        }
    })
}

/// Buffers only the kernels touch (held so they live as long as the bind groups).
struct BoundOnly<L: PairLaw> {
    _coeff: GpuBuffer<L::Gpu>,
    _species: GpuBuffer<[f32; 4]>,
    _params: Uniform<GpuParams>,
    _tick: GpuBuffer<u32>,
}

/// The force scheme ([`GpuKernel`]).
enum Forces {
    /// The cell list sorted every step and the per-particle force kernel.
    PerParticle {
        cells: Box<AnyGpuCellList>,
        force: (Kernel, wgpu::BindGroup),
    },
    /// Slot lists updated locally and the one-workgroup-per-cell force kernel.
    CellBlock(Box<CellBlock>),
}

pub(crate) struct GpuEngine<L: PairLaw> {
    ctx: GpuContext,
    system: System<L>,
    dt: f64,
    integrator: Integrator,
    check_every: u32,
    n: usize,
    axes: usize,
    pos: GpuBuffer<[f32; 4]>,
    vel: GpuBuffer<[f32; 4]>,
    acc: GpuBuffer<[f32; 4]>,
    vir: GpuBuffer<f32>,
    drift: (Kernel, wgpu::BindGroup),
    forces: Forces,
    /// With the thermostat: the kernel advancing the device step counter.
    tick: Option<(Kernel, wgpu::BindGroup)>,
    guard: GpuGuard,
    steps: u64,
    _bound: BoundOnly<L>,
}

/// A kernel of `src` after the shared pieces and the law's WGSL `law`.
fn kernel(
    ctx: &GpuContext,
    law: &str,
    src: &[&str],
    entry: &str,
    consts: &[(&str, f64)],
) -> Result<Kernel> {
    let mut sources = vec![DISPATCH_WGSL, CELLS_WGSL, PARAMS_WGSL, law];
    sources.extend_from_slice(src);
    Kernel::new(
        ctx,
        &KernelDesc {
            label: entry,
            sources: &sources,
            entry,
            workgroup_size: 64,
            constants: consts,
        },
    )
}

impl<L: PairLaw> GpuEngine<L> {
    /// The engine for a validated system at `dt`, at its initial state or, with `saved`,
    /// at a checkpointed one.
    pub fn new(
        ctx: &GpuContext,
        system: &System<L>,
        config: &Config,
        dt: f64,
        saved: Option<&Dynamics>,
    ) -> Result<Self> {
        let have = ctx.limits().max_storage_buffers_per_shader_stage;
        if have < STORAGE_BUFFERS_NEEDED {
            return Err(Error::Unsupported(format!(
                "the md GPU force kernel binds {STORAGE_BUFFERS_NEEDED} storage buffers, this \
                 device allows {have} per stage; use the CPU backend"
            )));
        }
        let n = system.particle_count();
        let axes = system.dim().axes();
        let species = system.species();
        let to4 = |v: &[f64], w: f32| -> [f32; 4] {
            let mut o = [0.0f32, 0.0, 0.0, w];
            for d in 0..axes {
                o[d] = v[d] as f32;
            }
            o
        };
        let (lo, len) = (system.lo(), system.lengths());
        let mut params = GpuParams {
            lo: [0.0; 4],
            hi: [1.0; 4],
            len: [1.0; 4],
            periodic: [0; 4],
            dt: dt as f32,
            half_dt: (0.5 * dt) as f32,
            n: n as u32,
            n_species: system.table().n_species() as u32,
            leapfrog: u32::from(config.integrator == Integrator::Leapfrog),
            dim: axes as u32,
            seed: config.thermostat.map_or(0, |l| l.seed),
            _pad1: 0,
        };
        for d in 0..axes {
            params.lo[d] = lo[d] as f32;
            params.hi[d] = (lo[d] + len[d]) as f32;
            params.len[d] = len[d] as f32;
            params.periodic[d] = u32::from(system.periodic()[d]);
        }
        let (mut pos_h, mut vel_h, steps): (Vec<[f32; 4]>, Vec<[f32; 4]>, u64) = match saved {
            None => (
                system
                    .positions()
                    .iter()
                    .zip(species)
                    .map(|(x, &s)| to4(x, s as f32))
                    .collect(),
                system.velocities().iter().map(|v| to4(v, 0.0)).collect(),
                0,
            ),
            Some(s) => {
                // The GPU keeps the system order: no slot order, no list positions.
                s.check(n, axes, &["pos", "vel"])?;
                if !s.order.is_empty() {
                    return Err(Error::checkpoint(
                        "the stored state has a CPU slot order; resume it on the CPU",
                    ));
                }
                let p: Vec<&[f64]> = s.pos.chunks_exact(axes).collect();
                let v: Vec<&[f64]> = s.vel.chunks_exact(axes).collect();
                (
                    p.iter()
                        .zip(species)
                        .map(|(x, &k)| to4(x, k as f32))
                        .collect(),
                    v.iter().map(|x| to4(x, 0.0)).collect(),
                    s.steps,
                )
            }
        };
        // A position just below an upper periodic face may round up onto it in f32.
        for x in &mut pos_h {
            for (d, c) in x.iter_mut().enumerate().take(axes) {
                if params.periodic[d] != 0 && *c >= params.hi[d] {
                    *c = params.lo[d];
                }
            }
        }
        // Frozen particles stand still.
        for (v, &k) in vel_h.iter_mut().zip(species) {
            if system.frozen()[k as usize] {
                *v = [0.0; 4];
            }
        }
        // Buffers hold at least one element (an empty system is legal).
        let pad = |mut v: Vec<[f32; 4]>| {
            if v.is_empty() {
                v.push([0.0; 4]);
            }
            v
        };
        let pos = GpuBuffer::from_slice(ctx, "md pos", &pad(pos_h))?;
        let vel = GpuBuffer::from_slice(ctx, "md vel", &pad(vel_h))?;
        let acc = GpuBuffer::<[f32; 4]>::zeroed(ctx, "md acc", n.max(1))?;
        let vir = GpuBuffer::<f32>::zeroed(ctx, "md vir", n.max(1))?;
        // The kernels index the table by the WGSL struct's size: refuse a law whose mirror
        // differs.
        simkit_backend::testing::check_struct_size::<L::Gpu>(
            L::WGSL,
            "MdCoeff",
            &format!("pair law '{}'", L::NAME),
        )?;
        let coeff: Vec<L::Gpu> = system
            .table()
            .coefficients::<f32>(config.shift)
            .iter()
            .map(L::gpu)
            .collect();
        let coeff = GpuBuffer::from_slice(ctx, "md pair coefficients", &coeff)?;
        // Per species: 1 / mass (0 for a frozen species, whose forces are not integrated)
        // and the thermostat's (c1, amplitude).
        let ou = config
            .thermostat
            .map(|l| crate::thermostat::ou_coefficients(system, &l, dt));
        let species_info: Vec<[f32; 4]> = system
            .masses()
            .iter()
            .enumerate()
            .map(|(s, &m)| {
                let im = if system.frozen()[s] {
                    0.0
                } else {
                    (1.0 / m) as f32
                };
                let (c1, amp) = ou.as_ref().map_or((1.0, 0.0), |c| c[s]);
                [im, c1 as f32, amp as f32, 0.0]
            })
            .collect();
        let species_info = GpuBuffer::from_slice(ctx, "md species", &species_info)?;
        let uniform = Uniform::new(ctx, "md params", &params)?;
        let cells = cell_list(ctx, system, &pos, n)?;
        // The device step counter keying the thermostat's random numbers (mod 2^32).
        let tick_buf = GpuBuffer::from_slice(ctx, "md tick", &[steps as u32])?;
        let (drift, tick) = if config.thermostat.is_some() {
            let k = kernel(
                ctx,
                L::WGSL,
                &[RNG_WGSL, NOISE_WGSL, DRIFT_WGSL, LANGEVIN_WGSL],
                "md_drift_langevin",
                &[],
            )?;
            let b = k.bind(
                ctx,
                &[
                    uniform.binding(),
                    pos.binding(),
                    vel.binding(),
                    acc.binding(),
                    species_info.binding(),
                    tick_buf.binding(),
                ],
            )?;
            let t = kernel(ctx, L::WGSL, &[TICK_WGSL], "md_tick", &[])?;
            let tb = t.bind(ctx, &[tick_buf.binding()])?;
            ((k, b), Some((t, tb)))
        } else {
            let k = kernel(ctx, L::WGSL, &[DRIFT_WGSL], "md_drift", &[])?;
            let b = k.bind(
                ctx,
                &[
                    uniform.binding(),
                    pos.binding(),
                    vel.binding(),
                    acc.binding(),
                ],
            )?;
            ((k, b), None)
        };
        let kick = match config.integrator {
            Integrator::VelocityVerlet => 1.0,
            Integrator::Leapfrog => 2.0,
        };
        // Initial forces; a fresh leapfrog run also takes its half kick v(dt/2).
        let start_kick = if saved.is_none() && config.integrator == Integrator::Leapfrog {
            1.0
        } else {
            0.0
        };
        let forces = match config.gpu_kernel {
            GpuKernel::PerParticle => {
                let GpuCellBuffers {
                    grid,
                    cell_start,
                    sorted_ids,
                    sorted_pos,
                    wrapped,
                } = cells.buffers();
                let force_resources = [
                    grid.binding(),
                    uniform.binding(),
                    cell_start.binding(),
                    sorted_ids.binding(),
                    sorted_pos.binding(),
                    wrapped.binding(),
                    coeff.binding(),
                    species_info.binding(),
                    acc.binding(),
                    vel.binding(),
                    vir.binding(),
                ];
                let k = kernel(ctx, L::WGSL, &[FORCE_WGSL], "md_force", &[("KICK", kick)])?;
                let b = k.bind(ctx, &force_resources)?;
                let init = kernel(
                    ctx,
                    L::WGSL,
                    &[FORCE_WGSL],
                    "md_force",
                    &[("KICK", start_kick)],
                )?;
                let init_bind = init.bind(ctx, &force_resources)?;
                let mut encoder = ctx.encoder("md init");
                record_pass(&mut encoder, "md init forces", |pass| {
                    cells.encode(ctx, pass)?;
                    init.dispatch_items(ctx, pass, &init_bind, n as u64)
                })?;
                ctx.submit(encoder);
                cells.check(ctx)?;
                Forces::PerParticle {
                    cells: Box::new(cells),
                    force: (k, b),
                }
            }
            GpuKernel::CellBlock { slots } => {
                let inputs = ForceInputs {
                    law: L::WGSL,
                    params: &uniform,
                    pos: &pos,
                    coeff: &coeff,
                    species: &species_info,
                    acc: &acc,
                    vel: &vel,
                    vir: &vir,
                };
                Forces::CellBlock(Box::new(CellBlock::new(
                    ctx,
                    cells,
                    n,
                    slots,
                    &inputs,
                    steps,
                    [kick, start_kick],
                )?))
            }
        };
        let mut watches = vec![
            Watch::checked(&pos, Precision::F32),
            Watch::checked(&vel, Precision::F32),
            Watch::checked(&acc, Precision::F32),
            Watch::checked(&vir, Precision::F32),
        ];
        if tick.is_some() {
            // The step counter is state too: a rollback must rewind it.
            watches.push(Watch::copied(&tick_buf));
        }
        if let Forces::CellBlock(b) = &forces {
            // Last: a non-finite state is reported as such before a lost particle.
            watches.push(Watch::checked(b.health(), Precision::F32));
        }
        let guard = GpuGuard::new(ctx, &watches)?;
        let engine = Self {
            ctx: ctx.clone(),
            system: system.clone(),
            dt,
            integrator: config.integrator,
            check_every: config.check_every,
            n,
            axes,
            pos,
            vel,
            acc,
            vir,
            drift,
            forces,
            tick,
            guard,
            steps,
            _bound: BoundOnly {
                _coeff: coeff,
                _species: species_info,
                _params: uniform,
                _tick: tick_buf,
            },
        };
        // The initial state must be finite, as on the CPU.
        let a = engine.acc.download(ctx)?;
        let v = engine.synced()?;
        let bad = a[..n]
            .iter()
            .map(|x| &x[..axes])
            .chain(v.iter().map(|x| &x[..axes]))
            .position(|x| x.iter().any(|c| !c.is_finite()));
        if let Some(k) = bad {
            let (what, i) = if k < n {
                ("force", k)
            } else {
                ("velocity", k - n)
            };
            let msg = format!("particle {i}: {what} not finite");
            return Err(match saved {
                Some(_) => Error::checkpoint(format!("the stored state is not valid: {msg}")),
                None => Error::invalid(
                    "initial state",
                    msg,
                    "particles (nearly) on top of each other or dt too large; move the \
                     particles apart or lower dt",
                ),
            });
        }
        Ok(engine)
    }

    /// Records one step, from the state at step `from`, into `encoder`.
    fn record_step(&self, encoder: &mut wgpu::CommandEncoder, from: u64) -> Result<()> {
        let ctx = &self.ctx;
        let n = self.n as u64;
        record_pass(encoder, "md step", |pass| {
            self.drift.0.dispatch_items(ctx, pass, &self.drift.1, n)?;
            match &self.forces {
                Forces::PerParticle { cells, force } => {
                    cells.encode(ctx, pass)?;
                    force.0.dispatch_items(ctx, pass, &force.1, n)?;
                }
                Forces::CellBlock(b) => b.record_step(ctx, pass, from)?,
            }
            if let Some((k, b)) = &self.tick {
                k.dispatch_items(ctx, pass, b, 1)?;
            }
            Ok(())
        })
    }

    /// Velocities at the step (leapfrog: `v(t + dt/2) - a(t) dt / 2`), `[x, y, z, 0]`.
    fn synced(&self) -> Result<Vec<[f32; 4]>> {
        let mut v = self.vel.download(&self.ctx)?;
        v.truncate(self.n);
        if self.integrator == Integrator::Leapfrog {
            let a = self.acc.download(&self.ctx)?;
            let h = (0.5 * self.dt) as f32;
            for (v, a) in v.iter_mut().zip(&a) {
                for d in 0..3 {
                    v[d] -= a[d] * h;
                }
            }
        }
        Ok(v)
    }

    fn widen(&self, v: &[[f32; 4]]) -> Vec<[f64; 3]> {
        v.iter()
            .take(self.n)
            .map(|x| std::array::from_fn(|d| if d < self.axes { f64::from(x[d]) } else { 0.0 }))
            .collect()
    }
}

impl<L: PairLaw> Engine for GpuEngine<L> {
    fn step(&mut self, steps: u32) -> Result<()> {
        let ctx = &self.ctx;
        let run = self.guard.run(
            ctx,
            self.steps,
            steps,
            self.check_every,
            STEPS_PER_SUBMIT,
            |encoder, from| self.record_step(encoder, from),
            |_| Ok(()),
        )?;
        match run {
            GuardedRun::Passed { steps } => {
                self.steps = steps;
                match &self.forces {
                    // A cell over the adapter's per-cell limit means truncated force loops.
                    Forces::PerParticle { cells, .. } => cells.check(ctx),
                    Forces::CellBlock(_) => Ok(()),
                }
            }
            GuardedRun::Failed {
                good,
                bad,
                label,
                index,
            } => {
                self.guard.rollback(ctx)?;
                self.steps = good;
                if let Forces::CellBlock(b) = &self.forces {
                    b.rebuild(ctx, good)?;
                    if label == HEALTH_LABEL && index == 0 {
                        return Err(Error::invalid(
                            "GpuKernel::CellBlock slots",
                            b.slots(),
                            format!(
                                "a cell collected more than {} particles between steps {good} \
                                 and {bad} (the run is rolled back to step {good}); give more \
                                 slots (GpuKernel::CellBlock {{ slots: Some(n) }}) or use \
                                 GpuKernel::PerParticle",
                                b.slots()
                            ),
                        ));
                    }
                    if label == HEALTH_LABEL {
                        return Err(blow_up(
                            bad,
                            good,
                            "a particle moved more than one cell width (at least the largest cutoff) in \
                             one step",
                            "a time step too large for the stiffest pair (see \
                             time_step_guide) or particles started (nearly) on top of each \
                             other; lower Config::dt",
                        ));
                    }
                }
                let (what, i) = match label.as_str() {
                    "md vir" => ("virial", index),
                    "md pos" => ("position", index / 4),
                    "md vel" => ("velocity", index / 4),
                    "md acc" => ("acceleration (or energy)", index / 4),
                    other => (other, index / 4),
                };
                Err(blow_up(
                    bad,
                    good,
                    format!(
                        "particle {i}: {what} component {} is not finite (a NaN position \
                         marks a particle that moved more than a box length in one step)",
                        index % 4
                    ),
                    "a time step too large for the stiffest pair (see time_step_guide) or \
                     particles started (nearly) on top of each other; lower Config::dt",
                ))
            }
        }
    }

    fn state(&mut self) -> Result<State> {
        let pos = self.pos.download(&self.ctx)?;
        let vel = self.synced()?;
        Ok(State {
            time: self.steps as f64 * self.dt,
            positions: self.widen(&pos),
            velocities: self.widen(&vel),
            angular_velocities: Vec::new(),
            species: self.system.species().to_vec(),
        })
    }

    fn diagnostics(&mut self) -> Result<Diagnostics> {
        let ns = self.system.table().n_species();
        let masses = self.system.masses();
        let vel = self.synced()?;
        let acc = self.acc.download(&self.ctx)?;
        let vir = self.vir.download(&self.ctx)?;
        let mut kin = vec![0.0f64; ns];
        let mut count = vec![0usize; ns];
        for (v, &s) in vel.iter().zip(self.system.species()) {
            let v2: f64 = v[..self.axes].iter().map(|&x| f64::from(x).powi(2)).sum();
            kin[s as usize] += 0.5 * masses[s as usize] * v2;
            count[s as usize] += 1;
        }
        let potential = 0.5 * acc[..self.n].iter().map(|a| f64::from(a[3])).sum::<f64>();
        let virial = 0.5 * vir[..self.n].iter().map(|&w| f64::from(w)).sum::<f64>();
        Ok(assemble(
            self.steps as f64 * self.dt,
            self.axes,
            self.system.volume(),
            &kin,
            &count,
            potential,
            virial,
        ))
    }

    fn forces(&mut self) -> Result<Vec<[f64; 3]>> {
        let acc = self.acc.download(&self.ctx)?;
        let masses = self.system.masses();
        Ok(acc
            .iter()
            .zip(self.system.species())
            .map(|(a, &s)| {
                let m = masses[s as usize];
                std::array::from_fn(|d| {
                    if d < self.axes {
                        f64::from(a[d]) * m
                    } else {
                        0.0
                    }
                })
            })
            .collect())
    }

    fn name(&self) -> String {
        let kernel = match &self.forces {
            Forces::PerParticle { .. } => "per-particle".to_string(),
            Forces::CellBlock(b) => format!("cell-block, {} slots", b.slots()),
        };
        format!("gpu f32 ({}, {kernel})", self.ctx.adapter_info().name)
    }

    fn steps_done(&self) -> u64 {
        self.steps
    }

    fn model(&self) -> String {
        crate::engine::model_name::<L>(true, Precision::F32, self.axes)
    }

    fn save(&mut self) -> Result<Dynamics> {
        let flat = |v: Vec<[f32; 4]>, n: usize, axes: usize| -> Vec<f64> {
            v.iter()
                .take(n)
                .flat_map(|x| x[..axes].iter().map(|&c| f64::from(c)))
                .collect()
        };
        Ok(Dynamics {
            steps: self.steps,
            time: self.steps as f64 * self.dt,
            width: self.axes as u32,
            pos: flat(self.pos.download(&self.ctx)?, self.n, self.axes),
            vel: flat(self.vel.download(&self.ctx)?, self.n, self.axes),
            ..Dynamics::default()
        })
    }
}

#[cfg(test)]
mod tests {
    use std::mem::offset_of;

    use simkit_backend::testing::assert_mirrors;

    use super::*;

    #[test]
    fn gpu_params_mirror_md_params() {
        assert_mirrors::<GpuParams>(
            PARAMS_WGSL,
            "MdParams",
            &[
                ("lo", offset_of!(GpuParams, lo)),
                ("hi", offset_of!(GpuParams, hi)),
                ("len", offset_of!(GpuParams, len)),
                ("periodic", offset_of!(GpuParams, periodic)),
                ("dt", offset_of!(GpuParams, dt)),
                ("half_dt", offset_of!(GpuParams, half_dt)),
                ("n", offset_of!(GpuParams, n)),
                ("n_species", offset_of!(GpuParams, n_species)),
                ("leapfrog", offset_of!(GpuParams, leapfrog)),
                ("dim", offset_of!(GpuParams, dim)),
                ("seed", offset_of!(GpuParams, seed)),
                ("_pad1", offset_of!(GpuParams, _pad1)),
            ],
        );
    }
}
