//! Brute force O(N^2): the reference every other method is tested against.

use simkit_backend::Result;

use crate::{CellGrid, NeighborSearch};

/// Tests every pair with the minimum image. O(N^2): the reference, and the fastest choice
/// below a few hundred particles.
#[derive(Clone, Debug)]
pub struct BruteForce<const D: usize> {
    grid: CellGrid<D>,
    wrapped: Vec<[f64; D]>,
}

impl<const D: usize> BruteForce<D> {
    /// A brute-force search over `grid` (only its box, periodicity and cutoff are used).
    pub fn new(grid: &CellGrid<D>) -> Self {
        Self {
            grid: grid.clone(),
            wrapped: Vec::new(),
        }
    }
}

impl<const D: usize> NeighborSearch<D> for BruteForce<D> {
    fn name(&self) -> String {
        "brute force".into()
    }

    fn build(&mut self, positions: &[[f64; D]]) -> Result<()> {
        self.wrapped = self.grid.wrap_all(positions)?;
        Ok(())
    }

    fn particle_count(&self) -> usize {
        self.wrapped.len()
    }

    fn for_each_pair<F: FnMut(usize, usize, [f64; D], f64)>(&mut self, mut f: F) -> Result<()> {
        let rc2 = self.grid.cutoff() * self.grid.cutoff();
        for (i, &ti) in self.wrapped.iter().enumerate() {
            for (j, &tj) in self.wrapped.iter().enumerate().skip(i + 1) {
                let (sep, r2) = self.grid.separation(ti, tj);
                if r2 <= rc2 {
                    f(i, j, sep, r2);
                }
            }
        }
        Ok(())
    }
}
