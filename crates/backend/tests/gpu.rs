//! GPU tests of the backend: they run on any adapter (lavapipe in CI) and are skipped with a
//! printed reason when there is none, unless `SIMKIT_REQUIRE_GPU=1` makes that a failure.
#![cfg(feature = "gpu")]

use simkit_backend::gpu::{DISPATCH_WGSL, run_pass};
use simkit_backend::prefix::exclusive_scan;
use simkit_backend::rng::{RNG_WGSL, rng_bit, rng_u32, rng_uniform};
use simkit_backend::testing::gpu_or_skip;
use simkit_backend::{Error, GpuBuffer, GpuScan, Kernel, KernelDesc};

/// The key of item `i` in the RNG test: seeds, steps and indices all vary.
fn key(i: u32) -> (u32, u32, u32) {
    (
        (i % 7).wrapping_mul(0x9E37_79B9),
        i / 1024,
        i.wrapping_mul(2_654_435_761),
    )
}

const RNG_TEST_WGSL: &str = r#"
@group(0) @binding(0) var<storage, read_write> words: array<u32>;
@group(0) @binding(1) var<storage, read_write> uniforms: array<f32>;
@group(0) @binding(2) var<storage, read_write> bits: array<u32>;

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let i = linear_workgroup(wid, nwg) * 64u + lid;
    if (i >= arrayLength(&words)) { return; }
    let seed = (i % 7u) * 0x9E3779B9u;
    let step = i / 1024u;
    let index = i * 2654435761u;
    words[i] = rng_u32(seed, step, index);
    uniforms[i] = rng_uniform(seed, step, index);
    bits[i] = rng_bit(seed, step, index);
}
"#;

#[test]
fn rng_is_bit_identical_on_cpu_and_gpu() {
    let Some(ctx) = gpu_or_skip("rng_is_bit_identical_on_cpu_and_gpu") else {
        return;
    };
    let n = 1_000_000usize;
    let kernel = Kernel::new(
        &ctx,
        &KernelDesc {
            label: "rng test",
            sources: &[RNG_WGSL, DISPATCH_WGSL, RNG_TEST_WGSL],
            entry: "main",
            workgroup_size: 64,
            constants: &[],
        },
    )
    .unwrap();
    let words = GpuBuffer::<u32>::zeroed(&ctx, "words", n).unwrap();
    let uniforms = GpuBuffer::<f32>::zeroed(&ctx, "uniforms", n).unwrap();
    let bits = GpuBuffer::<u32>::zeroed(&ctx, "bits", n).unwrap();
    let bind = kernel
        .bind(&ctx, &[words.binding(), uniforms.binding(), bits.binding()])
        .unwrap();
    run_pass(&ctx, "rng", |pass| {
        kernel.dispatch_items(&ctx, pass, &bind, n as u64)
    })
    .unwrap();
    let (w, u, b) = (
        words.download(&ctx).unwrap(),
        uniforms.download(&ctx).unwrap(),
        bits.download(&ctx).unwrap(),
    );
    for i in 0..n as u32 {
        let (s, t, x) = key(i);
        let k = i as usize;
        assert_eq!(w[k], rng_u32(s, t, x), "word {i}");
        assert_eq!(
            u[k].to_bits(),
            rng_uniform(s, t, x).to_bits(),
            "uniform {i}"
        );
        assert_eq!(b[k], rng_bit(s, t, x), "bit {i}");
    }
}

#[test]
fn scan_matches_cpu_for_awkward_lengths() {
    let Some(ctx) = gpu_or_skip("scan_matches_cpu_for_awkward_lengths") else {
        return;
    };
    let scan = GpuScan::new(&ctx).unwrap();
    for &n in &[
        0usize, 1, 255, 256, 257, 1023, 1024, 1025, 65_535, 1_000_003,
    ] {
        // Small pseudo-random counts, as in a counting sort.
        let input: Vec<u32> = (0..n as u32).map(|i| rng_u32(9, 0, i) % 17).collect();
        let buf = GpuBuffer::from_slice(&ctx, "scan input", &input).unwrap();
        let plan = scan.scan_in_place(&ctx, &buf).unwrap();
        let got = buf.download(&ctx).unwrap();
        let mut want = input.clone();
        let total = exclusive_scan(&mut want);
        assert_eq!(got, want, "length {n}");
        match plan.total() {
            Some(t) => assert_eq!(t.download(&ctx).unwrap(), vec![total], "total, length {n}"),
            None => assert_eq!(n, 0),
        }
    }
}

const FILL_WGSL: &str = r#"
@group(0) @binding(0) var<storage, read_write> out: array<u32>;
@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let i = linear_workgroup(wid, nwg) * 64u + lid;
    if (i < arrayLength(&out)) { out[i] = i ^ 0xA5A5A5A5u; }
}
"#;

