//! [`DistributedDem`]: the CPU run over the ranks of a [`Comm`] by spatial decomposition,
//! with results that do not depend on the rank count.

use std::hash::{Hash, Hasher};

use rayon::prelude::*;

use simkit_backend::comm::{Comm, ParticleDomain};
use simkit_backend::guard::{blow_up, chunks};
use simkit_backend::{Error, Precision, Result, Simulation};
use simkit_neighbor::GhostedList;

use crate::cpu::{
    AXES, ForceInput, WallT, contact_force, drift_velocity_verlet, max_displacement2, wall_force,
    walls_of, wrap,
};
use crate::engine::EngineState;
use crate::prepared::Prepared;
use crate::sim::{decode, encode, model_name};
use crate::{Config, ContactCoefficients, Diagnostics, Integrator, Scene, State, diagnostics};

/// Owned particles per rayon task of the per-particle passes.
const CHUNK: usize = 1024;

/// A particle as it travels between ranks (migration, checkpoint gather): scene index,
/// then position, velocity, acceleration, predicted velocity and list-build position, three
/// components each (`z = 0` in 2D).
type Record = [f64; 16];

/// Granular DEM over the ranks of a [`Comm`] (CPU, `f64`, velocity Verlet): spatial
/// decomposition with ghost particles, results independent of the rank count.
///
/// The box is cut along the horizontal axes into one region per rank
/// ([`ParticleDomain`]: in 2D along x only, so each rank holds whole columns under gravity;
/// in 3D along x and y), each at least the neighbour-list range (`2 r_max (1 + skin)`)
/// wide. A rank integrates the particles in its region (its *owned* particles) and keeps
/// ghost copies of the particles within the list range of its region, received from its
/// 4 neighbours in the shift pattern (x, then y) and refreshed every step. At every list
/// build (when some particle anywhere moved more than skin / 2: a global maximum) the
/// periodic coordinates are wrapped, particles migrate to the rank that now owns them, and
/// the ghosts and lists are made anew.
///
/// **Results do not depend on the rank count, bit for bit.** Each owned particle sums its
/// force in a fixed order that no decomposition changes: gravity, the walls in scene order,
/// then its contacts in increasing scene index of the partner (each pair is computed from
/// both ends: a full list, twice the pair work of the single-process half list), with
/// the contact law of the single-process CPU backend (the same function). A periodic image
/// gets its box length added by the rank that sends it, the same way for any rank count.
/// So on 1, 2, 3 or 4 ranks the positions and velocities are the same bits. They are *not*
/// the bits of [`crate::Dem`] on the CPU, which sums each particle's contacts in cell order
/// with the reactions of its half list: the two agree to rounding at first (about 1e-15
/// relative per step), and as any two codes that round differently they part like the
/// trajectories of a chaotic system over long runs, with the same statistics.
///
/// Position Verlet, `f32` and the GPU are not offered here (use [`crate::Dem`]).
///
/// Every method that takes `&mut self`, and the constructors, are collective: all ranks
/// call them in the same order with the same arguments (the constructors check that the
/// ranks' scenes and settings agree).
///
/// ```
/// use simkit_backend::comm::Comm;
/// use simkit_backend::Simulation;
/// use simkit_dem::scenes::{BedParams, vibrating_bed};
/// use simkit_dem::{Config, DistributedDem};
/// # fn main() -> simkit_backend::Result<()> {
/// let (scene, _) = vibrating_bed(&BedParams { n: 64, width: 8, ..BedParams::default() })?;
/// // `Comm::mpi()?` under `mpirun -np P` (feature `mpi`); here one process.
/// let mut sim = DistributedDem::new(&scene, &Config::default(), Comm::serial())?;
/// sim.step(200)?;
/// let d = sim.diagnostics()?; // on every rank
/// assert!(d.finite);
/// # Ok(())
/// # }
/// ```
pub struct DistributedDem {
    comm: Comm,
    scene: Scene,
    config: Config,
    engine: Engines,
}

/// The engine in the scene's dimension.
enum Engines {
    Two(Engine<2>),
    Three(Engine<3>),
}

/// Runs `$body` with `$e` bound to the engine, whatever its dimension.
macro_rules! with_engine {
    ($engines:expr, $e:ident => $body:expr) => {
        match $engines {
            Engines::Two($e) => $body,
            Engines::Three($e) => $body,
        }
    };
}

impl std::fmt::Debug for DistributedDem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DistributedDem")
            .field("comm", &self.comm)
            .field("particles", &self.len())
            .field("owned", &self.owned())
            .field("steps", &self.steps_done())
            .finish()
    }
}

