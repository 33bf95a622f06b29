//! Cartesian block decomposition of a 2D grid, halo exchange and gather.

use bytemuck::Pod;

use super::Comm;
use crate::{Error, Result};

/// The part of `n` cells that block `c` of `p` gets: `(start, len)`. The first `n % p`
/// blocks are one cell longer, so lengths differ by at most one and the blocks tile
/// `0..n` in order. Requires `c < p` and `p >= 1` (then `len = 0` when `p > n`).
pub fn split(n: usize, p: usize, c: usize) -> (usize, usize) {
    let (q, r) = (n / p, n % p);
    (c * q + c.min(r), q + usize::from(c < r))
}

/// One rank's block: cells `start[0]..start[0] + len[0]` along x and
/// `start[1]..start[1] + len[1]` along y of the global grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Block {
    /// First global cell `(x, y)` of the block.
    pub start: [usize; 2],
    /// Cells along x and y.
    pub len: [usize; 2],
}

/// The ranks next to one rank (`None` at a non-periodic edge of the domain; the rank
/// itself when a periodic axis has one block).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Neighbors {
    /// Towards smaller x.
    pub west: Option<usize>,
    /// Towards larger x.
    pub east: Option<usize>,
    /// Towards smaller y.
    pub south: Option<usize>,
    /// Towards larger y.
    pub north: Option<usize>,
}

/// An `n_x x n_y` grid cut into `p_x x p_y` blocks, one per rank; rank `r` holds block
/// `(r % p_x, r / p_x)` (x fastest). See [`split`] for the block sizes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CartDecomposition {
    global: [usize; 2],
    dims: [usize; 2],
    periodic: [bool; 2],
}

/// Messages a rank exchanges along an axis of `p` blocks in the worst case (the largest
/// over its blocks): 0, 1 (two blocks, not periodic) or 2.
fn faces(p: usize, periodic: bool) -> usize {
    match p {
        1 => 0,
        2 if !periodic => 1,
        _ => 2,
    }
}

impl CartDecomposition {
    /// Cuts `global = [n_x, n_y]` into `ranks` blocks. Among the factorisations
    /// `p_x * p_y = ranks` with at least one cell per block, picks the one whose largest
    /// per-rank halo (faces exchanged times the face length, `ceil(n / p)`) is smallest;
    /// ties go to more blocks along y (whole rows per rank). `periodic[axis]` makes the
    /// neighbours wrap around that axis.
    ///
    /// Errors: a zero size or rank count, or no factorisation that gives every rank a cell.
    pub fn new(global: [usize; 2], ranks: usize, periodic: [bool; 2]) -> Result<Self> {
        let [nx, ny] = global;
        if nx == 0 || ny == 0 {
            return Err(Error::invalid(
                "grid size",
                format!("{nx} x {ny}"),
                "both sides must be >= 1",
            ));
        }
        if ranks == 0 {
            return Err(Error::invalid("rank count", 0, "must be >= 1"));
        }
        let cost = |px: usize, py: usize| {
            faces(px, periodic[0]) * ny.div_ceil(py) + faces(py, periodic[1]) * nx.div_ceil(px)
        };
        let best = (1..=ranks)
            .filter(|px| ranks.is_multiple_of(*px))
            .map(|px| (px, ranks / px))
            .filter(|&(px, py)| px <= nx && py <= ny)
            .min_by_key(|&(px, py)| (cost(px, py), px));
        match best {
            Some((px, py)) => Self::with_dims(global, [px, py], periodic),
            None => Err(Error::invalid(
                "rank count",
                ranks,
                format!(
                    "cannot cut a {nx} x {ny} grid into {ranks} blocks of at least one cell \
                     (p_x * p_y = {ranks} with p_x <= {nx}, p_y <= {ny}); use fewer ranks or \
                     a larger grid"
                ),
            )),
        }
    }

    /// `global` cut into exactly `dims = [p_x, p_y]` blocks.
    ///
    /// Errors: a zero size or factor, or more blocks than cells along an axis.
    pub fn with_dims(global: [usize; 2], dims: [usize; 2], periodic: [bool; 2]) -> Result<Self> {
        for a in 0..2 {
            if dims[a] == 0 || dims[a] > global[a] {
                return Err(Error::invalid(
                    format!("blocks along axis {a}"),
                    dims[a],
                    format!(
                        "must be 1..={} (the grid's cells along that axis)",
                        global[a]
                    ),
                ));
            }
        }
        Ok(Self {
            global,
            dims,
            periodic,
        })
    }