#[test]
fn dispatch_and_download_beyond_the_workgroup_grid_limit() {
    let Some(ctx) = gpu_or_skip("dispatch_and_download_beyond_the_workgroup_grid_limit") else {
        return;
    };
    // More items than one grid dimension covers: forces the 2D grid path.
    let per_dim = ctx.limits().max_compute_workgroups_per_dimension as usize;
    let n = per_dim * 64 + 12_345;
    let kernel = Kernel::new(
        &ctx,
        &KernelDesc {
            label: "fill",
            sources: &[DISPATCH_WGSL, FILL_WGSL],
            entry: "main",
            workgroup_size: 64,
            constants: &[],
        },
    )
    .unwrap();
    let buf = GpuBuffer::<u32>::zeroed(&ctx, "big", n).unwrap();
    let bind = kernel.bind(&ctx, &[buf.binding()]).unwrap();
    run_pass(&ctx, "fill", |pass| {
        kernel.dispatch_items(&ctx, pass, &bind, n as u64)
    })
    .unwrap();
    let got = buf.download(&ctx).unwrap();
    assert_eq!(got.len(), n);
    for (i, &v) in got.iter().enumerate() {
        assert_eq!(v, i as u32 ^ 0xA5A5_A5A5, "element {i}");
    }
    // Zero items: nothing recorded, nothing fails.
    run_pass(&ctx, "empty", |pass| {
        kernel.dispatch_items(&ctx, pass, &bind, 0)
    })
    .unwrap();
}

const LOOPS_WGSL: &str = r#"
@group(0) @binding(0) var<storage, read> trips: array<u32>;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;
@compute @workgroup_size(1)
fn main() {
    // Two loops one after the other, then a nested pair: the counts show how far each ran.
    var a = 0u;
    for (var m = 0u; m < trips[0]; m++) { a += 1u; }
    var b = 0u;
    for (var m = 0u; m < trips[1]; m++) { b += 1u; }
    var c = 0u;
    for (var i = 0u; i < trips[2]; i++) {
        for (var j = 0u; j < trips[3]; j++) { c += 1u; }
    }
    out[0] = a;
    out[1] = b;
    out[2] = c;
}
"#;

/// Runs the three loops of `LOOPS_WGSL` once with the given trip counts.
fn run_loops(ctx: &simkit_backend::GpuContext, trips: [u32; 4]) -> Vec<u32> {
    let kernel = Kernel::new(
        ctx,
        &KernelDesc {
            label: "loops",
            sources: &[LOOPS_WGSL],
            entry: "main",
            workgroup_size: 1,
            constants: &[],
        },
    )
    .unwrap();
    let t = GpuBuffer::from_slice(ctx, "trips", &trips).unwrap();
    let out = GpuBuffer::<u32>::zeroed(ctx, "out", 3).unwrap();
    let bind = kernel.bind(ctx, &[t.binding(), out.binding()]).unwrap();
    run_pass(ctx, "loops", |pass| {
        kernel.dispatch_workgroups(ctx, pass, &bind, 1)
    })
    .unwrap();
    out.download(ctx).unwrap()
}

#[test]
fn shader_loop_limit_is_what_the_adapter_does() {
    let Some(ctx) = gpu_or_skip("shader_loop_limit_is_what_the_adapter_does") else {
        return;
    };
    // Within any limit: every loop runs to the end.
    assert_eq!(
        run_loops(&ctx, [30_000, 30_000, 40, 100]),
        vec![30_000, 30_000, 4_000]
    );
    let long = run_loops(&ctx, [40_000, 40_000, 300, 300]);
    match ctx.shader_loop_limit() {
        None => assert_eq!(long, vec![40_000, 40_000, 90_000], "{}", ctx.summary()),
        Some(limit) => {
            // One counter for the whole invocation: the second loop gets what the first
            // left (less the exit test each loop spends), and nested loops count their
            // outer passes too. A driver that allowed more, or counted per loop, fails here.
            let limit = limit as u32;
            assert_eq!(long[0], 40_000);
            let both = long[0] + long[1];
            assert!(
                (limit - 4..=limit).contains(&both),
                "{long:?}, limit {limit}"
            );
            assert!(long[2] <= 300, "{long:?}");
            let nested = run_loops(&ctx, [0, 0, 300, 300])[2];
            assert!(
                (limit - 2 * 302..=limit).contains(&nested),
                "{nested}, limit {limit}"
            );
        }
    }
}

