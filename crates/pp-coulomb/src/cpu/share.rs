//! How the processes of a run share what each computed for its own block of particles: one
//! process alone ([`Alone`]), or the ranks of a [`Comm`] with replicated data ([`Ranks`]).
//!
//! Every process holds all `N` particles; each computes the forces on, and integrates, its
//! own contiguous block of targets, then an all-gather gives every process the new values
//! of all the others.

use std::ops::Range;

use simkit_backend::comm::{Comm, split};
use simkit_backend::{Real, Result};

/// What the CPU engine's stepping loop needs from the processes around it.
pub(crate) trait Share {
    /// The targets this process computes, out of `n` particles.
    fn own(&self, n: usize) -> Range<usize>;
    /// Completes the first `n` entries of every array of `arrays` from every process's
    /// block (this process's block is already in place), in one message.
    fn gather<U: Real>(&self, arrays: &mut [&mut [U]], n: usize) -> Result<()>;
}

/// One process: it owns every particle and has nothing to gather.
pub(crate) struct Alone;

impl Share for Alone {
    fn own(&self, n: usize) -> Range<usize> {
        0..n
    }

    fn gather<U: Real>(&self, _arrays: &mut [&mut [U]], _n: usize) -> Result<()> {
        Ok(())
    }
}

/// The ranks of a communicator: rank `r` owns block `r` of [`split`] (contiguous, in rank
/// order, lengths differing by at most one).
pub(crate) struct Ranks<'a>(pub &'a Comm);

impl Share for Ranks<'_> {
    fn own(&self, n: usize) -> Range<usize> {
        let (start, len) = split(n, self.0.size(), self.0.rank());
        start..start + len
    }

    /// Each rank sends its block of every array padded to the longest block,
    /// `ceil(n / P)` values per array (`Comm::all_gather` wants equal lengths).
    fn gather<U: Real>(&self, arrays: &mut [&mut [U]], n: usize) -> Result<()> {
        let p = self.0.size();
        let width = n.div_ceil(p);
        if width == 0 || arrays.is_empty() {
            return Ok(());
        }
        let own = self.own(n);
        let mut send = Vec::with_capacity(width * arrays.len());
        for a in arrays.iter() {
            send.extend_from_slice(&a[own.clone()]);
            send.resize(send.len() + width - own.len(), U::default());
        }
        let all = self.0.all_gather(&send)?;
        // Rank r's message is `arrays.len()` runs of `width` values, its block first in each.
        for (r, message) in all.chunks_exact(width * arrays.len()).enumerate() {
            let (start, len) = split(n, p, r);
            for (a, run) in arrays.iter_mut().zip(message.chunks_exact(width)) {
                a[start..start + len].copy_from_slice(&run[..len]);
            }
        }
        Ok(())
    }
}
