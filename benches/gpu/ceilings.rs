//! The card's two ceilings, measured in the same run by small WGSL kernels of our own: the
//! memory bandwidth of a large buffer copy (bytes read plus bytes written) and the FMA rate
//! of independent register chains (one fused multiply-add = 2 flops), in f32 and, where the
//! adapter offers `SHADER_F64`, in f64.

use std::time::Instant;

use simkit::backend::gpu::{DISPATCH_WGSL, Kernel, KernelDesc, record_pass};
use simkit::backend::{GpuBuffer, GpuContext, Result};

/// `dst[i] = src[i]` over `vec4<f32>`, one element per invocation.
const COPY_WGSL: &str = "
@group(0) @binding(0) var<storage, read> src: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read_write> dst: array<vec4<f32>>;
@compute @workgroup_size(256)
fn copy(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let i = linear_workgroup(wid, nwg) * 256u + lid;
    if (i < arrayLength(&dst)) { dst[i] = src[i]; }
}
";

/// Eight independent chains of `vec4` FMAs per invocation, `ITER` rounds; the seeds come from
/// the invocation index so that nothing folds at compile time, and the sum is written out so
/// that nothing is dropped (`b < 1`: the chains stay finite).
const FMA_WGSL: &str = "
override ITER: u32 = 256u;
@group(0) @binding(0) var<storage, read_write> out: array<vec4<REAL>>;
@compute @workgroup_size(256)
fn fma_chains(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
              @builtin(local_invocation_index) lid: u32) {
    let i = linear_workgroup(wid, nwg) * 256u + lid;
    if (i >= arrayLength(&out)) { return; }
    let s = vec4<REAL>(REAL(i) * REAL(1e-9));
    let b = s * REAL(1e-3) + vec4<REAL>(REAL(0.999));
    let c = s * REAL(1e-6);
    var a0 = s; var a1 = s + c; var a2 = s + b; var a3 = s - c;
    var a4 = s * b; var a5 = s - b; var a6 = c; var a7 = b;
    for (var k = 0u; k < ITER; k = k + 1u) {
        a0 = fma(a0, b, c); a1 = fma(a1, b, c); a2 = fma(a2, b, c); a3 = fma(a3, b, c);
        a4 = fma(a4, b, c); a5 = fma(a5, b, c); a6 = fma(a6, b, c); a7 = fma(a7, b, c);
    }
    out[i] = ((a0 + a1) + (a2 + a3)) + ((a4 + a5) + (a6 + a7));
}
";

/// Rounds of [`FMA_WGSL`] per invocation.
const ITER: u32 = 1024;

/// Flops of one invocation of [`FMA_WGSL`]: `ITER` rounds of 8 chains of 4 lanes, 2 flops each.
const FLOPS_PER_ITEM: f64 = ITER as f64 * 8.0 * 4.0 * 2.0;

/// Measured ceilings of one adapter.
#[derive(Clone, Copy, Debug)]
pub struct Ceilings {
    /// Copy bandwidth, bytes read plus bytes written per second.
    pub copy_bytes_per_s: f64,
    /// f32 FMA rate, flops per second.
    pub fma_f32: f64,
    /// f64 FMA rate, flops per second (`None` without `SHADER_F64`).
    pub fma_f64: Option<f64>,
}

