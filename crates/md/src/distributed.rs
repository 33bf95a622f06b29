//! [`DistributedMd`]: the CPU run over the ranks of a [`Comm`] by spatial decomposition,
//! with results that do not depend on the rank count.

use rayon::prelude::*;

use simkit_backend::comm::{Comm, ParticleDomain};
use simkit_backend::guard::{Guarded, Halt, run_guarded, verdict};
use simkit_backend::particles::Dynamics;
use simkit_backend::{Distributed, Error, Precision, Result, Simulation, max_or_nan};
use simkit_neighbor::{
    ByDim, DistributedRun, Finding, GhostedList, RECORD, RankParticles, RankRun, RankView, by_dim,
    distributed_accessors,
};

use crate::cpu::{AXES, Kernel, beyond, kick_slice, list_range, reflect};
use crate::diagnostics::assemble;
use crate::engine::model_name;
use crate::sim::{decode_checkpoint, encode_checkpoint};
use crate::thermostat::{gaussians, ou_coefficients};
use crate::{Config, Diagnostics, Dim, Integrator, LennardJones, PairLaw, State, System};

/// Owned particles per rayon task of the per-particle passes.
const CHUNK: usize = 1024;

/// The owned columns of [`RankParticles`]: velocity (velocity Verlet `v(t)`, leapfrog
/// `v(t + dt/2)`), acceleration, force, and the sums of `phi` and `r . F` over the
/// particle's pairs (each pair counted at both ends) in the first two components, at the
/// last step of each checked stretch.
const VEL: usize = 0;
const ACC: usize = 1;
const FORCE: usize = 2;
const SUMS: usize = 3;
const COLS: usize = 4;

/// The likely cause of every blow-up the check finds (as [`crate::Md`]'s CPU backend).
const CAUSE: &str = "a time step too large for the stiffest pair (see time_step_guide) or \
                     particles started (nearly) on top of each other; lower Config::dt";

/// Molecular dynamics over the ranks of a [`Comm`] (CPU, `f64`): spatial decomposition
/// with ghost particles, results independent of the rank count.
///
/// The box is cut along x and y into one region per rank ([`ParticleDomain`], the
/// factorisation with the smallest faces; z is not cut), each at least the neighbour-list
/// range wide: `max r_c + skin` ([`Config::skin`]), capped as in [`crate::Md`] at half the
/// shortest periodic length. A rank integrates the particles in its region (its *owned*
/// particles) and keeps ghost copies of the particles within the list range of its region,
/// received from its 4 neighbours in the shift pattern (x, then y) and refreshed every
/// step. At every list build (when some particle anywhere moved more than half the skin: a
/// global maximum) the periodic coordinates are wrapped, particles migrate to the rank that
/// now owns them, and the ghosts and lists are made anew.
///
/// **Results do not depend on the rank count, bit for bit.** Each owned particle sums its
/// pair forces in increasing system index of the partner, from a full list (each pair is
/// computed from both ends: twice the pair work of the single-process half list), with
/// the pair law of the single-process CPU backend ([`crate::PairLaw::force_energy`], the same
/// function), and every per-particle update is the arithmetic of that backend. A periodic
/// image gets its box length added by the rank that sends it, the same way for any rank
/// count. So on 1, 2, 3 or 4 ranks the positions and velocities are the same bits, and
/// the diagnostics (per-particle terms gathered and summed in system order) too. They are
/// *not* the bits of [`crate::Md`], which sums each particle's pairs in cell order with
/// the reactions of its half list: the two agree to rounding at first, and as any two
/// codes that round differently they part like trajectories of a chaotic system over long
/// runs, with the same statistics.
///
/// Offered: velocity Verlet and leapfrog ([`Integrator`]), periodic and closed
/// (reflecting) axes in 2D and 3D, any pair table, the energy shift, frozen species and
/// the Langevin thermostat (its random numbers are keyed by step and system index, so
/// every rank count draws the same ones). `f32` and the GPU are not offered here (use
/// [`crate::Md`]).
///
/// Every method that takes `&mut self`, and the constructors, are collective: all ranks
/// call them in the same order with the same arguments (the constructors check that the
/// ranks' systems and settings agree).
///
/// ```
/// use simkit_backend::comm::Comm;
/// use simkit_md::{Config, Distributed, DistributedMd, LennardJones, PairTable, Simulation, scenes};
/// # fn main() -> simkit_backend::Result<()> {
/// let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5))?;
/// let system = scenes::fcc_lattice([4; 3], 0.8442, 1.44, table, &[0], 1)?;
/// // `Comm::mpi()?` under `mpirun -np P` (feature `mpi`); here one process.
/// let mut md = DistributedMd::new(system, &Config::default().with_dt(0.005), Comm::serial())?;
/// let e0 = md.diagnostics()?.total; // on every rank
/// md.step(100)?;
/// assert!((md.diagnostics()?.total - e0).abs() < 1e-2 * e0.abs());
/// // Checkpoints are Md's format: they resume on any rank count, or in `Md`.
/// let bytes = md.checkpoint()?;
/// let mut again = DistributedMd::<LennardJones>::resume(&bytes, Comm::serial())?;
/// md.step(10)?;
/// again.step(10)?;
/// assert_eq!(md.state()?, again.state()?);
/// # Ok(())
/// # }
/// ```
pub struct DistributedMd<L: PairLaw = LennardJones> {
    run: DistributedRun<Engine<2, L>, Engine<3, L>>,
    system: System<L>,
    config: Config,
}