    /// The global grid size `[n_x, n_y]`.
    pub fn global(&self) -> [usize; 2] {
        self.global
    }

    /// Blocks along each axis, `[p_x, p_y]`.
    pub fn dims(&self) -> [usize; 2] {
        self.dims
    }

    /// Whether the neighbours wrap around each axis.
    pub fn periodic(&self) -> [bool; 2] {
        self.periodic
    }

    /// Number of blocks (= ranks), `p_x * p_y`.
    pub fn ranks(&self) -> usize {
        self.dims[0] * self.dims[1]
    }

    /// Block coordinates `(c_x, c_y)` of `rank` (`rank < ranks()`).
    pub fn coords(&self, rank: usize) -> [usize; 2] {
        [rank % self.dims[0], rank / self.dims[0]]
    }

    /// The block of `rank` (`rank < ranks()`).
    pub fn block(&self, rank: usize) -> Block {
        let c = self.coords(rank);
        let (x0, lx) = split(self.global[0], self.dims[0], c[0]);
        let (y0, ly) = split(self.global[1], self.dims[1], c[1]);
        Block {
            start: [x0, y0],
            len: [lx, ly],
        }
    }

    /// The ranks next to `rank` (`rank < ranks()`).
    pub fn neighbors(&self, rank: usize) -> Neighbors {
        let c = self.coords(rank);
        let at = |cx: usize, cy: usize| cy * self.dims[0] + cx;
        let step = |axis: usize, up: bool| -> Option<usize> {
            let (p, k) = (self.dims[axis], c[axis]);
            let next = if up {
                if k + 1 < p {
                    Some(k + 1)
                } else {
                    self.periodic[axis].then_some(0)
                }
            } else if k > 0 {
                Some(k - 1)
            } else {
                self.periodic[axis].then_some(p - 1)
            };
            next.map(|n| if axis == 0 { at(n, c[1]) } else { at(c[0], n) })
        };
        Neighbors {
            west: step(0, false),
            east: step(0, true),
            south: step(1, false),
            north: step(1, true),
        }
    }

    /// `Ok` when `comm` has as many ranks as the decomposition has blocks.
    pub(super) fn check_comm(&self, comm: &Comm) -> Result<()> {
        if comm.size() != self.ranks() {
            return Err(Error::invalid(
                "communicator size",
                comm.size(),
                format!(
                    "the decomposition has {} x {} = {} blocks; build it for comm.size() ranks",
                    self.dims[0],
                    self.dims[1],
                    self.ranks()
                ),
            ));
        }
        Ok(())
    }