impl DistributedDem {
    /// Validates the scene and settings as [`crate::Dem::new`] does on the CPU (the same
    /// errors, on every rank) and builds this rank's part of the run. Collective; every
    /// rank passes the same scene and configuration.
    ///
    /// Errors: those of [`crate::Dem::new`]; [`Precision::F32`] or position Verlet
    /// (not offered here); more ranks than regions at least a list range wide fit in the
    /// box; ranks whose scenes or settings differ. An error on one rank is an error on
    /// every rank (the others name the rank that failed).
    pub fn new(scene: &Scene, config: &Config, comm: Comm) -> Result<Self> {
        Self::build(scene, config, comm, None)
    }

    /// Rebuilds a run from the bytes of [`DistributedDem::checkpoint`] (any rank count) or
    /// of [`crate::Dem`]'s `Restart::checkpoint` on the CPU in `f64`, on any rank count.
    /// Each rank takes the particles its region held at the last list build, the lists are
    /// made from the list-build positions, and the run continues with the bits of the
    /// uninterrupted distributed run. Collective; every rank passes the same bytes (e.g.
    /// from [`Comm::broadcast_from_root`] of the file rank 0 read).
    ///
    /// Errors: another crate's or model's checkpoint, a truncated, corrupt or inconsistent
    /// one (as `Dem::resume`), those of [`DistributedDem::new`]. An error on one rank is an
    /// error on every rank.
    pub fn resume(bytes: &[u8], comm: Comm) -> Result<Self> {
        let saved = comm.agree(decode(bytes).and_then(|s| {
            let want = model_name(false, Precision::F64, s.scene.dim().axes());
            if s.model == want {
                Ok(s)
            } else {
                Err(Error::checkpoint(format!(
                    "holds a {} run; DistributedDem resumes {want} runs (CPU, f64)",
                    s.model
                )))
            }
        }))?;
        Self::build(&saved.scene, &saved.config, comm, Some(&saved.engine))
    }

    fn build(
        scene: &Scene,
        config: &Config,
        comm: Comm,
        saved: Option<&EngineState>,
    ) -> Result<Self> {
        let prep = comm.agree(prepare(scene, config))?;
        // A digest of everything the ranks must agree on: the scene and settings as a
        // checkpoint stores them (with the state, when resuming).
        let mut h = std::collections::hash_map::DefaultHasher::new();
        let empty = EngineState {
            steps: 0,
            time: 0.0,
            started: false,
            width: 0,
            id: Vec::new(),
            pos: Vec::new(),
            vel: Vec::new(),
            acc: Vec::new(),
            aux: Vec::new(),
            reference: Vec::new(),
        };
        encode(scene, config, "", saved.cloned().unwrap_or(empty))?.hash(&mut h);
        comm.check_same(
            h.finish(),
            "DistributedDem inputs",
            "every rank must pass the same scene and configuration (or checkpoint)",
        )?;
        let engine = if prep.axes == 2 {
            Engines::Two(comm.agree(Engine::new(prep, &comm))?)
        } else {
            Engines::Three(comm.agree(Engine::new(prep, &comm))?)
        };
        let mut sim = Self {
            comm,
            scene: scene.clone(),
            config: *config,
            engine,
        };
        let comm = &sim.comm;
        with_engine!(&mut sim.engine, e => {
            let start = match saved {
                None => e.start(comm),
                Some(s) => e.load(comm, s),
            };
            comm.agree(start)?;
            e.keep();
        });
        Ok(sim)
    }

    /// The communicator.
    pub fn comm(&self) -> &Comm {
        &self.comm
    }

    /// The scene the run started from.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The configuration.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The time step in use.
    pub fn dt(&self) -> f64 {
        with_engine!(&self.engine, e => e.prep.dt)
    }

    /// Simulated time.
    pub fn time(&self) -> f64 {
        with_engine!(&self.engine, e => e.time)
    }

    /// Number of particles (all ranks).
    pub fn len(&self) -> usize {
        with_engine!(&self.engine, e => e.prep.n)
    }

    /// Whether the scene has no particles (never: scenes are not empty).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Particles this rank owns (integrates) now.
    pub fn owned(&self) -> usize {
        with_engine!(&self.engine, e => e.owned)
    }

    /// Ghost copies this rank holds now (particles of its neighbours and periodic images
    /// within the list range of its region).
    pub fn ghosts(&self) -> usize {
        with_engine!(&self.engine, e => e.pos.len() - e.owned)
    }

    /// Regions along x and y, `[p_x, p_y]`.
    pub fn dims(&self) -> [usize; 2] {
        with_engine!(&self.engine, e => e.list.domain().dims())
    }

