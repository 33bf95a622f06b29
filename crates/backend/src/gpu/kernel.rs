//! Compute kernels: WGSL modules, pipelines, bind groups and dispatch of any number of items.

use super::GpuContext;
use super::context::Pipeline;
use crate::{Error, Result};

/// WGSL helper shared by kernels dispatched with [`Kernel::dispatch_items`]:
/// `linear_workgroup(wid, nwg)` turns the 2D workgroup grid back into a linear index.
pub const DISPATCH_WGSL: &str = crate::wgsl!("dispatch.wgsl");

/// Everything needed to build a [`Kernel`].
#[derive(Clone, Debug)]
pub struct KernelDesc<'a> {
    /// Label for debugging and error messages.
    pub label: &'a str,
    /// WGSL sources, concatenated in order (e.g. `[RNG_WGSL, DISPATCH_WGSL, my_shader]`).
    pub sources: &'a [&'a str],
    /// Entry point name.
    pub entry: &'a str,
    /// Invocations per workgroup (the product of the shader's `@workgroup_size`), used to size
    /// item dispatches.
    pub workgroup_size: u32,
    /// Values for the shader's `override` constants (e.g. a tile size).
    pub constants: &'a [(&'a str, f64)],
}

/// A compute pipeline with its bind-group layout (group 0, derived from the shader).
pub struct Kernel {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    workgroup_size: u32,
    label: String,
}

impl std::fmt::Debug for Kernel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Kernel")
            .field("label", &self.label)
            .finish()
    }
}

/// Workgroup grid `(x, y)` covering `workgroups` workgroups within the per-dimension limit.
///
/// Kernels recover the linear workgroup index with `linear_workgroup` from
/// [`DISPATCH_WGSL`] and must ignore workgroups past the end (the grid may be rounded up).
pub fn workgroup_grid(ctx: &GpuContext, workgroups: u64) -> Result<(u32, u32)> {
    let max = u64::from(ctx.limits().max_compute_workgroups_per_dimension);
    if workgroups <= max {
        return Ok((workgroups as u32, 1));
    }
    let y = workgroups.div_ceil(max);
    if y > max {
        return Err(Error::invalid(
            "dispatch size",
            format!("{workgroups} workgroups"),
            format!("over the device's {max} x {max} workgroup grid; split the work"),
        ));
    }
    Ok((max as u32, y as u32))
}

impl Kernel {
    /// Compiles the WGSL and creates the pipeline; shader errors become [`Error::Gpu`]. A
    /// kernel of the same sources, entry point and constants built before on this device
    /// (through any clone of `ctx`) shares the pipeline compiled then.
    pub fn new(ctx: &GpuContext, desc: &KernelDesc<'_>) -> Result<Self> {
        if desc.workgroup_size == 0 {
            return Err(Error::invalid("workgroup_size", 0, "must be >= 1"));
        }
        let (pipeline, layout) = ctx.pipeline(
            desc.sources.join("\n"),
            desc.entry,
            desc.constants,
            |source| compile(ctx, desc, source),
        )?;
        Ok(Self {
            pipeline,
            layout,
            workgroup_size: desc.workgroup_size,
            label: desc.label.into(),
        })
    }

    /// A bind group for group 0 with `resources` at bindings 0, 1, 2, ...
    pub fn bind(
        &self,
        ctx: &GpuContext,
        resources: &[wgpu::BindingResource<'_>],
    ) -> Result<wgpu::BindGroup> {
        let entries: Vec<wgpu::BindGroupEntry<'_>> = resources
            .iter()
            .enumerate()
            .map(|(i, r)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: r.clone(),
            })
            .collect();
        ctx.checked(
            &format!("binding resources of kernel '{}'", self.label),
            || {
                ctx.device().create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some(&self.label),
                    layout: &self.layout,
                    entries: &entries,
                })
            },
        )
    }

    /// Records a dispatch covering `items` invocations (one per item, rounded up to whole
    /// workgroups, spread over a 2D grid when needed). `items == 0` records nothing.
    pub fn dispatch_items(
        &self,
        ctx: &GpuContext,
        pass: &mut wgpu::ComputePass<'_>,
        bind: &wgpu::BindGroup,
        items: u64,
    ) -> Result<()> {
        if items > u64::from(u32::MAX) {
            return Err(Error::invalid(
                format!("item count of kernel '{}'", self.label),
                items,
                "must fit in u32; split the work",
            ));
        }
        let groups = items.div_ceil(u64::from(self.workgroup_size));
        self.dispatch_workgroups(ctx, pass, bind, groups)
    }

    /// Records a dispatch of `workgroups` workgroups (spread over a 2D grid when needed).
    pub fn dispatch_workgroups(
        &self,
        ctx: &GpuContext,
        pass: &mut wgpu::ComputePass<'_>,
        bind: &wgpu::BindGroup,
        workgroups: u64,
    ) -> Result<()> {
        if workgroups == 0 {
            return Ok(());
        }
        let (x, y) = workgroup_grid(ctx, workgroups)?;
        self.dispatch_grid(pass, bind, x, y);
        Ok(())
    }

    /// Records a dispatch of an explicit `x` by `y` workgroup grid (e.g. 2D tiles).
    pub fn dispatch_grid(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        bind: &wgpu::BindGroup,
        x: u32,
        y: u32,
    ) {
        if x == 0 || y == 0 {
            return;
        }
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, bind, &[]);
        pass.dispatch_workgroups(x, y, 1);
    }

    /// The compiled pipeline (shared by every kernel of the same sources, entry point and
    /// constants on this device), for recording it in passes of your own.
    pub fn pipeline(&self) -> &wgpu::ComputePipeline {
        &self.pipeline
    }

    /// Invocations per workgroup.
    pub fn workgroup_size(&self) -> u32 {
        self.workgroup_size
    }
}

/// Compiles `source` (the joined sources of `desc`) into a pipeline and its group-0 layout;
/// shader errors become [`Error::Gpu`].
fn compile(ctx: &GpuContext, desc: &KernelDesc<'_>, source: &str) -> Result<Pipeline> {
    ctx.checked(&format!("compiling kernel '{}'", desc.label), || {
        let module = ctx
            .device()
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(desc.label),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
        let pipeline = ctx
            .device()
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(desc.label),
                layout: None,
                module: &module,
                entry_point: Some(desc.entry),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants: desc.constants,
                    ..Default::default()
                },
                cache: None,
            });
        let layout = pipeline.get_bind_group_layout(0);
        (pipeline, layout)
    })
}

/// Runs `record` inside one compute pass recorded into `encoder` (not submitted: several
/// passes and copies can share one submission).
pub fn record_pass(
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

/// Runs `record` inside one compute pass of a fresh encoder and submits it.
pub fn run_pass(
    ctx: &GpuContext,
    label: &str,
    record: impl FnOnce(&mut wgpu::ComputePass<'_>) -> Result<()>,
) -> Result<()> {
    let mut encoder = ctx.encoder(label);
    record_pass(&mut encoder, label, record)?;
    ctx.submit(encoder);
    Ok(())
}