#[test]
fn oversize_buffer_is_refused_with_the_limit_named() {
    let Some(ctx) = gpu_or_skip("oversize_buffer_is_refused_with_the_limit_named") else {
        return;
    };
    let limit = ctx.max_storage_bytes();
    let len = (limit / 4 + 1) as usize;
    let err = GpuBuffer::<u32>::zeroed(&ctx, "too big", len).unwrap_err();
    match &err {
        Error::BufferTooLarge {
            bytes, limit: l, ..
        } => {
            assert_eq!(*bytes, len as u64 * 4);
            assert!(*bytes > *l);
        }
        other => panic!("expected BufferTooLarge, got {other:?}"),
    }
    let msg = err.to_string();
    assert!(msg.contains("too big") && msg.contains("max_"), "{msg}");
}

#[test]
fn oversize_staging_and_uniform_buffers_are_errors_not_panics() {
    // Before: Staging::new multiplied the length unchecked and both created their buffers
    // outside an error scope, so the device's refusal was wgpu's panic.
    let Some(ctx) = gpu_or_skip("oversize_staging_and_uniform_buffers_are_errors_not_panics")
    else {
        return;
    };
    for len in [usize::MAX / 2, (ctx.max_storage_bytes() / 4 + 1) as usize] {
        let err = simkit_backend::gpu::Staging::<u32>::new(&ctx, len)
            .err()
            .expect("refused");
        assert!(
            matches!(
                err,
                Error::BufferTooLarge { .. } | Error::InvalidParameter { .. }
            ),
            "{err}"
        );
    }
    // A 128 KiB value: over every adapter's uniform-binding limit we know (64 KiB).
    let value = [[7u32; 4096]; 8];
    let limit = ctx.limits().max_uniform_buffer_binding_size;
    println!("max_uniform_buffer_binding_size {limit}");
    if (limit as usize) < size_of_val(&value) {
        let err = simkit_backend::gpu::Uniform::new(&ctx, "huge params", &value)
            .err()
            .expect("refused");
        assert!(
            err.to_string().contains("max_uniform_buffer_binding_size"),
            "{err}"
        );
    }
    // A small one is fine.
    assert!(simkit_backend::gpu::Uniform::new(&ctx, "small", &[1u32; 4]).is_ok());
}

#[test]
fn shader_errors_are_errors_not_panics() {
    let Some(ctx) = gpu_or_skip("shader_errors_are_errors_not_panics") else {
        return;
    };
    let err = Kernel::new(
        &ctx,
        &KernelDesc {
            label: "broken",
            sources: &["@compute @workgroup_size(1) fn main() { let x: u32 = 1.5; }"],
            entry: "main",
            workgroup_size: 1,
            constants: &[],
        },
    )
    .unwrap_err();
    assert!(matches!(err, Error::Gpu(_)), "{err:?}");
}

#[test]
fn a_kernel_built_again_shares_the_compiled_pipeline() {
    let Some(ctx) = gpu_or_skip("a_kernel_built_again_shares_the_compiled_pipeline") else {
        return;
    };
    const SOURCE: &str = "override SCALE: f32 = 1.0;
@group(0) @binding(0) var<storage, read_write> v: array<f32>;
@compute @workgroup_size(1) fn main() { v[0] = v[0] * SCALE; }";
    let build = |scale: f64| {
        let constants = [("SCALE", scale)];
        let desc = KernelDesc {
            label: "scale",
            sources: &[SOURCE],
            entry: "main",
            workgroup_size: 1,
            constants: &constants,
        };
        Kernel::new(&ctx, &desc).unwrap()
    };
    let (first, again, other) = (build(2.0), build(2.0), build(3.0));
    assert_eq!(
        first.pipeline(),
        again.pipeline(),
        "the same kernel compiled twice"
    );
    assert_ne!(
        first.pipeline(),
        other.pipeline(),
        "another constant, the same pipeline"
    );
    // Each still runs with its own constant.
    let v = GpuBuffer::<f32>::from_slice(&ctx, "v", &[1.0]).unwrap();
    for kernel in [&first, &again, &other] {
        let bind = kernel.bind(&ctx, &[v.binding()]).unwrap();
        run_pass(&ctx, "scale", |pass| {
            kernel.dispatch_workgroups(&ctx, pass, &bind, 1)
        })
        .unwrap();
    }
    assert_eq!(v.download(&ctx).unwrap(), [12.0]);
    // A shader that fails to compile is not kept: it fails again.
    let broken = KernelDesc {
        label: "broken",
        sources: &["@compute @workgroup_size(1) fn main() { let x: u32 = 2.5; }"],
        entry: "main",
        workgroup_size: 1,
        constants: &[],
    };
    for _ in 0..2 {
        assert!(matches!(Kernel::new(&ctx, &broken), Err(Error::Gpu(_))));
    }
}

#[test]
fn empty_buffers_round_trip() {
    let Some(ctx) = gpu_or_skip("empty_buffers_round_trip") else {
        return;
    };
    let buf = GpuBuffer::<f32>::from_slice(&ctx, "empty", &[]).unwrap();
    assert!(buf.download(&ctx).unwrap().is_empty());
    let err = buf.upload(&ctx, &[1.0]).unwrap_err();
    assert!(err.to_string().contains("empty"), "{err}");
}