    /// Neighbour-list builds so far (each with a migration), counted since this object was
    /// made (a resume counts one).
    pub fn list_builds(&self) -> u64 {
        with_engine!(&self.engine, e => e.builds)
    }

    /// Diagnostics of the current state (as [`crate::Dem::diagnostics`], from the gathered
    /// state), on every rank. Collective.
    ///
    /// Errors: a failed exchange.
    pub fn diagnostics(&mut self) -> Result<Diagnostics> {
        let s = self.state()?;
        self.diagnostics_of(&s)
    }

    /// Diagnostics of a state of this run's scene (e.g. the one [`Simulation::state`]
    /// returned); not collective.
    ///
    /// Errors: a state of another particle count.
    pub fn diagnostics_of(&self, state: &State) -> Result<Diagnostics> {
        let n = self.len();
        if state.positions.len() != n || state.velocities.len() != n {
            return Err(Error::invalid(
                "state length",
                state.positions.len(),
                format!("must equal the particle count {n}"),
            ));
        }
        with_engine!(&self.engine, e => diagnostics::compute(&e.prep, state.time, &state.positions, &state.velocities))
    }

    /// Vertical displacement of the vibrating walls at time `t`.
    pub fn wall_displacement(&self, t: f64) -> f64 {
        with_engine!(&self.engine, e => e.prep.wall_motion(t).0)
    }

    /// The complete state in the single-process checkpoint format (the particles in scene
    /// order, with their list-build positions), on every rank: resumes with
    /// [`DistributedDem::resume`] on any rank count, or with [`crate::Dem`]'s
    /// `Restart::resume` on the CPU in one process. Collective.
    ///
    /// Errors: a failed exchange.
    pub fn checkpoint(&mut self) -> Result<Vec<u8>> {
        let engine = with_engine!(&self.engine, e => e.gather_state(&self.comm))?;
        let axes = self.scene.dim().axes();
        let bytes = match engine {
            Some(s) => Some(encode(
                &self.scene,
                &self.config,
                &model_name(false, Precision::F64, axes),
                s,
            )?),
            None => None,
        };
        self.comm.broadcast_from_root(bytes)
    }

    /// Writes [`DistributedDem::checkpoint`] to `path` from rank 0, atomically. Collective.
    ///
    /// Errors: a failed exchange or write (on every rank).
    pub fn write_checkpoint(&mut self, path: impl AsRef<std::path::Path>) -> Result<()> {
        let bytes = self.checkpoint()?;
        let mine = self.comm.is_root().then_some(bytes.as_slice());
        self.comm.write_from_root(path.as_ref(), mine)
    }
}

impl Simulation for DistributedDem {
    type State = State;

    /// Advances `steps` steps on every rank, checking the state every
    /// [`Config::check_every`] steps and at the end as [`crate::Dem`] does; a failed check
    /// returns the same [`Error::BlowUp`] on every rank (the failure of the smallest scene
    /// index, or the deepest overlap) with the run rolled back everywhere to the last state
    /// that passed. Collective.
    fn step(&mut self, steps: u32) -> Result<()> {
        let comm = &self.comm;
        with_engine!(&mut self.engine, e => e.guarded(comm, steps))
    }

    /// The state of all particles in scene order (periodic coordinates wrapped), gathered
    /// on rank 0 and sent to every rank. Collective.
    fn state(&mut self) -> Result<State> {
        let comm = &self.comm;
        let s = with_engine!(&self.engine, e => e.gather_state(comm))?;
        let flat = s.map(|s| {
            let mut v = Vec::with_capacity(1 + 6 * s.id.len());
            v.push(s.time);
            let w = s.width as usize;
            for k in 0..s.id.len() {
                let mut x = [0.0; 3];
                x[..w].copy_from_slice(&s.pos[k * w..(k + 1) * w]);
                with_engine!(&self.engine, e => e.wrap3(&mut x));
                v.extend_from_slice(&x);
                let mut u = [0.0; 3];
                u[..w].copy_from_slice(&s.vel[k * w..(k + 1) * w]);
                v.extend_from_slice(&u);
            }
            v
        });
        let v = comm.broadcast_from_root(flat)?;
        let rows = v[1..].chunks_exact(6);
        Ok(State {
            time: v[0],
            positions: rows.clone().map(|r| [r[0], r[1], r[2]]).collect(),
            velocities: rows.map(|r| [r[3], r[4], r[5]]).collect(),
        })
    }

    fn steps_done(&self) -> u64 {
        with_engine!(&self.engine, e => e.steps)
    }