impl<L: PairLaw> std::fmt::Debug for DistributedMd<L> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.run.debug(f, "DistributedMd")
    }
}

impl<L: PairLaw> DistributedMd<L> {
    /// Validates the system and settings as [`crate::Md::new`] does on the CPU (the same
    /// errors, on every rank) and builds this rank's part of the run. Collective; every
    /// rank passes the same system and configuration.
    ///
    /// Errors: those of [`crate::Md::new`]; [`Precision::F32`] ([`Error::Unsupported`]:
    /// use `Md`); more ranks than regions at least a list range wide fit in the box (fewer
    /// ranks, a smaller skin or a larger box fix it); ranks whose systems or settings
    /// differ. An error on one rank is an error on every rank (the others name the rank
    /// that failed).
    pub fn new(system: System<L>, config: &Config, comm: Comm) -> Result<Self> {
        Self::build(system, config, comm, None)
    }

    fn build(
        system: System<L>,
        config: &Config,
        comm: Comm,
        saved: Option<&Dynamics>,
    ) -> Result<Self> {
        let dt = comm.agree(prepare(&system, config))?;
        // Everything the ranks must agree on: the system and settings as a checkpoint
        // stores them (with the state, when resuming).
        let state = saved.cloned().unwrap_or_default();
        let encoded = comm.agree(encode_checkpoint(&system, config, "", state))?;
        comm.agree_inputs(&encoded, "DistributedMd inputs")?;
        let engine = match system.dim() {
            Dim::Two => ByDim::Two(comm.agree(Engine::new(&system, config, dt, &comm))?),
            Dim::Three => ByDim::Three(comm.agree(Engine::new(&system, config, dt, &comm))?),
        };
        let mut run = DistributedRun::new(comm, engine);
        let (engine, comm) = run.parts();
        by_dim!(engine, e => e.start(comm, &system, saved)?);
        Ok(Self {
            run,
            system,
            config: *config,
        })
    }

    distributed_accessors!();

    /// The system the run started from.
    pub fn system(&self) -> &System<L> {
        &self.system
    }

    /// The settings of the run.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The neighbour-list range: `max r_c + skin`, capped at half the shortest periodic
    /// length (as in [`crate::Md`]); every region is at least this wide.
    pub fn list_range(&self) -> f64 {
        by_dim!(self.run.engine(), e => e.range)
    }

    /// Energies, virial pressure and per-species temperatures of the current state (as
    /// [`crate::Md::diagnostics`]; the per-particle terms are gathered to rank 0 and summed
    /// in system order, so they are the same bits on any rank count), on every rank.
    /// Collective.
    ///
    /// Errors: a failed exchange.
    pub fn diagnostics(&mut self) -> Result<Diagnostics> {
        let ns = self.system.table().n_species();
        let comm = self.run.comm();
        let sums = by_dim!(self.run.engine(), e => e.gather_sums(comm))?;
        let sums = comm.broadcast_from_root(sums)?;
        if sums.len() != ns + 2 {
            return Err(Error::invalid(
                "gathered diagnostics",
                sums.len(),
                format!("expected {} values; the ranks disagree", ns + 2),
            ));
        }
        let mut count = vec![0usize; ns];
        for &s in self.system.species() {
            count[s as usize] += 1;
        }
        Ok(assemble(
            self.time(),
            self.system.dim().axes(),
            self.system.volume(),
            &sums[..ns],
            &count,
            sums[ns],
            sums[ns + 1],
        ))
    }

    /// The force on every particle at the current positions in system order (`[fx, fy,
    /// 0]` in 2D; 0 on the particles of a frozen species, as [`crate::Md::forces`]), on
    /// every rank. Collective.
    ///
    /// Errors: a failed exchange.
    pub fn forces(&mut self) -> Result<Vec<[f64; 3]>> {
        let comm = self.run.comm();
        let rows = by_dim!(self.run.engine(), e => e.gather(comm))?;
        let frozen = self.system.frozen();
        let species = self.system.species();
        let flat = rows.map(|rows| {
            rows.iter()
                .enumerate()
                .flat_map(|(i, r)| {
                    let f = !frozen[species[i] as usize];
                    [10, 11, 12].map(|o| if f { r[o] } else { 0.0 })
                })
                .collect::<Vec<f64>>()
        });
        let v = comm.broadcast_from_root(flat)?;
        Ok(v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
    }
}

impl<L: PairLaw> Simulation for DistributedMd<L> {
    type State = State;

    /// Advances `steps` steps on every rank, checking the state every
    /// [`Config::check_every`] steps and at the end as [`crate::Md`] does; a failed check
    /// returns the same [`Error::BlowUp`] on every rank (the first finding by kind, then
    /// by system index) with the run rolled back everywhere to the last state that passed.
    /// Collective.
    fn step(&mut self, steps: u32) -> Result<()> {
        self.run.step(steps)
    }

    /// Time, positions (periodic coordinates wrapped), velocities at the step (leapfrog:
    /// synchronised) and species of all particles in system order, gathered on rank 0 and
    /// sent to every rank. Collective.
    fn state(&mut self) -> Result<State> {
        self.run.state(self.system.species())
    }

    fn steps_done(&self) -> u64 {
        self.run.steps()
    }