/// The median of `t` (not empty).
pub fn median(t: &[f64]) -> f64 {
    let mut t = t.to_vec();
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

/// Times `reps` dispatches of `kernel` over `items` items in one submission, `samples`
/// times after one warm-up; returns the seconds of each sample.
fn time_dispatches(
    ctx: &GpuContext,
    kernel: &Kernel,
    bind: &wgpu::BindGroup,
    items: u64,
    reps: u32,
    samples: usize,
) -> Result<Vec<f64>> {
    let run = |reps: u32| -> Result<f64> {
        let start = Instant::now();
        let mut encoder = ctx.encoder("ceiling");
        record_pass(&mut encoder, "ceiling", |pass| {
            for _ in 0..reps {
                kernel.dispatch_items(ctx, pass, bind, items)?;
            }
            Ok(())
        })?;
        ctx.submit(encoder);
        ctx.wait()?;
        Ok(start.elapsed().as_secs_f64())
    };
    run(1)?;
    (0..samples).map(|_| run(reps)).collect()
}

/// The copy bandwidth over two buffers of `bytes` each: `(bytes/s, samples)`.
pub fn copy_bandwidth(ctx: &GpuContext, bytes: u64, samples: usize) -> Result<(f64, Vec<f64>)> {
    let len = (bytes / 16) as usize;
    let data: Vec<[f32; 4]> = (0..len).map(|i| [i as f32; 4]).collect();
    let src = GpuBuffer::from_slice(ctx, "copy source", &data)?;
    let dst = GpuBuffer::<[f32; 4]>::zeroed(ctx, "copy destination", len)?;
    let kernel = Kernel::new(
        ctx,
        &KernelDesc {
            label: "copy ceiling",
            sources: &[DISPATCH_WGSL, COPY_WGSL],
            entry: "copy",
            workgroup_size: 256,
            constants: &[],
        },
    )?;
    let bind = kernel.bind(ctx, &[src.binding(), dst.binding()])?;
    let reps = 10;
    let t = time_dispatches(ctx, &kernel, &bind, len as u64, reps, samples)?;
    // Check that the copy happened (a fast kernel that copies nothing cannot pass).
    let back = dst.download(ctx)?;
    let step = (len / 1000).max(1);
    if (0..len).step_by(step).any(|i| back[i] != data[i]) {
        return Err(simkit::backend::Error::invalid(
            "copy ceiling",
            "destination",
            "differs from the source: the copy kernel is wrong on this adapter",
        ));
    }
    let moved = 2.0 * (len * 16) as f64 * f64::from(reps);
    Ok((moved / median(&t), t.iter().map(|s| moved / s).collect()))
}

/// The FMA rate in `precision` (`"f32"` or `"f64"`) over `items` invocations: `(flops/s,
/// samples)`.
pub fn fma_rate(
    ctx: &GpuContext,
    f64_lanes: bool,
    items: u64,
    samples: usize,
) -> Result<(f64, Vec<f64>)> {
    let source = if f64_lanes {
        "alias REAL = f64;\n"
    } else {
        "alias REAL = f32;\n"
    };
    let kernel = Kernel::new(
        ctx,
        &KernelDesc {
            label: "fma ceiling",
            sources: &[source, DISPATCH_WGSL, FMA_WGSL],
            entry: "fma_chains",
            workgroup_size: 256,
            constants: &[("ITER", f64::from(ITER))],
        },
    )?;
    let reps = 4;
    let t = if f64_lanes {
        let seed: Vec<[f64; 4]> = (0..items).map(|i| [1e-9 * i as f64; 4]).collect();
        let out = GpuBuffer::from_slice(ctx, "fma f64", &seed)?;
        let bind = kernel.bind(ctx, &[out.binding()])?;
        let t = time_dispatches(ctx, &kernel, &bind, items, reps, samples)?;
        let back = out.download(ctx)?;
        check_written(back.iter().map(|v| v[0]))?;
        t
    } else {
        let seed: Vec<[f32; 4]> = (0..items).map(|i| [1e-9 * i as f32; 4]).collect();
        let out = GpuBuffer::from_slice(ctx, "fma f32", &seed)?;
        let bind = kernel.bind(ctx, &[out.binding()])?;
        let t = time_dispatches(ctx, &kernel, &bind, items, reps, samples)?;
        let back = out.download(ctx)?;
        check_written(back.iter().map(|v| f64::from(v[0])))?;
        t
    };
    let flops = FLOPS_PER_ITEM * items as f64 * f64::from(reps);
    Ok((flops / median(&t), t.iter().map(|s| flops / s).collect()))
}

/// The FMA kernel's outputs are finite and not all equal to their seeds.
fn check_written(values: impl Iterator<Item = f64>) -> Result<()> {
    let v: Vec<f64> = values.collect();
    if v.iter().all(|x| x.is_finite()) && v.iter().skip(1).any(|&x| x != 0.0) {
        Ok(())
    } else {
        Err(simkit::backend::Error::invalid(
            "fma ceiling",
            "output",
            "not finite or never written: the FMA kernel is wrong on this adapter",
        ))
    }
}

/// One invocation bumps a counter that every dispatch reads and writes, so that the driver
/// must order the dispatches (a barrier between each two, as between the kernels of a step).
const BUMP_WGSL: &str = "
@group(0) @binding(0) var<storage, read_write> counter: array<u32>;
@compute @workgroup_size(64)
fn bump(@builtin(local_invocation_index) lid: u32) {
    if (lid == 0u) { counter[0] = counter[0] + 1u; }
}
";

/// The cost of one dependent dispatch, split into recording it on the host (wgpu's
/// validation and tracking, per dispatch) and executing it on the device (submit to done,
/// per dispatch): `count` dispatches of [`BUMP_WGSL`] in one pass, `samples` times after a
/// warm-up. Returns the samples of `(record seconds, execute seconds)` per dispatch.
pub fn dispatch_cost(ctx: &GpuContext, count: u32, samples: usize) -> Result<Vec<(f64, f64)>> {
    let counter = GpuBuffer::<u32>::zeroed(ctx, "dispatch counter", 1)?;
    let kernel = Kernel::new(
        ctx,
        &KernelDesc {
            label: "dispatch cost",
            sources: &[BUMP_WGSL],
            entry: "bump",
            workgroup_size: 64,
            constants: &[],
        },
    )?;
    let bind = kernel.bind(ctx, &[counter.binding()])?;
    let run = || -> Result<(f64, f64)> {
        let start = Instant::now();
        let mut encoder = ctx.encoder("dispatch cost");
        record_pass(&mut encoder, "dispatch cost", |pass| {
            for _ in 0..count {
                kernel.dispatch_grid(pass, &bind, 1, 1);
            }
            Ok(())
        })?;
        let recorded = start.elapsed().as_secs_f64();
        ctx.submit(encoder);
        ctx.wait()?;
        let done = start.elapsed().as_secs_f64();
        let per = f64::from(count);
        Ok((recorded / per, (done - recorded) / per))
    };
    run()?;
    let t = (0..samples).map(|_| run()).collect::<Result<Vec<_>>>()?;
    let expected = u64::from(count) * (samples as u64 + 1);
    let got = counter.download(ctx)?[0];
    if u64::from(got) != expected {
        return Err(simkit::backend::Error::invalid(
            "dispatch counter",
            got,
            format!("expected {expected}: the dispatches were not ordered on this adapter"),
        ));
    }
    Ok(t)
}
