//! GPU backend (WGSL): one byte per site packed four to a `u32`, the collision table in
//! workgroup memory, pull streaming, ping-pong buffers, a device-side step counter and many
//! steps per submission.

use backend::gpu::{DISPATCH_WGSL, Uniform};
use backend::rng::RNG_WGSL;
use backend::{GpuBuffer, GpuContext, Kernel, KernelDesc, Result, Simulation};
use bytemuck::{Pod, Zeroable};

use crate::random::{FORCE_STREAM, force_threshold};
use crate::{CollisionTable, Lattice, Params};

const STEP_WGSL: &str = include_str!("../../../shaders/lattice-gas/step.wgsl");
const COUNTER_WGSL: &str = include_str!("../../../shaders/lattice-gas/counter.wgsl");

/// Steps recorded into one command submission.
pub const STEPS_PER_SUBMIT: u32 = 64;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuParams {
    width: u32,
    height: u32,
    n_sites: u32,
    n_words: u32,
    seed: u32,
    force_seed: u32,
    threshold: u32,
    pad: u32,
}

/// The GPU backend.
pub struct GpuLattice {
    ctx: GpuContext,
    width: usize,
    height: usize,
    buffers: [GpuBuffer<u32>; 2],
    /// Bind groups stepping buffer 0 -> 1 and 1 -> 0.
    binds: [wgpu::BindGroup; 2],
    counter_bind: wgpu::BindGroup,
    step_kernel: Kernel,
    counter_kernel: Kernel,
    n_words: u64,
    current: usize,
    steps: u64,
    // Kept alive for the bind groups.
    _table: GpuBuffer<u32>,
    _params: Uniform<GpuParams>,
    _counter: GpuBuffer<u32>,
}

impl GpuLattice {
    /// Uploads `lattice` and compiles the step kernel for the boundaries of `params`.
    pub fn new(ctx: &GpuContext, lattice: Lattice, params: Params) -> Result<Self> {
        params.validate(&lattice)?;
        let (w, h) = (lattice.width(), lattice.height());
        let n_sites = w * h;
        let n_words = n_sites.div_ceil(4);
        let mut words = vec![0u32; n_words];
        for (s, &c) in lattice.cells().iter().enumerate() {
            words[s / 4] |= u32::from(c) << (8 * (s % 4));
        }
        let a = GpuBuffer::from_slice(ctx, "fhp lattice A", &words)?;
        let b = GpuBuffer::<u32>::zeroed(ctx, "fhp lattice B", n_words)?;
        let table: Vec<u32> = CollisionTable::new(params.rules)
            .entries
            .iter()
            .map(|&e| u32::from(e))
            .collect();
        let table = GpuBuffer::from_slice(ctx, "fhp collision table", &table)?;
        let gp = GpuParams {
            width: w as u32,
            height: h as u32,
            n_sites: n_sites as u32,
            n_words: n_words as u32,
            seed: params.seed,
            force_seed: params.seed ^ FORCE_STREAM,
            threshold: force_threshold(params.body_force),
            pad: 0,
        };
        let uniform = Uniform::new(ctx, "fhp params", &gp);
        let counter = GpuBuffer::from_slice(ctx, "fhp step counter", &[0u32])?;
        let step_kernel = Kernel::new(
            ctx,
            &KernelDesc {
                label: "fhp_step",
                sources: &[RNG_WGSL, DISPATCH_WGSL, STEP_WGSL],
                entry: "fhp_step",
                workgroup_size: 64,
                constants: &[("FLAGS", f64::from(params.flags()))],
            },
        )?;
        let counter_kernel = Kernel::new(
            ctx,
            &KernelDesc {
                label: "fhp_counter",
                sources: &[COUNTER_WGSL],
                entry: "advance",
                workgroup_size: 1,
                constants: &[],
            },
        )?;
        let bind = |s: &GpuBuffer<u32>, d: &GpuBuffer<u32>| {
            step_kernel.bind(
                ctx,
                &[
                    s.binding(),
                    d.binding(),
                    table.binding(),
                    uniform.binding(),
                    counter.binding(),
                ],
            )
        };
        let binds = [bind(&a, &b)?, bind(&b, &a)?];
        let counter_bind = counter_kernel.bind(ctx, &[counter.binding()])?;
        Ok(Self {
            ctx: ctx.clone(),
            width: w,
            height: h,
            buffers: [a, b],
            binds,
            counter_bind,
            step_kernel,
            counter_kernel,
            n_words: n_words as u64,
            current: 0,
            steps: 0,
            _table: table,
            _params: uniform,
            _counter: counter,
        })
    }
}

impl Simulation for GpuLattice {
    type State = Lattice;

    fn step(&mut self, steps: u32) -> Result<()> {
        let mut left = steps;
        while left > 0 {
            let batch = left.min(STEPS_PER_SUBMIT);
            let ctx = self.ctx.clone();
            let mut current = self.current;
            ctx.checked("recording FHP steps", || -> Result<()> {
                backend::gpu::run_pass(&ctx, "fhp steps", |pass| {
                    for _ in 0..batch {
                        self.step_kernel.dispatch_items(
                            &ctx,
                            pass,
                            &self.binds[current],
                            self.n_words,
                        )?;
                        self.counter_kernel
                            .dispatch_grid(pass, &self.counter_bind, 1, 1);
                        current ^= 1;
                    }
                    Ok(())
                })
            })??;
            self.current = current;
            self.steps += u64::from(batch);
            left -= batch;
        }
        Ok(())
    }

    fn state(&mut self) -> Result<Lattice> {
        let words = self.buffers[self.current].download(&self.ctx)?;
        let n = self.width * self.height;
        let cells: Vec<u8> = (0..n)
            .map(|s| (words[s / 4] >> (8 * (s % 4))) as u8)
            .collect();
        Ok(Lattice::from_raw(self.width, self.height, cells))
    }

    fn steps_done(&self) -> u64 {
        self.steps
    }

    fn backend_name(&self) -> String {
        format!("gpu ({})", self.ctx.adapter_info().name)
    }
}