    fn backend_name(&self) -> String {
        let threads = rayon::current_num_threads();
        let plural = if threads == 1 { "" } else { "s" };
        let kernel = by_dim!(self.run.engine(), e => e.kernel.name());
        format!(
            "cpu f64 ({} ranks, {threads} thread{plural} each, full lists, {kernel})",
            self.run.comm().size()
        )
    }
}

impl<L: PairLaw> Distributed for DistributedMd<L> {
    fn comm(&self) -> &Comm {
        self.run.comm()
    }

    /// The complete state in [`crate::Md`]'s checkpoint format (`Md<cpu f64, D>`: the
    /// particles in system order with their list-build positions), on every rank: resumes
    /// with [`Distributed::resume`] on any rank count, or with `Md`'s `Restart::resume`
    /// on the CPU in one process. The bytes are the same on any rank count. Collective.
    ///
    /// Errors: a failed exchange.
    fn checkpoint(&mut self) -> Result<Vec<u8>> {
        let model = model_name::<L>(false, Precision::F64, self.system.dim().axes());
        let (system, config) = (&self.system, &self.config);
        self.run
            .checkpoint(|d| encode_checkpoint(system, config, &model, d))
    }

    /// Rebuilds a run from the bytes of [`Distributed::checkpoint`] (any rank count) or
    /// of [`crate::Md`]'s `Restart::checkpoint` on the CPU in `f64`, on any rank count.
    /// Each rank takes the particles its region held at the last list build, the lists are
    /// made from the list-build positions, and the run continues with the bits of the
    /// uninterrupted distributed run. Collective; every rank passes the same bytes (checked;
    /// [`Distributed::resume_file`] reads a file on rank 0 and sends it).
    ///
    /// Errors: another crate's or model's checkpoint (`f32`, GPU, another law), a
    /// truncated, corrupt or inconsistent one (as `Md::resume`), those of
    /// [`DistributedMd::new`]. An error on one rank is an error on every rank.
    fn resume(bytes: &[u8], comm: Comm) -> Result<Self> {
        let (system, config, engine) = comm.agree(decode_checkpoint::<L>(bytes).and_then(
            |(written, system, config, e)| {
                let want = model_name::<L>(false, Precision::F64, system.dim().axes());
                if written == want {
                    Ok((system, config, e))
                } else {
                    Err(Error::checkpoint(format!(
                        "holds a {written} run; DistributedMd resumes {want} runs (CPU, \
                         f64); resume it with Md on the backend that wrote it"
                    )))
                }
            },
        ))?;
        Self::build(system, &config, comm, Some(&engine))
    }
}

/// The shared validation of [`crate::Md::new`] (the time step), plus what this run does
/// not offer.
fn prepare<L: PairLaw>(system: &System<L>, config: &Config) -> Result<f64> {
    if config.precision != Precision::F64 {
        return Err(Error::Unsupported(
            "DistributedMd computes in f64; use Precision::F64, or Md for f32".into(),
        ));
    }
    config.resolve_dt(system)
}

/// What a blow-up check found on a rank, `[kind, id, axis, value, extra]`; the kinds in
/// the order of [`crate::Md`]'s check: 0 non-finite position, 1 velocity, 2 acceleration,
/// 3 leapfrog velocity at the step, 4 outside the box, 5 farther than skin / 2 from the
/// list-build position (value: the distance), 6 kinetic energy, 7 pair energy, 8 virial
/// (non-finite values), 9 a kinetic energy whose total over all particles may overflow;
/// [`NOTHING`] (kind 10) when all is well.
const NOTHING: Finding = [10.0, 0.0, 0.0, 0.0, 0.0];

/// The finding to report of two: the lower kind, then the smaller system index.
fn worse(a: Finding, b: Finding) -> Finding {
    if (b[0], b[1]) < (a[0], a[1]) { b } else { a }
}

/// This rank's part of the run in dimension `D`: its particles ([`RankParticles`], the
/// species as their constants) and what the law and the integrator need.
struct Engine<const D: usize, L: PairLaw> {
    p: RankParticles<D, u32>,
    dt: f64,
    integrator: Integrator,
    check_every: u32,
    masses: Vec<f64>,
    /// `1 / m` per species, `0` for a frozen species (as in the CPU backend).
    inv_mass: Vec<f64>,
    frozen: Vec<bool>,
    n_species: usize,
    coeff: Vec<L::Coeff<f64>>,
    /// The Langevin thermostat: seed and `(c1, amplitude)` per species.
    langevin: Option<(u32, Vec<(f64, f64)>)>,
    lo: [f64; D],
    hi: [f64; D],
    periodic: [bool; D],
    range: f64,
    /// `((range - r_c) / 2)^2`: a larger squared displacement triggers a list build.
    rebuild2: f64,
    steps: u64,
    /// The step count of the guard's copy.
    kept_steps: u64,
    kernel: Kernel,
}

impl<const D: usize, L: PairLaw> Engine<D, L>
where
    [f64; D]: bytemuck::Pod,
{
    /// The engine without particles (they come with [`Engine::start`]).
    fn new(system: &System<L>, config: &Config, dt: f64, comm: &Comm) -> Result<Self> {
        let (lo3, len3, per3) = (system.lo(), system.lengths(), system.periodic());
        let r_c = system.table().max_cutoff();
        let range = list_range(system, config.skin);
        let half_skin = 0.5 * (range - r_c);
        // md has no vertical axis: x and y are cut as the faces are smallest.
        let domain = ParticleDomain::new(
            [lo3[0], lo3[1]],
            [len3[0], len3[1]],
            [per3[0], per3[1]],
            range,
            None,
            comm.size(),
        )?;
        let frozen = system.frozen().to_vec();
        let periodic_z = (D == 3 && per3[2]).then_some((lo3[2], len3[2]));
        let (lo, len, periodic): ([f64; D], [f64; D], [bool; D]) = (
            std::array::from_fn(|d| lo3[d]),
            std::array::from_fn(|d| len3[d]),
            std::array::from_fn(|d| per3[d]),
        );
        let list = GhostedList::new(domain, periodic_z, range)?;
        Ok(Self {
            p: RankParticles::new(
                list,
                (lo, len, periodic),
                system.species().to_vec(),
                0,
                COLS,
            )?,
            dt,
            integrator: config.integrator,
            check_every: config.check_every,
            masses: system.masses().to_vec(),
            inv_mass: system
                .masses()
                .iter()
                .zip(&frozen)
                .map(|(&m, &f)| if f { 0.0 } else { 1.0 / m })
                .collect(),
            frozen,
            n_species: system.table().n_species(),
            coeff: system.table().coefficients::<f64>(config.shift),
            langevin: config
                .thermostat
                .map(|l| (l.seed, ou_coefficients(system, &l, dt))),
            lo,
            hi: std::array::from_fn(|d| lo3[d] + len3[d]),
            periodic,
            range,
            rebuild2: half_skin * half_skin,
            steps: 0,
            kept_steps: 0,
            kernel: Kernel::detect(),
        })
    }

    /// The initial state (the system's, or a checkpoint's), its forces and the initial
    /// check, as the CPU backend makes them. Collective; an error is every rank's.
    fn start(&mut self, comm: &Comm, system: &System<L>, saved: Option<&Dynamics>) -> Result<()> {
        match saved {
            None => {
                let (positions, velocities) = (system.positions(), system.velocities());
                let mine = self
                    .p
                    .start(comm, |i| std::array::from_fn(|d| positions[i][d]));
                for (k, &i) in mine.iter().enumerate() {
                    if !self.frozen[system.species()[i] as usize] {
                        self.p
                            .set(false, VEL, k, std::array::from_fn(|d| velocities[i][d]));
                    }
                }
                // Wraps (a no-op for a valid system) and makes ghosts and lists.
                self.p.rebuild(comm)?;
            }
            Some(s) => {
                let n = self.p.total();
                comm.agree(s.check(n, D, &["pos", "vel", "reference"]))?;
                let mine = self.p.load(
                    comm,
                    n,
                    |k| Dynamics::at::<D>(&s.reference, k),
                    |k| s.particle(k),
                );
                for (k, &slot) in mine.iter().enumerate() {
                    self.p.set_position(k, Dynamics::at(&s.pos, slot));
                    if !self.frozen[self.p.props()[k] as usize] {
                        self.p.set(false, VEL, k, Dynamics::at(&s.vel, slot));
                    }
                }
                self.steps = s.steps;
                self.p.relist(comm)?;
                // A stored position must be one the run could have produced.
                let found = self.all_findings(comm)?;
                if found[0] < NOTHING[0] {
                    let (what, _) = self.describe(&found);
                    return Err(Error::checkpoint(format!(
                        "the stored state is not valid: {what}"
                    )));
                }
            }
        }
        self.forces::<true>(None);
        if saved.is_none() && self.integrator == Integrator::Leapfrog {
            let h = 0.5 * self.dt;
            let cols = self.p.parts().cols;
            let [vel, acc, ..] = cols else {
                unreachable!("md's columns")
            };
            kick_slice(vel, acc, h);
        }
        let found = self.all_findings(comm)?;
        if found[0] < NOTHING[0] {
            let (what, cause) = self.describe(&found);
            return Err(Error::invalid(
                "initial state",
                what,
                format!("{cause}; move the particles apart or lower dt"),
            ));
        }
        Ok(())
    }

    /// Forces on the owned particles at the current positions (owned and ghosts), the
    /// accelerations `F / m` and, with `kick = Some(h)`, the closing kick `v += a h`, in
    /// one pass; with `ENERGY`, each particle's sums of `phi` and `r . F` too. Each
    /// particle adds its pairs in the order of its list (increasing system index of the
    /// partner), with the CPU backend's pair law.
    fn forces<const ENERGY: bool>(&mut self, kick: Option<f64>) {
        let pad = 2.0 * self.range;
        let (kernel, inv_mass, coeff, ns) =
            (self.kernel, &self.inv_mass, &self.coeff, self.n_species);
        let parts = self.p.parts();
        let n = parts.owned;
        let [vel, acc, force, sums] = parts.cols else {
            unreachable!("md's columns")
        };
        let (offsets, partners) = parts.list.csr();
        let species = parts.props;
        let inp = PairInputs::<D, L> {
            pos: parts.pos,
            species,
            coeff,
            n_species: ns,
            pad,
            offsets,
            partners,
        };
        force[..n]
            .par_chunks_mut(CHUNK)
            .zip(acc.par_chunks_mut(CHUNK))
            .zip(vel.par_chunks_mut(CHUNK))
            .zip(sums.par_chunks_mut(CHUNK))
            .enumerate()
            .for_each(|(c, (((force, acc), vel), sums))| {
                let first = c * CHUNK;
                pair_sums::<D, L, ENERGY>(kernel, &inp, first, force, sums);
                for (k, ((f, a), v)) in force.iter().zip(acc.iter_mut()).zip(vel).enumerate() {
                    let im = inv_mass[species[first + k] as usize];
                    *a = f.map(|x| x * im);
                    if let Some(h) = kick {
                        for d in 0..D {
                            v[d] += a[d] * h;
                        }
                    }
                }
            });
    }

    /// The opening kick `v += a h` (when `open = Some(h)`) and the drift of a step
    /// (Newtonian, or the thermostatted `A O A` of BAOAB), reflecting at closed faces;
    /// returns this rank's largest squared displacement since the list build (NaN if any
    /// is NaN). The arithmetic of the CPU backend, particle by particle.
    fn move_particles(&mut self, open: Option<f64>) -> f64 {
        let (lo, hi, per, dt) = (self.lo, self.hi, self.periodic, self.dt);
        let step = self.steps as u32;
        let langevin = &self.langevin;
        let parts = self.p.parts();
        let n = parts.owned;
        let [vel, acc, ..] = parts.cols else {
            unreachable!("md's columns")
        };
        let (pos, reference) = (&mut parts.pos[..n], parts.reference);
        let displacement = |x: &[f64; D], r: &[f64; D]| {
            let mut s2 = 0.0;
            for d in 0..D {
                let s = x[d] - r[d];
                s2 += s * s;
            }
            s2
        };
        match langevin {
            None => pos
                .par_chunks_mut(CHUNK)
                .zip(vel.par_chunks_mut(CHUNK))
                .zip(acc.par_chunks(CHUNK))
                .zip(reference.par_chunks(CHUNK))
                .map(|(((x, v), a), r)| {
                    let mut m = 0.0;
                    for (((x, v), a), r) in x.iter_mut().zip(v).zip(a).zip(r) {
                        for d in 0..D {
                            if let Some(h) = open {
                                v[d] += a[d] * h;
                            }
                            x[d] += v[d] * dt;
                            if !per[d] {
                                reflect(&mut x[d], &mut v[d], lo[d], hi[d]);
                            }
                        }
                        m = max_or_nan(m, displacement(x, r));
                    }
                    m
                })
                .reduce(|| 0.0, max_or_nan),
            Some((seed, ou)) => {
                let (seed, h) = (*seed, 0.5 * dt);
                let (species, id) = (&parts.props[..n], &parts.id[..n]);
                pos.par_chunks_mut(CHUNK)
                    .zip(vel.par_chunks_mut(CHUNK))
                    .zip(acc.par_chunks(CHUNK))
                    .zip(reference.par_chunks(CHUNK))
                    .enumerate()
                    .map(|(c, (((x, v), a), r))| {
                        if let Some(hk) = open {
                            kick_slice(v, a, hk);
                        }
                        let mut m = 0.0;
                        for (k, ((x, v), r)) in x.iter_mut().zip(v).zip(r).enumerate() {
                            let i = c * CHUNK + k;
                            let (c1, amp) = ou[species[i] as usize];
                            let g = gaussians::<D>(seed, step, id[i]);
                            for d in 0..D {
                                let w = c1 * v[d] + amp * g[d];
                                x[d] += (v[d] + w) * h;
                                v[d] = w;
                                if !per[d] {
                                    reflect(&mut x[d], &mut v[d], lo[d], hi[d]);
                                }
                            }
                            m = max_or_nan(m, displacement(x, r));
                        }
                        m
                    })
                    .reduce(|| 0.0, max_or_nan)
            }
        }
    }

    /// One step; `energy`: the potential energy and virial at its end too.
    fn one_step(&mut self, comm: &Comm, energy: bool) -> Result<()> {
        let (open, close) = match self.integrator {
            Integrator::VelocityVerlet => (Some(0.5 * self.dt), 0.5 * self.dt),
            Integrator::Leapfrog => (None, self.dt),
        };
        let moved2 = comm.all_max(self.move_particles(open))?;
        // A particle that moved farther than the list range since the build (or to a
        // non-finite position) may have jumped past the next region: the run blew up. The
        // maximum is global, so every rank count stops at the same step.
        if moved2.is_nan() || moved2 > self.range * self.range {
            return Err(Error::invalid(
                "largest displacement since the last list build",
                moved2.sqrt(),
                format!(
                    "must stay below the list range {} (a particle moved that far within a \
                     few steps)",
                    self.range
                ),
            ));
        }
        // A list build migrates particles: the owned count changes between steps, so
        // every pass reads it afresh.
        if beyond(moved2, self.rebuild2) {
            self.p.rebuild(comm)?;
        } else {
            self.p.refresh(comm)?;
        }
        if energy {
            self.forces::<true>(Some(close));
        } else {
            self.forces::<false>(Some(close));
        }
        self.steps += 1;
        Ok(())
    }

    /// Every rank's first finding, the same on every rank. Collective.
    fn all_findings(&self, comm: &Comm) -> Result<Finding> {
        RankParticles::<D, u32>::findings(comm, self.check(), NOTHING, worse)
    }

    /// This rank's first finding (the checks of the CPU backend, over the owned
    /// particles; within a kind the smallest system index).
    fn check(&self) -> Finding {
        let p = &self.p;
        let (vel, acc, sums) = (p.col(VEL), p.col(ACC), p.col(SUMS));
        let mut found = NOTHING;
        let mut note = |f: Finding| found = worse(found, f);
        let h = 0.5 * self.dt;
        let leapfrog = self.integrator == Integrator::Leapfrog;
        // Kinetic energies above this could overflow the total (in any order).
        let ke_limit = f64::MAX / p.total().max(1) as f64;
        for k in 0..p.owned() {
            let id = f64::from(p.id()[k]);
            for (kind, v) in [(0.0, &p.pos()[k]), (1.0, &vel[k]), (2.0, &acc[k])] {
                if let Some(d) = (0..D).find(|&d| !v[d].is_finite()) {
                    note([kind, id, d as f64, v[d], 0.0]);
                }
            }
            if leapfrog {
                for d in 0..D {
                    let u = vel[k][d] - acc[k][d] * h;
                    if !u.is_finite() {
                        note([3.0, id, d as f64, u, 0.0]);
                        break;
                    }
                }
            }
            let (x, r) = (p.pos()[k], p.reference()[k]);
            for d in 0..D {
                let (lo, hi) = (self.lo[d], self.hi[d]);
                let (y, out) = if self.periodic[d] {
                    (r[d], !(r[d] >= lo && r[d] < hi))
                } else {
                    (x[d], !(x[d] >= lo && x[d] <= hi))
                };
                if out {
                    note([4.0, id, d as f64, y, 0.0]);
                    break;
                }
            }
            let mut s2 = 0.0;
            for d in 0..D {
                let s = x[d] - r[d];
                s2 += s * s;
            }
            if beyond(s2, self.rebuild2) {
                note([5.0, id, 0.0, s2.sqrt(), 0.0]);
            }
            let v2: f64 = vel[k].iter().map(|x| x * x).sum();
            let ke = 0.5 * self.masses[p.props()[k] as usize] * v2;
            for (kind, x) in [(6.0, ke), (7.0, sums[k][0]), (8.0, sums[k][1])] {
                if !x.is_finite() {
                    note([kind, id, 0.0, x, 0.0]);
                }
            }
            if ke > ke_limit {
                note([9.0, id, 0.0, ke, 0.0]);
            }
        }
        found
    }

    /// The blow-up message and cause of a finding (the same on every rank).
    fn describe(&self, f: &Finding) -> (String, String) {
        let (kind, id, axis) = (f[0] as usize, f[1] as usize, AXES[(f[2] as usize).min(2)]);
        let what = match kind {
            0..=2 => {
                let name = ["position", "velocity", "acceleration"][kind];
                format!("particle {id}: {name} {axis} = {}", f[3])
            }
            3 => format!("particle {id}: velocity {axis} at the step = {}", f[3]),
            4 => {
                let d = f[2] as usize;
                format!(
                    "particle {id}: position {axis} = {} left the box [{}, {}] (it moved more \
                     than a box length in one step)",
                    f[3], self.lo[d], self.hi[d]
                )
            }
            5 => format!(
                "particle {id}: {} from its position at the last list build, more than \
                 skin / 2 = {}",
                f[3],
                self.rebuild2.sqrt()
            ),
            6..=8 => {
                let name = ["kinetic energy", "pair energy", "virial"][kind - 6];
                format!("particle {id}: {name} = {}", f[3])
            }
            _ => format!(
                "particle {id}: kinetic energy = {}, the total over {} particles may overflow",
                f[3],
                self.p.total()
            ),
        };
        (what, CAUSE.to_string())
    }

    /// Every particle's record on rank 0 in system order (`None` elsewhere): position
    /// wrapped, velocity at the step (leapfrog: synchronised), acceleration, force,
    /// `phi` and `r . F` sums.
    fn gather(&self, comm: &Comm) -> Result<Option<Vec<[f64; RECORD]>>> {
        let p = &self.p;
        let h = 0.5 * self.dt;
        let leapfrog = self.integrator == Integrator::Leapfrog;
        let (vel, acc, force, sums) = (p.col(VEL), p.col(ACC), p.col(FORCE), p.col(SUMS));
        p.gather(comm, |k| {
            let mut r = [0.0; RECORD - 1];
            let mut x = p.pos()[k];
            p.wrap(&mut x);
            for d in 0..D {
                r[d] = x[d];
                r[3 + d] = if leapfrog {
                    vel[k][d] - acc[k][d] * h
                } else {
                    vel[k][d]
                };
                r[6 + d] = acc[k][d];
                r[9 + d] = force[k][d];
            }
            r[12] = sums[k][0];
            r[13] = sums[k][1];
            r
        })
    }

    /// On rank 0: the kinetic energy of every species, the potential energy and the
    /// virial, summed in system order (`None` elsewhere).
    fn gather_sums(&self, comm: &Comm) -> Result<Option<Vec<f64>>> {
        let Some(rows) = self.gather(comm)? else {
            return Ok(None);
        };
        let species = self.p.table();
        let mut out = vec![0.0; self.n_species + 2];
        let (mut potential, mut virial) = (0.0, 0.0);
        for (i, r) in rows.iter().enumerate() {
            let s = species[i] as usize;
            let v2: f64 = r[4..4 + D].iter().map(|x| x * x).sum();
            out[s] += 0.5 * self.masses[s] * v2;
            potential += r[13];
            virial += r[14];
        }
        // Each pair was counted at both ends.
        out[self.n_species] = 0.5 * potential;
        out[self.n_species + 1] = 0.5 * virial;
        Ok(Some(out))
    }
}

/// The blow-up guard's view of a rank's engine (see [`simkit_backend::guard`]): every
/// decision is taken by all ranks together.
struct Checked<'a, const D: usize, L: PairLaw> {
    e: &'a mut Engine<D, L>,
    comm: &'a Comm,
}

