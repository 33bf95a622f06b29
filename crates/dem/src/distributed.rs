//! [`DistributedDem`]: the CPU run over the ranks of a [`Comm`] by spatial decomposition,
//! with results that do not depend on the rank count.

use rayon::prelude::*;

use simkit_backend::comm::{Comm, ParticleDomain};
use simkit_backend::guard::{Guarded, Halt, run_guarded, verdict};
use simkit_backend::particles::Dynamics;
use simkit_backend::{Distributed, Error, Precision, Result, Simulation};
use simkit_neighbor::{
    ByDim, DistributedRun, Finding, GhostedList, RECORD, RankParticles, RankRun, RankView, by_dim,
    distributed_accessors,
};

use crate::cpu::{
    AXES, ForceInput, WallT, contact_force, drift_velocity_verlet, max_displacement2, wall_force,
    walls_of, wrap,
};
use crate::engine::model_name;
use crate::prepared::Prepared;
use crate::sim::{decode, encode};
use crate::spin::open_spin;
use crate::{Config, ContactLaw, Diagnostics, Integrator, Material, Scene, State, diagnostics};

mod contacts;

use contacts::RankHistory;

/// Owned particles per rayon task of the per-particle passes.
const CHUNK: usize = 1024;

/// The shared columns of [`RankParticles`] (owned and ghosts): the velocities the dashpots
/// read, predicted at the force time, and (rotating scenes) the angular velocities
/// predicted at the force time.
const AUX: usize = 0;
const SPIN_P: usize = 1;
/// The owned columns: velocities and accelerations, and (rotating scenes) angular
/// velocities and angular accelerations. An angular 3-vector is held in a `D`-column: as
/// it is in 3D, its z component first in 2D ([`to_column`]).
const VEL: usize = 0;
const ACC: usize = 1;
const SPIN: usize = 2;
const ALPHA: usize = 3;

/// An angular 3-vector in a `D`-column (2D: `[w_z, 0]`).
fn to_column<const D: usize>(w: [f64; 3]) -> [f64; D] {
    std::array::from_fn(|d| match (D, d) {
        (3, _) => w[d],
        (_, 0) => w[2],
        _ => 0.0,
    })
}

/// The angular 3-vector of a `D`-column (the inverse of [`to_column`]).
fn from_column<const D: usize>(c: &[f64; D]) -> [f64; 3] {
    if D == 3 {
        std::array::from_fn(|d| c[d])
    } else {
        [0.0, 0.0, c[0]]
    }
}

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
/// **Rotation and contact history** run as in [`crate::Dem`]: a rotating scene integrates
/// the angular velocities with the translation's velocity Verlet scheme (the angular
/// velocity predicted at the force time travels to the ghosts with the predicted velocity),
/// and a law that keeps a history ([`ContactLaw::HISTORY`], at most 12 values here) keeps
/// it per contact *from each end*: every owned particle holds its own copy of the history
/// of each of its contacts (the partner named by its scene index, walls included), advanced
/// by its own force evaluation, so that no copy depends on which rank holds the partner.
/// The two copies of a pair are mirror images (the law's
/// [`swap_history`](ContactLaw::swap_history) of each other). A copy travels with its
/// particle when the particle migrates, comes back with the blow-up guard's rollback, and
/// goes into checkpoints (both copies of every pair; [`crate::Dem`] resumes them, and a
/// [`crate::Dem`] checkpoint, which holds one copy per pair, gives both ends theirs).
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
/// let mut sim = DistributedDem::new(scene, &Config::default(), Comm::serial())?;
/// sim.step(200)?;
/// let d = sim.diagnostics()?; // on every rank
/// assert!(d.finite);
/// # Ok(())
/// # }
/// ```
pub struct DistributedDem<L: ContactLaw = Material> {
    run: DistributedRun<Engine<2, L>, Engine<3, L>>,
    scene: Scene<L>,
    config: Config,
}

impl<L: ContactLaw> std::fmt::Debug for DistributedDem<L> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.run.debug(f, "DistributedDem")
    }
}

