//! [`RankParticles`]: one rank's particles in a distributed particle run (spatial
//! decomposition, ghosts, migration, snapshots, gathers in global order), the skeleton that
//! `dem`'s and `md`'s distributed runs share.

use bytemuck::Pod;

use simkit_backend::comm::Comm;
use simkit_backend::{Error, Result};

use crate::GhostedList;

/// Values in a [`Record`]: the global index, the position and the per-particle columns.
pub const RECORD: usize = 32;

/// A particle as it travels between ranks (migration, gathers in global order): its global
/// index, then its position and columns, `D` values each (see [`RankParticles`]); unused
/// values are 0.
pub type Record = [f64; RECORD];

/// What a rank's check found, as the ranks exchange it: `[kind, global index, a, b, c]`,
/// the kinds and the meaning of `a, b, c` the crate's own; `kind` at or above the crate's
/// "nothing found" value means the check passed.
pub type Finding = [f64; 5];

/// One rank's particles in a distributed particle run whose results must not depend on the
/// rank count: the decomposition and full lists ([`GhostedList`]), the owned particles
/// (integrated here) and the ghosts (copies of the particles within the list range of the
/// region), and their data in local order, owned first.
///
/// The data per particle:
/// - its global index, its constants `C` (species, radius, mass, ...: a copy of the run's
///   table entry, fetched by index for owned particles and ghosts alike),
/// - its position (owned: not wrapped since the list build; ghosts: refreshed every step,
///   periodic images shifted),
/// - `shared` vector columns that the pair terms read from ghosts too (e.g. `dem`'s
///   predicted velocities), refreshed with the positions,
/// - `cols` vector columns of the owned particles only (velocities, accelerations, ...),
/// - the position of the last list build (owned).
///
/// A list build ([`RankParticles::rebuild`]) wraps the periodic coordinates, sends every
/// particle with its columns to the rank that owns it now, and makes ghosts and lists
/// anew; [`RankParticles::keep`] and [`RankParticles::restore`] are the blow-up guard's
/// copy of the owned data (the lists are rebuilt from the kept list-build positions, so
/// they are those the run had). Every method that takes a [`Comm`] is collective, and an
/// error on one rank is an error on every rank.
#[derive(Clone, Debug)]
pub struct RankParticles<const D: usize, C> {
    list: GhostedList<D>,
    lo: [f64; D],
    hi: [f64; D],
    len: [f64; D],
    periodic: [bool; D],
    /// Constants of every particle of the run, by global index.
    table: Vec<C>,
    owned: usize,
    id: Vec<u32>,
    props: Vec<C>,
    pos: Vec<[f64; D]>,
    shared: Vec<Vec<[f64; D]>>,
    cols: Vec<Vec<[f64; D]>>,
    reference: Vec<[f64; D]>,
    builds: u64,
    kept: Kept<D>,
}

/// The owned data at the last [`RankParticles::keep`].
#[derive(Clone, Debug, Default)]
struct Kept<const D: usize> {
    id: Vec<u32>,
    pos: Vec<[f64; D]>,
    shared: Vec<Vec<[f64; D]>>,
    cols: Vec<Vec<[f64; D]>>,
    reference: Vec<[f64; D]>,
}

/// Simultaneous access to the local data of a [`RankParticles`] (see
/// [`RankParticles::parts`]).
#[derive(Debug)]
pub struct Parts<'a, const D: usize, C> {
    /// Owned particles (the first entries of the local arrays).
    pub owned: usize,
    /// Global index, owned then ghosts.
    pub id: &'a [u32],
    /// Constants, owned then ghosts.
    pub props: &'a [C],
    /// Positions, owned then ghosts.
    pub pos: &'a mut [[f64; D]],
    /// The shared columns, owned then ghosts.
    pub shared: &'a mut [Vec<[f64; D]>],
    /// The columns of the owned particles.
    pub cols: &'a mut [Vec<[f64; D]>],
    /// The list-build positions of the owned particles.
    pub reference: &'a [[f64; D]],
    /// The lists (partners in local order, sorted by global index).
    pub list: &'a GhostedList<D>,
}

