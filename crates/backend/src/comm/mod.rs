//! Communication between the processes of a distributed run: one layer every crate uses.
//!
//! - [`Comm`]: the communicator. [`Comm::serial`] (always compiled) is one process talking to
//!   itself; `Comm::mpi` (cargo feature `mpi`, off by default) is `MPI_COMM_WORLD` through
//!   the `mpi` crate (rsmpi, MPI-3). Crates take a `Comm` and run the same code on both, so
//!   single-process paths and their tests need no MPI.
//! - [`CartDecomposition`]: a 2D grid cut into `p_x x p_y` rectangular blocks, one per rank
//!   (the factors chosen from the grid shape to keep the halo small, uneven splits allowed),
//!   with neighbour ranks (periodic wrap where asked), halo exchange in the shift pattern
//!   ([`CartDecomposition::exchange_halo`]) and gather of the blocks to rank 0
//!   ([`CartDecomposition::gather`]).
//! - [`ParticleDomain`]: a particle box cut along x and y into one region per rank (at least
//!   a ghost halo wide), with ownership, migration of particles to their owners
//!   ([`ParticleDomain::migrate`]) and ghost copies of the particles near a region's faces
//!   ([`ParticleDomain::ghosts`], [`GhostPlan::refresh`]), in the same shift pattern.
//!
//! Every operation here is collective unless its documentation says otherwise: all ranks
//! must call it, in the same order. Reductions are bitwise deterministic: [`Comm::all_max`]
//! and [`Comm::all_min`] are exact in any order, and [`Comm::all_sum`] adds the ranks'
//! values in rank order on every rank (not MPI's reduction tree), so its result depends on
//! the rank count only through the per-rank partial sums the caller passes in.
//!
//! ```
//! use simkit_backend::comm::{CartDecomposition, Comm};
//! # fn main() -> simkit_backend::Result<()> {
//! let comm = Comm::serial();
//! assert_eq!((comm.rank(), comm.size()), (0, 1));
//! assert_eq!(comm.all_sum(2.5)?, 2.5);
//! // A 5 x 4 field, periodic along x: the halo exchange wraps the block onto itself.
//! let d = CartDecomposition::new([5, 4], comm.size(), [true, false])?;
//! let (nx, ny) = (5, 4);
//! let w = nx + 2;
//! let mut f = vec![0.0f64; w * (ny + 2)];
//! for j in 1..=ny {
//!     for i in 1..=nx {
//!         f[j * w + i] = (10 * j + i) as f64;
//!     }
//! }
//! d.exchange_halo(&comm, &mut f, 1)?;
//! assert_eq!(f[2 * w], f[2 * w + nx]); // west ghost = east-most interior cell
//! assert_eq!(f[w + 1 - w], 0.0); // no south neighbour: the south ghost row is untouched
//! # Ok(())
//! # }
//! ```

mod cart;
mod domain;

pub use cart::{Block, CartDecomposition, Neighbors, split};
pub use domain::{GhostPlan, ParticleDomain};

use crate::{Error, Result, max_or_nan};
use bytemuck::Pod;

#[cfg(feature = "mpi")]
use std::rc::Rc;

/// The processes of a run and the messages between them (see the [module docs](self)).
///
/// Cloning is cheap and shares the same communicator. With MPI, dropping the last clone
/// finalises MPI (it cannot be started again in the same process). With the `mpi` feature
/// a `Comm` is neither `Send` nor `Sync`: it stays on the thread that made it, which is
/// the one thread that communicates (rayon workers compute, they never send).
#[derive(Clone)]
pub struct Comm {
    kind: Kind,
}

#[derive(Clone)]
enum Kind {
    Serial,
    #[cfg(feature = "mpi")]
    Mpi(Rc<MpiWorld>),
}

/// The world communicator and the MPI environment it lives in (dropped in this order).
#[cfg(feature = "mpi")]
struct MpiWorld {
    world: mpi::topology::SimpleCommunicator,
    _universe: mpi::environment::Universe,
}