    /// Fills the ghost layers of this rank's block from the neighbouring blocks, in the
    /// shift pattern: first along x (the `depth` easternmost interior columns go east while
    /// the west ghost columns arrive from the west, then the reverse), then along y with
    /// whole padded rows, so the corner ghosts travel in the second shift and each rank
    /// talks to 4 neighbours, not 8 (4 messages per exchange, fewer at domain edges).
    ///
    /// `planes` holds one or more fields of this rank's block (`comm.rank()`), each padded
    /// with `depth` ghost layers: row-major `(len_x + 2 depth) x (len_y + 2 depth)` values,
    /// all fields in one message per shift. Ghosts on a side without a neighbour (a
    /// non-periodic domain edge) are left as they are for the caller's boundary rule.
    /// Collective.
    ///
    /// Errors: a communicator of another size, `depth == 0`, a `planes` length that is not
    /// a whole number of padded fields, or a block thinner than `depth` along an axis that
    /// exchanges, on any rank: every rank returns the error (the others name the rank that
    /// failed and carry its message).
    pub fn exchange_halo<T: Pod>(&self, comm: &Comm, planes: &mut [T], depth: usize) -> Result<()> {
        self.check_comm(comm)?;
        let rank = comm.rank();
        let b = self.block(rank);
        let nb = self.neighbors(rank);
        let [nx, ny] = b.len;
        let d = depth;
        let (w, hgt) = (nx + 2 * d, ny + 2 * d);
        let plane = w * hgt;
        // Every rank checks its own block and fields; the outcome is agreed before any
        // message moves, so a bad input on one rank is an error on every rank.
        let checked = (|| {
            if d == 0 {
                return Err(Error::invalid("halo depth", 0, "must be >= 1"));
            }
            if planes.is_empty() || !planes.len().is_multiple_of(plane) {
                return Err(Error::invalid(
                    "length of the padded fields",
                    planes.len(),
                    format!(
                        "must be a positive multiple of ({nx} + 2*{d}) x ({ny} + 2*{d}) = {plane}"
                    ),
                ));
            }
            for (axis, len, has) in [
                (0, nx, nb.west.is_some() || nb.east.is_some()),
                (1, ny, nb.south.is_some() || nb.north.is_some()),
            ] {
                if has && len < d {
                    return Err(Error::invalid(
                        format!("block of rank {rank} along axis {axis}"),
                        len,
                        format!(
                            "a halo of depth {d} needs blocks of at least {d} cells; use \
                             fewer ranks or a shallower halo"
                        ),
                    ));
                }
            }
            Ok(planes.len() / plane)
        })();
        let count = comm.agree(checked)?;
        // Along x: columns `c0..c0 + d` of rows d..d + ny of every plane.
        let cols = |f: &[T], c0: usize| -> Vec<T> {
            let mut out = Vec::with_capacity(count * ny * d);
            for p in f.chunks(plane) {
                for j in d..d + ny {
                    out.extend_from_slice(&p[j * w + c0..j * w + c0 + d]);
                }
            }
            out
        };
        let put_cols = |f: &mut [T], c0: usize, v: &[T]| {
            let mut it = v.chunks(d);
            for p in f.chunks_mut(plane) {
                for j in d..d + ny {
                    if let Some(src) = it.next() {
                        p[j * w + c0..j * w + c0 + d].copy_from_slice(src);
                    }
                }
            }
        };
        let mut recv = vec![T::zeroed(); count * ny * d];
        let x_moves = [
            (nx, nb.east, nb.west, 0, 0u16),  // east-going: fill the west ghosts
            (d, nb.west, nb.east, d + nx, 1), // west-going: fill the east ghosts
        ];
        for (from, dest, source, into, tag) in x_moves {
            if dest.is_none() && source.is_none() {
                continue;
            }
            let send = if dest.is_some() {
                cols(planes, from)
            } else {
                Vec::new()
            };
            comm.shift(&send, dest, &mut recv, source, tag)?;
            if source.is_some() {
                put_cols(planes, into, &recv);
            }
        }
        // Along y: whole padded rows `r0..r0 + d` (x ghosts included: the corners).
        let rows = |f: &[T], r0: usize| -> Vec<T> {
            let mut out = Vec::with_capacity(count * d * w);
            for p in f.chunks(plane) {
                out.extend_from_slice(&p[r0 * w..(r0 + d) * w]);
            }
            out
        };
        let mut recv = vec![T::zeroed(); count * d * w];
        let y_moves = [
            (ny, nb.north, nb.south, 0, 2u16), // north-going: fill the south ghosts
            (d, nb.south, nb.north, d + ny, 3), // south-going: fill the north ghosts
        ];
        for (from, dest, source, into, tag) in y_moves {
            if dest.is_none() && source.is_none() {
                continue;
            }
            let send = if dest.is_some() {
                rows(planes, from)
            } else {
                Vec::new()
            };
            comm.shift(&send, dest, &mut recv, source, tag)?;
            if source.is_some() {
                for (p, v) in planes.chunks_mut(plane).zip(recv.chunks(d * w)) {
                    p[into * w..(into + d) * w].copy_from_slice(v);
                }
            }
        }
        Ok(())
    }

    /// The global fields on rank 0 (`Some`, each row-major `n_x x n_y`, concatenated) from
    /// every rank's block (`local`: the same number of fields, each row-major
    /// `len_x x len_y` without ghosts, concatenated); `None` on the other ranks. Collective.
    ///
    /// Errors: a communicator of another size, a `local` that is not a whole number of this
    /// rank's blocks, or ranks that disagree on the number of fields, on every rank.
    pub fn gather<T: Pod>(&self, comm: &Comm, local: &[T]) -> Result<Option<Vec<T>>> {
        self.check_comm(comm)?;
        let cells = |r: usize| {
            let b = self.block(r);
            b.len[0] * b.len[1]
        };
        let mine = cells(comm.rank());
        let checked = if local.is_empty() || !local.len().is_multiple_of(mine) {
            Err(Error::invalid(
                "length of the local fields",
                local.len(),
                format!("must be a positive multiple of this rank's block ({mine} cells)"),
            ))
        } else {
            Ok(local.len() / mine)
        };
        let count = comm.agree(checked)?;
        // Rank 0 checks what arrived; its verdict is agreed too (the others have nothing
        // to check but must not go on when rank 0 fails).
        let gathered = comm.gather_to_root(local)?;
        comm.agree(self.assemble(gathered, count))
    }

