//! Spatial decomposition of a particle box: which rank owns a particle, migration of
//! particles to their owners, and ghost copies of the particles near a region's faces, all
//! exchanged in the shift pattern (x, then y).

use bytemuck::Pod;

use super::{CartDecomposition, Comm, split};
use crate::{Error, Result};

/// A box cut along x and y into one rectangular region per rank, for particle codes with a
/// short-range interaction (spatial or domain decomposition).
///
/// The x-y extent of the box is divided into cells at least `halo` wide, and the cells
/// into `p_x x p_y` blocks by a [`CartDecomposition`] (uneven splits allowed; rank `r` holds
/// block `(r % p_x, r / p_x)`). Rank `r` owns the particles whose x and y lie in its
/// region ([`ParticleDomain::region`]); coordinates outside the box along a closed axis
/// belong to the edge regions. Any further axis (z in 3D) is not cut.
///
/// Every region is at least one cell, so at least `halo`, wide: a particle within `halo` of
/// a region lies in that region or in one of its 8 neighbours, and each rank exchanges
/// ghosts with 4 of them only ([`ParticleDomain::ghosts`]: first along x, then along y with
/// the x ghosts included, so the corners arrive in the second shift).
///
/// ```
/// use simkit_backend::comm::{Comm, ParticleDomain};
/// # fn main() -> simkit_backend::Result<()> {
/// let comm = Comm::serial();
/// // A 10 x 4 box, periodic along x, ghosts within 1.5 of a face.
/// let d = ParticleDomain::new([0.0, 0.0], [10.0, 4.0], [true, false], 1.5, None, comm.size())?;
/// assert_eq!(d.owner([9.9, 2.0]), 0);
/// // Particles as [x, y]: the one near x = 0 comes back as a ghost shifted by +10 (the
/// // periodic image east of the box), the one near x = 10 shifted by -10.
/// let mut local = vec![[0.5, 2.0], [5.0, 2.0], [9.5, 2.0]];
/// let plan = d.ghosts(&comm, &mut local, |p| *p, |p, s| {
///     p[0] += s[0];
///     p[1] += s[1];
/// })?;
/// assert_eq!((plan.owned(), plan.ghosts()), (3, 2));
/// assert_eq!(&local[3..], &[[10.5, 2.0], [-0.5, 2.0]]);
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct ParticleDomain {
    cart: CartDecomposition,
    lo: [f64; 2],
    len: [f64; 2],
    periodic: [bool; 2],
    /// Cells along x and y.
    cells: [usize; 2],
    halo: f64,
}

/// Which entries of the local array go to which neighbour, in the order of the
/// exchanges, as [`ParticleDomain::ghosts`] found them; [`GhostPlan::refresh`] sends the
/// same entries again with their current values (e.g. every time step between two list
/// builds).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GhostPlan {
    phases: Vec<Phase>,
    owned: usize,
    total: usize,
}

/// One message of a ghost exchange.
#[derive(Clone, Debug, PartialEq)]
struct Phase {
    /// Local indices of the entries sent.
    send: Vec<u32>,
    /// Added to the x and y of every entry sent (a periodic image), if any.
    shift: Option<[f64; 2]>,
    dest: Option<usize>,
    source: Option<usize>,
    /// Entries received (appended to the local array).
    recv: usize,
    tag: u16,
}

/// Tags of the four ghost messages and of the migration messages.
const GHOST_TAG: u16 = 0x4740;
const MIGRATE_TAG: u16 = 0x4d40;