impl std::fmt::Debug for Comm {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "Comm({}, rank {} of {})",
            self.name(),
            self.rank(),
            self.size()
        )
    }
}

impl Default for Comm {
    /// [`Comm::serial`].
    fn default() -> Self {
        Self::serial()
    }
}

impl Comm {
    /// One process, rank 0 of 1: every exchange is a copy onto itself (periodic wrap) or
    /// nothing, every reduction returns its input.
    pub fn serial() -> Self {
        Self { kind: Kind::Serial }
    }

    /// `MPI_COMM_WORLD`: initialises MPI (thread level `MPI_THREAD_SERIALIZED`, so any one
    /// thread at a time may communicate; rayon workers never do). Start the program with
    /// `mpirun -np P ...`; run directly it is one rank of one.
    ///
    /// Errors: MPI was already initialised in this process (call this once and clone the
    /// `Comm`), or the library gives less than `MPI_THREAD_SERIALIZED`.
    #[cfg(feature = "mpi")]
    pub fn mpi() -> Result<Self> {
        use mpi::Threading;
        let Some((universe, level)) = mpi::initialize_with_threading(Threading::Serialized) else {
            return Err(Error::invalid(
                "Comm::mpi",
                "MPI already initialised",
                "initialise MPI once per process and clone the Comm it returns",
            ));
        };
        if level < Threading::Serialized {
            return Err(Error::Unsupported(format!(
                "the MPI library gives thread level {level:?}; simkit needs \
                 MPI_THREAD_SERIALIZED (build OpenMPI or MPICH with thread support)"
            )));
        }
        let world = universe.world();
        Ok(Self {
            kind: Kind::Mpi(Rc::new(MpiWorld {
                world,
                _universe: universe,
            })),
        })
    }