impl<L: ContactLaw> DistributedDem<L> {
    /// Validates the scene and settings as [`crate::Dem::new`] does on the CPU (the same
    /// errors, on every rank) and builds this rank's part of the run. Collective; every
    /// rank passes the same scene and configuration.
    ///
    /// Errors: those of [`crate::Dem::new`]; [`Precision::F32`] or position Verlet
    /// (not offered here); more ranks than regions at least a list range wide fit in the
    /// box; ranks whose scenes or settings differ. An error on one rank is an error on
    /// every rank (the others name the rank that failed).
    pub fn new(scene: Scene<L>, config: &Config, comm: Comm) -> Result<Self> {
        Self::build(scene, config, comm, None)
    }

    fn build(
        scene: Scene<L>,
        config: &Config,
        comm: Comm,
        saved: Option<&Dynamics>,
    ) -> Result<Self> {
        let prep = comm.agree(prepare(&scene, config))?;
        // Everything the ranks must agree on: the scene and settings as a checkpoint stores
        // them (with the state, when resuming).
        let encoded = comm.agree(encode(
            &scene,
            config,
            "",
            saved.cloned().unwrap_or_default(),
        ))?;
        comm.agree_inputs(&encoded, "DistributedDem inputs")?;
        let engine = if prep.axes == 2 {
            ByDim::Two(comm.agree(Engine::new(prep, &comm))?)
        } else {
            ByDim::Three(comm.agree(Engine::new(prep, &comm))?)
        };
        let mut run = DistributedRun::new(comm, engine);
        let (engine, comm) = run.parts();
        by_dim!(engine, e => comm.agree(match saved {
            None => e.start(comm),
            Some(s) => e.load(comm, s),
        }))?;
        Ok(Self {
            run,
            scene,
            config: *config,
        })
    }

    distributed_accessors!();

    /// The scene the run started from.
    pub fn scene(&self) -> &Scene<L> {
        &self.scene
    }

    /// The configuration.
    pub fn config(&self) -> &Config {
        &self.config
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
        by_dim!(self.run.engine(), e => diagnostics::compute(&e.prep, state.time, &state.positions, &state.velocities, &state.angular_velocities))
    }

    /// Vertical displacement of the vibrating walls at time `t`.
    pub fn wall_displacement(&self, t: f64) -> f64 {
        by_dim!(self.run.engine(), e => e.prep.wall_motion(t).0)
    }
}

impl<L: ContactLaw> Simulation for DistributedDem<L> {
    type State = State;

    /// Advances `steps` steps on every rank, checking the state every
    /// [`Config::check_every`] steps and at the end as [`crate::Dem`] does; a failed check
    /// returns the same [`Error::BlowUp`] on every rank (the failure of the smallest scene
    /// index, or the deepest overlap) with the run rolled back everywhere to the last state
    /// that passed. Collective.
    fn step(&mut self, steps: u32) -> Result<()> {
        self.run.step(steps)
    }

    /// The state of all particles in scene order (periodic coordinates wrapped), gathered
    /// on rank 0 and sent to every rank. Collective.
    fn state(&mut self) -> Result<State> {
        let species = by_dim!(self.run.engine(), e => e.prep.species.clone());
        let mut state = self.run.state(&species)?;
        let comm = self.run.comm();
        let spins = by_dim!(self.run.engine(), e => e.gather_spins(comm));
        let spins = comm.share_from_root(spins)?;
        state.angular_velocities = spins.chunks_exact(3).map(|w| [w[0], w[1], w[2]]).collect();
        Ok(state)
    }

    fn steps_done(&self) -> u64 {
        self.run.steps()
    }

    fn backend_name(&self) -> String {
        let threads = rayon::current_num_threads();
        let plural = if threads == 1 { "" } else { "s" };
        format!(
            "cpu f64 ({} ranks, {threads} thread{plural} each)",
            self.run.comm().size()
        )
    }
}

impl<L: ContactLaw> Distributed for DistributedDem<L> {
    fn comm(&self) -> &Comm {
        self.run.comm()
    }

    /// The complete state in the single-process checkpoint format (the particles in scene
    /// order, with their list-build positions), on every rank: resumes with
    /// [`Distributed::resume`] on any rank count, or with [`crate::Dem`]'s
    /// `Restart::resume` on the CPU in one process. Collective.
    ///
    /// Errors: a failed exchange.
    fn checkpoint(&mut self) -> Result<Vec<u8>> {
        let model = model_name::<L>(false, Precision::F64, self.scene.dim().axes());
        let (scene, config) = (&self.scene, &self.config);
        self.run.checkpoint(|d| encode(scene, config, &model, d))
    }