#[test]
fn a_wgsl_function_evaluates_like_its_rust_twin() {
    use simkit_backend::rng::{RNG_WGSL, rng_u32};
    use simkit_backend::testing::eval_wgsl;
    let Some(ctx) = gpu_or_skip("a_wgsl_function_evaluates_like_its_rust_twin") else {
        return;
    };
    // 100,000 keys: more than one row of the workgroup grid on no adapter, but over many
    // workgroups, so the harness's index arithmetic is exercised too.
    let keys: Vec<[u32; 4]> = (0..100_000u32)
        .map(|i| [i.wrapping_mul(2_654_435_761), i / 7, i, 0])
        .collect();
    let gpu: Vec<u32> = eval_wgsl(
        &ctx,
        &[RNG_WGSL],
        "vec4<u32>",
        "u32",
        "rng_u32(x.x, x.y, x.z)",
        &keys,
    )
    .unwrap();
    let cpu: Vec<u32> = keys.iter().map(|k| rng_u32(k[0], k[1], k[2])).collect();
    assert_eq!(gpu, cpu);
    let none: Vec<u32> = eval_wgsl(
        &ctx,
        &[RNG_WGSL],
        "vec4<u32>",
        "u32",
        "x.x",
        &[] as &[[u32; 4]],
    )
    .unwrap();
    assert!(none.is_empty());
}

#[test]
fn wgsl_struct_layouts_are_read_with_their_padding() {
    use simkit_backend::testing::{WgslStruct, wgsl_struct};
    let src = "struct S { a: f32, b: vec3<f32>, c: u32 }\nstruct T { x: vec2<f32>, y: f32 }";
    let s = wgsl_struct(src, "S").unwrap();
    let names = |w: &WgslStruct| {
        w.members
            .iter()
            .map(|(n, o)| (n.clone(), *o))
            .collect::<Vec<_>>()
    };
    assert_eq!(s.size, 32);
    assert_eq!(
        names(&s),
        [("a".into(), 0), ("b".into(), 16), ("c".into(), 28)]
    );
    let t = wgsl_struct(src, "T").unwrap();
    assert_eq!((t.size, t.members.len()), (16, 2));
    assert!(wgsl_struct(src, "Missing").is_err());
    assert!(wgsl_struct("struct {", "S").is_err());
}

#[test]
fn a_drifted_mirror_is_caught() {
    use simkit_backend::testing::assert_mirrors;
    #[repr(C)]
    #[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
    struct P {
        n: u32,
        dt: f32,
    }
    let wgsl = "struct P { n: u32, dt: f32 }";
    assert_mirrors::<P>(
        wgsl,
        "P",
        &[
            ("n", std::mem::offset_of!(P, n)),
            ("dt", std::mem::offset_of!(P, dt)),
        ],
    );
    // A WGSL side that gained a field (or reordered two) no longer matches.
    for drifted in [
        "struct P { n: u32, dt: f32, extra: u32 }",
        "struct P { dt: f32, n: u32 }",
    ] {
        let caught = std::panic::catch_unwind(|| {
            assert_mirrors::<P>(
                drifted,
                "P",
                &[
                    ("n", std::mem::offset_of!(P, n)),
                    ("dt", std::mem::offset_of!(P, dt)),
                ],
            );
        });
        assert!(caught.is_err(), "{drifted}");
    }
}

#[test]
fn a_wait_longer_than_the_limit_is_an_error_naming_it() {
    // Before: `wait` blocked without a limit, so a hung device hung the caller.
    let Some(ctx) = gpu_or_skip("a_wait_longer_than_the_limit_is_an_error_naming_it") else {
        return;
    };
    assert_eq!(ctx.wait_limit(), simkit_backend::gpu::DEFAULT_WAIT_LIMIT);
    let len = (ctx.max_storage_bytes().min(1 << 28) / 4) as usize;
    let a = GpuBuffer::<u32>::zeroed(&ctx, "big", len).unwrap();
    let b = GpuBuffer::<u32>::zeroed(&ctx, "copy", len).unwrap();
    let hurried = ctx
        .clone()
        .with_wait_limit(std::time::Duration::from_nanos(1));
    // Work that takes far longer than a nanosecond: 16 copies of the buffer.
    let mut encoder = ctx.encoder("copies");
    for _ in 0..16 {
        encoder.copy_buffer_to_buffer(a.raw(), 0, b.raw(), 0, (len * 4) as u64);
    }
    ctx.submit(encoder);
    let err = hurried.wait().expect_err("a nanosecond is too short");
    assert!(err.to_string().contains("did not finish"), "{err}");
    // The device is fine: the default limit waits for the work.
    ctx.wait().unwrap();
}
