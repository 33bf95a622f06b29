//! GPU backend (WGSL): tiled stencil with a one-cell halo in workgroup memory, or a plain
//! global-memory stencil, plus a ghost-cell kernel; many steps per submission.
//!
//! Each species lives in its own pair of storage buffers (ping-pong), so the largest grid is
//! set by one species plane against `max_storage_buffer_binding_size`, not by all of them.

use std::fmt::Write as _;

use simkit_backend::gpu::{DISPATCH_WGSL, GpuGuard, GuardReport, Watch};
use simkit_backend::guard::{blow_up, chunks};
use simkit_backend::{Error, GpuBuffer, GpuContext, Kernel, KernelDesc, Real, Result};

use crate::boundary::{Boundary, fill_ghosts};
use crate::config::{Config, GpuKernel, GpuOptions};
use crate::engine::Engine;
use crate::grid::{Grid, first_bad_cell, pad};
use crate::model::Model;
use crate::stepper::{
    Guard, Integrator, Stepping, check_dt, check_dt_with, check_model, checked_bound,
    divergence_cause, dt_bound, recheck_bound,
};

const COMMON_WGSL: &str = simkit_backend::wgsl!("stencil_common.wgsl");
const TILED_WGSL: &str = simkit_backend::wgsl!("stencil_tiled.wgsl");
const GLOBAL_WGSL: &str = simkit_backend::wgsl!("stencil_global.wgsl");
const GHOSTS_WGSL: &str = simkit_backend::wgsl!("ghosts.wgsl");
const DIFFUSIVITY_WGSL: &str = simkit_backend::wgsl!("diffusivity.wgsl");
/// Accessors of the params buffer (`param_dt`, `boundary_code`, `mp`, ...).
const PARAMS_WGSL: &str = simkit_backend::wgsl!("params.wgsl");
/// The boundary rule `ghost_value`, twin of [`crate::boundary::ghost_value`].
const BOUNDARY_WGSL: &str = simkit_backend::wgsl!("boundary.wgsl");
/// Species the params layout has room for (Dirichlet values per edge).
const MAX_SPECIES: usize = 4;

/// Layout of the params buffer, one array of reals bound by every kernel: the only place
/// the positions are written down. [`header_wgsl`] hands the same values to WGSL as the
/// constants `P_*` that `params.wgsl` reads.
mod params_at {
    use super::MAX_SPECIES;
    /// Time step `dt`.
    pub const DT: usize = 0;
    /// `1 / h^2`.
    pub const INV_H2: usize = 1;
    /// Boundary codes of the four edges (west, east, south, north).
    pub const BOUNDARY: usize = 2;
    /// Dirichlet values, `MAX_SPECIES` per edge, edges in the same order.
    pub const DIRICHLET: usize = BOUNDARY + 4;
    /// First model parameter ([`crate::Model::gpu_params`]).
    pub const MODEL: usize = DIRICHLET + 4 * MAX_SPECIES;
}

/// The WGSL every rd kernel starts with: `alias real = f32|f64;`, the params layout constants
/// `P_*` and the boundary codes `BC_*`, all written from the Rust definitions.
fn header_wgsl<T: Real>() -> String {
    let mut w = format!("alias real = {};\n", T::WGSL);
    for (name, at) in [
        ("P_DT", params_at::DT),
        ("P_INV_H2", params_at::INV_H2),
        ("P_BOUNDARY", params_at::BOUNDARY),
        ("P_DIRICHLET", params_at::DIRICHLET),
        ("P_MAX_SPECIES", MAX_SPECIES),
        ("P_MODEL", params_at::MODEL),
    ] {
        let _ = writeln!(w, "const {name}: u32 = {at}u;");
    }
    for (name, b) in [
        ("BC_NO_FLUX", Boundary::NoFlux),
        ("BC_PERIODIC", Boundary::Periodic),
        ("BC_DIRICHLET", Boundary::Dirichlet(Vec::new())),
    ] {
        let _ = writeln!(w, "const {name}: u32 = {}u;", b.code());
    }
    w
}