impl<const D: usize, L: PairLaw> Guarded for Checked<'_, D, L>
where
    [f64; D]: bytemuck::Pod,
{
    fn steps_done(&self) -> u64 {
        self.e.steps
    }

    fn keep(&mut self) -> Result<()> {
        self.e.p.keep();
        self.e.kept_steps = self.e.steps;
        Ok(())
    }

    fn advance(&mut self, n: u32) -> std::result::Result<(), Halt> {
        for s in 0..n {
            // The energies only where the check (and the caller) looks: the last step. A
            // particle that moved too far, or a list build that failed on every rank
            // (positions a grid cannot hold): the run blew up within the stretch.
            self.e
                .one_step(self.comm, s + 1 == n)
                .map_err(|err| Halt::BlowUp {
                    step: self.e.steps + 1,
                    what: err.to_string(),
                    cause: CAUSE.to_string(),
                })?;
        }
        Ok(())
    }

    fn check(&mut self) -> std::result::Result<(), Halt> {
        let found = self.e.all_findings(self.comm)?;
        let failure = (found[0] < NOTHING[0]).then(|| self.e.describe(&found));
        verdict(self.e.steps, failure)
    }

    fn restore(&mut self) -> Result<()> {
        self.e.p.restore(self.comm)?;
        self.e.steps = self.e.kept_steps;
        Ok(())
    }
}

