//! [`DistributedRun`]: the model-independent half of a distributed particle run (the
//! communicator, the engine of the system's dimension, the gathers of the state and of
//! the checkpoint record), shared by `dem`'s and `md`'s distributed
//! types.

use simkit_backend::Result;
use simkit_backend::comm::Comm;
use simkit_backend::particles::{Dynamics, State};

/// A value for a 2D or a 3D run.
#[derive(Clone, Debug)]
pub enum ByDim<A, B> {
    /// Two dimensions.
    Two(A),
    /// Three dimensions.
    Three(B),
}

/// Evaluates `$body` with `$x` bound to the value of a [`ByDim`], whatever its dimension.
#[macro_export]
macro_rules! by_dim {
    ($value:expr, $x:ident => $body:expr) => {
        match $value {
            $crate::ByDim::Two($x) => $body,
            $crate::ByDim::Three($x) => $body,
        }
    };
}

/// The sizes of one rank's part of a run (see [`crate::RankParticles`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RankView {
    /// Particles of the run (all ranks).
    pub total: usize,
    /// Particles this rank owns.
    pub owned: usize,
    /// Ghost copies this rank holds.
    pub ghosts: usize,
    /// Regions along x and y.
    pub dims: [usize; 2],
    /// List builds so far.
    pub builds: u64,
}

/// What a model's per-rank engine gives [`DistributedRun`]. Every method that takes a
/// [`Comm`] is collective.
pub trait RankRun {
    /// Sizes of this rank's part.
    fn view(&self) -> RankView;
    /// Steps done.
    fn steps(&self) -> u64;
    /// Simulated time.
    fn time(&self) -> f64;
    /// The time step.
    fn dt(&self) -> f64;
    /// Advances `steps` steps with the blow-up guard, the same outcome on every rank.
    fn step(&mut self, comm: &Comm, steps: u32) -> Result<()>;
    /// Every particle's position (periodic coordinates wrapped) and velocity at the step,
    /// `[x, y, z, vx, vy, vz]` (`z = vz = 0` in 2D), in global order on rank 0 (`None`
    /// elsewhere).
    fn gather_motion(&self, comm: &Comm) -> Result<Option<Vec<[f64; 6]>>>;
    /// The complete dynamic state in global order (slot order empty) on rank 0 (`None`
    /// elsewhere): the single-process checkpoint record.
    fn gather_dynamics(&self, comm: &Comm) -> Result<Option<Dynamics>>;
}

/// The communicator and the per-rank engine of a distributed particle run, with what does
/// not depend on the model.
#[derive(Debug)]
pub struct DistributedRun<A, B> {
    comm: Comm,
    engine: ByDim<A, B>,
}

impl<A: RankRun, B: RankRun> DistributedRun<A, B> {
    /// A run of `engine` over `comm`.
    pub fn new(comm: Comm, engine: ByDim<A, B>) -> Self {
        Self { comm, engine }
    }

    /// The communicator.
    pub fn comm(&self) -> &Comm {
        &self.comm
    }

    /// The engine and the communicator.
    pub fn parts(&mut self) -> (&mut ByDim<A, B>, &Comm) {
        (&mut self.engine, &self.comm)
    }

    /// The engine.
    pub fn engine(&self) -> &ByDim<A, B> {
        &self.engine
    }

    /// Sizes of this rank's part.
    pub fn view(&self) -> RankView {
        by_dim!(&self.engine, e => e.view())
    }

    /// Steps done.
    pub fn steps(&self) -> u64 {
        by_dim!(&self.engine, e => e.steps())
    }

    /// Simulated time.
    pub fn time(&self) -> f64 {
        by_dim!(&self.engine, e => e.time())
    }

    /// The time step.
    pub fn dt(&self) -> f64 {
        by_dim!(&self.engine, e => e.dt())
    }

    /// Advances `steps` steps on every rank. Collective.
    ///
    /// Errors: ranks that asked for different step counts; those of the model's guarded
    /// step, the same on every rank.
    pub fn step(&mut self, steps: u32) -> Result<()> {
        let comm = &self.comm;
        comm.agree_steps(steps)?;
        by_dim!(&mut self.engine, e => e.step(comm, steps))
    }

    /// Time, positions, velocities and `species` of all particles in global order, on
    /// every rank. Collective.
    ///
    /// Errors: a failed exchange.
    pub fn state(&self, species: &[u32]) -> Result<State> {
        let rows = by_dim!(&self.engine, e => e.gather_motion(&self.comm));
        let flat = rows.map(|rows| rows.map(|r| r.into_iter().flatten().collect::<Vec<f64>>()));
        let v = self.comm.share_from_root(flat)?;
        let rows = v.chunks_exact(6);
        Ok(State {
            time: self.time(),
            positions: rows.clone().map(|r| [r[0], r[1], r[2]]).collect(),
            velocities: rows.map(|r| [r[3], r[4], r[5]]).collect(),
            angular_velocities: Vec::new(),
            species: species.to_vec(),
        })
    }

    /// The checkpoint `encode` makes of the gathered dynamic state (on rank 0), on every
    /// rank: the same bytes on any rank count. Collective.
    ///
    /// Errors: a failed exchange or encoding (on every rank).
    pub fn checkpoint(&self, encode: impl FnOnce(Dynamics) -> Result<Vec<u8>>) -> Result<Vec<u8>> {
        let saved = by_dim!(&self.engine, e => e.gather_dynamics(&self.comm));
        let bytes = saved.and_then(|s| s.map(encode).transpose());
        self.comm.share_from_root(bytes)
    }

    /// The standard `Debug` fields of a distributed type named `name`.
    pub fn debug(&self, f: &mut std::fmt::Formatter<'_>, name: &str) -> std::fmt::Result {
        let v = self.view();
        f.debug_struct(name)
            .field("comm", &self.comm)
            .field("particles", &v.total)
            .field("owned", &v.owned)
            .field("steps", &self.steps())
            .finish()
    }
}

/// The accessors every distributed particle type offers, for an `impl` block of a type
/// with a field `run: DistributedRun<_, _>` (the communicator and the checkpoint are the
/// type's `simkit_backend::Distributed` implementation).
#[macro_export]
macro_rules! distributed_accessors {
    () => {
        /// The time step in use.
        pub fn dt(&self) -> f64 {
            self.run.dt()
        }

        /// Simulated time.
        pub fn time(&self) -> f64 {
            self.run.time()
        }

        /// Number of particles (all ranks).
        pub fn len(&self) -> usize {
            self.run.view().total
        }

        /// Whether the run has no particles.
        pub fn is_empty(&self) -> bool {
            self.len() == 0
        }

        /// Particles this rank owns (integrates) now.
        pub fn owned(&self) -> usize {
            self.run.view().owned
        }

        /// Ghost copies this rank holds now (particles of its neighbours and periodic
        /// images within the list range of its region).
        pub fn ghosts(&self) -> usize {
            self.run.view().ghosts
        }

        /// Regions along x and y, `[p_x, p_y]`.
        pub fn dims(&self) -> [usize; 2] {
            self.run.view().dims
        }

        /// Neighbour-list builds so far (each with a migration), counted since this object
        /// was made (the start counts one, a resume too).
        pub fn list_builds(&self) -> u64 {
            self.run.view().builds
        }
    };
}