impl ParticleDomain {
    /// The box `[lo, lo + len)` (x and y) with the given periodic axes, cut into
    /// `ranks` regions at least `halo` wide: into `dims = [p_x, p_y]` blocks when given
    /// (e.g. `[ranks, 1]` to keep a vertical y whole), else into the factorisation with
    /// the smallest faces ([`CartDecomposition::new`]).
    ///
    /// Errors: non-finite or non-positive lengths or halo, a non-finite corner, or more
    /// blocks along an axis than the `floor(len / halo)` cells it holds (a smaller halo, a
    /// larger box or fewer ranks fixes it).
    pub fn new(
        lo: [f64; 2],
        len: [f64; 2],
        periodic: [bool; 2],
        halo: f64,
        dims: Option<[usize; 2]>,
        ranks: usize,
    ) -> Result<Self> {
        if !(halo.is_finite() && halo > 0.0) {
            return Err(Error::invalid(
                "ghost halo width",
                halo,
                "must be finite and > 0",
            ));
        }
        for a in 0..2 {
            if !(lo[a].is_finite() && len[a].is_finite() && len[a] > 0.0) {
                return Err(Error::invalid(
                    format!("box along axis {a}"),
                    format!("corner {}, length {}", lo[a], len[a]),
                    "the corner must be finite and the length finite and > 0",
                ));
            }
        }
        // Cells at least `halo` wide; a cell count that does not fit usize saturates.
        let cells = len.map(|l| ((l / halo).floor() as usize).max(1));
        let cart = match dims {
            Some(d) => CartDecomposition::with_dims(cells, d, periodic),
            None => CartDecomposition::new(cells, ranks, periodic),
        }
        .map_err(|e| {
            Error::invalid(
                "rank count",
                ranks,
                format!(
                    "the box {} x {} holds {} x {} regions at least {halo} (the ghost halo) \
                     wide ({e}); use fewer ranks or a larger box",
                    len[0], len[1], cells[0], cells[1]
                ),
            )
        })?;
        if cart.ranks() != ranks {
            return Err(Error::invalid(
                "decomposition",
                format!("{:?}", cart.dims()),
                format!("p_x * p_y must equal the rank count {ranks}"),
            ));
        }
        Ok(Self {
            cart,
            lo,
            len,
            periodic,
            cells,
            halo,
        })
    }

    /// Regions along x and y, `[p_x, p_y]`.
    pub fn dims(&self) -> [usize; 2] {
        self.cart.dims()
    }

    /// Number of regions (ranks).
    pub fn ranks(&self) -> usize {
        self.cart.ranks()
    }

    /// The ghost halo width.
    pub fn halo(&self) -> f64 {
        self.halo
    }

    /// Coordinate of the lower face of block `c` along `axis` (`c == p` gives the upper
    /// face of the box).
    fn face(&self, axis: usize, c: usize) -> f64 {
        let p = self.cart.dims()[axis];
        if c >= p {
            return self.lo[axis] + self.len[axis];
        }
        let (start, _) = split(self.cells[axis], p, c);
        self.lo[axis] + self.len[axis] * (start as f64 / self.cells[axis] as f64)
    }

    /// The block along `axis` that holds coordinate `x` (outside the box: the edge block).
    fn block_along(&self, axis: usize, x: f64) -> usize {
        let p = self.cart.dims()[axis];
        (1..p).take_while(|&c| x >= self.face(axis, c)).count()
    }

    /// The rank whose region holds `(x, y)`; coordinates outside the box (or NaN) belong to
    /// the edge regions, so every particle has one owner. Periodic coordinates must be
    /// wrapped into the box first.
    pub fn owner(&self, xy: [f64; 2]) -> usize {
        let c = [self.block_along(0, xy[0]), self.block_along(1, xy[1])];
        c[1] * self.cart.dims()[0] + c[0]
    }

    /// Lower and upper corners (x, y) of `rank`'s region (`rank < ranks()`).
    pub fn region(&self, rank: usize) -> ([f64; 2], [f64; 2]) {
        let c = self.cart.coords(rank);
        (
            [self.face(0, c[0]), self.face(1, c[1])],
            [self.face(0, c[0] + 1), self.face(1, c[1] + 1)],
        )
    }