    /// Rank 0's global fields from the gathered blocks (`None` elsewhere).
    fn assemble<T: Pod>(
        &self,
        gathered: Option<Vec<Vec<T>>>,
        count: usize,
    ) -> Result<Option<Vec<T>>> {
        let Some(parts) = gathered else {
            return Ok(None);
        };
        let [gx, gy] = self.global;
        let mut out = vec![T::zeroed(); count * gx * gy];
        for (r, part) in parts.iter().enumerate() {
            let b = self.block(r);
            let [lx, ly] = b.len;
            if part.len() != count * lx * ly {
                return Err(Error::invalid(
                    format!("values gathered from rank {r}"),
                    part.len(),
                    format!(
                        "expected {count} fields of {lx} x {ly}: every rank must pass the same fields"
                    ),
                ));
            }
            for (s, f) in part.chunks(lx * ly).enumerate() {
                for (j, row) in f.chunks(lx).enumerate() {
                    let at = s * gx * gy + (b.start[1] + j) * gx + b.start[0];
                    out[at..at + lx].copy_from_slice(row);
                }
            }
        }
        Ok(Some(out))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn blocks_tile_the_axis_and_differ_by_at_most_one(n in 1usize..500, p in 1usize..40) {
            let mut next = 0;
            let mut lens = Vec::new();
            for c in 0..p {
                let (s, l) = split(n, p, c);
                prop_assert_eq!(s, next);
                next += l;
                lens.push(l);
            }
            prop_assert_eq!(next, n);
            let (lo, hi) = (lens.iter().min().unwrap(), lens.iter().max().unwrap());
            prop_assert!(hi - lo <= 1);
            // The longer blocks come first.
            prop_assert!(lens.windows(2).all(|w| w[0] >= w[1]));
        }

        #[test]
        fn blocks_tile_the_grid_exactly(
            nx in 1usize..60, ny in 1usize..60, ranks in 1usize..13,
            px in any::<bool>(), py in any::<bool>()
        ) {
            let Ok(d) = CartDecomposition::new([nx, ny], ranks, [px, py]) else {
                // Only when no factorisation gives each block a cell.
                prop_assert!((1..=ranks).filter(|a| ranks % a == 0).all(|a| a > nx || ranks / a > ny));
                return Ok(());
            };
            prop_assert_eq!(d.ranks(), ranks);
            let mut owner = vec![usize::MAX; nx * ny];
            for r in 0..ranks {
                let b = d.block(r);
                prop_assert!(b.len[0] >= 1 && b.len[1] >= 1);
                for y in b.start[1]..b.start[1] + b.len[1] {
                    for x in b.start[0]..b.start[0] + b.len[0] {
                        prop_assert_eq!(owner[y * nx + x], usize::MAX, "cell ({}, {}) twice", x, y);
                        owner[y * nx + x] = r;
                    }
                }
                // Neighbours are mutual.
                let n = d.neighbors(r);
                if let Some(e) = n.east { prop_assert_eq!(d.neighbors(e).west, Some(r)); }
                if let Some(s) = n.north { prop_assert_eq!(d.neighbors(s).south, Some(r)); }
            }
            prop_assert!(owner.iter().all(|&o| o < ranks));
        }
    }

    #[test]
    fn the_factors_follow_the_grid_shape() {
        let dims = |nx, ny, p| {
            CartDecomposition::new([nx, ny], p, [false; 2])
                .unwrap()
                .dims()
        };
        assert_eq!(dims(100, 100, 4), [2, 2]);
        assert_eq!(dims(1000, 10, 4), [4, 1]);
        assert_eq!(dims(10, 1000, 4), [1, 4]);
        assert_eq!(dims(37, 23, 3), [3, 1]);
        assert_eq!(dims(64, 64, 2), [1, 2]); // a tie: whole rows
        assert_eq!(dims(5, 1, 5), [5, 1]);
        assert!(CartDecomposition::new([2, 2], 5, [false; 2]).is_err());
        assert!(CartDecomposition::new([0, 2], 1, [false; 2]).is_err());
        assert_eq!(split(10, 3, 0), (0, 4));
        assert_eq!(split(10, 3, 2), (7, 3));
    }

    #[test]
    fn neighbours_wrap_only_on_periodic_axes() {
        let d = CartDecomposition::with_dims([9, 9], [3, 1], [true, false]).unwrap();
        let n = d.neighbors(0);
        assert_eq!(
            (n.west, n.east, n.south, n.north),
            (Some(2), Some(1), None, None)
        );
        let d = CartDecomposition::with_dims([9, 9], [1, 1], [true, true]).unwrap();
        let n = d.neighbors(0);
        assert_eq!(
            (n.west, n.east, n.south, n.north),
            (Some(0), Some(0), Some(0), Some(0))
        );
    }

