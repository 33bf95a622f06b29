//! The GPU side of the blow-up check: the finite tests on bits against Rust's, and
//! `GpuGuard` finding the first bad value and rolling back to the last good snapshot; and
//! GPU errors outside error scopes turning into `Err` instead of a panic.
#![cfg(feature = "gpu")]

use simkit_backend::gpu::{GUARD_WGSL, GpuGuard, Watch};
use simkit_backend::testing::{eval_wgsl, gpu_or_skip};
use simkit_backend::{GpuBuffer, GpuContext, Precision};

fn special_f32() -> Vec<f32> {
    vec![
        0.0,
        -0.0,
        1.0,
        f32::MAX,
        f32::MIN,
        f32::MIN_POSITIVE,
        1e-45, // subnormal
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        -f32::NAN,
        f32::from_bits(0x7f80_0001), // signalling NaN
        f32::from_bits(0xffc0_1234),
    ]
}

#[test]
fn finite_tests_on_bits_match_rust() {
    let Some(ctx) = gpu_or_skip("finite_tests_on_bits_match_rust") else {
        return;
    };
    let xs: Vec<u32> = special_f32().iter().map(|x| x.to_bits()).collect();
    let got: Vec<u32> = eval_wgsl(
        &ctx,
        &[GUARD_WGSL],
        "u32",
        "u32",
        "u32(finite_f32_bits(x))",
        &xs,
    )
    .unwrap();
    let want: Vec<u32> = special_f32()
        .iter()
        .map(|x| u32::from(x.is_finite()))
        .collect();
    assert_eq!(got, want);
    let doubles = [
        0.0f64,
        -1.0,
        f64::MAX,
        f64::MIN_POSITIVE,
        5e-324,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NAN,
        f64::from_bits(0x7ff0_0000_0000_0001),
    ];
    let highs: Vec<u32> = doubles.iter().map(|x| (x.to_bits() >> 32) as u32).collect();
    let got: Vec<u32> = eval_wgsl(
        &ctx,
        &[GUARD_WGSL],
        "u32",
        "u32",
        "u32(finite_f64_high_bits(x))",
        &highs,
    )
    .unwrap();
    let want: Vec<u32> = doubles.iter().map(|x| u32::from(x.is_finite())).collect();
    assert_eq!(got, want);
}

fn run_check(ctx: &GpuContext, guard: &GpuGuard) {
    let mut encoder = ctx.encoder("test check");
    guard.record(ctx, &mut encoder).unwrap();
    ctx.submit(encoder);
}

#[test]
fn guard_finds_the_first_bad_value_and_rolls_back() {
    let Some(ctx) = gpu_or_skip("guard_finds_the_first_bad_value_and_rolls_back") else {
        return;
    };
    let good: Vec<[f32; 4]> = (0..1000).map(|i| [i as f32, 1.0, -2.0, 0.5]).collect();
    let doubles: Vec<f64> = (0..300).map(|i| i as f64 * 0.25).collect();
    let counts: Vec<u32> = (0..77).collect();
    let pos = GpuBuffer::from_slice(&ctx, "positions", &good).unwrap();
    let energy = GpuBuffer::from_slice(&ctx, "energies", &doubles).unwrap();
    let cells = GpuBuffer::from_slice(&ctx, "cells", &counts).unwrap();
    let guard = GpuGuard::new(
        &ctx,
        &[
            Watch::checked(&pos, Precision::F32),
            Watch::checked(&energy, Precision::F64),
            Watch::copied(&cells),
        ],
    )
    .unwrap();

    // Clean state: every check passes and nothing is flagged.
    guard.begin(&ctx).unwrap();
    run_check(&ctx, &guard);
    run_check(&ctx, &guard);
    let r = guard.report(&ctx).unwrap();
    assert_eq!((r.passed, r.bad), (2, None));

    // The state turns bad between two checks: the first bad scalar is named, later checks
    // neither count nor overwrite the snapshot, and a rollback restores the last good state.
    guard.begin(&ctx).unwrap();
    run_check(&ctx, &guard);
    let mut broken = good.clone();
    broken[700][2] = f32::NAN;
    broken[900][0] = f32::INFINITY;
    pos.upload(&ctx, &broken).unwrap();
    cells.upload(&ctx, &vec![9u32; 77]).unwrap();
    run_check(&ctx, &guard);
    run_check(&ctx, &guard);
    let r = guard.report(&ctx).unwrap();
    assert_eq!(r.passed, 1);
    assert_eq!(r.bad, Some(("positions".to_string(), 700 * 4 + 2)));
    guard.rollback(&ctx).unwrap();
    assert_eq!(pos.download(&ctx).unwrap(), good);
    assert_eq!(cells.download(&ctx).unwrap(), counts);

    // f64 values are read as f64: a NaN in the second value is index 1.
    guard.begin(&ctx).unwrap();
    run_check(&ctx, &guard);
    let mut bad = doubles.clone();
    bad[1] = f64::NEG_INFINITY;
    energy.upload(&ctx, &bad).unwrap();
    run_check(&ctx, &guard);
    let r = guard.report(&ctx).unwrap();
    assert_eq!(r.bad, Some(("energies".to_string(), 1)));
    guard.rollback(&ctx).unwrap();
    assert_eq!(energy.download(&ctx).unwrap(), doubles);
}

#[test]
fn errors_outside_scopes_and_lost_devices_are_errs_naming_the_adapter() {
    if gpu_or_skip("errors_outside_scopes_and_lost_devices_are_errs_naming_the_adapter").is_none() {
        return;
    }
    // A context of its own: this test destroys its device.
    let ctx = GpuContext::new().unwrap();
    let name = ctx.adapter_info().name.clone();
    ctx.health().unwrap();
    // A buffer over the device's size limit, created outside any error scope: wgpu's
    // default handler would panic; the context keeps the error for the next call.
    let _ = ctx.device().create_buffer(&wgpu::BufferDescriptor {
        label: Some("too large"),
        size: ctx.limits().max_buffer_size.saturating_add(4),
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    });
    let e = ctx.wait().unwrap_err().to_string();
    assert!(e.contains(&name), "{e}");
    // Reported once.
    ctx.health().unwrap();
    // A lost device fails every later call.
    ctx.device().destroy();
    let buf = GpuBuffer::<u32>::zeroed(&ctx, "after loss", 4);
    let e = match buf {
        Err(e) => e.to_string(),
        Ok(b) => b.download(&ctx).unwrap_err().to_string(),
    };
    assert!(e.contains(&name), "{e}");
    let _ = ctx.device().poll(wgpu::PollType::wait_indefinitely());
    let e = ctx.health().unwrap_err().to_string();
    assert!(e.contains("lost") && e.contains(&name), "{e}");
    assert!(ctx.health().is_err(), "a lost device stays lost");
}