    /// Sends every particle of `items` to the rank that owns it (by `xy`, wrapped into the
    /// box along periodic axes) and returns this rank's particles: those it kept, in their
    /// order, then those received. In the shift pattern: first along x, then along y, so a
    /// particle may move into any of the 8 neighbouring regions (as after a few time steps
    /// between list builds). Collective.
    ///
    /// Errors: a communicator of another size, or a particle owned by a region that is not
    /// a neighbour (it moved farther than one region, e.g. a blown-up run): then every rank
    /// returns an error (this rank's own, or one naming the rank that found it).
    pub fn migrate<R: Pod>(
        &self,
        comm: &Comm,
        items: Vec<R>,
        xy: impl Fn(&R) -> [f64; 2],
    ) -> Result<Vec<R>> {
        self.cart.check_comm(comm)?;
        let me = self.cart.coords(comm.rank());
        let nb = self.cart.neighbors(comm.rank());
        let dims = self.cart.dims();
        let mut items = items;
        // A particle that belongs to no neighbour stays here, and after the exchanges
        // every rank returns the error (none is left waiting in a collective call).
        let mut stray: Option<Error> = None;
        for (axis, down, up) in [(0, nb.west, nb.east), (1, nb.south, nb.north)] {
            let p = dims[axis];
            let below = (me[axis] + p - 1) % p;
            let above = (me[axis] + 1) % p;
            let (mut keep, mut to_down, mut to_up) = (Vec::new(), Vec::new(), Vec::new());
            for it in items {
                let x = xy(&it)[axis];
                let c = self.block_along(axis, x);
                if c == me[axis] {
                    keep.push(it);
                } else if down.is_some() && c == below {
                    to_down.push(it);
                } else if up.is_some() && c == above {
                    to_up.push(it);
                } else {
                    keep.push(it);
                    stray.get_or_insert_with(|| {
                        Error::invalid(
                            "particle migration",
                            format!("coordinate {x} along axis {axis}"),
                            format!(
                                "a particle may move at most into the next region (block {} \
                                 of {p}) between exchanges; it reached block {c}: the run \
                                 moved too far between list builds (blown up?)",
                                me[axis]
                            ),
                        )
                    });
                }
            }
            let tag = MIGRATE_TAG + 2 * axis as u16;
            // Down-going: from the `up` neighbour; then up-going: from the `down` one.
            keep.extend(comm.shift_vec(&to_down, down, up, tag)?);
            keep.extend(comm.shift_vec(&to_up, up, down, tag + 1)?);
            items = keep;
        }
        comm.agree(stray.map_or(Ok(()), Err))?;
        Ok(items)
    }

    /// Appends to `local` (this rank's owned particles, each inside its region along x and
    /// y) copies of every particle of the other regions, and of periodic images, that lie
    /// within `halo` of the region, and returns the plan of the exchange. In the shift
    /// pattern: west-going and east-going messages of the owned particles within `halo` of
    /// the west and east faces, then south- and north-going ones of the owned particles and
    /// the x ghosts, so the corner ghosts travel in the second shift. A copy that crosses a
    /// periodic face gets `shift(copy, [sx, sy])` with the box length added or subtracted
    /// (called only when the shift is not zero). With one region along a periodic axis the
    /// messages go to this rank itself (its own images). Collective.
    ///
    /// Errors: a communicator of another size.
    pub fn ghosts<R: Pod>(
        &self,
        comm: &Comm,
        local: &mut Vec<R>,
        xy: impl Fn(&R) -> [f64; 2],
        shift: impl Fn(&mut R, [f64; 2]),
    ) -> Result<GhostPlan> {
        self.cart.check_comm(comm)?;
        let rank = comm.rank();
        let me = self.cart.coords(rank);
        let nb = self.cart.neighbors(rank);
        let dims = self.cart.dims();
        let (lo, hi) = self.region(rank);
        let mut plan = GhostPlan {
            phases: Vec::with_capacity(4),
            owned: local.len(),
            total: local.len(),
        };
        let moves = [
            (0, false, nb.west, nb.east),
            (0, true, nb.east, nb.west),
            (1, false, nb.south, nb.north),
            (1, true, nb.north, nb.south),
        ];
        // Along x only the owned particles are candidates; along y the x ghosts too.
        let mut candidates = local.len();
        for (k, (axis, up, dest, source)) in moves.into_iter().enumerate() {
            if axis == 1 && !up {
                candidates = local.len();
            }
            let send: Vec<u32> = match dest {
                None => Vec::new(),
                Some(_) => (0..candidates)
                    .filter(|&i| {
                        let x = xy(&local[i])[axis];
                        if up {
                            x >= hi[axis] - self.halo
                        } else {
                            x < lo[axis] + self.halo
                        }
                    })
                    .map(|i| i as u32)
                    .collect(),
            };
            // Crossing the periodic face: the copy is the image on the other side.
            let crosses = if up {
                me[axis] + 1 == dims[axis]
            } else {
                me[axis] == 0
            };
            let shift_by = (crosses && dest.is_some()).then(|| {
                let mut s = [0.0; 2];
                s[axis] = if up { -self.len[axis] } else { self.len[axis] };
                s
            });
            let mut phase = Phase {
                send,
                shift: shift_by,
                dest,
                source,
                recv: 0,
                tag: GHOST_TAG + k as u16,
            };
            let got = phase.exchange(comm, local, None, &shift)?;
            phase.recv = got.len();
            local.extend(got);
            plan.phases.push(phase);
        }
        plan.total = local.len();
        Ok(plan)
    }
}

