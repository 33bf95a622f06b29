//! The blow-up check every time-stepping crate runs inside `step(n)`.
//!
//! A run that turns non-finite (or leaves the limits of its model) must not return `Ok`.
//! Every simulation therefore checks its state at fixed steps while it runs: every
//! `check_every` steps counted from step 0 (so the same steps are checked however a run is
//! split into `step(n)` calls, and a resumed run checks where the uninterrupted one did), and
//! at the end of each `step(n)` call. Before each stretch it keeps a copy of the last state
//! that passed; when a check fails, the simulation is put back to that copy and `step`
//! returns [`Error::BlowUp`] naming the step, the first bad particle or cell, and the likely
//! cause. `check_every = 0` turns the interval checks off (the end-of-call check stays).
//!
//! The CPU side is [`chunks`] and [`first_non_finite`]; the GPU side is
//! [`crate::gpu::GpuGuard`], which checks and copies on the device without a round trip per
//! stretch.
//!
//! ```
//! use simkit_backend::guard::{chunks, first_non_finite};
//! // Steps 95..=260 with a check every 100 steps: stretches end at 100, 200 and 260.
//! assert_eq!(chunks(95, 165, 100).collect::<Vec<_>>(), vec![5, 100, 60]);
//! assert_eq!(first_non_finite(&[1.0f64, 2.0, f64::NAN, f64::INFINITY]), Some(2));
//! ```

use rayon::prelude::*;

use crate::{Error, Real};

/// Default interval, in steps, of the finite-state check (about 1 % of a step's work or less
/// in every crate: one pass over the state and one copy of it per interval).
pub const DEFAULT_CHECK_EVERY: u32 = 100;

/// Splits the `steps` steps that follow step `done` into stretches that end on multiples of
/// `every` (counted from step 0) and at `done + steps`; `every = 0` gives one stretch.
/// Yields nothing for `steps = 0`.
pub fn chunks(done: u64, steps: u32, every: u32) -> impl Iterator<Item = u32> {
    let end = done + u64::from(steps);
    let mut at = done;
    std::iter::from_fn(move || {
        if at >= end {
            return None;
        }
        let next = if every == 0 {
            end
        } else {
            let every = u64::from(every);
            ((at / every + 1) * every).min(end)
        };
        let n = (next - at) as u32;
        at = next;
        Some(n)
    })
}

/// The step count after `steps` more steps from `done`, or the error that names the overflow
/// of the step counter (every run refuses it before stepping).
///
/// ```
/// use simkit_backend::guard::end_step;
/// assert_eq!(end_step(10, 5).unwrap(), 15);
/// assert!(end_step(u64::MAX - 1, 2).is_err());
/// ```
pub fn end_step(done: u64, steps: u32) -> crate::Result<u64> {
    done.checked_add(u64::from(steps)).ok_or_else(|| {
        Error::invalid(
            "steps",
            steps,
            format!("{done} steps are done: the step counter would overflow"),
        )
    })
}

/// Index of the first value that is NaN or infinite, if any (in parallel for long slices).
pub fn first_non_finite<T: Real>(values: &[T]) -> Option<usize> {
    const SERIAL: usize = 1 << 15;
    if values.len() <= SERIAL {
        values.iter().position(|v| !v.to_f64().is_finite())
    } else {
        values
            .par_chunks(SERIAL)
            .position_first(|c| c.iter().any(|v| !v.to_f64().is_finite()))
            .and_then(|chunk| {
                let base = chunk * SERIAL;
                values[base..]
                    .iter()
                    .position(|v| !v.to_f64().is_finite())
                    .map(|i| base + i)
            })
    }
}

/// The [`Error::BlowUp`] for a check at step `step` that found `what` (e.g.
/// `"particle 17: position x = NaN"`), with the usual `cause`, after the simulation was put
/// back to step `rolled_back_to`.
pub fn blow_up(
    step: u64,
    rolled_back_to: u64,
    what: impl Into<String>,
    cause: impl Into<String>,
) -> Error {
    Error::BlowUp {
        step,
        what: what.into(),
        cause: cause.into(),
        rolled_back_to,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stretches_end_on_absolute_multiples() {
        let c = |d, s, e| chunks(d, s, e).collect::<Vec<u32>>();
        assert_eq!(c(0, 250, 100), vec![100, 100, 50]);
        assert_eq!(c(100, 100, 100), vec![100]);
        assert_eq!(c(7, 3, 0), vec![3]);
        assert!(c(7, 0, 10).is_empty());
        assert_eq!(c(0, 3, 1), vec![1, 1, 1]);
        // The checked steps do not depend on how a run is split into calls.
        let ends = |calls: &[u32]| {
            let mut done = 0u64;
            let mut out = Vec::new();
            for &n in calls {
                for s in chunks(done, n, 40) {
                    done += u64::from(s);
                    if done.is_multiple_of(40) {
                        out.push(done);
                    }
                }
            }
            out
        };
        assert_eq!(ends(&[200]), ends(&[13, 87, 50, 50]));
    }

    #[test]
    fn finds_the_first_bad_value_in_long_and_short_slices() {
        assert_eq!(first_non_finite::<f32>(&[]), None);
        assert_eq!(first_non_finite(&[1.0f32, f32::NEG_INFINITY]), Some(1));
        let mut long = vec![0.5f64; 200_000];
        assert_eq!(first_non_finite(&long), None);
        long[150_001] = f64::NAN;
        long[190_000] = f64::INFINITY;
        assert_eq!(first_non_finite(&long), Some(150_001));
        let e = blow_up(300, 200, "cell (3, 4): u = NaN", "dt over the bound");
        let s = e.to_string();
        assert!(
            s.contains("300") && s.contains("(3, 4)") && s.contains("step 200"),
            "{s}"
        );
    }
}