impl<const D: usize, L: PairLaw> RankRun for Engine<D, L>
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
        self.steps as f64 * self.dt
    }

    fn dt(&self) -> f64 {
        self.dt
    }

    fn step(&mut self, comm: &Comm, steps: u32) -> Result<()> {
        let every = self.check_every;
        run_guarded(&mut Checked { e: self, comm }, steps, every)
    }

    fn gather_motion(&self, comm: &Comm) -> Result<Option<Vec<[f64; 6]>>> {
        let rows = self.gather(comm)?;
        Ok(rows.map(|rows| {
            rows.iter()
                .map(|r| std::array::from_fn(|c| r[1 + c]))
                .collect()
        }))
    }

    /// Positions as the run holds them, velocities as the integrator stores them, the
    /// list-build positions, in system order.
    fn gather_dynamics(&self, comm: &Comm) -> Result<Option<Dynamics>> {
        let p = &self.p;
        let vel = p.col(VEL);
        let rows = p.gather(comm, |k| {
            let mut r = [0.0; RECORD - 1];
            r[..D].copy_from_slice(&p.pos()[k]);
            r[3..3 + D].copy_from_slice(&vel[k]);
            r[6..6 + D].copy_from_slice(&p.reference()[k]);
            r
        })?;
        Ok(rows.map(|rows| {
            let column = |o: usize| -> Vec<f64> {
                rows.iter()
                    .flat_map(|r| r[o..o + D].iter().copied())
                    .collect()
            };
            Dynamics {
                steps: self.steps,
                time: self.time(),
                width: D as u32,
                pos: column(1),
                vel: column(4),
                reference: column(7),
                ..Dynamics::default()
            }
        }))
    }
}