/// Reaction–diffusion on the GPU. The fields stay on the device between `step` calls;
/// `state()` downloads them.
///
/// The stability bound is checked at construction, at `set_stepping` and, for models whose
/// diffusivity depends on the fields, again before each `step` call from the current fields:
/// a reduction kernel finds the largest effective diffusivity on the device (in f32) and only
/// that one number is read back; inside a call the same reduction runs at every check (one
/// number read back per `check_every` steps) when the guard is enforced.
///
/// The finite checks run on the device ([`GpuGuard`], watching both ping-pong buffers of
/// every species), with one small download per `step` call.
pub(crate) struct GpuRd<T: Real, M: Model> {
    ctx: GpuContext,
    model: M,
    grid: Grid<T>,
    stepping: Stepping,
    options: GpuOptions,
    a: Vec<GpuBuffer<T>>,
    params: GpuBuffer<T>,
    stencil: Kernel,
    ghosts: Vec<Kernel>,
    bind_ab: wgpu::BindGroup,
    bind_ba: wgpu::BindGroup,
    bind_ba_avg: wgpu::BindGroup,
    ghosts_a: Vec<wgpu::BindGroup>,
    ghosts_b: Vec<wgpu::BindGroup>,
    stencil_avg: Kernel,
    cur_is_a: bool,
    reduce: Option<Reduce>,
    guard: GpuGuard,
    check_every: u32,
    steps: u64,
    snapshot_fresh: bool,
    // Kept alive for the bind groups.
    b: Vec<GpuBuffer<T>>,
    _coef: GpuBuffer<T>,
}

impl<T: Real, M: Model> std::fmt::Debug for GpuRd<T, M> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuRd")
            .field("model", &self.model)
            .field("nx", &self.grid.nx())
            .field("ny", &self.grid.ny())
            .field("stepping", &self.stepping)
            .field("options", &self.options)
            .finish()
    }
}

fn params_vec<T: Real, M: Model>(model: &M, grid: &Grid<T>, s: &Stepping) -> Vec<T> {
    let mut p = vec![0.0f64; params_at::MODEL];
    p[params_at::DT] = s.dt;
    p[params_at::INV_H2] = 1.0 / (grid.h() * grid.h());
    for (e, b) in grid.boundaries().edges().into_iter().enumerate() {
        p[params_at::BOUNDARY + e] = f64::from(b.code());
        if let Boundary::Dirichlet(v) = b {
            for (k, x) in v.iter().enumerate() {
                p[params_at::DIRICHLET + e * MAX_SPECIES + k] = *x;
            }
        }
    }
    p.extend(model.gpu_params());
    p.into_iter().map(T::from_f64).collect()
}

/// WGSL bindings for `ns` species and the accessors the kernel bodies use:
/// `load_global(f, idx)` and `put(s, v)`. Stencil kernels (`reduce == false`): `src<s>`,
/// `dst<s>`, then `coef`, `params`. The diffusivity reduction (`reduce == true`): `src<s>`,
/// `coef`, `params`, then the atomic `dmax`, and `put` does nothing.
fn bindings_wgsl(ns: usize, reduce: bool) -> String {
    let mut w = String::new();
    let mut at = 0;
    let mut bind = |w: &mut String, decl: String| {
        let _ = writeln!(w, "@group(0) @binding({at}) {decl};");
        at += 1;
    };
    for s in 0..ns {
        bind(&mut w, format!("var<storage, read> src{s}: array<real>"));
    }
    if !reduce {
        for s in 0..ns {
            bind(
                &mut w,
                format!("var<storage, read_write> dst{s}: array<real>"),
            );
        }
    }
    bind(&mut w, "var<storage, read> coef: array<real>".into());
    bind(&mut w, "var<storage, read> params: array<real>".into());
    if reduce {
        bind(&mut w, "var<storage, read_write> dmax: atomic<u32>".into());
    }
    w.push_str("fn load_global(f: u32, idx: u32) -> real {\n");
    for s in 0..ns {
        let _ = writeln!(w, "    if f == {s}u {{ return src{s}[idx]; }}");
    }
    w.push_str("    return coef[(f - NS) * plane() + idx];\n}\n");
    w.push_str("fn put(s: u32, v: real) {\n");
    if !reduce {
        for s in 0..ns {
            let _ = writeln!(
                w,
                "    if s == {s}u {{ if AVERAGE {{ dst{s}[cell] = real(0.5) * (dst{s}[cell] + v); }} else {{ dst{s}[cell] = v; }} }}"
            );
        }
    }
    w.push_str("}\n");
    w
}

/// The kernel that fills the ghost layer of species `s` (boundary rule `ghost_value` of
/// `boundary.wgsl`) on an `nx x ny` grid; `header` is [`header_wgsl`]. Bindings: the padded
/// species plane, then params.
fn ghost_kernel(ctx: &GpuContext, header: &str, nx: usize, ny: usize, s: usize) -> Result<Kernel> {
    Kernel::new(
        ctx,
        &KernelDesc {
            label: "rd ghosts",
            sources: &[
                header,
                DISPATCH_WGSL,
                PARAMS_WGSL,
                BOUNDARY_WGSL,
                GHOSTS_WGSL,
            ],
            entry: "main",
            workgroup_size: 64,
            constants: &[("NX", nx as f64), ("NY", ny as f64), ("S", s as f64)],
        },
    )
}

