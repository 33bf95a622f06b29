//! The trait shared by every method and backend, and per-particle neighbour lists.

use simkit_backend::{Error, Result};

/// Per-particle neighbour lists in compressed sparse row form: the neighbours of particle
/// `i` are `neighbors[offsets[i]..offsets[i + 1]]`, in ascending order.
#[derive(Clone, Debug, PartialEq, Eq, Default)]
pub struct NeighborLists {
    /// `N + 1` offsets into `neighbors`.
    pub offsets: Vec<usize>,
    /// Neighbour indices.
    pub neighbors: Vec<u32>,
}

impl NeighborLists {
    /// Full lists (every pair appears in both particles' lists) of `n` particles from
    /// unordered pairs `(i, j)`.
    ///
    /// Errors: `n` over `u32::MAX` (indices are `u32`), a pair with an index `>= n` or with
    /// `i == j`, or lists too large to allocate.
    pub fn from_pairs(n: usize, pairs: &[(u32, u32)]) -> Result<Self> {
        if n > u32::MAX as usize {
            return Err(Error::invalid(
                "particle count",
                n,
                "must be at most 2^32 - 1 (neighbour indices are stored as u32)",
            ));
        }
        for (k, &(i, j)) in pairs.iter().enumerate() {
            if i as usize >= n || j as usize >= n || i == j {
                return Err(Error::invalid(
                    format!("pairs[{k}]"),
                    format!("({i}, {j})"),
                    format!("must be two different particle indices below n = {n}"),
                ));
            }
        }
        // Every entry is one of the 2 * pairs.len() ends of a pair (the pairs are already in
        // memory); the offsets grow with n, which may be far larger than the input.
        let mut counts = zeroed_offsets(n)?;
        for &(i, j) in pairs {
            counts[i as usize] += 1;
            counts[j as usize] += 1;
        }
        let mut offsets = zeroed_offsets(n)?;
        let mut acc = 0;
        for (o, c) in offsets.iter_mut().zip(&counts) {
            *o = acc;
            acc += c;
        }
        drop(counts);
        let mut cursor = offsets.clone();
        let mut neighbors = vec![0u32; acc];
        for &(i, j) in pairs {
            neighbors[cursor[i as usize]] = j;
            cursor[i as usize] += 1;
            neighbors[cursor[j as usize]] = i;
            cursor[j as usize] += 1;
        }
        for i in 0..n {
            neighbors[offsets[i]..offsets[i + 1]].sort_unstable();
        }
        Ok(Self { offsets, neighbors })
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// Whether there are no particles.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Neighbours of particle `i` (ascending), or `None` if there is no particle `i`
    /// (`i >= len()`) or the public `offsets` do not index into `neighbors`.
    pub fn of(&self, i: usize) -> Option<&[u32]> {
        let start = *self.offsets.get(i)?;
        let end = *self.offsets.get(i.checked_add(1)?)?;
        self.neighbors.get(start..end)
    }

    /// Number of neighbours of every particle.
    ///
    /// Errors when the public fields do not form CSR lists: `offsets` decreasing, past the
    /// end of `neighbors`, or a list longer than `u32::MAX`.
    pub fn counts(&self) -> Result<Vec<u32>> {
        if let Some(&last) = self.offsets.last()
            && last > self.neighbors.len()
        {
            return Err(Error::invalid(
                format!("offsets[{}]", self.offsets.len() - 1),
                last,
                format!(
                    "past the end of neighbors (length {}); offsets index into neighbors",
                    self.neighbors.len()
                ),
            ));
        }
        self.offsets
            .windows(2)
            .enumerate()
            .map(|(i, w)| {
                w[1].checked_sub(w[0])
                    .and_then(|c| u32::try_from(c).ok())
                    .ok_or_else(|| {
                        Error::invalid(
                            format!("offsets[{i}..={}]", i + 1),
                            format!("{}..{}", w[0], w[1]),
                            "offsets must not decrease, and a list holds at most u32::MAX \
                             entries",
                        )
                    })
            })
            .collect()
    }
}

/// A neighbour search: build from positions, then enumerate the pairs within the cutoff.
///
/// Implemented by [`BruteForce`](crate::BruteForce), [`LinkedCells`](crate::LinkedCells),
/// [`SortedCells`](crate::SortedCells), [`VerletList`](crate::VerletList) and
/// [`GpuNeighborSearch`](crate::GpuNeighborSearch), so tests and benchmarks swap them freely.
pub trait NeighborSearch<const D: usize> {
    /// Short method name for reports (e.g. `"sorted cells"`).
    fn name(&self) -> String;

    /// (Re)builds from positions; validates them (NaN, out of a non-periodic box).
    fn build(&mut self, positions: &[[f64; D]]) -> Result<()>;

    /// Number of particles of the last build.
    fn particle_count(&self) -> usize;

    /// Calls `f(i, j, sep, r2)` once per unordered pair within the cutoff, with the minimum
    /// image `sep = r_i - r_j` and `r2 = |sep|^2`.
    fn for_each_pair<F: FnMut(usize, usize, [f64; D], f64)>(&mut self, f: F) -> Result<()>;

    /// Number of unordered pairs within the cutoff.
    fn pair_count(&mut self) -> Result<usize> {
        let mut n = 0;
        self.for_each_pair(|_, _, _, _| n += 1)?;
        Ok(n)
    }

    /// Number of neighbours of every particle.
    fn neighbor_counts(&mut self) -> Result<Vec<u32>> {
        let mut counts = vec![0u32; self.particle_count()];
        self.for_each_pair(|i, j, _, _| {
            counts[i] += 1;
            counts[j] += 1;
        })?;
        Ok(counts)
    }

    /// Sorted full neighbour lists of every particle.
    fn neighbor_lists(&mut self) -> Result<NeighborLists> {
        let mut pairs = Vec::new();
        self.for_each_pair(|i, j, _, _| pairs.push((i as u32, j as u32)))?;
        NeighborLists::from_pairs(self.particle_count(), &pairs)
    }
}

/// `n + 1` zeros, or an error when they cannot be allocated.
fn zeroed_offsets(n: usize) -> Result<Vec<usize>> {
    let mut v = Vec::new();
    if n.checked_add(1)
        .is_none_or(|len| v.try_reserve_exact(len).is_err())
    {
        return Err(Error::invalid(
            "particle count",
            n,
            "the neighbour list offsets do not fit in memory; use fewer particles",
        ));
    }
    v.resize(n + 1, 0);
    Ok(v)
}