    /// Rebuilds a run from the bytes of [`Distributed::checkpoint`] (any rank count) or
    /// of [`crate::Dem`]'s `Restart::checkpoint` on the CPU in `f64`, on any rank count.
    /// Each rank takes the particles its region held at the last list build, the lists are
    /// made from the list-build positions, and the run continues with the bits of the
    /// uninterrupted distributed run. Collective; every rank passes the same bytes (checked;
    /// [`Distributed::resume_file`] reads a file on rank 0 and sends it).
    ///
    /// Errors: another crate's or model's checkpoint, a truncated, corrupt or inconsistent
    /// one (as `Dem::resume`), those of [`DistributedDem::new`]. An error on one rank is an
    /// error on every rank.
    fn resume(bytes: &[u8], comm: Comm) -> Result<Self> {
        let saved = comm.agree(decode::<L>(bytes).and_then(|s| {
            let want = model_name::<L>(false, Precision::F64, s.scene.dim().axes());
            if s.model == want {
                Ok(s)
            } else {
                Err(Error::checkpoint(format!(
                    "holds a {} run; DistributedDem resumes {want} runs (CPU, f64)",
                    s.model
                )))
            }
        }))?;
        Self::build(saved.scene, &saved.config, comm, Some(&saved.engine))
    }
}

/// The shared validation of [`crate::Dem::new`], plus what this run does not offer.
fn prepare<L: ContactLaw>(scene: &Scene<L>, config: &Config) -> Result<Prepared<L>> {
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
    // Refused before the scene is prepared: the law's history must fit a record.
    RankHistory::new(L::HISTORY, 0, 0)?;
    let prep = Prepared::new(scene, config, false)?;
    diagnostics::check_initial_overlaps(&prep)?;
    Ok(prep)
}

/// What a blow-up check found on a rank, as the ranks exchange it: `[kind, id, a, b, c]`
/// with kind 0 (non-finite position: a = axis, b = value), 1 (non-finite velocity), 2
/// (non-finite angular velocity), 3 (outside the box: a = axis, b = coordinate), 4
/// (overlap: a = ratio, b = 0 for a particle or 1 for a wall, c = its index), 5 (nothing).
const NOTHING: Finding = [5.0, 0.0, 0.0, 0.0, 0.0];
/// The overlap kind of a [`Finding`].
const OVERLAP: f64 = 4.0;

/// This rank's part of the run in dimension `D`: its particles ([`RankParticles`]), their
/// contact history ([`RankHistory`]) and the contact law's inputs.
struct Engine<const D: usize, L: ContactLaw> {
    prep: Prepared<L>,
    p: RankParticles<D, ()>,
    history: RankHistory,
    time: f64,
    started: bool,
    steps: u64,
    /// The clock of the guard's copy: time, started, steps.
    kept: (f64, bool, u64),
    /// Radius, mass and species of every local entry (owned, then ghosts), and `1 / m` and
    /// `1 / I` (rotating scenes) of the owned particles, from the scene by global index
    /// after every list build.
    radius: Vec<f64>,
    mass: Vec<f64>,
    species: Vec<u32>,
    inv_mass: Vec<f64>,
    inv_inertia: Vec<f64>,
    /// Rotating scenes: the predicted angular velocities of every local entry as
    /// 3-vectors (from the shared column, before each force pass).
    omega_p: Vec<[f64; 3]>,
    coeff: Vec<L::Coeff<f64>>,
    walls: Vec<WallT<f64, L::Coeff<f64>>>,
    gravity: [f64; D],
    periodic: [bool; D],
    lo: [f64; D],
    len: [f64; D],
    cut2: f64,
    rebuild_dist2: f64,
}