/// The on-device reduction of the model's effective diffusivity (field-dependent models).
struct Reduce {
    kernel: Kernel,
    bind_a: wgpu::BindGroup,
    bind_b: wgpu::BindGroup,
    dmax: GpuBuffer<u32>,
}

impl<T: Real, M: Model> GpuRd<T, M> {
    /// Uploads the grid and builds the kernels from a validated `config` (its stepping and
    /// GPU options). Errors: bad model/grid/dt (as on the CPU), `f64` without `SHADER_F64`, a
    /// tile over the device's workgroup limits, a grid over the buffer or dispatch limits.
    /// The run starts `steps` steps in.
    pub(crate) fn new(
        ctx: &GpuContext,
        grid: Grid<T>,
        model: M,
        config: &Config,
        steps: u64,
    ) -> Result<Self> {
        let (stepping, options) = (config.stepping, config.gpu);
        check_model(&model, &grid)?;
        check_dt(&model, &grid, &stepping)?;
        if T::WGSL == "f64" && !ctx.has_f64() {
            return Err(Error::Unsupported(format!(
                "f64 fields on the GPU need SHADER_F64, which adapter '{}' lacks; use f32 or the CPU backend",
                ctx.adapter_info().name
            )));
        }
        if model.species() > MAX_SPECIES {
            return Err(Error::invalid(
                "number of species",
                model.species(),
                format!("the GPU backend supports at most {MAX_SPECIES}"),
            ));
        }
        let (nx, ny) = (grid.nx(), grid.ny());
        let ns = model.species();
        let nf = ns + model.coefficients().len();
        let (tx, ty) = options.tile;
        let lim = ctx.limits();
        let tile_bytes =
            (u64::from(tx) + 2) * (u64::from(ty) + 2) * nf as u64 * size_of::<T>() as u64;
        if tx == 0
            || ty == 0
            || tx > lim.max_compute_workgroup_size_x
            || ty > lim.max_compute_workgroup_size_y
            || tx * ty > lim.max_compute_invocations_per_workgroup
            || tile_bytes > u64::from(lim.max_compute_workgroup_storage_size)
        {
            return Err(Error::invalid(
                "GPU tile",
                format!("{tx} x {ty}"),
                format!(
                    "needs 1..={} x 1..={} with at most {} invocations and {} bytes of workgroup memory (this tile: {tile_bytes})",
                    lim.max_compute_workgroup_size_x,
                    lim.max_compute_workgroup_size_y,
                    lim.max_compute_invocations_per_workgroup,
                    lim.max_compute_workgroup_storage_size
                ),
            ));
        }
        if 2 * ns as u32 + 2 > lim.max_storage_buffers_per_shader_stage {
            return Err(Error::Unsupported(format!(
                "{ns} species need {} storage buffers per shader stage, over this device's {}; use fewer species or the CPU backend",
                2 * ns + 2,
                lim.max_storage_buffers_per_shader_stage
            )));
        }
        let (gx, gy) = (nx.div_ceil(tx as usize), ny.div_ceil(ty as usize));
        let maxg = lim.max_compute_workgroups_per_dimension as usize;
        if gx > maxg || gy > maxg {
            return Err(Error::invalid(
                "grid size",
                format!("{nx} x {ny}"),
                format!(
                    "needs {gx} x {gy} workgroups, over the device limit {maxg}; use a larger tile or split the grid"
                ),
            ));
        }

        let plane = (nx + 2) * (ny + 2);
        let mut init = grid.padded();
        for (s, f) in init.chunks_mut(plane).enumerate() {
            fill_ghosts(f, nx, ny, s, grid.boundaries());
        }
        let coef_fields: Vec<Vec<T>> = model
            .coefficients()
            .iter()
            .map(|c| c.iter().map(|&v| T::from_f64(v)).collect())
            .collect();
        let mut coef = pad(&coef_fields, nx, ny);
        let cbc = grid.boundaries().for_coefficients();
        for f in coef.chunks_mut(plane) {
            fill_ghosts(f, nx, ny, 0, &cbc);
        }
        if coef.is_empty() {
            coef.push(T::default());
        }
        let a = init
            .chunks(plane)
            .enumerate()
            .map(|(s, f)| GpuBuffer::from_slice(ctx, &format!("rd species {s} (a)"), f))
            .collect::<Result<Vec<_>>>()?;
        let b = init
            .chunks(plane)
            .enumerate()
            .map(|(s, f)| GpuBuffer::from_slice(ctx, &format!("rd species {s} (b)"), f))
            .collect::<Result<Vec<_>>>()?;
        let coef = GpuBuffer::from_slice(ctx, "rd coefficients", &coef)?;
        let params =
            GpuBuffer::from_slice(ctx, "rd params", &params_vec(&model, &grid, &stepping))?;

        let header = header_wgsl::<T>();
        let body = match options.kernel {
            GpuKernel::Tiled => TILED_WGSL,
            GpuKernel::Global => GLOBAL_WGSL,
        };
        let bindings = bindings_wgsl(ns, false);
        let sources = [
            header.as_str(),
            bindings.as_str(),
            PARAMS_WGSL,
            COMMON_WGSL,
            model.wgsl(),
            body,
        ];
        let constants = |avg: f64| {
            [
                ("NX", nx as f64),
                ("NY", ny as f64),
                ("NS", ns as f64),
                ("NF", nf as f64),
                ("TX", f64::from(tx)),
                ("TY", f64::from(ty)),
                ("AVERAGE", avg),
            ]
        };
        let make = |label: &str, avg: f64| {
            Kernel::new(
                ctx,
                &KernelDesc {
                    label,
                    sources: &sources,
                    entry: "main",
                    workgroup_size: tx * ty,
                    constants: &constants(avg),
                },
            )
        };
        let stencil = make("rd stencil", 0.0)?;
        let stencil_avg = make("rd stencil (Heun average)", 1.0)?;
        let ghosts = (0..ns)
            .map(|s| ghost_kernel(ctx, &header, nx, ny, s))
            .collect::<Result<Vec<_>>>()?;
        let sb = |k: &Kernel, src: &[GpuBuffer<T>], dst: &[GpuBuffer<T>]| {
            let mut entries: Vec<wgpu::BindingResource<'_>> =
                src.iter().chain(dst).map(GpuBuffer::binding).collect();
            entries.push(coef.binding());
            entries.push(params.binding());
            k.bind(ctx, &entries)
        };
        let bind_ab = sb(&stencil, &a, &b)?;
        let bind_ba = sb(&stencil, &b, &a)?;
        let bind_ba_avg = sb(&stencil_avg, &b, &a)?;
        let gb = |bufs: &[GpuBuffer<T>]| {
            ghosts
                .iter()
                .zip(bufs)
                .map(|(k, buf)| k.bind(ctx, &[buf.binding(), params.binding()]))
                .collect::<Result<Vec<_>>>()
        };
        let ghosts_a = gb(&a)?;
        let ghosts_b = gb(&b)?;
        let reduce = if model.field_dependent_diffusivity() {
            let rb = bindings_wgsl(ns, true);
            let kernel = Kernel::new(
                ctx,
                &KernelDesc {
                    label: "rd max diffusivity",
                    sources: &[
                        header.as_str(),
                        rb.as_str(),
                        PARAMS_WGSL,
                        COMMON_WGSL,
                        model.wgsl(),
                        DIFFUSIVITY_WGSL,
                    ],
                    entry: "main",
                    workgroup_size: tx * ty,
                    constants: &constants(0.0),
                },
            )?;
            let dmax = GpuBuffer::<u32>::zeroed(ctx, "rd max diffusivity", 1)?;
            let rbind = |bufs: &[GpuBuffer<T>]| {
                let mut entries: Vec<wgpu::BindingResource<'_>> =
                    bufs.iter().map(GpuBuffer::binding).collect();
                entries.extend([coef.binding(), params.binding(), dmax.binding()]);
                kernel.bind(ctx, &entries)
            };
            let (bind_a, bind_b) = (rbind(&a)?, rbind(&b)?);
            Some(Reduce {
                kernel,
                bind_a,
                bind_b,
                dmax,
            })
        } else {
            None
        };
        let watches: Vec<Watch<'_>> = a
            .iter()
            .chain(&b)
            .map(|buf| Watch::checked(buf, T::PRECISION))
            .collect();
        let guard = GpuGuard::new(ctx, &watches)?;
        Ok(Self {
            ctx: ctx.clone(),
            model,
            grid,
            stepping,
            options,
            a,
            params,
            stencil,
            ghosts,
            bind_ab,
            bind_ba,
            bind_ba_avg,
            ghosts_a,
            ghosts_b,
            stencil_avg,
            cur_is_a: true,
            reduce,
            guard,
            check_every: config.check_every,
            steps,
            snapshot_fresh: true,
            b,
            _coef: coef,
        })
    }