impl Phase {
    /// Sends the listed entries of `local` (shifted) and returns what arrived; with
    /// `expect`, checks that the same number arrived as when the plan was made.
    fn exchange<R: Pod>(
        &self,
        comm: &Comm,
        local: &[R],
        expect: Option<usize>,
        shift: &impl Fn(&mut R, [f64; 2]),
    ) -> Result<Vec<R>> {
        if self.dest.is_none() && self.source.is_none() {
            return Ok(Vec::new());
        }
        let out: Vec<R> = self
            .send
            .iter()
            .map(|&i| {
                let mut r = local[i as usize];
                if let Some(s) = self.shift {
                    shift(&mut r, s);
                }
                r
            })
            .collect();
        match expect {
            None => comm.shift_vec(&out, self.dest, self.source, self.tag),
            Some(n) => {
                let mut recv = vec![R::zeroed(); if self.source.is_some() { n } else { 0 }];
                comm.shift(&out, self.dest, &mut recv, self.source, self.tag)?;
                Ok(recv)
            }
        }
    }
}

impl GhostPlan {
    /// Owned particles at the front of the local array.
    pub fn owned(&self) -> usize {
        self.owned
    }

    /// Ghost copies after them.
    pub fn ghosts(&self) -> usize {
        self.total - self.owned
    }

    /// Entries this rank sends per exchange (ghost copies it provides, counted once per
    /// message).
    pub fn sent(&self) -> usize {
        self.phases.iter().map(|p| p.send.len()).sum()
    }

    /// Messages this rank sends per exchange (to itself included).
    pub fn messages(&self) -> usize {
        self.phases.iter().filter(|p| p.dest.is_some()).count()
    }

