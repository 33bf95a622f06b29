//! The force buffers of one block of the half list: what the pair kernel writes and how
//! the totals read it back.
//!
//! A block writes its particles' forces and the reactions it owes to later slots. Its
//! same-image partners lie within about one layer of cells after it
//! ([`HalfListBlock::near_reach`]), so a dense buffer over `start..near_reach` holds them.
//! The cross-image partners of a box periodic along its slowest (last) axis may lie a whole
//! system away (the first layer pairs with the last), so those beyond the dense span are
//! queued apart, one entry per pair. A dense buffer over every slot a block reaches would
//! instead hold about the whole system for each block of the first layer: 650 bytes per
//! atom at 2.4 million `in.lj` atoms, where the block and its layer need under 150.

use simkit_backend::{Error, Real, Result};
use simkit_neighbor::HalfListBlock;

/// One block's force buffers (see the module doc).
#[derive(Clone, Debug, Default)]
pub(crate) struct BlockForces<T, const D: usize> {
    /// Forces on slots `start..near_reach`: the block's own and the reactions it owes
    /// within that span.
    pub near: Vec<[T; D]>,
    /// The reactions owed across a periodic face beyond the dense span, one per such pair,
    /// in the kernel's visiting order (particle by particle, each one's cross-image
    /// partners in list order).
    pub far: Vec<[T; D]>,
    /// `(slot, index into far)` of every entry of `far`, sorted by slot (pairs with the
    /// same slot in visiting order), so a target block finds its entries by bisection.
    far_by_slot: Vec<(u32, u32)>,
}

impl<T: Real, const D: usize> BlockForces<T, D> {
    /// Sizes the buffers for block `nb` of a list just built over `n` particles. Refuses a
    /// list that names a slot beyond the particles (the kernel relies on it).
    pub fn fit(&mut self, nb: &HalfListBlock<T, D>, n: usize) -> Result<()> {
        if nb.reach() > n {
            return Err(Error::invalid(
                "neighbour list",
                format!("a pair with slot {}", nb.reach() - 1),
                format!("must name slots below the particle count {n}; this is a bug"),
            ));
        }
        // Sizes only: the kernel clears `near` and writes every entry of `far` each pass.
        let near = nb.near_reach();
        self.near.resize(near - nb.start(), [T::ZERO; D]);
        self.far_by_slot.clear();
        let beyond = nb
            .image_partners()
            .iter()
            .filter(|&&(j, _)| j as usize >= near);
        self.far_by_slot
            .extend(beyond.zip(0u32..).map(|(&(j, _), q)| (j, q)));
        self.far_by_slot.sort_by_key(|&(j, _)| j);
        self.far.resize(self.far_by_slot.len(), [T::ZERO; D]);
        Ok(())
    }

    /// Adds this block's dense entries on slots `start..start + f.len()` (those its dense
    /// span covers); `from` is the block's first slot (`from <= start`).
    pub fn add_dense(&self, from: usize, start: usize, f: &mut [[T; D]]) {
        let end = (from + self.near.len()).min(start + f.len());
        if end <= start {
            return;
        }
        for (fi, x) in f[..end - start].iter_mut().zip(&self.near[start - from..]) {
            for d in 0..D {
                fi[d] += x[d];
            }
        }
    }

    /// Adds this block's queued cross-image reactions on slots `start..start + f.len()`
    /// (in slot order, ties in visiting order).
    pub fn add_far(&self, start: usize, f: &mut [[T; D]]) {
        let first = self
            .far_by_slot
            .partition_point(|&(j, _)| (j as usize) < start);
        for &(j, q) in &self.far_by_slot[first..] {
            let Some(fi) = f.get_mut(j as usize - start) else {
                break;
            };
            let x = self.far[q as usize];
            for d in 0..D {
                fi[d] += x[d];
            }
        }
    }
}
