//! CPU lookup-table backend: one byte per site, rows in parallel with rayon.
//!
//! Each row gathers its incoming particles from three padded row copies (the row itself and
//! its two neighbours, wrapped or zero-filled at the edges), so the inner loop has no
//! branches; the collision is one lookup in the 512-entry [`CollisionTable`].

use backend::{Result, Simulation};
use rayon::prelude::*;

use crate::random::{FORCE_STREAM, force_threshold, step_key};
use crate::{CollisionTable, EAST, Lattice, Params, WALL, WEST};
use backend::rng::pcg_hash;

/// The lookup-table CPU backend.
pub struct LutCpu {
    lattice: Lattice,
    next: Vec<u8>,
    params: Params,
    table: CollisionTable,
    steps: u64,
}

impl LutCpu {
    /// A lookup-table simulation of `lattice` under `params` (validated).
    pub fn new(lattice: Lattice, params: Params) -> Result<Self> {
        params.validate(&lattice)?;
        let next = vec![0; lattice.cells().len()];
        Ok(Self {
            table: CollisionTable::new(params.rules),
            lattice,
            next,
            params,
            steps: 0,
        })
    }

    fn step_once(&mut self) {
        let w = self.lattice.width();
        let h = self.lattice.height();
        let t = self.steps as u32;
        let ctx = RowCtx {
            src: self.lattice.cells(),
            w,
            h,
            params: &self.params,
            table: &self.table.entries,
            key: step_key(self.params.seed, t),
            force_key: step_key(self.params.seed ^ FORCE_STREAM, t),
            threshold: force_threshold(self.params.body_force),
        };
        let force = self.params.body_force > 0.0;
        self.next.par_chunks_mut(w).enumerate().for_each_init(
            || vec![0u8; 3 * (w + 2)],
            |pad, (j, row)| {
                if force {
                    ctx.row::<true>(j, row, pad);
                } else {
                    ctx.row::<false>(j, row, pad);
                }
            },
        );
        let cells = std::mem::take(&mut self.next);
        self.next =
            std::mem::replace(&mut self.lattice, Lattice::from_raw(w, h, cells)).into_cells();
        self.steps += 1;
    }
}

struct RowCtx<'a> {
    src: &'a [u8],
    w: usize,
    h: usize,
    params: &'a Params,
    table: &'a [u8],
    key: u32,
    force_key: u32,
    threshold: u32,
}

impl RowCtx<'_> {
    /// Copies row `jj` (wrapped or absent) into `dst` (length w + 2) with one padding site
    /// on each side.
    fn pad_row(&self, jj: Option<usize>, dst: &mut [u8]) {
        let w = self.w;
        match jj {
            None => dst.fill(0),
            Some(jj) => {
                let row = &self.src[jj * w..(jj + 1) * w];
                dst[1..=w].copy_from_slice(row);
                if self.params.periodic_x {
                    dst[0] = row[w - 1];
                    dst[w + 1] = row[0];
                } else {
                    dst[0] = 0;
                    dst[w + 1] = 0;
                }
            }
        }
    }

    fn neighbour_row(&self, j: usize, up: bool) -> Option<usize> {
        let h = self.h;
        if up {
            if j + 1 < h {
                Some(j + 1)
            } else {
                self.params.periodic_y.then_some(0)
            }
        } else if j > 0 {
            Some(j - 1)
        } else {
            self.params.periodic_y.then_some(h - 1)
        }
    }

    #[inline(always)]
    fn row<const FORCE: bool>(&self, j: usize, out: &mut [u8], pad: &mut [u8]) {
        let w = self.w;
        let (mid, rest) = pad.split_at_mut(w + 2);
        let (up, down) = rest.split_at_mut(w + 2);
        self.pad_row(Some(j), mid);
        self.pad_row(self.neighbour_row(j, true), up);
        self.pad_row(self.neighbour_row(j, false), down);
        if j & 1 == 1 {
            self.sites::<FORCE, true>(j, out, mid, up, down);
        } else {
            self.sites::<FORCE, false>(j, out, mid, up, down);
        }
        if self.params.inflow && out[0] & WALL == 0 {
            out[0] = EAST;
        }
        if self.params.outflow && out[w - 1] & WALL == 0 {
            out[w - 1] = 0;
        }
    }

    /// Gather + collide for the sites of row `j`, in runs of sites that share one
    /// chirality hash (32 consecutive site indices).
    #[inline(always)]
    fn sites<const FORCE: bool, const ODD: bool>(
        &self,
        j: usize,
        out: &mut [u8],
        mid: &[u8],
        up: &[u8],
        down: &[u8],
    ) {
        let w = self.w;
        let base = (j * w) as u32;
        let mut i = 0;
        while i < w {
            let s0 = base + i as u32;
            let run = (32 - (s0 & 31) as usize).min(w - i);
            let word = pcg_hash((s0 >> 5) ^ self.key) >> (s0 & 31);
            for (q, o) in out[i..i + run].iter_mut().enumerate() {
                let i = i + q;
                // Padded index i + 1 is site i; sources at i - 1 / i + 1 are i / i + 2.
                let mut n = (mid[i] & 1) | (mid[i + 2] & 8) | (mid[i + 1] & WALL);
                if ODD {
                    n |=
                        (up[i + 1] & 2) | (up[i + 2] & 4) | (down[i + 2] & 16) | (down[i + 1] & 32);
                } else {
                    n |= (up[i] & 2) | (up[i + 1] & 4) | (down[i + 1] & 16) | (down[i] & 32);
                }
                let r = (word >> q) & 1;
                let mut v = self.table[(usize::from(n) << 1) | r as usize];
                if FORCE
                    && v & (WALL | EAST | WEST) == WEST
                    && (pcg_hash((s0 + q as u32) ^ self.force_key) >> 8) < self.threshold
                {
                    v ^= EAST | WEST;
                }
                *o = v;
            }
            i += run;
        }
    }
}

impl Simulation for LutCpu {
    type State = Lattice;

    fn step(&mut self, steps: u32) -> Result<()> {
        for _ in 0..steps {
            self.step_once();
        }
        Ok(())
    }

    fn state(&mut self) -> Result<Lattice> {
        Ok(self.lattice.clone())
    }

    fn steps_done(&self) -> u64 {
        self.steps
    }

    fn backend_name(&self) -> String {
        "cpu-lut".into()
    }
}
