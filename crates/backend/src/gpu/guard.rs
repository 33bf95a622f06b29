//! [`GpuGuard`]: the blow-up check of the GPU backends, on the device (see
//! [`crate::guard`]).
//!
//! A backend lists its state buffers once ([`Watch::checked`] for floating-point state whose
//! every value must stay finite, [`Watch::copied`] for the rest of the state, e.g. integer
//! counters or ping-pong partners). Each [`GpuGuard::record`] appends to a command encoder a
//! check of the checked buffers and, while every check so far has passed, a copy of all
//! watched buffers into snapshots. Checks therefore cost no host round trip; the host reads
//! the outcome once per `step(n)` call ([`GpuGuard::report`]) and, after a failed check,
//! copies the snapshots back ([`GpuGuard::rollback`]): the live buffers then hold the last
//! state that passed.

use bytemuck::{Pod, Zeroable};

use super::{DISPATCH_WGSL, GpuBuffer, GpuContext, Kernel, KernelDesc, Uniform};
use crate::{Error, Precision, Result};

/// The WGSL pieces the guard kernels share: `GuardParams` and the finite tests on bits
/// (`finite_f32_bits`, `finite_f64_high_bits`), the twins of `f32::is_finite` and
/// `f64::is_finite`.
pub const GUARD_WGSL: &str = crate::wgsl!("guard.wgsl");
const CHECK_WGSL: &str = crate::wgsl!("guard_check.wgsl");
const KEEP_WGSL: &str = crate::wgsl!("guard_keep.wgsl");
const COUNT_WGSL: &str = crate::wgsl!("guard_count.wgsl");
const WORKGROUP: u32 = 256;
/// `flags[2 + b]` when watched buffer `b` has no bad value.
const NONE: u32 = u32::MAX;

/// Mirror of `GuardParams` in `shaders/guard.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct GuardParams {
    id: u32,
    words: u32,
    count: u32,
    pad: u32,
}

/// One state buffer a [`GpuGuard`] watches.
#[derive(Clone, Debug)]
pub struct Watch<'a> {
    buffer: &'a wgpu::Buffer,
    label: &'a str,
    bytes: u64,
    check: Option<Precision>,
}

impl<'a> Watch<'a> {
    /// A buffer whose every scalar, read as `precision` (e.g. a `GpuBuffer<[f32; 4]>` as
    /// [`Precision::F32`]), must stay finite; it is also snapshotted.
    pub fn checked<T: Pod>(buffer: &'a GpuBuffer<T>, precision: Precision) -> Self {
        Self {
            buffer: buffer.raw(),
            label: buffer.label(),
            bytes: (buffer.len() * size_of::<T>()) as u64,
            check: Some(precision),
        }
    }

    /// A buffer that is part of the state but not checked (integers, flags); it is
    /// snapshotted and restored with the checked ones.
    pub fn copied<T: Pod>(buffer: &'a GpuBuffer<T>) -> Self {
        Self {
            buffer: buffer.raw(),
            label: buffer.label(),
            bytes: (buffer.len() * size_of::<T>()) as u64,
            check: None,
        }
    }
}

struct Watched {
    live: wgpu::Buffer,
    snapshot: GpuBuffer<u32>,
    label: String,
    check: Option<(wgpu::BindGroup, u32)>,
    keep: wgpu::BindGroup,
    words: u32,
    _params: [Uniform<GuardParams>; 2],
}

/// What one `step(n)` call's checks found (see [`GpuGuard::report`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GuardReport {
    /// Checks recorded since [`GpuGuard::begin`] that passed (the first, recorded before any
    /// step, is the starting state).
    pub passed: u32,
    /// The first bad value, when a check failed: the watched buffer's label and the index
    /// of the value (in scalars of the watched precision).
    pub bad: Option<(String, u32)>,
}

/// The outcome of [`GpuGuard::run`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum GuardedRun {
    /// Every check passed: the run is at step `steps`.
    Passed {
        /// Steps done after the call.
        steps: u64,
    },
    /// A check failed. The live buffers still hold the state where it failed (read what
    /// the message needs), then call [`GpuGuard::rollback`] to go back to step `good`.
    Failed {
        /// The step of the last check that passed.
        good: u64,
        /// The step of the check that failed.
        bad: u64,
        /// The watched buffer with the first bad value.
        label: String,
        /// The index of the value (in scalars of the watched precision).
        index: u32,
    },
}