    /// The model's largest effective diffusivity for the current fields (on the device for
    /// field-dependent models; the maximum is taken in f32).
    fn max_diffusivity(&self) -> Result<f64> {
        let Some(r) = &self.reduce else {
            return Ok(self.model.max_diffusivity(&self.grid));
        };
        r.dmax.upload(&self.ctx, &[0])?;
        let (tx, ty) = self.options.tile;
        let (gx, gy) = (
            self.grid.nx().div_ceil(tx as usize) as u32,
            self.grid.ny().div_ceil(ty as usize) as u32,
        );
        let bind = if self.cur_is_a { &r.bind_a } else { &r.bind_b };
        simkit_backend::gpu::run_pass(&self.ctx, "rd max diffusivity", |pass| {
            r.kernel.dispatch_grid(pass, bind, gx, gy);
            Ok(())
        })?;
        let bits = r.dmax.download(&self.ctx)?;
        Ok(f64::from(f32::from_bits(bits[0])))
    }

    fn record_step(&mut self, pass: &mut wgpu::ComputePass<'_>) -> Result<()> {
        let ghost_items = (2 * (self.grid.nx() + self.grid.ny())) as u64;
        let (gx, gy) = (
            self.grid.nx().div_ceil(self.options.tile.0 as usize) as u32,
            self.grid.ny().div_ceil(self.options.tile.1 as usize) as u32,
        );
        match self.stepping.integrator {
            Integrator::Euler => {
                let (bind, ghost) = if self.cur_is_a {
                    (&self.bind_ab, &self.ghosts_b)
                } else {
                    (&self.bind_ba, &self.ghosts_a)
                };
                self.stencil.dispatch_grid(pass, bind, gx, gy);
                for (k, g) in self.ghosts.iter().zip(ghost) {
                    k.dispatch_items(&self.ctx, pass, g, ghost_items)?;
                }
                self.cur_is_a = !self.cur_is_a;
            }
            Integrator::Heun => {
                // Heun keeps the state in `a`: a -> b (Euler stage), then a = (a + b + dt F(b)) / 2.
                self.stencil.dispatch_grid(pass, &self.bind_ab, gx, gy);
                for (k, g) in self.ghosts.iter().zip(&self.ghosts_b) {
                    k.dispatch_items(&self.ctx, pass, g, ghost_items)?;
                }
                self.stencil_avg
                    .dispatch_grid(pass, &self.bind_ba_avg, gx, gy);
                for (k, g) in self.ghosts.iter().zip(&self.ghosts_a) {
                    k.dispatch_items(&self.ctx, pass, g, ghost_items)?;
                }
            }
        }
        Ok(())
    }