impl<const D: usize, C: Copy + Send + Sync> RankParticles<D, C>
where
    [f64; D]: Pod,
{
    /// No particles yet, over the decomposition and lists of `list`, in the box `[lo, lo +
    /// len)` with `periodic` axes, for a run whose particles have the constants `table`,
    /// with `shared` shared and `cols` owned columns.
    ///
    /// Errors: more columns than a [`Record`] holds (`1 + D (1 + shared + cols) <= 32`).
    pub fn new(
        list: GhostedList<D>,
        box_: ([f64; D], [f64; D], [bool; D]),
        table: Vec<C>,
        shared: usize,
        cols: usize,
    ) -> Result<Self> {
        let width = 1 + D * (1 + shared + cols);
        if width > RECORD {
            return Err(Error::invalid(
                "per-particle columns",
                format!("{shared} shared and {cols} owned in {D}D"),
                format!("a record holds {RECORD} values, these need {width}; this is a bug"),
            ));
        }
        let (lo, len, periodic) = box_;
        Ok(Self {
            list,
            lo,
            hi: std::array::from_fn(|d| lo[d] + len[d]),
            len,
            periodic,
            table,
            owned: 0,
            id: Vec::new(),
            props: Vec::new(),
            pos: Vec::new(),
            shared: vec![Vec::new(); shared],
            cols: vec![Vec::new(); cols],
            reference: Vec::new(),
            builds: 0,
            kept: Kept::default(),
        })
    }

    /// The decomposition and lists.
    pub fn list(&self) -> &GhostedList<D> {
        &self.list
    }

    /// Particles of the run (all ranks).
    pub fn total(&self) -> usize {
        self.table.len()
    }

    /// The constants of every particle of the run, by global index.
    pub fn table(&self) -> &[C] {
        &self.table
    }

    /// Sizes of this rank's part.
    pub fn view(&self) -> crate::RankView {
        crate::RankView {
            total: self.total(),
            owned: self.owned,
            ghosts: self.ghosts(),
            dims: self.list.domain().dims(),
            builds: self.builds,
        }
    }

    /// Owned particles.
    pub fn owned(&self) -> usize {
        self.owned
    }

    /// Ghost entries.
    pub fn ghosts(&self) -> usize {
        self.pos.len() - self.owned
    }

    /// List builds so far (each with a migration; a start or a resume counts one).
    pub fn builds(&self) -> u64 {
        self.builds
    }

    /// Global indices, owned then ghosts.
    pub fn id(&self) -> &[u32] {
        &self.id
    }

    /// Constants, owned then ghosts.
    pub fn props(&self) -> &[C] {
        &self.props
    }

    /// Positions, owned then ghosts.
    pub fn pos(&self) -> &[[f64; D]] {
        &self.pos
    }

    /// Owned column `c`.
    pub fn col(&self, c: usize) -> &[[f64; D]] {
        &self.cols[c]
    }

    /// Shared column `c`, owned then ghosts.
    pub fn shared(&self, c: usize) -> &[[f64; D]] {
        &self.shared[c]
    }

    /// The list-build positions of the owned particles.
    pub fn reference(&self) -> &[[f64; D]] {
        &self.reference
    }

    /// Every local array at once, for passes that read some and write others.
    pub fn parts(&mut self) -> Parts<'_, D, C> {
        Parts {
            owned: self.owned,
            id: &self.id,
            props: &self.props,
            pos: &mut self.pos,
            shared: &mut self.shared,
            cols: &mut self.cols,
            reference: &self.reference,
            list: &self.list,
        }
    }

    /// Wraps the periodic coordinates of `x` into the box (one box length at most).
    pub fn wrap(&self, x: &mut [f64; D]) {
        crate::wrap_periodic(x, self.lo, self.hi, self.len, self.periodic);
    }

    /// Whether this rank's region holds (wrapped) position `x`.
    fn mine(&self, comm: &Comm, x: [f64; D]) -> bool {
        let mut x = x;
        self.wrap(&mut x);
        self.list.domain().owner([x[0], x[1]]) == comm.rank()
    }

    /// Makes `ids` (global indices) the owned particles, their columns sized and zero.
    fn take(&mut self, ids: &[usize]) {
        let n = ids.len();
        self.owned = n;
        self.id = ids.iter().map(|&i| i as u32).collect();
        self.props = ids.iter().map(|&i| self.table[i]).collect();
        for v in std::iter::once(&mut self.pos)
            .chain(std::iter::once(&mut self.reference))
            .chain(self.shared.iter_mut())
            .chain(self.cols.iter_mut())
        {
            v.clear();
            v.resize(n, [0.0; D]);
        }
    }

    /// The initial state: this rank takes the particles of the run whose (wrapped)
    /// position `position(i)` lies in its region, at that position, columns zero. Returns
    /// their global indices (local order) so that the caller fills the columns, then calls
    /// [`RankParticles::rebuild`].
    pub fn start(&mut self, comm: &Comm, position: impl Fn(usize) -> [f64; D]) -> Vec<usize> {
        let mine: Vec<usize> = (0..self.total())
            .filter(|&i| self.mine(comm, position(i)))
            .collect();
        self.take(&mine);
        for (k, &i) in mine.iter().enumerate() {
            self.pos[k] = position(i);
        }
        mine
    }

    /// A checkpointed state of `slots` slots: this rank takes the slots whose list-build
    /// position `reference(slot)` lies in its region (where the run that wrote it had the
    /// particle), the particle of global index `id(slot)`, with that list-build position.
    /// Returns the slots taken (local order) so that the caller fills the positions and
    /// columns, then calls [`RankParticles::relist`].
    pub fn load(
        &mut self,
        comm: &Comm,
        slots: usize,
        reference: impl Fn(usize) -> [f64; D],
        id: impl Fn(usize) -> usize,
    ) -> Vec<usize> {
        let mine: Vec<usize> = (0..slots)
            .filter(|&k| {
                let r = reference(k);
                self.list.domain().owner([r[0], r[1]]) == comm.rank()
            })
            .collect();
        let ids: Vec<usize> = mine.iter().map(|&k| id(k)).collect();
        self.take(&ids);
        for (k, &slot) in mine.iter().enumerate() {
            self.reference[k] = reference(slot);
        }
        mine
    }

    /// Sets the position of owned particle `k` (after [`RankParticles::load`]).
    pub fn set_position(&mut self, k: usize, x: [f64; D]) {
        self.pos[k] = x;
    }

    /// Sets owned column `c` of owned particle `k`, or shared column `c` when `shared`
    /// (after [`RankParticles::start`] or [`RankParticles::load`]).
    pub fn set(&mut self, shared: bool, c: usize, k: usize, x: [f64; D]) {
        let col = if shared {
            &mut self.shared[c]
        } else {
            &mut self.cols[c]
        };
        col[k] = x;
    }

    /// The record of owned particle `k` with position `x` (the list-build position in
    /// place of the position when `reference`).
    fn record(&self, k: usize, x: &[f64; D]) -> Record {
        let mut r = [0.0; RECORD];
        r[0] = f64::from(self.id[k]);
        r[1..1 + D].copy_from_slice(x);
        let mut at = 1 + D;
        for col in self.shared.iter().chain(&self.cols) {
            r[at..at + D].copy_from_slice(&col[k]);
            at += D;
        }
        r
    }

    /// Refuses (on every rank) a global index that is not a particle of the run.
    fn check_ids<'a>(
        &self,
        comm: &Comm,
        what: &str,
        ids: impl IntoIterator<Item = &'a f64>,
    ) -> Result<()> {
        let total = self.total();
        let bad = ids.into_iter().find(|&&i| !(i >= 0.0 && i < total as f64));
        comm.agree(match bad {
            Some(i) => Err(Error::invalid(
                what,
                i,
                format!("must be below the particle count {total}"),
            )),
            None => Ok(()),
        })
    }

    /// A list build: wraps the owned positions, sends every particle with its columns to
    /// the rank that owns it now, and makes the ghosts and lists anew from the new
    /// list-build positions (the wrapped positions). Collective.
    ///
    /// Errors: a particle that left the reach of the neighbouring regions, a corrupt
    /// index, or a failed exchange (on every rank).
    pub fn rebuild(&mut self, comm: &Comm) -> Result<()> {
        let out: Vec<Record> = (0..self.owned)
            .map(|k| {
                let mut x = self.pos[k];
                self.wrap(&mut x);
                self.record(k, &x)
            })
            .collect();
        let got = self.list.domain().migrate(comm, out, |r| [r[1], r[2]])?;
        self.check_ids(comm, "migrated particle index", got.iter().map(|r| &r[0]))?;
        let ids: Vec<usize> = got.iter().map(|r| r[0] as usize).collect();
        self.take(&ids);
        for (k, r) in got.iter().enumerate() {
            self.pos[k] = std::array::from_fn(|d| r[1 + d]);
            let mut at = 1 + D;
            for col in self.shared.iter_mut().chain(self.cols.iter_mut()) {
                col[k] = std::array::from_fn(|d| r[at + d]);
                at += D;
            }
        }
        self.reference.clone_from(&self.pos);
        self.relist(comm)
    }

    /// Ghosts and lists from the list-build positions of the owned particles, then the
    /// ghosts' positions and shared columns refreshed. Collective.
    ///
    /// Errors: a corrupt index or a failed exchange (on every rank).
    pub fn relist(&mut self, comm: &Comm) -> Result<()> {
        let n = self.owned;
        self.list.build(comm, &self.reference, &self.id[..n])?;
        self.id.truncate(n);
        self.props.truncate(n);
        let ghosts: Vec<f64> = self.list.ids()[n..].iter().map(|&i| f64::from(i)).collect();
        self.check_ids(comm, "ghost particle index", &ghosts)?;
        for &i in &self.list.ids()[n..] {
            self.id.push(i);
            self.props.push(self.table[i as usize]);
        }
        let len = self.list.len();
        self.pos.resize(len, [0.0; D]);
        for col in &mut self.shared {
            col.resize(len, [0.0; D]);
        }
        self.refresh(comm)?;
        self.builds += 1;
        Ok(())
    }

    /// Sends the owned positions (periodic images shifted) and shared columns to the ranks
    /// that hold ghosts of them. Collective.
    ///
    /// Errors: a failed exchange.
    pub fn refresh(&mut self, comm: &Comm) -> Result<()> {
        self.list.refresh(comm, &mut self.pos, true)?;
        for col in &mut self.shared {
            self.list.refresh(comm, col, false)?;
        }
        Ok(())
    }

    /// Copies the owned data (the blow-up guard's snapshot).
    pub fn keep(&mut self) {
        let (k, n) = (&mut self.kept, self.owned);
        k.id.clear();
        k.id.extend_from_slice(&self.id[..n]);
        k.pos.clear();
        k.pos.extend_from_slice(&self.pos[..n]);
        k.shared.resize(self.shared.len(), Vec::new());
        for (to, from) in k.shared.iter_mut().zip(&self.shared) {
            to.clear();
            to.extend_from_slice(&from[..n]);
        }
        k.cols.clone_from(&self.cols);
        k.reference.clone_from(&self.reference);
    }

    /// Puts every rank back to its snapshot (the particles it owned then) and remakes
    /// ghosts and lists from the kept list-build positions, so the lists are those the run
    /// had. Collective.
    ///
    /// Errors: as [`RankParticles::relist`].
    pub fn restore(&mut self, comm: &Comm) -> Result<()> {
        let ids: Vec<usize> = self.kept.id.iter().map(|&i| i as usize).collect();
        self.take(&ids);
        let k = &self.kept;
        self.pos.clone_from(&k.pos);
        for (to, from) in self.shared.iter_mut().zip(&k.shared) {
            to.clone_from(from);
        }
        self.cols.clone_from(&k.cols);
        self.reference.clone_from(&k.reference);
        self.relist(comm)
    }

    /// Every particle's record in global order on rank 0 (`None` elsewhere):
    /// `row(k)` gives owned particle `k`'s values after its global index (the position
    /// slots first). Collective.
    ///
    /// Errors: a failed exchange, or ranks whose particles are not each particle once.
    pub fn gather(
        &self,
        comm: &Comm,
        row: impl Fn(usize) -> [f64; RECORD - 1],
    ) -> Result<Option<Vec<Record>>> {
        let mine: Vec<Record> = (0..self.owned)
            .map(|k| {
                let mut r = [0.0; RECORD];
                r[0] = f64::from(self.id[k]);
                r[1..].copy_from_slice(&row(k));
                r
            })
            .collect();
        comm.gather_indexed::<RECORD>(&mine, self.total())
    }

    /// The first finding of all ranks, the same on every rank: `mine` folded with every
    /// rank's by `worse` (which returns the one to report of two). Collective.
    ///
    /// Errors: a failed exchange.
    pub fn findings(
        comm: &Comm,
        mine: Finding,
        nothing: Finding,
        worse: impl Fn(Finding, Finding) -> Finding,
    ) -> Result<Finding> {
        let all = comm.all_gather(&[mine])?;
        Ok(all.iter().copied().fold(nothing, worse))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use simkit_backend::comm::ParticleDomain;

    fn rank() -> RankParticles<2, u32> {
        let domain = ParticleDomain::new([0.0; 2], [8.0; 2], [true; 2], 1.2, None, 1).unwrap();
        let list = GhostedList::<2>::new(domain, None, 1.2).unwrap();
        RankParticles::new(list, ([0.0; 2], [8.0; 2], [true; 2]), vec![7, 8, 9], 1, 2).unwrap()
    }

    #[test]
    fn start_rebuild_keep_restore_and_gather() {
        let comm = Comm::serial();
        let mut r = rank();
        let x = [[0.3, 4.0], [7.8, 4.0], [4.0, 4.0]];
        let mine = r.start(&comm, |i| x[i]);
        assert_eq!(mine, [0, 1, 2]);
        for (k, &i) in mine.iter().enumerate() {
            r.set(false, 0, k, [i as f64, 1.0]);
            r.set(true, 0, k, [10.0 + i as f64, 0.0]);
        }
        r.rebuild(&comm).unwrap();
        assert_eq!((r.owned(), r.builds()), (3, 1));
        // Particle 0 sees 1 through the periodic face; the ghost carries its shared column.
        assert_eq!(r.props()[..3], [7, 8, 9]);
        assert!(r.ghosts() > 0);
        let g = 3 + r.id()[3..].iter().position(|&i| i == 1).unwrap();
        assert_eq!(r.shared(0)[g], [11.0, 0.0]);
        r.keep();
        r.parts().pos[0] = [f64::NAN, 0.0];
        r.parts().cols[0][1] = [99.0, 99.0];
        r.restore(&comm).unwrap();
        assert_eq!(r.pos()[0], [0.3, 4.0]);
        assert_eq!(r.col(0)[1], [1.0, 1.0]);
        let rows = r.gather(&comm, |k| {
            let mut v = [0.0; RECORD - 1];
            v[..2].copy_from_slice(&r.col(0)[k]);
            v
        });
        let rows = rows.unwrap().unwrap();
        assert_eq!(rows.len(), 3);
        assert_eq!(rows[2][..3], [2.0, 2.0, 1.0]);
        // Too many columns for a record.
        let domain = ParticleDomain::new([0.0; 2], [8.0; 2], [true; 2], 1.2, None, 1).unwrap();
        let list = GhostedList::<3>::new(domain, None, 1.2).unwrap();
        assert!(
            RankParticles::<3, u32>::new(list, ([0.0; 3], [8.0; 3], [true; 3]), vec![], 3, 7)
                .is_err()
        );
    }
}