    fn backend_name(&self) -> String {
        let threads = rayon::current_num_threads();
        let plural = if threads == 1 { "" } else { "s" };
        format!(
            "cpu f64 ({} ranks, {threads} thread{plural} each)",
            self.comm.size()
        )
    }
}

/// The shared validation of [`crate::Dem::new`], plus what this run does not offer.
fn prepare(scene: &Scene, config: &Config) -> Result<Prepared> {
    if config.precision != Precision::F64 {
        return Err(Error::Unsupported(
            "DistributedDem computes in f64; use Precision::F64 or Dem for f32".into(),
        ));
    }
    if config.integrator != Integrator::VelocityVerlet {
        return Err(Error::Unsupported(
            "DistributedDem integrates with velocity Verlet; use Integrator::VelocityVerlet \
             or Dem for position Verlet"
                .into(),
        ));
    }
    let prep = Prepared::new(scene, config, false)?;
    diagnostics::check_initial_overlaps(&prep)?;
    Ok(prep)
}

/// The owned particles at the last check that passed, and the clock.
#[derive(Default)]
struct Snapshot<const D: usize> {
    id: Vec<u32>,
    pos: Vec<[f64; D]>,
    vel: Vec<[f64; D]>,
    acc: Vec<[f64; D]>,
    aux: Vec<[f64; D]>,
    reference: Vec<[f64; D]>,
    time: f64,
    started: bool,
    steps: u64,
}

/// What a blow-up check found on a rank, as the ranks exchange it: `[kind, id, a, b, c]`
/// with kind 0 (non-finite position: a = axis, b = value), 1 (non-finite velocity), 2
/// (outside the box: a = axis, b = coordinate), 3 (overlap: a = ratio, b = 0 for a particle
/// or 1 for a wall, c = its index), 4 (nothing).
type Finding = [f64; 5];

const NOTHING: Finding = [4.0, 0.0, 0.0, 0.0, 0.0];

/// This rank's part of the run in dimension `D`.
struct Engine<const D: usize> {
    prep: Prepared,
    /// The decomposition, the ghosts and the full lists (partners by scene index).
    list: GhostedList<D>,
    time: f64,
    started: bool,
    steps: u64,
    builds: u64,
    /// Owned particles at the front of the local arrays, ghosts after them.
    owned: usize,
    /// Scene index, owned then ghosts.
    id: Vec<u32>,
    /// Positions, owned then ghosts (owned: not wrapped since the list build).
    pos: Vec<[f64; D]>,
    /// Velocities the dashpots read (predicted at the force time), owned then ghosts.
    aux: Vec<[f64; D]>,
    radius: Vec<f64>,
    mass: Vec<f64>,
    species: Vec<u32>,
    /// Owned only.
    vel: Vec<[f64; D]>,
    acc: Vec<[f64; D]>,
    inv_mass: Vec<f64>,
    reference: Vec<[f64; D]>,
    snap: Snapshot<D>,
    coeff: Vec<ContactCoefficients>,
    walls: Vec<WallT<f64>>,
    gravity: [f64; D],
    periodic: [bool; D],
    lo: [f64; D],
    len: [f64; D],
    cut2: f64,
    rebuild_dist2: f64,
}