    /// Records `n` steps into `enc`, submitting it (and starting a new one) whenever
    /// `steps_per_submit` steps are in it; `in_encoder` counts the steps already there.
    fn record_steps(
        &mut self,
        enc: &mut wgpu::CommandEncoder,
        in_encoder: &mut u32,
        n: u32,
    ) -> Result<()> {
        let mut left = n;
        while left > 0 {
            let m = left.min(self.options.steps_per_submit - *in_encoder);
            {
                let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("rd steps"),
                    timestamp_writes: None,
                });
                for _ in 0..m {
                    self.record_step(&mut pass)?;
                }
            }
            left -= m;
            *in_encoder += m;
            if *in_encoder == self.options.steps_per_submit {
                self.ctx
                    .submit(std::mem::replace(enc, self.ctx.encoder("rd steps")));
                *in_encoder = 0;
            }
        }
        Ok(())
    }

    /// After a failed finite check: puts the buffers back to the last check that passed
    /// (`report.passed` of `checks`), names the first bad cell (by running the failed stretch
    /// again from there and reading the fields, then going back again) and returns the
    /// [`Error::BlowUp`].
    fn roll_back(&mut self, report: &GuardReport, checks: &[(u64, bool)]) -> Result<()> {
        let passed = report.passed as usize;
        let Some(&(good_step, good_a)) = passed.checked_sub(1).and_then(|k| checks.get(k)) else {
            return Err(Error::Gpu(format!(
                "the blow-up check found the state at the start of the step call non-finite \
                 ({:?}); rebuild the simulation from finite fields",
                report.bad
            )));
        };
        let failed = checks.get(passed).map_or(self.steps, |c| c.0);
        self.guard.rollback(&self.ctx)?;
        self.steps = good_step;
        self.cur_is_a = good_a;
        self.snapshot_fresh = false;
        let mut enc = self.ctx.encoder("rd steps (locating the blow-up)");
        let mut in_encoder = 0;
        // At most one stretch: at most u32::MAX steps.
        self.record_steps(&mut enc, &mut in_encoder, (failed - good_step) as u32)?;
        self.ctx.submit(enc);
        let mut data = Vec::new();
        for buf in self.current() {
            data.extend(buf.download(&self.ctx)?);
        }
        self.guard.rollback(&self.ctx)?;
        self.cur_is_a = good_a;
        let (nx, ny) = (self.grid.nx(), self.grid.ny());
        let what = first_bad_cell(&data, nx, ny).unwrap_or_else(|| match &report.bad {
            Some((label, i)) => format!("buffer '{label}' at index {i} is not finite"),
            None => "a non-finite value".into(),
        });
        let bound = dt_bound(self.max_diffusivity()?, self.grid.h());
        let cause = divergence_cause(self.model.name(), &self.stepping, bound);
        Err(blow_up(failed, good_step, what, cause))
    }

    fn current(&self) -> &[GpuBuffer<T>] {
        if self.cur_is_a { &self.a } else { &self.b }
    }

    /// Makes `a` hold the state (Heun reads and writes `a` only).
    fn settle_in_a(&mut self) -> Result<()> {
        if !self.cur_is_a {
            let mut enc = self.ctx.encoder("rd copy b -> a");
            for (b, a) in self.b.iter().zip(&self.a) {
                enc.copy_buffer_to_buffer(b.raw(), 0, a.raw(), 0, a.raw().size());
            }
            self.ctx.submit(enc);
            self.cur_is_a = true;
        }
        Ok(())
    }
}