    /// `"serial"` or `"mpi"`.
    pub fn name(&self) -> &'static str {
        match &self.kind {
            Kind::Serial => "serial",
            #[cfg(feature = "mpi")]
            Kind::Mpi(_) => "mpi",
        }
    }

    /// This process's rank, `0..size()`.
    pub fn rank(&self) -> usize {
        match &self.kind {
            Kind::Serial => 0,
            #[cfg(feature = "mpi")]
            Kind::Mpi(m) => {
                use mpi::traits::Communicator;
                m.world.rank() as usize
            }
        }
    }

    /// Number of ranks.
    pub fn size(&self) -> usize {
        match &self.kind {
            Kind::Serial => 1,
            #[cfg(feature = "mpi")]
            Kind::Mpi(m) => {
                use mpi::traits::Communicator;
                m.world.size() as usize
            }
        }
    }

    /// Whether this is rank 0, the rank that receives gathered fields and writes files.
    pub fn is_root(&self) -> bool {
        self.rank() == 0
    }

    /// Stops every rank of the run with exit status `code` (`MPI_Abort`; on one process,
    /// `std::process::exit`). For a failure on one rank that the others cannot learn of
    /// (they would wait for it forever in the next collective call). Not collective.
    pub fn abort(&self, code: i32) -> ! {
        match &self.kind {
            Kind::Serial => std::process::exit(code),
            #[cfg(feature = "mpi")]
            Kind::Mpi(m) => {
                use mpi::traits::Communicator;
                m.world.abort(code)
            }
        }
    }

    /// This process's place among the ranks on the same machine: `(local rank, ranks on
    /// this machine)` (`MPI_Comm_split_type` with `MPI_COMM_TYPE_SHARED`; one process:
    /// `(0, 1)`). For picking one of the machine's GPUs per rank
    /// (`GpuContext::for_local_rank`). Collective.
    pub fn local_rank(&self) -> (usize, usize) {
        match &self.kind {
            Kind::Serial => (0, 1),
            #[cfg(feature = "mpi")]
            Kind::Mpi(m) => {
                use mpi::traits::Communicator;
                let node = m.world.split_shared(m.world.rank());
                (node.rank() as usize, node.size() as usize)
            }
        }
    }

    /// Waits until every rank has called it.
    pub fn barrier(&self) {
        match &self.kind {
            Kind::Serial => {}
            #[cfg(feature = "mpi")]
            Kind::Mpi(m) => {
                use mpi::traits::CommunicatorCollectives;
                m.world.barrier();
            }
        }
    }

    fn check_rank(&self, what: &str, r: Option<usize>) -> Result<()> {
        match r {
            Some(r) if r >= self.size() => Err(Error::invalid(
                what,
                r,
                format!("must be a rank below the communicator size {}", self.size()),
            )),
            _ => Ok(()),
        }
    }

    /// Checks a shift's partners: `true` when both are this rank (the message is a copy),
    /// an error for a rank `>= size()`.
    fn to_itself(&self, dest: Option<usize>, source: Option<usize>) -> Result<bool> {
        self.check_rank("destination rank", dest)?;
        self.check_rank("source rank", source)?;
        let me = Some(self.rank());
        Ok(dest == me && source == me)
    }

    /// One step of a shift: sends `send` to rank `dest` and receives `recv.len()` values
    /// from rank `source` into `recv`, at the same time (`MPI_Sendrecv`, so a ring or a
    /// chain of shifts cannot deadlock). `None` means no partner on that side (a domain
    /// edge): nothing is sent or received there. `tag` tells shifts apart. Collective over
    /// the ranks that name each other.
    ///
    /// Errors: a rank `>= size()`; on one process, a partner on one side only (the message
    /// would never arrive) or `send` and `recv` of different lengths; with MPI, a message of
    /// another length than `recv` (on the receiving rank; the message is taken off the
    /// wire whole and dropped, so the communicator stays usable and the job is not
    /// aborted by a truncated receive). Such an error is the receiving rank's alone: a
    /// caller that goes on to other collective calls agrees on it first ([`Comm::agree`]).
    // `tag` only matters between processes.
    #[cfg_attr(not(feature = "mpi"), allow(unused_variables))]
    pub fn shift<T: Pod>(
        &self,
        send: &[T],
        dest: Option<usize>,
        recv: &mut [T],
        source: Option<usize>,
        tag: u16,
    ) -> Result<()> {
        if self.to_itself(dest, source)? {
            if send.len() != recv.len() {
                return Err(Error::invalid(
                    "length of a message to this rank itself",
                    send.len(),
                    format!("must equal the receive buffer's length {}", recv.len()),
                ));
            }
            recv.copy_from_slice(send);
            return Ok(());
        }
        match &self.kind {
            Kind::Serial => serial_partners(dest, source),
            #[cfg(feature = "mpi")]
            Kind::Mpi(m) => {
                let want = std::mem::size_of_val(recv);
                let into: &mut [u8] = bytemuck::cast_slice_mut(recv);
                mpi_shift(&m.world, send, dest, source, tag, |msg, bytes, from| {
                    if bytes != want {
                        return refuse(
                            msg,
                            bytes,
                            from,
                            &format!(
                                "the receiver expected {want} bytes: the ranks disagree on the \
                             block sizes"
                            ),
                        );
                    }
                    msg.matched_receive_into(into);
                    Ok(())
                })
                .map(|_| ())
            }
        }
    }

    /// One step of a shift whose message may have any length: sends `send` to rank `dest`
    /// and returns what rank `source` sent this rank (empty when `source` is `None`). The
    /// receiver learns the length from the message itself (`MPI_Mprobe`), so no count
    /// travels ahead of the data and nothing is allocated beyond what arrived. Collective
    /// over the ranks that name each other, as [`Comm::shift`].
    ///
    /// Errors: as [`Comm::shift`], and with MPI a message that is not a whole number of
    /// `T` values.
    #[cfg_attr(not(feature = "mpi"), allow(unused_variables))]
    pub fn shift_vec<T: Pod>(
        &self,
        send: &[T],
        dest: Option<usize>,
        source: Option<usize>,
        tag: u16,
    ) -> Result<Vec<T>> {
        if self.to_itself(dest, source)? {
            return Ok(send.to_vec());
        }
        match &self.kind {
            Kind::Serial => serial_partners(dest, source).map(|()| Vec::new()),
            #[cfg(feature = "mpi")]
            Kind::Mpi(m) => mpi_shift(&m.world, send, dest, source, tag, |msg, bytes, from| {
                let size = std::mem::size_of::<T>();
                if size == 0 || !bytes.is_multiple_of(size) {
                    return refuse(
                        msg,
                        bytes,
                        from,
                        &format!(
                            "must be a whole number of {size}-byte values: the ranks disagree \
                         on the message type"
                        ),
                    );
                }
                let mut out = vec![T::zeroed(); bytes / size];
                msg.matched_receive_into(bytemuck::cast_slice_mut::<T, u8>(&mut out));
                Ok(out)
            })
            .map(Option::unwrap_or_default),
        }
    }

    /// Every rank's `send` (the same length on all ranks), concatenated in rank order, on
    /// every rank.
    ///
    /// Errors: with MPI, ranks that pass different lengths give garbage or abort, so keep
    /// the lengths equal; on one process, never.
    pub fn all_gather<T: Pod>(&self, send: &[T]) -> Result<Vec<T>> {
        match &self.kind {
            Kind::Serial => Ok(send.to_vec()),
            #[cfg(feature = "mpi")]
            Kind::Mpi(m) => {
                use mpi::traits::CommunicatorCollectives;
                let bytes: &[u8] = bytemuck::cast_slice(send);
                let mut all = vec![0u8; bytes.len() * self.size()];
                m.world.all_gather_into(bytes, &mut all[..]);
                Ok(from_bytes(&all))
            }
        }
    }

    /// The largest of the ranks' `x`, on every rank; NaN if any rank's `x` is NaN (unlike
    /// `f64::max`, so a blown-up rank is never hidden). Exact in any order.
    pub fn all_max(&self, x: f64) -> Result<f64> {
        Ok(self
            .all_gather(&[x])?
            .into_iter()
            .fold(f64::NEG_INFINITY, max_or_nan))
    }

    /// The smallest of the ranks' `x`, on every rank; NaN if any rank's `x` is NaN.
    pub fn all_min(&self, x: f64) -> Result<f64> {
        Ok(-self
            .all_gather(&[-x])?
            .into_iter()
            .fold(f64::NEG_INFINITY, max_or_nan))
    }

    /// The sum of the ranks' `x`, added in rank order (`((x_0 + x_1) + x_2) + ...`) on every
    /// rank: the same bits on every rank and in every run with the same rank count.
    pub fn all_sum(&self, x: f64) -> Result<f64> {
        let all = self.all_gather(&[x])?;
        Ok(all[1..].iter().fold(all[0], |a, b| a + b))
    }

    /// Whether any rank passes `true`, on every rank.
    pub fn all_any(&self, x: bool) -> Result<bool> {
        Ok(self.all_gather(&[u8::from(x)])?.contains(&1))
    }

    /// `local` on every rank if it is `Ok` on every rank; else this rank's error, or on the
    /// ranks that had none an error naming the first rank that failed and carrying its
    /// message, so that no rank goes on to wait for the others in a collective call (e.g.
    /// after validating inputs that every rank checks on its own). Collective: the rule for
    /// every check that can fail inside a collective operation (one all-gather of a byte
    /// when every rank passes; two more, of the message lengths and the messages, when one
    /// fails).
    pub fn agree<T>(&self, local: Result<T>) -> Result<T> {
        let failed = self.all_gather(&[u8::from(local.is_err())])?;
        let Some(r) = failed.iter().position(|f| *f == 1) else {
            return local;
        };
        // The first failing rank's message, on every rank (each passes its own, padded to
        // the longest: all_gather needs equal lengths).
        let mine = match &local {
            Err(e) => e.to_string().into_bytes(),
            Ok(_) => Vec::new(),
        };
        let lens = self.all_gather(&[mine.len() as u64])?;
        let longest = lens.iter().copied().max().unwrap_or(0) as usize;
        let mut padded = mine;
        padded.resize(longest, 0);
        let all = self.all_gather(&padded)?;
        let theirs = &all[r * longest..r * longest + lens[r] as usize];
        match local {
            Err(e) => Err(e),
            Ok(_) => Err(Error::invalid(
                format!("the inputs of rank {r}"),
                "rejected there",
                format!(
                    "rank {r} reported: {}; every rank must pass the same particles and \
                     configuration (or checkpoint)",
                    String::from_utf8_lossy(theirs)
                ),
            )),
        }
    }

    /// `Ok` when every rank passes the same `digest` (e.g. a hash of its inputs); else, on
    /// every rank, an error naming `what` and the first rank that differs from rank 0, with
    /// `fix` as the remedy. Collective.
    pub fn check_same(&self, digest: u64, what: &str, fix: &str) -> Result<()> {
        let all = self.all_gather(&[digest])?;
        match all.iter().position(|d| *d != all[0]) {
            Some(r) => Err(Error::invalid(
                what,
                format!("rank {r} differs from rank 0"),
                fix,
            )),
            None => Ok(()),
        }
    }

    /// `Ok` when every rank asked for the same number of `steps` in a collective `step`
    /// (ranks that asked for different counts would wait for each other forever); else the
    /// error of [`Comm::check_same`] on every rank. Collective: one all-gather of a number.
    pub fn agree_steps(&self, steps: u32) -> Result<()> {
        self.check_same(
            u64::from(steps),
            "step count",
            "every rank must call step(n) with the same n",
        )
    }

    /// `Ok` when every rank passed the same inputs: `encoded` (the inputs as a checkpoint
    /// stores them, with the state when resuming) hashed and compared across ranks; else
    /// the error of [`Comm::check_same`] naming `what`, on every rank. Collective.
    pub fn agree_inputs(&self, encoded: &[u8], what: &str) -> Result<()> {
        use std::hash::{Hash, Hasher};
        let mut h = std::collections::hash_map::DefaultHasher::new();
        encoded.hash(&mut h);
        self.check_same(
            h.finish(),
            what,
            "every rank must pass the same inputs and configuration (or checkpoint)",
        )
    }

    /// Rank 0's `data` on every rank (`MPI_Bcast` of the length, then of the values): rank 0
    /// passes `Some`, the others anything (their `data` is ignored). E.g. rank 0 reads a
    /// checkpoint file and every rank resumes from the bytes.
    ///
    /// Errors: rank 0 passes `None`.
    pub fn broadcast_from_root<T: Pod>(&self, data: Option<Vec<T>>) -> Result<Vec<T>> {
        let root_missing = || {
            Error::invalid(
                "broadcast_from_root",
                "None on rank 0",
                "rank 0 must pass the data (Some) that the other ranks receive",
            )
        };
        match &self.kind {
            Kind::Serial => data.ok_or_else(root_missing),
            #[cfg(feature = "mpi")]
            Kind::Mpi(m) => {
                use mpi::traits::{Communicator, Root};
                let root = m.world.process_at_rank(0);
                // A length of u64::MAX stands for "rank 0 has nothing", so all ranks fail.
                let mut len = match (&data, self.is_root()) {
                    (Some(d), true) => std::mem::size_of_val(d.as_slice()) as u64,
                    (None, true) => u64::MAX,
                    _ => 0,
                };
                root.broadcast_into(&mut len);
                if len == u64::MAX {
                    return Err(root_missing());
                }
                let n = usize::try_from(len).map_err(|_| {
                    Error::invalid(
                        "broadcast_from_root",
                        format!("{len} bytes"),
                        "too many for this machine",
                    )
                })?;
                let mut bytes = vec![0u8; n];
                if let (true, Some(d)) = (self.is_root(), &data) {
                    bytes.copy_from_slice(bytemuck::cast_slice(d));
                }
                // In pieces of at most 1 GiB: MPI counts are 32-bit, so one broadcast of
                // 2 GiB or more would fail. (OpenMPI refuses an empty buffer's dangling
                // pointer: nothing to send then.)
                for piece in bytes.chunks_mut(1 << 30) {
                    root.broadcast_into(piece);
                }
                Ok(from_bytes(&bytes))
            }
        }
    }

    /// Rank 0's data on every rank, where rank 0 (or any rank) may have failed to produce
    /// it: `root` is `Ok(Some(data))` on rank 0 and `Ok(None)` elsewhere, or an error on
    /// any rank, which every rank then returns ([`Comm::agree`]) before anything is sent, so
    /// no rank waits in the broadcast. E.g. a state gathered and encoded on rank 0.
    /// Collective.
    pub fn share_from_root<T: Pod>(&self, root: Result<Option<Vec<T>>>) -> Result<Vec<T>> {
        let root = self.agree(root)?;
        self.broadcast_from_root(root)
    }

    /// Writes `bytes` (rank 0's; the other ranks pass `None`) to `path` from rank 0, atomically
    /// ([`crate::checkpoint::write_file`]: parent directories are created). Collective: every
    /// rank returns once the file is complete; if rank 0 fails it returns its error and the
    /// other ranks an [`Error::Io`] naming the path. For checkpoints gathered on rank 0.
    pub fn write_from_root(&self, path: &std::path::Path, bytes: Option<&[u8]>) -> Result<()> {
        let written = match bytes {
            Some(b) if self.is_root() => crate::checkpoint::write_file(path, b),
            _ => Ok(()),
        };
        // Rank 0 tells the others whether the file is there.
        if self.all_any(written.is_err())? {
            written?;
            return Err(Error::Io {
                path: path.display().to_string(),
                message: "rank 0 could not write the file (its error is on rank 0)".into(),
            });
        }
        Ok(())
    }

    /// The records of particles spread over the ranks (each rank passes those it owns;
    /// element 0 of a record is the particle's global index, `0..total`) on rank 0 in
    /// global order: `Some` there, `None` on the other ranks. Collective.
    ///
    /// Errors (on every rank: rank 0's check is agreed): the ranks together do not hold
    /// each of the `total` particles exactly once, or a message rank 0 cannot read.
    pub fn gather_indexed<const K: usize>(
        &self,
        mine: &[[f64; K]],
        total: usize,
    ) -> Result<Option<Vec<[f64; K]>>>
    where
        [f64; K]: Pod,
    {
        let checked = self.gather_to_root(mine).and_then(|parts| {
            let Some(parts) = parts else {
                return Ok(None);
            };
            let mut rows: Vec<[f64; K]> = parts.into_iter().flatten().collect();
            rows.sort_by(|a, b| a[0].total_cmp(&b[0]));
            if rows.len() != total || rows.iter().enumerate().any(|(k, r)| r[0] != k as f64) {
                return Err(Error::invalid(
                    "gathered particles",
                    rows.len(),
                    format!("the ranks must own each of the {total} particles exactly once"),
                ));
            }
            Ok(Some(rows))
        });
        self.agree(checked)
    }

    /// Every rank's `send` (any length per rank) on rank 0, in rank order: `Some` there,
    /// `None` on the other ranks.
    pub fn gather_to_root<T: Pod>(&self, send: &[T]) -> Result<Option<Vec<Vec<T>>>> {
        match &self.kind {
            Kind::Serial => Ok(Some(vec![send.to_vec()])),
            #[cfg(feature = "mpi")]
            Kind::Mpi(m) => {
                use mpi::traits::{Communicator, Destination, Source};
                const TAG: i32 = 0x5347; // gather
                let bytes: &[u8] = bytemuck::cast_slice(send);
                if self.rank() != 0 {
                    m.world.process_at_rank(0).send_with_tag(bytes, TAG);
                    return Ok(None);
                }
                let mut out = vec![send.to_vec()];
                for r in 1..self.size() {
                    let (got, _) = m
                        .world
                        .process_at_rank(r as i32)
                        .receive_vec_with_tag::<u8>(TAG);
                    if got.len() % std::mem::size_of::<T>().max(1) != 0 {
                        return Err(Error::invalid(
                            format!("message from rank {r} to the gather"),
                            format!("{} bytes", got.len()),
                            "every rank must gather values of the same type",
                        ));
                    }
                    out.push(from_bytes(&got));
                }
                Ok(Some(out))
            }
        }
    }
}