    #[test]
    fn a_serial_exchange_wraps_periodic_axes_at_any_depth() {
        let comm = Comm::serial();
        for depth in 1..=3 {
            let (nx, ny) = (5, 4);
            let (w, h) = (nx + 2 * depth, ny + 2 * depth);
            let d = CartDecomposition::new([nx, ny], 1, [true, true]).unwrap();
            // Two planes; interior cell (x, y) of plane s holds 1000 s + 10 y + x + 1.
            let val = |s: usize, x: usize, y: usize| (1000 * s + 10 * y + x + 1) as f32;
            let mut f = vec![0.0f32; 2 * w * h];
            for s in 0..2 {
                for y in 0..ny {
                    for x in 0..nx {
                        f[s * w * h + (y + depth) * w + x + depth] = val(s, x, y);
                    }
                }
            }
            d.exchange_halo(&comm, &mut f, depth).unwrap();
            // Every padded cell, corners included, holds its periodic image.
            for s in 0..2 {
                for j in 0..h {
                    for i in 0..w {
                        let x = (i + nx * depth - depth) % nx;
                        let y = (j + ny * depth - depth) % ny;
                        assert_eq!(
                            f[s * w * h + j * w + i],
                            val(s, x, y),
                            "depth {depth} ({i}, {j})"
                        );
                    }
                }
            }
            // Non-periodic: the ghosts stay.
            let d = CartDecomposition::new([nx, ny], 1, [false, false]).unwrap();
            let mut g = vec![-1.0f32; w * h];
            d.exchange_halo(&comm, &mut g, depth).unwrap();
            assert!(g.iter().all(|&v| v == -1.0));
        }
        let d = CartDecomposition::new([3, 3], 1, [true, true]).unwrap();
        assert!(d.exchange_halo(&comm, &mut [0.0f64; 24], 1).is_err());
        assert!(d.exchange_halo(&comm, &mut [0.0f64; 25], 0).is_err());
        assert!(d.exchange_halo(&comm, &mut [0.0f64; 7 * 7], 2).is_ok());
        let thin = CartDecomposition::new([1, 3], 1, [true, false]).unwrap();
        assert!(thin.exchange_halo(&comm, &mut [0.0f64; 5 * 7], 2).is_err());
    }

    #[test]
    fn a_serial_gather_returns_the_fields_and_reductions_their_input() {
        let comm = Comm::serial();
        let d = CartDecomposition::new([3, 2], 1, [false; 2]).unwrap();
        let local: Vec<u32> = (0..12).collect();
        assert_eq!(d.gather(&comm, &local).unwrap(), Some(local.clone()));
        assert!(d.gather(&comm, &local[..5]).is_err());
        let two = CartDecomposition::new([3, 2], 2, [false; 2]).unwrap();
        assert!(two.gather(&comm, &local).is_err());
        assert!(comm.all_max(f64::NAN).unwrap().is_nan());
        assert_eq!(comm.all_min(-3.0).unwrap(), -3.0);
        assert_eq!(comm.all_sum(0.1).unwrap(), 0.1);
        assert!(comm.all_any(true).unwrap() && !comm.all_any(false).unwrap());
        assert!(
            comm.shift(&[1.0f64], Some(0), &mut [0.0; 1], None, 0)
                .is_err()
        );
        assert!(
            comm.shift(&[1.0f64], Some(1), &mut [0.0; 1], Some(1), 0)
                .is_err()
        );
        let mut r = [0.0f64; 2];
        comm.shift(&[1.0, 2.0], Some(0), &mut r, Some(0), 0)
            .unwrap();
        assert_eq!(r, [1.0, 2.0]);
        assert_eq!(
            comm.shift_vec(&[5u32, 6, 7], Some(0), Some(0), 0).unwrap(),
            [5, 6, 7]
        );
        assert!(
            comm.shift_vec::<u32>(&[], None, None, 0)
                .unwrap()
                .is_empty()
        );
        assert!(comm.shift_vec(&[1u32], Some(0), None, 0).is_err());
        assert!(comm.shift_vec(&[1u32], Some(2), Some(2), 0).is_err());
        assert_eq!(
            comm.broadcast_from_root(Some(vec![3u8, 4])).unwrap(),
            [3, 4]
        );
        assert!(comm.broadcast_from_root::<u8>(None).is_err());
    }
}