impl<T: Real, M: Model> Engine<T, M> for GpuRd<T, M> {
    fn step(&mut self, steps: u32) -> Result<()> {
        simkit_backend::guard::end_step(self.steps, steps)?;
        let field_dependent = self.model.field_dependent_diffusivity();
        if field_dependent {
            check_dt_with(
                self.model.name(),
                self.max_diffusivity()?,
                self.grid.h(),
                &self.stepping,
            )?;
        }
        if steps == 0 {
            return Ok(());
        }
        if self.stepping.integrator == Integrator::Heun {
            self.settle_in_a()?;
        }
        let recheck = field_dependent && self.stepping.guard == Guard::Enforce;
        self.guard.begin(&self.ctx)?;
        // Step and ping-pong side of every recorded check, in order (the first is the start).
        let mut checks = vec![(self.steps, self.cur_is_a)];
        let mut enc = self.ctx.encoder("rd steps");
        self.guard.record(&self.ctx, &mut enc)?;
        let mut in_encoder = 0;
        let mut stretches = chunks(self.steps, steps, self.check_every).peekable();
        while let Some(n) = stretches.next() {
            self.record_steps(&mut enc, &mut in_encoder, n)?;
            self.steps += u64::from(n);
            self.snapshot_fresh = false;
            self.guard.record(&self.ctx, &mut enc)?;
            checks.push((self.steps, self.cur_is_a));
            if recheck && stretches.peek().is_some() {
                self.ctx
                    .submit(std::mem::replace(&mut enc, self.ctx.encoder("rd steps")));
                in_encoder = 0;
                let d = self.max_diffusivity()?;
                let bound = recheck_bound(
                    self.model.name(),
                    d,
                    self.grid.h(),
                    &self.stepping,
                    self.steps,
                );
                if let Err(e) = bound {
                    // A non-finite state also gives a NaN D_max: the finite check decides.
                    let report = self.guard.report(&self.ctx)?;
                    if report.bad.is_some() {
                        return self.roll_back(&report, &checks);
                    }
                    return Err(e);
                }
            }
        }
        self.ctx.submit(enc);
        let report = self.guard.report(&self.ctx)?;
        if report.bad.is_some() {
            return self.roll_back(&report, &checks);
        }
        Ok(())
    }
    fn state(&mut self) -> Result<Grid<T>> {
        if !self.snapshot_fresh {
            let mut data = Vec::new();
            for buf in self.current() {
                data.extend(buf.download(&self.ctx)?);
            }
            self.grid.set_from_padded(&data);
            self.snapshot_fresh = true;
        }
        Ok(self.grid.clone())
    }

    fn steps_done(&self) -> u64 {
        self.steps
    }

    fn model(&self) -> &M {
        &self.model
    }

    fn stepping(&self) -> Stepping {
        self.stepping
    }