    /// Sends the same entries as when the plan was made, with their current values in
    /// `local` (owned particles first, then the ghosts, `owned() + ghosts()` entries, of any
    /// `Pod` type), and overwrites the ghosts with what arrives; `shift` as for
    /// [`ParticleDomain::ghosts`]. Collective.
    ///
    /// Errors: a `local` of another length than the plan's, or (with MPI) a message of
    /// another length than when the plan was made (ranks that disagree on the plan).
    pub fn refresh<R: Pod>(
        &self,
        comm: &Comm,
        local: &mut [R],
        shift: impl Fn(&mut R, [f64; 2]),
    ) -> Result<()> {
        if local.len() != self.total {
            return Err(Error::invalid(
                "length of the local particles",
                local.len(),
                format!(
                    "must equal the plan's {} owned plus {} ghosts",
                    self.owned,
                    self.ghosts()
                ),
            ));
        }
        let mut at = self.owned;
        for p in &self.phases {
            let got = p.exchange(comm, local, Some(p.recv), &shift)?;
            local[at..at + got.len()].copy_from_slice(&got);
            at += p.recv;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn domain(len: [f64; 2], periodic: [bool; 2], halo: f64, dims: [usize; 2]) -> ParticleDomain {
        ParticleDomain::new(
            [0.0, 0.0],
            len,
            periodic,
            halo,
            Some(dims),
            dims[0] * dims[1],
        )
        .expect("domain")
    }

    #[test]
    fn regions_tile_the_box_and_owners_agree_with_them() {
        let d = domain([10.0, 7.0], [false, true], 1.2, [3, 2]);
        let mut area = 0.0;
        for r in 0..6 {
            let (lo, hi) = d.region(r);
            assert!(
                hi[0] - lo[0] >= 1.2 && hi[1] - lo[1] >= 1.2,
                "{lo:?} {hi:?}"
            );
            area += (hi[0] - lo[0]) * (hi[1] - lo[1]);
            // Corners belong to the region (lower faces in, upper faces out).
            assert_eq!(d.owner(lo), r);
            assert_eq!(d.owner([hi[0] - 1e-9, hi[1] - 1e-9]), r);
        }
        assert!((area - 70.0).abs() < 1e-9, "{area}");
        // Outside a closed axis: the edge regions.
        assert_eq!(d.owner([-5.0, 0.1]), 0);
        assert_eq!(d.owner([50.0, 0.1]), 2);
        assert_eq!(d.owner([f64::NAN, 0.1]), 0);
    }

    #[test]
    fn too_many_regions_for_the_halo_are_refused() {
        let e = ParticleDomain::new([0.0; 2], [3.0, 3.0], [false; 2], 1.1, Some([3, 1]), 3)
            .expect_err("3 regions of 1.0 < 1.1");
        assert!(e.to_string().contains("fewer ranks"), "{e}");
        for halo in [0.0, f64::NAN, -1.0] {
            assert!(ParticleDomain::new([0.0; 2], [3.0; 2], [false; 2], halo, None, 1).is_err());
        }
    }

    #[test]
    fn one_region_ghosts_are_the_periodic_images_near_the_faces() {
        let d = domain([6.0, 5.0], [true, true], 1.0, [1, 1]);
        let comm = Comm::serial();
        let owned = vec![[0.5, 0.5], [3.0, 2.5], [5.5, 4.25]];
        let mut local = owned.clone();
        let plan = d
            .ghosts(
                &comm,
                &mut local,
                |p| *p,
                |p, s| {
                    p[0] += s[0];
                    p[1] += s[1];
                },
            )
            .expect("ghosts");
        // x: (6.5, 0.5) and (-0.5, 4.25); y from the owned and those: every image of the
        // two corner particles.
        let mut ghosts = local[3..].to_vec();
        ghosts.sort_by(|a, b| a.partial_cmp(b).expect("finite"));
        let want = [
            [-0.5, -0.75],
            [-0.5, 4.25],
            [0.5, 5.5],
            [5.5, -0.75],
            [6.5, 0.5],
            [6.5, 5.5],
        ];
        assert_eq!(ghosts, want);
        assert_eq!((plan.owned(), plan.ghosts(), plan.messages()), (3, 6, 4));
        // A refresh sends the same entries with the new values.
        local[0] = [0.25, 0.75];
        plan.refresh(&comm, &mut local, |p, s| {
            p[0] += s[0];
            p[1] += s[1];
        })
        .expect("refresh");
        assert!(local[3..].contains(&[6.25, 0.75]) && local[3..].contains(&[6.25, 5.75]));
        assert!(plan.refresh(&comm, &mut local[..4], |_, _| {}).is_err());
    }

    #[test]
    fn closed_axes_have_no_images_and_migration_keeps_everything() {
        let d = domain([6.0, 5.0], [false, false], 1.0, [1, 1]);
        let comm = Comm::serial();
        let mut local = vec![[0.5, 0.5], [5.5, 4.5]];
        let plan = d
            .ghosts(&comm, &mut local, |p| *p, |_, _| {})
            .expect("ghosts");
        assert_eq!((plan.ghosts(), plan.messages()), (0, 0));
        let moved = d
            .migrate(&comm, vec![[-1.0, 9.0], [3.0, 3.0]], |p| *p)
            .expect("migrate");
        assert_eq!(moved, vec![[-1.0, 9.0], [3.0, 3.0]]);
    }
}