impl<const D: usize, L: ContactLaw> Engine<D, L>
where
    [f64; D]: bytemuck::Pod,
{
    /// The engine without particles (they come with [`Engine::start`] or
    /// [`Engine::load`]).
    fn new(prep: Prepared<L>, comm: &Comm) -> Result<Self> {
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
        let (lo, len, periodic): ([f64; D], [f64; D], [bool; D]) = (
            std::array::from_fn(|d| prep.lo[d]),
            std::array::from_fn(|d| prep.len[d]),
            std::array::from_fn(|d| prep.periodic[d]),
        );
        let list = GhostedList::new(domain, periodic_z, range)?;
        let spin = usize::from(prep.rotation);
        Ok(Self {
            p: RankParticles::new(
                list,
                (lo, len, periodic),
                vec![(); prep.n],
                1 + spin,
                2 + 2 * spin,
            )?,
            history: RankHistory::new(L::HISTORY, prep.walls.len(), prep.n)?,
            time: 0.0,
            started: false,
            steps: 0,
            kept: (0.0, false, 0),
            radius: Vec::new(),
            mass: Vec::new(),
            species: Vec::new(),
            inv_mass: Vec::new(),
            inv_inertia: Vec::new(),
            omega_p: Vec::new(),
            coeff: prep.pairs.iter().map(L::coefficients).collect(),
            walls: walls_of::<f64, D, L>(&prep),
            gravity,
            periodic,
            lo,
            len,
            cut2: (r_max + r_max) * (r_max + r_max),
            rebuild_dist2: 0.25 * prep.skin * prep.skin,
            prep,
        })
    }

    /// The scene's radius, mass and species of every local entry, and the inverse masses
    /// and moments of inertia of the owned particles (after a list build).
    fn sync(&mut self) {
        let (p, ids) = (&self.prep, self.p.id());
        self.radius = ids.iter().map(|&i| p.radius[i as usize]).collect();
        self.mass = ids.iter().map(|&i| p.mass[i as usize]).collect();
        self.species = ids.iter().map(|&i| p.species[i as usize]).collect();
        let owned = &ids[..self.p.owned()];
        self.inv_mass = owned.iter().map(|&i| 1.0 / p.mass[i as usize]).collect();
        if p.rotation {
            self.inv_inertia = owned.iter().map(|&i| 1.0 / p.inertia[i as usize]).collect();
        }
    }

    /// The initial state: every rank takes the scene's particles in its region.
    fn start(&mut self, comm: &Comm) -> Result<()> {
        let prep = &self.prep;
        let mine = self
            .p
            .start(comm, |i| std::array::from_fn(|d| prep.positions[i][d]));
        for (k, &i) in mine.iter().enumerate() {
            let v = std::array::from_fn(|d| prep.velocities[i][d]);
            self.p.set(false, VEL, k, v);
            if prep.rotation {
                self.p.set(false, SPIN, k, to_column(prep.omega[i]));
            }
        }
        self.rebuild(comm)
    }

    /// A checkpointed state: every rank takes the particles whose list-build position lies
    /// in its region (where the run that wrote it had them), with their angular velocities
    /// and the history of their contacts (a pair stored once, as [`crate::Dem`] stores it,
    /// gives the other end its mirror image).
    fn load(&mut self, comm: &Comm, s: &Dynamics) -> Result<()> {
        let n = self.prep.n;
        s.check(n, D, &["pos", "vel", "acc", "aux", "reference"])?;
        self.prep.check_saved_extras(s)?;
        let at = |v: &[f64], k: usize| -> [f64; D] { Dynamics::at(v, k) };
        let mine = self
            .p
            .load(comm, n, |k| at(&s.reference, k), |k| s.particle(k));
        for (k, &slot) in mine.iter().enumerate() {
            self.p.set_position(k, at(&s.pos, slot));
            self.p.set(false, VEL, k, at(&s.vel, slot));
            self.p.set(false, ACC, k, at(&s.acc, slot));
            self.p.set(true, AUX, k, at(&s.aux, slot));
            if self.prep.rotation {
                let w = |c: usize| to_column(std::array::from_fn(|d| s.spin[9 * slot + c + d]));
                self.p.set(false, SPIN, k, w(0));
                self.p.set(false, ALPHA, k, w(3));
                self.p.set(true, SPIN_P, k, w(6));
            }
        }
        (self.time, self.started, self.steps) = (s.time, s.started, s.steps);
        self.p.relist(comm)?;
        self.sync();
        let h = L::HISTORY;
        let index: std::collections::HashMap<[u32; 2], usize> = s
            .contacts
            .iter()
            .enumerate()
            .map(|(k, &key)| (key, k))
            .collect();
        let n = n as u32;
        self.history.assign(&self.p, |i, partner, out| {
            let value = |k: usize| &s.history[k * h..(k + 1) * h];
            if let Some(&k) = index.get(&[i, partner]) {
                out.copy_from_slice(value(k));
            } else if let Some(&k) = (partner < n).then(|| index.get(&[partner, i])).flatten() {
                out.copy_from_slice(value(k));
                L::swap_history(out);
            }
        });
        Ok(())
    }

    /// A list build with migration ([`RankParticles::rebuild`]); the contact history
    /// travels with its particles.
    fn rebuild(&mut self, comm: &Comm) -> Result<()> {
        let moved = if self.history.on() {
            let records = self.history.records(&self.p);
            self.p
                .list()
                .domain()
                .migrate(comm, records, |r| [r[2], r[3]])?
        } else {
            Vec::new()
        };
        self.p.rebuild(comm)?;
        self.sync();
        self.history.assign_records(&self.p, &moved);
        Ok(())
    }

    /// Forces and torques at the current time from the positions and predicted
    /// velocities into `acc` and `alpha` (as accelerations), advancing the contact history.
    fn forces(&mut self) {
        if self.prep.rotation {
            let w = self.p.shared(SPIN_P);
            self.omega_p.clear();
            self.omega_p.extend(w.iter().map(from_column));
        }
        match (self.prep.friction, self.prep.rotation) {
            (true, true) => self.forces_variant::<true, true>(),
            (true, false) => self.forces_variant::<true, false>(),
            (false, true) => self.forces_variant::<false, true>(),
            (false, false) => self.forces_variant::<false, false>(),
        }
    }

    fn forces_variant<const FRICTION: bool, const ROT: bool>(&mut self) {
        let (zw, vw) = self.prep.wall_motion(self.time);
        let parts = self.p.parts();
        let inp = ForceInput {
            pos: parts.pos,
            vel: &parts.shared[AUX],
            radius: &self.radius,
            mass: &self.mass,
            species: &self.species,
            omega: &self.omega_p,
            dt: self.prep.dt,
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
        let (list, inv_mass, inv_inertia) = (parts.list, &self.inv_mass, &self.inv_inertia);
        let (vel_acc, spins) = parts.cols.split_at_mut(SPIN);
        let count = parts.owned.div_ceil(CHUNK);
        // Without rotation there are no torques: an empty slice per chunk.
        let alpha: Vec<&mut [[f64; D]]> = match spins.get_mut(ALPHA - SPIN) {
            Some(a) => a.chunks_mut(CHUNK).collect(),
            None => (0..count).map(|_| Default::default()).collect(),
        };
        let hist = self.history.chunks(parts.owned, CHUNK);
        vel_acc[ACC]
            .par_chunks_mut(CHUNK)
            .zip(alpha)
            .zip(hist)
            .enumerate()
            .for_each(|(c, ((acc, alpha), mut hist))| {
                for (k, a) in acc.iter_mut().enumerate() {
                    let i = c * CHUNK + k;
                    let mut f = [0.0; D];
                    let mut t = [0.0; 3];
                    for (f, g) in f.iter_mut().zip(inp.gravity) {
                        *f += g * inp.mass[i];
                    }
                    for (w, wall) in inp.walls.iter().enumerate() {
                        let hw = hist.wall(k, w);
                        wall_force::<f64, D, L, FRICTION, ROT>(&inp, wall, i, hw, &mut f, &mut t);
                    }
                    let xi = inp.pos[i];
                    for (e, &j) in list.partners(i).iter().enumerate() {
                        let j = j as usize;
                        let sep: [f64; D] = std::array::from_fn(|d| xi[d] - inp.pos[j][d]);
                        let hp = hist.pair(k, e);
                        let fp = contact_force::<f64, D, L, FRICTION, ROT>(&inp, i, j, sep, hp);
                        if let Some(fp) = fp {
                            for (f, x) in f.iter_mut().zip(fp.f) {
                                *f += x;
                            }
                            for (t, x) in t.iter_mut().zip(fp.t_i) {
                                *t += x;
                            }
                        }
                    }
                    for d in 0..D {
                        a[d] = f[d] * inv_mass[i];
                    }
                    if ROT {
                        alpha[k] = to_column(t.map(|x| x * inv_inertia[i]));
                    }
                }
            });
    }

    /// `steps` velocity Verlet steps without checks.
    fn advance(&mut self, comm: &Comm, steps: u32) -> Result<()> {
        if steps == 0 {
            return Ok(());
        }
        let rotation = self.prep.rotation;
        if !self.started {
            let parts = self.p.parts();
            let n = parts.owned;
            parts.shared[AUX][..n].copy_from_slice(&parts.cols[VEL]);
            if rotation {
                parts.shared[SPIN_P][..n].copy_from_slice(&parts.cols[SPIN]);
            }
            self.p.refresh(comm)?;
            self.forces();
            self.started = true;
        }
        let dt = self.prep.dt;
        let h = 0.5 * dt;
        for _ in 0..steps {
            // A list build migrates particles: the owned count changes between steps.
            let max2 = {
                let parts = self.p.parts();
                let n = parts.owned;
                let (pos, shared) = (&mut parts.pos[..n], &mut *parts.shared);
                let [vel, acc, spins @ ..] = &mut *parts.cols else {
                    unreachable!("dem's columns")
                };
                if let [w, alpha] = spins {
                    open_spin(
                        w.as_flattened_mut(),
                        &mut shared[SPIN_P].as_flattened_mut()[..n * D],
                        alpha.as_flattened(),
                        h,
                    );
                }
                pos.par_chunks_mut(CHUNK)
                    .zip(vel.par_chunks_mut(CHUNK))
                    .zip(shared[AUX][..n].par_chunks_mut(CHUNK))
                    .zip(acc.par_chunks(CHUNK))
                    .zip(parts.reference.par_chunks(CHUNK))
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
                self.p.refresh(comm)?;
            }
            self.forces();
            let [vel, acc, spins @ ..] = &mut *self.p.parts().cols else {
                unreachable!("dem's columns")
            };
            kick(vel, acc, h);
            if let [w, alpha] = spins {
                kick(w, alpha, h);
            }
        }
        Ok(())
    }

    /// This rank's first finding: non-finite position, velocity or angular velocity, a
    /// particle outside the box by more than its radius (each the smallest scene index of
    /// its kind), the deepest contact over `max_overlap`.
    fn check(&self) -> Finding {
        let (p, n) = (&self.p, self.p.owned());
        let (pos, id) = (p.pos(), p.id());
        let mut found = NOTHING;
        let spin: &[[f64; D]] = if self.prep.rotation { p.col(SPIN) } else { &[] };
        for (kind, v) in [(0.0, &pos[..n]), (1.0, p.col(VEL)), (2.0, spin)] {
            for (k, x) in v.iter().enumerate() {
                if let Some(d) = (0..D).find(|&d| !x[d].is_finite()) {
                    // An angular velocity names its axis (2D: z).
                    let axis = if kind == 2.0 && D == 2 { 2 } else { d };
                    found = worse(found, [kind, f64::from(id[k]), axis as f64, x[d], 0.0]);
                }
            }
        }
        if found[0] < NOTHING[0] {
            return found;
        }
        for d in (0..D).filter(|&d| !self.periodic[d]) {
            let lo = self.prep.lo[d];
            let hi = lo + self.prep.len[d];
            for (k, x) in pos[..n].iter().enumerate() {
                let r = self.radius[k];
                if x[d] < lo - r || x[d] > hi + r {
                    found = worse(found, [3.0, f64::from(id[k]), d as f64, x[d], 0.0]);
                }
            }
        }
        if found[0] < NOTHING[0] || !self.prep.max_overlap.is_finite() {
            return found;
        }
        let (zw, _) = self.prep.wall_motion(self.time);
        let vert = self.prep.vertical;
        for i in 0..n {
            let (xi, ri) = (pos[i], self.radius[i]);
            let me = f64::from(id[i]);
            for &j in p.list().partners(i) {
                let j = j as usize;
                let r2: f64 = (0..D).map(|d| (xi[d] - pos[j][d]).powi(2)).sum();
                let rj = self.radius[j];
                let ratio = (ri + rj - r2.sqrt()) / ri.min(rj);
                if ratio > self.prep.max_overlap {
                    found = worse(found, [OVERLAP, me, ratio, 0.0, f64::from(id[j])]);
                }
            }
            let mut x = xi;
            wrap(&mut x, self.periodic, self.lo, self.len);
            for (w, (pw, wt)) in self.prep.walls.iter().zip(&self.walls).enumerate() {
                let at = if wt.wrap { x } else { xi };
                let ratio = pw.overlap(&at, ri, zw, vert) / ri;
                if ratio > self.prep.max_overlap {
                    found = worse(found, [OVERLAP, me, ratio, 1.0, w as f64]);
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
            0..=2 => {
                let name = ["position", "velocity", "angular velocity"][kind];
                (
                    format!("particle {id}: {name} {} = {}", AXES[f[2] as usize], f[3]),
                    p.non_finite_cause(),
                )
            }
            3 => {
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

    /// Every particle's record on rank 0 in scene order (`None` elsewhere): position as the
    /// run holds it, velocity, acceleration, predicted velocity, list-build position
    /// (`D` values each at 0, 3, 6, 9, 12 after the index), then in a rotating scene the
    /// angular velocity, angular acceleration and predicted angular velocity (3 values each
    /// at 15, 18, 21).
    fn gather(&self, comm: &Comm) -> Result<Option<Vec<[f64; RECORD]>>> {
        let p = &self.p;
        let (vel, acc, aux) = (p.col(VEL), p.col(ACC), p.shared(AUX));
        let rotation = self.prep.rotation;
        p.gather(comm, |k| {
            let mut r = [0.0; RECORD - 1];
            for (o, v) in [
                (0, &p.pos()[k]),
                (3, &vel[k]),
                (6, &acc[k]),
                (9, &aux[k]),
                (12, &p.reference()[k]),
            ] {
                r[o..o + D].copy_from_slice(v);
            }
            if rotation {
                for (o, v) in [
                    (15, &p.col(SPIN)[k]),
                    (18, &p.col(ALPHA)[k]),
                    (21, &p.shared(SPIN_P)[k]),
                ] {
                    r[o..o + 3].copy_from_slice(&from_column(v));
                }
            }
            r
        })
    }

    /// Every particle's angular velocity on rank 0 in scene order (`None` elsewhere; empty
    /// without rotation).
    fn gather_spins(&self, comm: &Comm) -> Result<Option<Vec<f64>>> {
        if !self.prep.rotation {
            return Ok(Some(Vec::new()));
        }
        let p = &self.p;
        let rows = p.gather(comm, |k| {
            let mut r = [0.0; RECORD - 1];
            r[..3].copy_from_slice(&from_column(&p.col(SPIN)[k]));
            r
        })?;
        Ok(rows.map(|rows| rows.iter().flat_map(|r| [r[1], r[2], r[3]]).collect()))
    }

    /// Every contact history of the run on rank 0 (`None` elsewhere), both copies of each
    /// pair, sorted by `(particle, partner)` (the same on any rank count).
    fn gather_history(&self, comm: &Comm) -> Result<Option<Contacts>> {
        let h = L::HISTORY;
        if h == 0 {
            return Ok(Some(Default::default()));
        }
        let parts = comm.gather_to_root(&self.history.records(&self.p))?;
        Ok(parts.map(|parts| {
            let mut all: Vec<_> = parts.into_iter().flatten().collect();
            all.sort_by_key(|r| (r[0] as u32, r[1] as u32));
            let keys = all.iter().map(|r| [r[0] as u32, r[1] as u32]).collect();
            let values = all
                .iter()
                .flat_map(|r| r[4..4 + h].iter().copied())
                .collect();
            (keys, values)
        }))
    }
}

/// Contact keys `(particle, partner)` and their history values, as a checkpoint stores them.
type Contacts = (Vec<[u32; 2]>, Vec<f64>);

/// The closing half kick `v += a dt / 2` (`h = dt / 2`) of owned particles' velocities or
/// angular velocities.
fn kick<const D: usize>(v: &mut [[f64; D]], a: &[[f64; D]], h: f64) {
    v.par_chunks_mut(CHUNK)
        .zip(a.par_chunks(CHUNK))
        .for_each(|(v, a)| {
            for (v, a) in v.iter_mut().zip(a) {
                for d in 0..D {
                    v[d] += a[d] * h;
                }
            }
        });
}

/// The finding to report of two: the lower kind; within non-finite values and escapes the
/// smaller scene index; within overlaps the deeper (then the smaller index).
fn worse(a: Finding, b: Finding) -> Finding {
    if b[0] != a[0] {
        return if b[0] < a[0] { b } else { a };
    }
    if a[0] == OVERLAP {
        if b[2] > a[2] || (b[2] == a[2] && b[1] < a[1]) {
            return b;
        }
        return a;
    }
    if b[1] < a[1] { b } else { a }
}

/// The blow-up guard's view of a rank's engine (see [`simkit_backend::guard`]): every
/// decision is taken by all ranks together.
struct Checked<'a, const D: usize, L: ContactLaw> {
    e: &'a mut Engine<D, L>,
    comm: &'a Comm,
}

impl<const D: usize, L: ContactLaw> Guarded for Checked<'_, D, L>
where
    [f64; D]: bytemuck::Pod,
{
    fn steps_done(&self) -> u64 {
        self.e.steps
    }

    fn keep(&mut self) -> Result<()> {
        let e = &mut *self.e;
        e.p.keep();
        e.history.keep(&e.p);
        e.kept = (e.time, e.started, e.steps);
        Ok(())
    }

    fn advance(&mut self, n: u32) -> std::result::Result<(), Halt> {
        // A list build that failed on every rank (particles that jumped a region,
        // positions a grid cannot hold): the run blew up within the stretch.
        self.e.advance(self.comm, n).map_err(|err| Halt::BlowUp {
            step: self.e.steps + u64::from(n),
            what: format!("the neighbour-list build failed: {err}"),
            cause: self.e.prep.non_finite_cause(),
        })?;
        self.e.steps += u64::from(n);
        Ok(())
    }

    fn check(&mut self) -> std::result::Result<(), Halt> {
        let found = RankParticles::<D, ()>::findings(self.comm, self.e.check(), NOTHING, worse)?;
        let failure = (found[0] < NOTHING[0]).then(|| self.e.describe(&found));
        verdict(self.e.steps, failure)
    }

    fn restore(&mut self) -> Result<()> {
        let e = &mut *self.e;
        e.p.restore(self.comm)?;
        e.sync();
        e.history.restore(&e.p);
        (e.time, e.started, e.steps) = e.kept;
        Ok(())
    }
}

impl<const D: usize, L: ContactLaw> RankRun for Engine<D, L>
where
    [f64; D]: bytemuck::Pod,
{
    fn view(&self) -> RankView {
        self.p.view()
    }

    fn steps(&self) -> u64 {
        self.steps
    }

    fn time(&self) -> f64 {
        self.time
    }

    fn dt(&self) -> f64 {
        self.prep.dt
    }

    fn step(&mut self, comm: &Comm, steps: u32) -> Result<()> {
        let every = self.prep.check_every;
        run_guarded(&mut Checked { e: self, comm }, steps, every)
    }

    fn gather_motion(&self, comm: &Comm) -> Result<Option<Vec<[f64; 6]>>> {
        let rows = self.gather(comm)?;
        Ok(rows.map(|rows| {
            rows.iter()
                .map(|r| {
                    let mut x: [f64; D] = std::array::from_fn(|d| r[1 + d]);
                    wrap(&mut x, self.periodic, self.lo, self.len);
                    std::array::from_fn(|c| match c {
                        0..3 if c < D => x[c],
                        3..6 if c - 3 < D => r[4 + c - 3],
                        _ => 0.0,
                    })
                })
                .collect()
        }))
    }

    fn gather_dynamics(&self, comm: &Comm) -> Result<Option<Dynamics>> {
        let rows = self.gather(comm)?;
        let history = self.gather_history(comm)?;
        let rotation = self.prep.rotation;
        Ok(rows.zip(history).map(|(rows, (contacts, history))| {
            let column = |o: usize| -> Vec<f64> {
                rows.iter()
                    .flat_map(|r| r[o..o + D].iter().copied())
                    .collect()
            };
            Dynamics {
                steps: self.steps,
                time: self.time,
                started: self.started,
                width: D as u32,
                order: Vec::new(),
                pos: column(1),
                vel: column(4),
                acc: column(7),
                aux: column(10),
                reference: column(13),
                spin: if rotation {
                    rows.iter()
                        .flat_map(|r| r[16..25].iter().copied())
                        .collect()
                } else {
                    Vec::new()
                },
                contacts,
                history,
            }
        }))
    }
}