    fn set_stepping(&mut self, stepping: Stepping) -> Result<()> {
        check_dt_with(
            self.model.name(),
            self.max_diffusivity()?,
            self.grid.h(),
            &stepping,
        )?;
        self.params
            .upload(&self.ctx, &params_vec(&self.model, &self.grid, &stepping))?;
        self.stepping = stepping;
        Ok(())
    }

    /// For models whose diffusivity depends on the fields, the maximum is reduced on the
    /// device (in f32) and read back.
    fn stable_dt(&self) -> Result<f64> {
        checked_bound(self.model.name(), self.max_diffusivity()?, self.grid.h())
    }

    fn name(&self) -> String {
        let k = match self.options.kernel {
            GpuKernel::Tiled => "tiled",
            GpuKernel::Global => "global",
        };
        format!(
            "gpu {k} {}x{} ({})",
            self.options.tile.0,
            self.options.tile.1,
            self.ctx.adapter_info().name
        )
    }
}

#[cfg(test)]
mod tests {
    use simkit_backend::rng::rng_uniform;
    use simkit_backend::testing::{eval_wgsl, gpu_or_skip};

    use super::*;
    use crate::boundary::ghost_value;
    use crate::{Boundaries, GrayScott};

    /// A small grid with distinct values in every cell.
    fn grid(nx: usize, ny: usize, bc: Boundaries) -> Grid<f32> {
        let field = |seed: u32| {
            (0..nx * ny)
                .map(|k| 4.0 * rng_uniform(seed, 0, k as u32) - 1.0)
                .collect()
        };
        Grid::new(nx, ny, 0.5, bc, vec![field(1), field(2)]).unwrap()
    }

    /// Boundary sets that together put every code and distinct Dirichlet values on every edge.
    fn boundary_sets() -> Vec<Boundaries> {
        vec![
            Boundaries {
                west: Boundary::Dirichlet(vec![0.5, -1.25]),
                east: Boundary::Dirichlet(vec![2.0, 3.5]),
                south: Boundary::Periodic,
                north: Boundary::Periodic,
            },
            Boundaries {
                west: Boundary::NoFlux,
                east: Boundary::NoFlux,
                south: Boundary::Dirichlet(vec![-0.75, 1e-20]),
                north: Boundary::Dirichlet(vec![1e6, 0.0]),
            },
        ]
    }

    /// Every value the kernels read from params, through the accessors of `params.wgsl`,
    /// is the quantity `params_vec` was given: dt, 1/h^2, the boundary code and Dirichlet
    /// values of each edge, and the model parameters.
    #[test]
    fn shaders_read_params_where_params_vec_writes_them() {
        let Some(ctx) = gpu_or_skip("shaders_read_params_where_params_vec_writes_them") else {
            return;
        };
        let model = GrayScott::new(2e-5, 1e-5, 0.035, 0.065).unwrap();
        let stepping = Stepping::euler(0.125);
        let n = params_at::MODEL + 4;
        let reader = format!(
            "var<private> params: array<f32, {n}>;\n\
             fn read_all(p: array<f32, {n}>) -> array<f32, {n}> {{\n\
                 params = p;\n\
                 var o: array<f32, {n}>;\n\
                 o[0] = param_dt();\n\
                 o[1] = param_inv_h2();\n\
                 for (var e = 0u; e < 4u; e++) {{\n\
                     o[2u + e] = real(boundary_code(e));\n\
                     for (var s = 0u; s < 4u; s++) {{ o[6u + 4u * e + s] = dirichlet_value(e, s); }}\n\
                 }}\n\
                 for (var k = 0u; k < 4u; k++) {{ o[22u + k] = mp(k); }}\n\
                 return o;\n\
             }}\n"
        );
        let header = header_wgsl::<f32>();
        let ty = format!("array<f32, {n}>");
        for bc in boundary_sets() {
            let g = grid(5, 4, bc.clone());
            let p: [f32; 26] = params_vec(&model, &g, &stepping).try_into().unwrap();
            let got: Vec<[f32; 26]> = eval_wgsl(
                &ctx,
                &[&header, &reader, PARAMS_WGSL],
                &ty,
                &ty,
                "read_all(x)",
                &[p],
            )
            .unwrap();
            // The quantities in the order `read_all` lists them (its own order, not the layout).
            let mut want = vec![0.125, 4.0];
            let codes = bc.edges().map(|b| match b {
                Boundary::NoFlux => 0.0,
                Boundary::Periodic => 1.0,
                Boundary::Dirichlet(_) => 2.0,
            });
            want.extend(codes);
            for b in bc.edges() {
                let mut v = match b {
                    Boundary::Dirichlet(v) => v.clone(),
                    _ => Vec::new(),
                };
                v.resize(4, 0.0);
                want.extend(v);
            }
            want.extend([2e-5, 1e-5, 0.035, 0.035 + 0.065]);
            let want: Vec<f32> = want.into_iter().map(|v| v as f32).collect();
            assert_eq!(got[0].to_vec(), want, "{bc:?}");
        }
    }