/// Device-side finite checks with snapshots of the last state that passed.
pub struct GpuGuard {
    check: Kernel,
    keep: Kernel,
    count: Kernel,
    count_bind: wgpu::BindGroup,
    flags: GpuBuffer<u32>,
    watched: Vec<Watched>,
}

impl std::fmt::Debug for GpuGuard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuGuard")
            .field(
                "watched",
                &self.watched.iter().map(|w| &w.label).collect::<Vec<_>>(),
            )
            .finish()
    }
}

fn to_u32(what: &str, label: &str, n: u64) -> Result<u32> {
    u32::try_from(n).map_err(|_| {
        Error::invalid(
            format!("{what} of watched buffer '{label}'"),
            n,
            "over 2^32 - 1; the guard checks at most 2^32 - 1 values per buffer",
        )
    })
}

impl GpuGuard {
    /// Builds the kernels and one snapshot per watched buffer (as large as the buffer).
    pub fn new(ctx: &GpuContext, watches: &[Watch<'_>]) -> Result<Self> {
        let kernel = |label: &str, source: &'static str, entry: &str, wg: u32| {
            Kernel::new(
                ctx,
                &KernelDesc {
                    label,
                    sources: &[DISPATCH_WGSL, GUARD_WGSL, source],
                    entry,
                    workgroup_size: wg,
                    constants: &[],
                },
            )
        };
        let check = kernel("guard check", CHECK_WGSL, "check", WORKGROUP)?;
        let keep = kernel("guard keep", KEEP_WGSL, "keep", WORKGROUP)?;
        let count = kernel("guard count", COUNT_WGSL, "count", 1)?;
        let flags = GpuBuffer::<u32>::zeroed(ctx, "guard flags", 2 + watches.len())?;
        let count_bind = count.bind(ctx, &[flags.binding()])?;
        let mut watched = Vec::with_capacity(watches.len());
        for (id, w) in watches.iter().enumerate() {
            let words = to_u32("size in words", w.label, w.bytes.div_ceil(4))?;
            let snapshot = GpuBuffer::<u32>::zeroed(
                ctx,
                &format!("guard snapshot of {}", w.label),
                words as usize,
            )?;
            let keep_params = Uniform::new(
                ctx,
                "guard keep params",
                &GuardParams {
                    id: id as u32,
                    words: 1,
                    count: words,
                    pad: 0,
                },
            )?;
            let keep_bind = keep.bind(
                ctx,
                &[
                    w.buffer.as_entire_binding(),
                    snapshot.binding(),
                    flags.binding(),
                    keep_params.binding(),
                ],
            )?;
            let per_value = match w.check {
                Some(Precision::F64) => 2,
                _ => 1,
            };
            let values = to_u32("value count", w.label, w.bytes / (4 * u64::from(per_value)))?;
            let check_params = Uniform::new(
                ctx,
                "guard check params",
                &GuardParams {
                    id: id as u32,
                    words: per_value,
                    count: values,
                    pad: 0,
                },
            )?;
            let check_bind = match w.check {
                Some(_) if values > 0 => Some((
                    check.bind(
                        ctx,
                        &[
                            w.buffer.as_entire_binding(),
                            flags.binding(),
                            check_params.binding(),
                        ],
                    )?,
                    values,
                )),
                _ => None,
            };
            watched.push(Watched {
                live: w.buffer.clone(),
                snapshot,
                label: w.label.to_string(),
                check: check_bind,
                keep: keep_bind,
                words,
                _params: [keep_params, check_params],
            });
        }
        Ok(Self {
            check,
            keep,
            count,
            count_bind,
            flags,
            watched,
        })
    }

    /// Clears the outcome for a new `step(n)` call; record a check of the starting state
    /// next, so that there is a snapshot to go back to.
    pub fn begin(&self, ctx: &GpuContext) -> Result<()> {
        let mut init = vec![NONE; self.flags.len()];
        init[0] = 0;
        init[1] = 0;
        self.flags.upload(ctx, &init)
    }

