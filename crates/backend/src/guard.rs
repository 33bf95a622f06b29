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
//! The CPU side is one loop, [`run_guarded`], over any state that implements [`Guarded`]
//! (keep a copy, advance a stretch, check, put the copy back), with [`chunks`] for the
//! stretches and [`first_non_finite`] for the usual check; every CPU engine of every crate
//! runs its `step(n)` through it, single-process and distributed alike. The GPU side is
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

use crate::{Error, Real, Result};

/// Default interval, in steps, of the finite-state check (about 1 % of a step's work or less
/// in every crate: one pass over the state and one copy of it per interval).
pub const DEFAULT_CHECK_EVERY: u32 = 100;

/// Splits the `steps` steps that follow step `done` into stretches that end on multiples of
/// `every` (counted from step 0) and at `done + steps`; `every = 0` gives one stretch.
/// Yields nothing for `steps = 0`.
///
/// Overflow-safe: the stretches stop at `u64::MAX` (a run refuses a step count that would
/// pass it before stepping, [`end_step`]).
pub fn chunks(done: u64, steps: u32, every: u32) -> impl Iterator<Item = u32> {
    let end = done.saturating_add(u64::from(steps));
    let mut at = done;
    std::iter::from_fn(move || {
        if at >= end {
            return None;
        }
        let next = if every == 0 {
            end
        } else {
            let every = u64::from(every);
            // The next multiple of `every`, or the end where that multiple is past u64::MAX.
            (at / every + 1)
                .checked_mul(every)
                .map_or(end, |m| m.min(end))
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

/// Why a stretch of steps or its check stopped the run (see [`Guarded`]).
#[derive(Debug)]
pub enum Halt {
    /// The run broke at step `step`: `what` names the first bad value (e.g. `"particle
    /// 17: position x = NaN"`), `cause` the likely cause and its fix. [`run_guarded`] puts
    /// the kept state back and returns [`Error::BlowUp`].
    BlowUp {
        /// The step at which the failure was found.
        step: u64,
        /// What was found.
        what: String,
        /// The likely cause.
        cause: String,
    },
    /// An error returned as it is after the kept state is put back (a failed exchange, or
    /// a blow-up the engine described itself).
    Error(Error),
}

impl From<Error> for Halt {
    fn from(e: Error) -> Self {
        Halt::Error(e)
    }
}

/// The outcome of a check at step `step` that found `failure` (`(what, cause)`, see
/// [`Halt::BlowUp`]), or passed (`None`).
///
/// Errors: [`Halt::BlowUp`] for a failure.
pub fn verdict(step: u64, failure: Option<(String, String)>) -> std::result::Result<(), Halt> {
    match failure {
        None => Ok(()),
        Some((what, cause)) => Err(Halt::BlowUp { step, what, cause }),
    }
}

/// A simulation state that [`run_guarded`] advances in checked stretches.
pub trait Guarded {
    /// Steps done since the start of the run.
    fn steps_done(&self) -> u64;

    /// Keeps a copy of the current state (with its step count): the state a failure in
    /// the coming stretch puts back.
    fn keep(&mut self) -> Result<()>;

    /// Advances `n >= 1` steps without checks, counting them in
    /// [`steps_done`](Guarded::steps_done).
    fn advance(&mut self, n: u32) -> std::result::Result<(), Halt>;

    /// Checks the state reached by the stretch.
    fn check(&mut self) -> std::result::Result<(), Halt>;

    /// Puts the kept state back (the step count included).
    fn restore(&mut self) -> Result<()>;

    /// Runs between two stretches of one call, after the check passed (e.g. a stability
    /// bound that depends on the fields). Nothing by default.
    fn between(&mut self) -> Result<()> {
        Ok(())
    }
}

/// Advances `g` by `steps` steps in the stretches of [`chunks`] (ending on multiples of
/// `every`, counted from step 0, and at the end of the call): before each stretch the
/// state is kept, after it checked; a stretch or check that fails puts the kept state back
/// and returns the failure ([`Error::BlowUp`] naming the step, what was found, the cause
/// and the step rolled back to). `steps = 0` does nothing.
///
/// Errors: a step count that would overflow the counter ([`end_step`], before any step),
/// the failures above, and errors of `keep`, `restore` and `between`.
pub fn run_guarded<G: Guarded + ?Sized>(g: &mut G, steps: u32, every: u32) -> Result<()> {
    end_step(g.steps_done(), steps)?;
    let mut stretches = chunks(g.steps_done(), steps, every).peekable();
    while let Some(n) = stretches.next() {
        g.keep()?;
        let halted = g.advance(n).and_then(|()| g.check());
        match halted {
            Ok(()) => {}
            Err(Halt::BlowUp { step, what, cause }) => {
                g.restore()?;
                return Err(blow_up(step, g.steps_done(), what, cause));
            }
            Err(Halt::Error(e)) => {
                g.restore()?;
                return Err(e);
            }
        }
        if stretches.peek().is_some() {
            g.between()?;
        }
    }
    Ok(())
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

    /// A counter that "blows up" at step `bad` (found by the check after the stretch),
    /// logging the guard's calls.
    struct Toy {
        steps: u64,
        kept: u64,
        bad: u64,
        log: Vec<String>,
    }

    impl Guarded for Toy {
        fn steps_done(&self) -> u64 {
            self.steps
        }
        fn keep(&mut self) -> Result<()> {
            self.kept = self.steps;
            self.log.push(format!("keep {}", self.steps));
            Ok(())
        }
        fn advance(&mut self, n: u32) -> std::result::Result<(), Halt> {
            self.steps += u64::from(n);
            Ok(())
        }
        fn check(&mut self) -> std::result::Result<(), Halt> {
            if self.steps >= self.bad {
                return Err(Halt::BlowUp {
                    step: self.steps,
                    what: "x = NaN".into(),
                    cause: "dt".into(),
                });
            }
            Ok(())
        }
        fn restore(&mut self) -> Result<()> {
            self.steps = self.kept;
            self.log.push(format!("restore {}", self.steps));
            Ok(())
        }
        fn between(&mut self) -> Result<()> {
            self.log.push(format!("between {}", self.steps));
            Ok(())
        }
    }

    #[test]
    fn a_step_count_that_would_overflow_is_refused_before_stepping() {
        // A run resumed from a checkpoint whose step count is near u64::MAX: `step(10)`
        // is an error naming the steps, and nothing is advanced or kept.
        let mut t = Toy {
            steps: u64::MAX - 5,
            kept: 0,
            bad: u64::MAX,
            log: Vec::new(),
        };
        let e = run_guarded(&mut t, 10, 100).unwrap_err();
        assert!(e.to_string().contains("steps"), "{e}");
        assert_eq!(t.steps, u64::MAX - 5);
        assert!(t.log.is_empty(), "{:?}", t.log);
        // The stretches never overflow either: they stop at u64::MAX (before, the next
        // multiple of `every` wrapped past it and the iterator never ended in release).
        assert_eq!(chunks(u64::MAX - 5, 5, 100).collect::<Vec<_>>(), vec![5]);
        assert_eq!(chunks(u64::MAX - 5, 10, 100).sum::<u32>(), 5);
    }

    #[test]
    fn the_guarded_loop_keeps_checks_and_rolls_back() {
        let mut t = Toy {
            steps: 95,
            kept: 0,
            bad: u64::MAX,
            log: Vec::new(),
        };
        run_guarded(&mut t, 165, 100).unwrap();
        assert_eq!(t.steps, 260);
        assert_eq!(
            t.log,
            [
                "keep 95",
                "between 100",
                "keep 100",
                "between 200",
                "keep 200"
            ]
        );
        t.bad = 330;
        t.log.clear();
        let e = run_guarded(&mut t, 200, 100).unwrap_err();
        assert!(matches!(
            e,
            Error::BlowUp {
                step: 400,
                rolled_back_to: 300,
                ..
            }
        ));
        assert_eq!(t.steps, 300);
        assert_eq!(t.log.last().map(String::as_str), Some("restore 300"));
        // Overflow is refused before stepping; zero steps do nothing.
        t.steps = u64::MAX - 3;
        assert!(run_guarded(&mut t, 5, 100).is_err());
        assert_eq!(t.steps, u64::MAX - 3);
        t.log.clear();
        run_guarded(&mut t, 0, 100).unwrap();
        assert!(t.log.is_empty());
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