    /// The boundary rule: WGSL `ghost_value` against Rust `ghost_value` for every boundary
    /// kind on a sample of values (0, 1, negative, tiny, large): bit for bit (one exact
    /// doubling and one rounded subtraction on both sides).
    #[test]
    fn boundary_rule_matches_rust() {
        let Some(ctx) = gpu_or_skip("boundary_rule_matches_rust") else {
            return;
        };
        let values = [0.0f32, 1.0, -2.5, 0.3, 1e-20, 3e7];
        let mut inputs = Vec::new();
        let mut want = Vec::new();
        for b in [
            Boundary::NoFlux,
            Boundary::Periodic,
            Boundary::Dirichlet(Vec::new()),
        ] {
            for g in [0.0f32, 1.0, -1.25, 1e-20, 1e6] {
                for inner in values {
                    for opposite in values {
                        let rule = match b {
                            Boundary::Dirichlet(_) => Boundary::Dirichlet(vec![f64::from(g)]),
                            _ => b.clone(),
                        };
                        inputs.push([b.code() as f32, g, inner, opposite]);
                        want.push(ghost_value(&rule, 0, inner, opposite));
                    }
                }
            }
        }
        let header = header_wgsl::<f32>();
        let got: Vec<f32> = eval_wgsl(
            &ctx,
            &[&header, BOUNDARY_WGSL],
            "vec4<f32>",
            "f32",
            "ghost_value(u32(x.x), x.y, x.z, x.w)",
            &inputs,
        )
        .unwrap();
        for ((x, g), w) in inputs.iter().zip(&got).zip(&want) {
            assert_eq!(
                g.to_bits(),
                w.to_bits(),
                "input {x:?}: GPU {g:e}, CPU {w:e}"
            );
        }
    }

    /// The ghost kernel at every boundary cell of a 7 x 5 grid (both species, every boundary
    /// set) equals `fill_ghosts` bit for bit; corners are left as they were on both sides.
    #[test]
    fn ghost_kernel_matches_fill_ghosts() {
        let Some(ctx) = gpu_or_skip("ghost_kernel_matches_fill_ghosts") else {
            return;
        };
        let (nx, ny) = (7, 5);
        let plane = (nx + 2) * (ny + 2);
        let model = GrayScott::spots();
        let header = header_wgsl::<f32>();
        for bc in boundary_sets() {
            let g = grid(nx, ny, bc.clone());
            let params = params_vec(&model, &g, &Stepping::euler(1.0));
            let params = GpuBuffer::from_slice(&ctx, "params", &params).unwrap();
            for (s, f) in g.padded().chunks(plane).enumerate() {
                // Ghosts start as garbage; both sides must overwrite every edge cell.
                let mut want: Vec<f32> = f.to_vec();
                for (k, v) in want.iter_mut().enumerate() {
                    let (i, j) = (k % (nx + 2), k / (nx + 2));
                    if i == 0 || j == 0 || i == nx + 1 || j == ny + 1 {
                        *v = -7.0 - k as f32;
                    }
                }
                let buf = GpuBuffer::from_slice(&ctx, "plane", &want).unwrap();
                fill_ghosts(&mut want, nx, ny, s, &bc);
                let kernel = ghost_kernel(&ctx, &header, nx, ny, s).unwrap();
                let bind = kernel
                    .bind(&ctx, &[buf.binding(), params.binding()])
                    .unwrap();
                simkit_backend::gpu::run_pass(&ctx, "ghosts", |pass| {
                    kernel.dispatch_items(&ctx, pass, &bind, (2 * (nx + ny)) as u64)
                })
                .unwrap();
                let got = buf.download(&ctx).unwrap();
                for (k, (a, b)) in got.iter().zip(&want).enumerate() {
                    assert_eq!(
                        a.to_bits(),
                        b.to_bits(),
                        "{bc:?}, species {s}, padded cell ({}, {}): GPU {a:e}, CPU {b:e}",
                        k % (nx + 2),
                        k / (nx + 2)
                    );
                }
            }
        }
    }
}