impl<const D: usize> Engine<D>
where
    [f64; D]: bytemuck::Pod,
{
    /// The engine without particles (they come with [`Engine::start`] or
    /// [`Engine::load`]).
    fn new(prep: Prepared, comm: &Comm) -> Result<Self> {
        let range = prep.cutoff + prep.skin;
        // 2D: columns under the vertical y; 3D: x and y (the vertical z is not cut).
        let dims = (D == 2).then_some([comm.size(), 1]);
        let domain = ParticleDomain::new(
            [prep.lo[0], prep.lo[1]],
            [prep.len[0], prep.len[1]],
            [prep.periodic[0], prep.periodic[1]],
            range,
            dims,
            comm.size(),
        )?;
        let mut gravity = [0.0; D];
        gravity[prep.vertical] = -prep.gravity;
        let r_max = prep.cutoff / 2.0;
        let periodic_z = (D == 3 && prep.periodic[2]).then_some((prep.lo[2], prep.len[2]));
        Ok(Self {
            list: GhostedList::new(domain, periodic_z, range)?,
            time: 0.0,
            started: false,
            steps: 0,
            builds: 0,
            owned: 0,
            id: Vec::new(),
            pos: Vec::new(),
            aux: Vec::new(),
            radius: Vec::new(),
            mass: Vec::new(),
            species: Vec::new(),
            vel: Vec::new(),
            acc: Vec::new(),
            inv_mass: Vec::new(),
            reference: Vec::new(),
            snap: Snapshot::default(),
            coeff: prep.coeff.clone(),
            walls: walls_of::<f64, D>(&prep),
            gravity,
            periodic: std::array::from_fn(|d| prep.periodic[d]),
            lo: std::array::from_fn(|d| prep.lo[d]),
            len: std::array::from_fn(|d| prep.len[d]),
            cut2: (r_max + r_max) * (r_max + r_max),
            rebuild_dist2: 0.25 * prep.skin * prep.skin,
            prep,
        })
    }

    fn xy(x: &[f64; D]) -> [f64; 2] {
        [x[0], x[1]]
    }

    /// Wraps the periodic coordinates of a 3-vector (the first `D` used).
    fn wrap3(&self, x: &mut [f64; 3]) {
        let mut y: [f64; D] = std::array::from_fn(|d| x[d]);
        wrap(&mut y, self.periodic, self.lo, self.len);
        x[..D].copy_from_slice(&y);
    }

    /// The initial state: every rank takes the scene's particles in its region.
    fn start(&mut self, comm: &Comm) -> Result<()> {
        let mut owned = Vec::new();
        for i in 0..self.prep.n {
            let mut x: [f64; D] = std::array::from_fn(|d| self.prep.positions[i][d]);
            wrap(&mut x, self.periodic, self.lo, self.len);
            if self.list.domain().owner(Self::xy(&x)) == comm.rank() {
                owned.push(i);
            }
        }
        let n = owned.len();
        self.take(&owned);
        for (k, &i) in owned.iter().enumerate() {
            self.pos[k] = std::array::from_fn(|d| self.prep.positions[i][d]);
            self.vel[k] = std::array::from_fn(|d| self.prep.velocities[i][d]);
        }
        self.acc = vec![[0.0; D]; n];
        self.aux = vec![[0.0; D]; n];
        self.reference.clone_from(&self.pos);
        self.rebuild(comm)
    }

    /// Sets the owned scene indices and their constants (the dynamic arrays sized, not
    /// filled).
    fn take(&mut self, ids: &[usize]) {
        let p = &self.prep;
        self.owned = ids.len();
        self.id = ids.iter().map(|&i| i as u32).collect();
        self.radius = ids.iter().map(|&i| p.radius[i]).collect();
        self.mass = ids.iter().map(|&i| p.mass[i]).collect();
        self.inv_mass = ids.iter().map(|&i| 1.0 / p.mass[i]).collect();
        self.species = ids.iter().map(|&i| p.species[i]).collect();
        self.pos.resize(ids.len(), [0.0; D]);
        self.vel.resize(ids.len(), [0.0; D]);
    }

    /// A checkpointed state: every rank takes the particles whose list-build position lies
    /// in its region (where the run that wrote it had them).
    fn load(&mut self, comm: &Comm, s: &EngineState) -> Result<()> {
        let n = self.prep.n;
        s.check(n, D)?;
        let at = |v: &[f64], k: usize| -> [f64; D] { std::array::from_fn(|d| v[k * D + d]) };
        let mine: Vec<usize> = (0..n)
            .filter(|&k| self.list.domain().owner(Self::xy(&at(&s.reference, k))) == comm.rank())
            .collect();
        let ids: Vec<usize> = mine.iter().map(|&k| s.id[k] as usize).collect();
        self.take(&ids);
        self.pos = mine.iter().map(|&k| at(&s.pos, k)).collect();
        self.vel = mine.iter().map(|&k| at(&s.vel, k)).collect();
        self.acc = mine.iter().map(|&k| at(&s.acc, k)).collect();
        self.aux = mine.iter().map(|&k| at(&s.aux, k)).collect();
        self.reference = mine.iter().map(|&k| at(&s.reference, k)).collect();
        (self.time, self.started, self.steps) = (s.time, s.started, s.steps);
        self.relist(comm)
    }

    /// Wraps the owned positions, sends every particle to the rank that owns it now, and
    /// makes the ghosts and lists anew.
    fn rebuild(&mut self, comm: &Comm) -> Result<()> {
        let n = self.owned;
        let out: Vec<Record> = (0..n)
            .map(|k| {
                let mut x = self.pos[k];
                wrap(&mut x, self.periodic, self.lo, self.len);
                self.record(k, &x)
            })
            .collect();
        let got = self.list.domain().migrate(comm, out, |r| [r[1], r[2]])?;
        let ids: Vec<usize> = got.iter().map(|r| r[0] as usize).collect();
        let bad = ids.iter().find(|&&i| i >= self.prep.n).map(|&i| {
            Error::invalid(
                "migrated particle index",
                i,
                format!("must be below the particle count {}", self.prep.n),
            )
        });
        // Every rank stops, not only the one that received it.
        comm.agree(bad.map_or(Ok(()), Err))?;
        self.take(&ids);
        let part = |o: usize| -> Vec<[f64; D]> {
            got.iter()
                .map(|r| std::array::from_fn(|d| r[o + d]))
                .collect()
        };
        self.pos = part(1);
        self.vel = part(4);
        self.acc = part(7);
        self.aux = part(10);
        self.reference.clone_from(&self.pos);
        self.relist(comm)
    }

    /// Ghosts and lists from the list-build positions of the owned particles, then the
    /// ghosts refreshed with the current positions and velocities.
    fn relist(&mut self, comm: &Comm) -> Result<()> {
        let n = self.owned;
        self.list.build(comm, &self.reference, &self.id[..n])?;
        let p = &self.prep;
        let ghosts = &self.list.ids()[n..];
        let bad = ghosts.iter().find(|&&i| i as usize >= p.n).map(|&i| {
            Error::invalid(
                "ghost particle index",
                i,
                format!("must be below the particle count {}", p.n),
            )
        });
        comm.agree(bad.map_or(Ok(()), Err))?;
        for &i in ghosts {
            let i = i as usize;
            self.id.push(i as u32);
            self.radius.push(p.radius[i]);
            self.mass.push(p.mass[i]);
            self.species.push(p.species[i]);
        }
        self.pos.resize(self.list.len(), [0.0; D]);
        self.aux.resize(self.list.len(), [0.0; D]);
        self.refresh(comm)?;
        self.builds += 1;
        Ok(())
    }

    /// Sends the owned positions and predicted velocities to the ranks that hold them as
    /// ghosts.
    fn refresh(&mut self, comm: &Comm) -> Result<()> {
        self.list.refresh(comm, &mut self.pos, true)?;
        self.list.refresh(comm, &mut self.aux, false)
    }

    /// Forces at the current time from the positions and predicted velocities into
    /// `acc` (as accelerations).
    fn forces(&mut self) {
        if self.prep.friction {
            self.forces_variant::<true>();
        } else {
            self.forces_variant::<false>();
        }
    }

    fn forces_variant<const FRICTION: bool>(&mut self) {
        let (zw, vw) = self.prep.wall_motion(self.time);
        let inp = ForceInput {
            pos: &self.pos,
            vel: &self.aux,
            radius: &self.radius,
            mass: &self.mass,
            species: &self.species,
            n_species: self.prep.n_species,
            coeff: &self.coeff,
            walls: &self.walls,
            gravity: self.gravity,
            zw,
            vw,
            vert: self.prep.vertical,
            periodic: self.periodic,
            lo: self.lo,
            len: self.len,
            cut2: self.cut2,
            block: usize::MAX,
        };
        let (list, inv_mass) = (&self.list, &self.inv_mass);
        self.acc
            .par_chunks_mut(CHUNK)
            .enumerate()
            .for_each(|(c, acc)| {
                for (k, a) in acc.iter_mut().enumerate() {
                    let i = c * CHUNK + k;
                    let mut f = [0.0; D];
                    for (f, g) in f.iter_mut().zip(inp.gravity) {
                        *f += g * inp.mass[i];
                    }
                    for w in inp.walls {
                        wall_force::<f64, D, FRICTION>(&inp, w, i, &mut f);
                    }
                    let xi = inp.pos[i];
                    for &j in list.partners(i) {
                        let j = j as usize;
                        let sep: [f64; D] = std::array::from_fn(|d| xi[d] - inp.pos[j][d]);
                        if let Some(fp) = contact_force::<f64, D, FRICTION>(&inp, i, j, sep) {
                            for d in 0..D {
                                f[d] += fp[d];
                            }
                        }
                    }
                    for d in 0..D {
                        a[d] = f[d] * inv_mass[i];
                    }
                }
            });
    }

    /// `steps` velocity Verlet steps without checks.
    fn advance(&mut self, comm: &Comm, steps: u32) -> Result<()> {
        if steps == 0 {
            return Ok(());
        }
        if !self.started {
            let n = self.owned;
            self.aux[..n].copy_from_slice(&self.vel);
            self.refresh(comm)?;
            self.forces();
            self.started = true;
        }
        let dt = self.prep.dt;
        let h = 0.5 * dt;
        for _ in 0..steps {
            // A list build migrates particles: the owned count changes between steps.
            let n = self.owned;
            let max2 = {
                let (pos, aux) = (&mut self.pos[..n], &mut self.aux[..n]);
                pos.par_chunks_mut(CHUNK)
                    .zip(self.vel.par_chunks_mut(CHUNK))
                    .zip(aux.par_chunks_mut(CHUNK))
                    .zip(self.acc.par_chunks(CHUNK))
                    .zip(self.reference.par_chunks(CHUNK))
                    .map(|((((x, v), vp), a), r)| {
                        drift_velocity_verlet(
                            x.as_flattened_mut(),
                            v.as_flattened_mut(),
                            vp.as_flattened_mut(),
                            a.as_flattened(),
                            h,
                            dt,
                        );
                        max_displacement2(x, r)
                    })
                    .reduce(|| 0.0, f64::max)
            };
            self.time += dt;
            if comm.all_max(max2)? > self.rebuild_dist2 {
                self.rebuild(comm)?;
            } else {
                self.refresh(comm)?;
            }
            self.forces();
            self.vel
                .par_chunks_mut(CHUNK)
                .zip(self.acc.par_chunks(CHUNK))
                .for_each(|(v, a)| {
                    for (v, a) in v.iter_mut().zip(a) {
                        for d in 0..D {
                            v[d] += a[d] * h;
                        }
                    }
                });
        }
        Ok(())
    }

    /// `steps` steps in stretches ending on multiples of `check_every`, each followed by
    /// the blow-up check on every rank; a failure anywhere rolls every rank back.
    fn guarded(&mut self, comm: &Comm, steps: u32) -> Result<()> {
        for n in chunks(self.steps, steps, self.prep.check_every) {
            if let Err(e) = self.advance(comm, n) {
                // A list build that failed on every rank (particles that jumped a region,
                // positions a grid cannot hold): the run blew up within the stretch.
                let bad = self.steps + u64::from(n);
                self.restore(comm)?;
                return Err(blow_up(
                    bad,
                    self.steps,
                    format!("the neighbour-list build failed: {e}"),
                    self.prep.non_finite_cause(),
                ));
            }
            self.steps += u64::from(n);
            let all = comm.all_gather(&[self.check()])?;
            let worst = all.iter().copied().fold(NOTHING, worse);
            if worst[0] < 4.0 {
                let bad = self.steps;
                self.restore(comm)?;
                let (what, cause) = self.describe(&worst);
                return Err(blow_up(bad, self.steps, what, cause));
            }
            self.keep();
        }
        Ok(())
    }

    /// This rank's first finding: non-finite position, non-finite velocity, a particle
    /// outside the box by more than its radius (each the smallest scene index of its
    /// kind), the deepest contact over `max_overlap`.
    fn check(&self) -> Finding {
        let n = self.owned;
        let mut found = NOTHING;
        for (kind, v) in [(0.0, &self.pos[..n]), (1.0, &self.vel[..])] {
            for (k, x) in v.iter().enumerate() {
                if let Some(d) = (0..D).find(|&d| !x[d].is_finite()) {
                    found = worse(found, [kind, f64::from(self.id[k]), d as f64, x[d], 0.0]);
                }
            }
        }
        if found[0] < 4.0 {
            return found;
        }
        for d in (0..D).filter(|&d| !self.periodic[d]) {
            let lo = self.prep.lo[d];
            let hi = lo + self.prep.len[d];
            for (k, x) in self.pos[..n].iter().enumerate() {
                let r = self.radius[k];
                if x[d] < lo - r || x[d] > hi + r {
                    found = worse(found, [2.0, f64::from(self.id[k]), d as f64, x[d], 0.0]);
                }
            }
        }
        if found[0] < 4.0 || !self.prep.max_overlap.is_finite() {
            return found;
        }
        let (zw, _) = self.prep.wall_motion(self.time);
        let vert = self.prep.vertical;
        for i in 0..n {
            let (xi, ri) = (self.pos[i], self.radius[i]);
            let id = f64::from(self.id[i]);
            for &j in self.list.partners(i) {
                let j = j as usize;
                let r2: f64 = (0..D).map(|d| (xi[d] - self.pos[j][d]).powi(2)).sum();
                let rj = self.radius[j];
                let ratio = (ri + rj - r2.sqrt()) / ri.min(rj);
                if ratio > self.prep.max_overlap {
                    found = worse(found, [3.0, id, ratio, 0.0, f64::from(self.id[j])]);
                }
            }
            let mut x = xi;
            wrap(&mut x, self.periodic, self.lo, self.len);
            for (w, (pw, wt)) in self.prep.walls.iter().zip(&self.walls).enumerate() {
                let at = if wt.wrap { x } else { xi };
                let ratio = pw.overlap(&at, ri, zw, vert) / ri;
                if ratio > self.prep.max_overlap {
                    found = worse(found, [3.0, id, ratio, 1.0, w as f64]);
                }
            }
        }
        found
    }

    /// The blow-up message of a finding (the same on every rank).
    fn describe(&self, f: &Finding) -> (String, String) {
        let (kind, id) = (f[0] as usize, f[1] as usize);
        let p = &self.prep;
        match kind {
            0 | 1 => {
                let name = if kind == 0 { "position" } else { "velocity" };
                (
                    format!("particle {id}: {name} {} = {}", AXES[f[2] as usize], f[3]),
                    p.non_finite_cause(),
                )
            }
            2 => {
                let d = f[2] as usize;
                let (lo, hi) = (p.lo[d], p.lo[d] + p.len[d]);
                (
                    format!(
                        "particle {id}: position {} = {}, outside the box [{lo}, {hi}] by \
                         more than its radius {}",
                        AXES[d], f[3], p.radius[id]
                    ),
                    p.escape_cause(),
                )
            }
            _ => {
                let other = if f[3] == 0.0 {
                    format!("particle {}", f[4] as usize)
                } else {
                    format!("wall {}", f[4] as usize)
                };
                (
                    format!(
                        "particle {id} overlaps {other} by {} of the smaller radius (limit \
                         Config::max_overlap = {})",
                        f[2], p.max_overlap
                    ),
                    p.overlap_cause(),
                )
            }
        }
    }

    /// Copies the owned state into the guard's snapshot.
    fn keep(&mut self) {
        let (s, n) = (&mut self.snap, self.owned);
        s.id.clone_from(&self.id);
        s.id.truncate(n);
        s.pos.clone_from(&self.pos);
        s.pos.truncate(n);
        s.aux.clone_from(&self.aux);
        s.aux.truncate(n);
        s.vel.clone_from(&self.vel);
        s.acc.clone_from(&self.acc);
        s.reference.clone_from(&self.reference);
        (s.time, s.started, s.steps) = (self.time, self.started, self.steps);
    }

    /// Puts every rank back to its snapshot (the particles it owned then) and remakes
    /// ghosts and lists from the list-build positions, so the lists are those the run had.
    fn restore(&mut self, comm: &Comm) -> Result<()> {
        let s = &self.snap;
        let ids: Vec<usize> = s.id.iter().map(|&i| i as usize).collect();
        let (pos, vel, acc, aux, reference) = (
            s.pos.clone(),
            s.vel.clone(),
            s.acc.clone(),
            s.aux.clone(),
            s.reference.clone(),
        );
        (self.time, self.started, self.steps) = (s.time, s.started, s.steps);
        self.take(&ids);
        (self.pos, self.vel, self.acc, self.aux, self.reference) = (pos, vel, acc, aux, reference);
        self.relist(comm)
    }

    /// The record of owned particle `k` with position `x`.
    fn record(&self, k: usize, x: &[f64; D]) -> Record {
        let mut r = [0.0; 16];
        r[0] = f64::from(self.id[k]);
        let parts = [
            (1, x),
            (4, &self.vel[k]),
            (7, &self.acc[k]),
            (10, &self.aux[k]),
            (13, &self.reference[k]),
        ];
        for (o, v) in parts {
            r[o..o + D].copy_from_slice(v);
        }
        r
    }

    /// The dynamic state of all particles in scene order on rank 0 (`None` elsewhere).
    fn gather_state(&self, comm: &Comm) -> Result<Option<EngineState>> {
        let n = self.owned;
        let mine: Vec<Record> = (0..n).map(|k| self.record(k, &self.pos[k])).collect();
        let total = self.prep.n;
        let Some(rows) = comm.gather_indexed::<16>(&mine, total)? else {
            return Ok(None);
        };
        let column = |o: usize| -> Vec<f64> {
            rows.iter()
                .flat_map(|r| r[o..o + D].iter().copied())
                .collect()
        };
        Ok(Some(EngineState {
            steps: self.steps,
            time: self.time,
            started: self.started,
            width: D as u32,
            id: (0..total as u32).collect(),
            pos: column(1),
            vel: column(4),
            acc: column(7),
            aux: column(10),
            reference: column(13),
        }))
    }
}

/// The finding to report of two: the lower kind; within non-finite values and escapes the
/// smaller scene index; within overlaps the deeper (then the smaller index).
fn worse(a: Finding, b: Finding) -> Finding {
    if b[0] != a[0] {
        return if b[0] < a[0] { b } else { a };
    }
    if a[0] == 3.0 {
        if b[2] > a[2] || (b[2] == a[2] && b[1] < a[1]) {
            return b;
        }
        return a;
    }
    if b[1] < a[1] { b } else { a }
}