/// The values of `T` whose bytes are `bytes` (a whole number of values), copied into
/// aligned storage.
#[cfg(feature = "mpi")]
fn from_bytes<T: Pod>(bytes: &[u8]) -> Vec<T> {
    let mut out = vec![T::zeroed(); bytes.len() / std::mem::size_of::<T>().max(1)];
    bytemuck::cast_slice_mut::<T, u8>(&mut out).copy_from_slice(bytes);
    out
}

/// A shift on one process with partners that are not both this rank: only "no partner on
/// either side" is meaningful (a message to or from another rank would never arrive).
fn serial_partners(dest: Option<usize>, source: Option<usize>) -> Result<()> {
    match (dest, source) {
        (None, None) => Ok(()),
        _ => Err(Error::invalid(
            "shift partners on one process",
            format!("dest {dest:?}, source {source:?}"),
            "give both as Some(0) (a copy onto itself) or both as None",
        )),
    }
}

/// One shift over MPI for partners that are not both this rank: posts the send to `dest`
/// (non-blocking, so a ring or chain of shifts cannot deadlock), probes the message from
/// `source` (`MPI_Mprobe`), hands it with its length in bytes and its sender to `take`
/// (which must receive it: [`mpi::point_to_point::Message`] panics when dropped unread),
/// then waits for the send. `None` when there is no source.
#[cfg(feature = "mpi")]
fn mpi_shift<T: Pod, R>(
    world: &mpi::topology::SimpleCommunicator,
    send: &[T],
    dest: Option<usize>,
    source: Option<usize>,
    tag: u16,
    take: impl FnOnce(mpi::point_to_point::Message, usize, usize) -> Result<R>,
) -> Result<Option<R>> {
    use mpi::datatype::Equivalence;
    use mpi::traits::{Communicator, Destination, Source};
    let tag = i32::from(tag);
    let out: &[u8] = bytemuck::cast_slice(send);
    mpi::request::scope(|scope| {
        let sending = dest.map(|d| {
            world
                .process_at_rank(d as i32)
                .immediate_send_with_tag(scope, out, tag)
        });
        let got = source
            .map(|s| {
                let (msg, status) = world.process_at_rank(s as i32).matched_probe_with_tag(tag);
                let bytes = status.count(u8::equivalent_datatype());
                take(msg, usize::try_from(bytes).unwrap_or(0), s)
            })
            .transpose();
        if let Some(request) = sending {
            request.wait_without_status();
        }
        got
    })
}

/// Refuses a probed message of `bytes` bytes from rank `from` for the reason `why`: receives
/// it into a scratch buffer of its own length and drops it, so it is taken off the wire
/// whole (a receive into a smaller buffer would be `MPI_ERR_TRUNCATE`, which aborts the
/// job), and returns the error naming the sender.
#[cfg(feature = "mpi")]
fn refuse<R>(msg: mpi::point_to_point::Message, bytes: usize, from: usize, why: &str) -> Result<R> {
    let mut sink = vec![0u8; bytes];
    msg.matched_receive_into(&mut sink[..]);
    Err(Error::invalid(
        format!("message from rank {from}"),
        format!("{bytes} bytes"),
        why,
    ))
}