    /// Records, in one compute pass on `encoder`, a check of every checked buffer and, if no
    /// check has failed since [`GpuGuard::begin`], a snapshot of every watched buffer.
    pub fn record(&self, ctx: &GpuContext, encoder: &mut wgpu::CommandEncoder) -> Result<()> {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("guard"),
            timestamp_writes: None,
        });
        for w in &self.watched {
            if let Some((bind, values)) = &w.check {
                self.check
                    .dispatch_items(ctx, &mut pass, bind, u64::from(*values))?;
            }
        }
        for w in &self.watched {
            self.keep
                .dispatch_items(ctx, &mut pass, &w.keep, u64::from(w.words))?;
        }
        self.count.dispatch_grid(&mut pass, &self.count_bind, 1, 1);
        Ok(())
    }

    /// Waits for the recorded work and reads what the checks found (one small download).
    pub fn report(&self, ctx: &GpuContext) -> Result<GuardReport> {
        let flags = self.flags.download(ctx)?;
        let bad = (flags[1] != 0)
            .then(|| {
                self.watched
                    .iter()
                    .zip(&flags[2..])
                    .find(|(_, i)| **i != NONE)
                    .map(|(w, i)| (w.label.clone(), *i))
            })
            .flatten();
        Ok(GuardReport {
            passed: flags[0],
            bad,
        })
    }

    /// The stepping loop of a GPU backend: records the `steps` steps that follow step
    /// `done` in the stretches of [`crate::guard::chunks`] (ending on multiples of `every`
    /// and at the end of the call) without a host round trip, and reads the outcome once.
    ///
    /// `record_step(encoder, step)` records the step that starts at step `step`;
    /// `after_stretch(encoder)` records what the backend checks beyond the finite values
    /// (e.g. a kernel that writes a watched health buffer), before the guard's own check
    /// and snapshot of each stretch. A command buffer is submitted every `per_submit`
    /// steps. On [`GuardedRun::Failed`] the caller explains the failure from the live
    /// buffers and calls [`GpuGuard::rollback`].
    ///
    /// A failed check of the starting state (nothing stepped) is `Failed` with `good = bad =
    /// done`; the snapshots then hold the last state that passed in an earlier call.
    ///
    /// Errors: a step count that would overflow, and any GPU failure.
    #[allow(clippy::too_many_arguments)]
    pub fn run(
        &self,
        ctx: &GpuContext,
        done: u64,
        steps: u32,
        every: u32,
        per_submit: u32,
        mut record_step: impl FnMut(&mut wgpu::CommandEncoder, u64) -> Result<()>,
        mut after_stretch: impl FnMut(&mut wgpu::CommandEncoder) -> Result<()>,
    ) -> Result<GuardedRun> {
        crate::guard::end_step(done, steps)?;
        if steps == 0 {
            return Ok(GuardedRun::Passed { steps: done });
        }
        self.begin(ctx)?;
        // The step of every recorded check; the first is the starting state.
        let mut checks = vec![done];
        let mut encoder = ctx.encoder("guarded steps");
        self.record(ctx, &mut encoder)?;
        let (mut at, mut recorded) = (done, 0);
        for stretch in crate::guard::chunks(done, steps, every) {
            for _ in 0..stretch {
                record_step(&mut encoder, at)?;
                at += 1;
                recorded += 1;
                if recorded == per_submit.max(1) {
                    ctx.submit(std::mem::replace(
                        &mut encoder,
                        ctx.encoder("guarded steps"),
                    ));
                    recorded = 0;
                }
            }
            after_stretch(&mut encoder)?;
            self.record(ctx, &mut encoder)?;
            checks.push(at);
        }
        ctx.submit(encoder);
        let report = self.report(ctx)?;
        Ok(match report.bad {
            None => GuardedRun::Passed { steps: at },
            Some((label, index)) => {
                // `passed = 0`: the starting state failed (e.g. a health flag a rebuild set
                // after a rollback): nothing was stepped, `good = bad = done`, and the
                // snapshots still hold the last state that passed in an earlier call.
                let passed = (report.passed as usize).min(checks.len() - 1);
                GuardedRun::Failed {
                    good: checks[passed.saturating_sub(1)],
                    bad: checks[passed],
                    label,
                    index,
                }
            }
        })
    }

    /// Copies every snapshot back into its live buffer: the state of the last check that
    /// passed.
    pub fn rollback(&self, ctx: &GpuContext) -> Result<()> {
        let mut encoder = ctx.encoder("guard rollback");
        for w in &self.watched {
            if w.words > 0 {
                encoder.copy_buffer_to_buffer(
                    w.snapshot.raw(),
                    0,
                    &w.live,
                    0,
                    u64::from(w.words) * 4,
                );
            }
        }
        ctx.submit(encoder);
        ctx.wait()
    }
}