/// Partners per chunk of the pair sums: the law is evaluated for a chunk's lanes at once
/// (the compiler vectorises it), then the terms are added one by one in list order.
const LANES: usize = 16;

/// What the pair sums read: positions and species (owned then ghosts), the flat
/// species-pair table, the full lists of the owned particles.
struct PairInputs<'a, const D: usize, L: PairLaw> {
    pos: &'a [[f64; D]],
    species: &'a [u32],
    coeff: &'a [L::Coeff<f64>],
    n_species: usize,
    /// A separation beyond every cutoff (for the unused lanes).
    pad: f64,
    offsets: &'a [u32],
    partners: &'a [u32],
}

/// The pair sums of owned particles `first..first + force.len()`, compiled for the best
/// instruction set of this CPU ([`Kernel`]: the same bits on every one, since Rust never
/// fuses a multiply and an add on its own).
fn pair_sums<const D: usize, L: PairLaw, const ENERGY: bool>(
    kernel: Kernel,
    inp: &PairInputs<'_, D, L>,
    first: usize,
    force: &mut [[f64; D]],
    ew: &mut [[f64; D]],
) {
    match kernel {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `Kernel::detect` only returns Avx512 when the CPU has these features.
        Kernel::Avx512 => unsafe { pair_sums_avx512::<D, L, ENERGY>(inp, first, force, ew) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `Kernel::detect` only returns Avx2 (or better) when the CPU has AVX2, FMA.
        Kernel::Avx2 => unsafe { pair_sums_avx2::<D, L, ENERGY>(inp, first, force, ew) },
        _ => pair_sums_body::<D, L, ENERGY>(inp, first, force, ew),
    }
}

/// [`pair_sums_body`] compiled for AVX-512.
///
/// # Safety
/// The CPU must have AVX-512F, AVX-512VL, AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
unsafe fn pair_sums_avx512<const D: usize, L: PairLaw, const ENERGY: bool>(
    inp: &PairInputs<'_, D, L>,
    first: usize,
    force: &mut [[f64; D]],
    ew: &mut [[f64; D]],
) {
    pair_sums_body::<D, L, ENERGY>(inp, first, force, ew);
}

/// [`pair_sums_body`] compiled for AVX2.
///
/// # Safety
/// The CPU must have AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn pair_sums_avx2<const D: usize, L: PairLaw, const ENERGY: bool>(
    inp: &PairInputs<'_, D, L>,
    first: usize,
    force: &mut [[f64; D]],
    ew: &mut [[f64; D]],
) {
    pair_sums_body::<D, L, ENERGY>(inp, first, force, ew);
}

/// For each owned particle `i = first + k`: `force[k]` = the sum of `(f / r) (x_i - x_j)`
/// over its list (increasing system index of the partner `j`), and with `ENERGY`
/// `ew[k][..2] = [sum phi, sum r . F]`, the terms from [`PairLaw::force_energy`]. The law runs on a
/// chunk of [`LANES`] partners at once; the sums then take the terms one by one in list
/// order, so the result is the bits of a plain loop over the list.
#[inline(always)]
fn pair_sums_body<const D: usize, L: PairLaw, const ENERGY: bool>(
    inp: &PairInputs<'_, D, L>,
    first: usize,
    force: &mut [[f64; D]],
    ew: &mut [[f64; D]],
) {
    let ns = inp.n_species;
    for (k, (f, ew)) in force.iter_mut().zip(ew.iter_mut()).enumerate() {
        let i = first + k;
        let xi = inp.pos[i];
        let row = &inp.coeff[inp.species[i] as usize * ns..][..ns];
        let mut fi = [0.0; D];
        let (mut e, mut w) = (0.0, 0.0);
        let list = &inp.partners[inp.offsets[i] as usize..inp.offsets[i + 1] as usize];
        for chunk in list.chunks(LANES) {
            // Unused lanes: a separation beyond every cutoff (never summed).
            let mut s = [[0.0; LANES]; D];
            s[0] = [inp.pad; LANES];
            let mut cs = [row[0]; LANES];
            for (l, &j) in chunk.iter().enumerate() {
                let j = j as usize;
                let xj = inp.pos[j];
                for d in 0..D {
                    s[d][l] = xi[d] - xj[d];
                }
                cs[l] = row[inp.species[j] as usize];
            }
            let (mut fr, mut pe, mut r2s) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
            for l in 0..LANES {
                let mut r2 = 0.0;
                for sd in &s {
                    r2 += sd[l] * sd[l];
                }
                (fr[l], pe[l]) = L::force_energy(&cs[l], r2);
                r2s[l] = r2;
            }
            for l in 0..chunk.len() {
                for d in 0..D {
                    fi[d] += fr[l] * s[d][l];
                }
                if ENERGY {
                    e += pe[l];
                    w += fr[l] * r2s[l];
                }
            }
        }
        *f = fi;
        if ENERGY {
            (ew[0], ew[1]) = (e, w);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{LennardJones, PairTable};

    /// Every compiled kernel gives the bits of a plain loop over the list, with and
    /// without the energies, for lists of every length around the chunk width.
    #[test]
    fn pair_sums_are_a_plain_loop_on_every_kernel() {
        let mut t = PairTable::uniform(2, LennardJones::new(1.0, 1.0, 2.5)).unwrap();
        t.set(0, 1, LennardJones::weighted(1.3, 0.9, 1.0, 0.4, 2.0))
            .unwrap();
        let coeff = t.coefficients::<f64>(true);
        let n = 70;
        let u = |k: usize, a: u32| f64::from(simkit_backend::rng::rng_uniform(5, a, k as u32));
        let pos: Vec<[f64; 3]> = (0..n)
            .map(|k| [4.0 * u(k, 0), 4.0 * u(k, 1), 4.0 * u(k, 2)])
            .collect();
        let species: Vec<u32> = (0..n as u32).map(|k| k % 2).collect();
        // Particle i lists the next i % 40 particles (0 to 39 partners).
        let (mut offsets, mut partners) = (vec![0u32], Vec::new());
        for i in 0..n {
            partners.extend((1..=i % 40).map(|k| ((i + k) % n) as u32));
            offsets.push(partners.len() as u32);
        }
        let inp = PairInputs::<3, LennardJones> {
            pos: &pos,
            species: &species,
            coeff: &coeff,
            n_species: 2,
            pad: 10.0,
            offsets: &offsets,
            partners: &partners,
        };
        let mut want = vec![([0.0; 3], [0.0; 2]); n];
        for (i, (f, ew)) in want.iter_mut().enumerate() {
            for &j in &partners[offsets[i] as usize..offsets[i + 1] as usize] {
                let j = j as usize;
                let s: [f64; 3] = std::array::from_fn(|d| pos[i][d] - pos[j][d]);
                let mut r2 = 0.0;
                for x in s {
                    r2 += x * x;
                }
                let c = &coeff[species[i] as usize * 2 + species[j] as usize];
                let (fr, pe) = LennardJones::force_energy(c, r2);
                for d in 0..3 {
                    f[d] += fr * s[d];
                }
                ew[0] += pe;
                ew[1] += fr * r2;
            }
        }
        assert!(want.iter().any(|(f, _)| f[0] != 0.0));
        for kernel in Kernel::available() {
            let (mut f, mut ew) = (vec![[0.0; 3]; n], vec![[0.0; 3]; n]);
            pair_sums::<3, LennardJones, true>(kernel, &inp, 0, &mut f, &mut ew);
            let (mut g, mut unused) = (vec![[0.0; 3]; n], vec![[7.0; 3]; n]);
            pair_sums::<3, LennardJones, false>(kernel, &inp, 0, &mut g, &mut unused);
            for i in 0..n {
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&f[i]), bits(&want[i].0), "{kernel:?} particle {i}");
                assert_eq!(bits(&g[i]), bits(&want[i].0), "{kernel:?} particle {i}");
                assert_eq!(
                    bits(&ew[i][..2]),
                    bits(&want[i].1),
                    "{kernel:?} particle {i}"
                );
                assert_eq!(unused[i], [7.0; 3], "energies left alone without ENERGY");
            }
        }
    }
}
