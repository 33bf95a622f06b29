//! [`DistributedRd`]: one grid cut into blocks over the ranks of a [`Comm`], each rank
//! advancing its block on the CPU, bit-identical to the single-process CPU run.

use simkit_backend::comm::{Block, CartDecomposition, Comm};
use simkit_backend::guard::{Guarded, Halt, first_non_finite, run_guarded};
use simkit_backend::{Distributed, Real, Result, Simulation};

use crate::boundary::{Boundaries, Boundary, fill_ghosts, ghost_value};
use crate::config::Config;
use crate::cpu::{interior_pass, padded_max_diffusivity};
use crate::grid::{Grid, pad};
use crate::model::Model;
use crate::sim::{RunState, decode_checkpoint, encode_checkpoint};
use crate::stepper::{
    Integrator, Stepping, check_dt, check_dt_with, check_model, divergence_cause, dt_bound,
    recheck_bound,
};

/// Reaction–diffusion of one grid block-decomposed over the ranks of a [`Comm`] (CPU only).
///
/// The grid is cut by [`CartDecomposition::new`] (blocks as even as the rank count allows,
/// uneven splits included; periodic edges make the blocks wrap). Each rank keeps its block
/// with one ghost layer. Every stencil pass (one per Euler step, two per Heun step) runs the
/// same row kernel as the single-process CPU backend on the rank's interior, then refreshes
/// the ghosts: from the neighbouring blocks by a halo exchange in the shift pattern (x, then
/// y; 4 messages), and on the edges of the domain by the same boundary rule
/// (`ghost_value`). Each cell therefore sees exactly the inputs, and runs exactly the
/// arithmetic, of the single-process run, so [`Simulation::state`] returns a grid
/// bit-identical to [`crate::Rd`] on [`simkit_backend::Backend::Cpu`] for every rank count,
/// grid size and boundary kind. Temporal blocking ([`Config::steps_per_sweep`]) is not used
/// here (it would need halos `k` cells deep every `k` steps); it never changes results.
///
/// The blow-up checks of [`crate::Rd`] run on every rank at the same steps and are reduced
/// over the ranks before anything is decided, so all ranks roll back together and return
/// the same [`Error::BlowUp`](simkit_backend::Error::BlowUp) (naming the same first bad cell, in global coordinates) as
/// the single-process run.
///
/// It implements [`Distributed`]: checkpoints are those of [`crate::Rd`]
/// ([`Distributed::checkpoint`] gathers the grid on rank 0 and encodes it as `Rd` does), and
/// [`Distributed::resume`] takes such bytes on any number of ranks, so a run moves between
/// one process and any rank count, bit for bit.
///
/// Every method that takes `&mut self` or returns a `Result` is collective: all ranks call
/// it, in the same order. Each rank builds the run from the whole initial grid (simple,
/// but every rank holds the grid, and its encoding for the check that the ranks agree,
/// while the run is built); [`Simulation::state`] and [`Distributed::checkpoint`] return
/// the whole run on every rank.
///
/// ```
/// use simkit_backend::comm::Comm;
/// use simkit_rd::{Backend, Config, Distributed, DistributedRd, GrayScott, Rd, Restart, Simulation};
/// use simkit_rd::{Stepping, scenes::gray_scott_square};
/// # fn main() -> simkit_backend::Result<()> {
/// let grid = gray_scott_square::<f64>(24, 1.0, 6, 1)?;
/// let model = GrayScott::new(1.0, 0.5, 0.04, 0.06)?;
/// let config = Config::new(Stepping::euler(0.2));
/// // `Comm::mpi()?` under `mpirun -np P` (feature `mpi`); here one process.
/// let mut dist = DistributedRd::new(grid.clone(), model.clone(), &config, Comm::serial())?;
/// dist.step(30)?;
/// let mut one = Rd::new(grid, model, &config, Backend::Cpu)?;
/// one.step(30)?;
/// assert_eq!(dist.state()?, one.state()?); // on every rank
/// // The checkpoint is Rd's: it resumes in one process too.
/// let bytes = dist.checkpoint()?;
/// assert_eq!(Rd::<f64, GrayScott>::resume(&bytes, Backend::Cpu)?.state()?, one.state()?);
/// # Ok(())
/// # }
/// ```
pub struct DistributedRd<T: Real, M: Model> {
    comm: Comm,
    decomposition: CartDecomposition,
    block: Block,
    model: M,
    /// The settings (its stepping is the run's).
    config: Config,
    /// Simulated time at step `epoch_step` (carried through checkpoints of [`crate::Rd`]).
    epoch_time: f64,
    /// Step of the last change of `dt` in the run this one was resumed from.
    epoch_step: u64,
    h: f64,
    boundaries: Boundaries,
    /// The padded species planes of this rank's block, `(len_x + 2) x (len_y + 2)` each.
    cur: Vec<T>,
    tmp: Vec<T>,
    /// The padded coefficient planes of the block (ghosts from the global grid; static).
    coef: Vec<T>,
    /// The padded fields at the last check that passed.
    good: Vec<T>,
    /// The step count of `good`.
    good_steps: u64,
    steps: u64,
}

impl<T: Real, M: Model> std::fmt::Debug for DistributedRd<T, M> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DistributedRd")
            .field("comm", &self.comm)
            .field("decomposition", &self.decomposition)
            .field("model", &self.model)
            .field("stepping", &self.config.stepping)
            .field("steps", &self.steps)
            .finish()
    }
}

/// The padded window of block `b` (one ghost layer) out of padded global planes.
fn window<T: Real>(global: &[T], gnx: usize, gny: usize, b: &Block) -> Vec<T> {
    let (gw, gplane) = (gnx + 2, (gnx + 2) * (gny + 2));
    let [x0, y0] = b.start;
    let [nx, ny] = b.len;
    let mut out = Vec::with_capacity((global.len() / gplane) * (nx + 2) * (ny + 2));
    for p in global.chunks(gplane) {
        for j in y0..y0 + ny + 2 {
            out.extend_from_slice(&p[j * gw + x0..j * gw + x0 + nx + 2]);
        }
    }
    out
}

/// The first non-finite value of a rank, as `[class, species, y, x, value]` in `f64`
/// (class 0: an interior cell, `(x, y)` global; class 1: a ghost cell on the domain edge,
/// `(x, y)` global padded; class 2: none), ordered like the single-process scan.
type BadCell = [f64; 5];

impl<T: Real, M: Model> DistributedRd<T, M> {
    /// Validates `config`, checks the model against `grid` and `dt` against the stability
    /// bound (as [`crate::Rd::new`] does, with the same errors on every rank), checks that
    /// every rank passed the same grid, model and config, cuts the grid into `comm.size()`
    /// blocks and keeps this rank's. Collective.
    ///
    /// Errors: those of [`crate::Rd::new`] on the CPU, ranks whose inputs differ, or a
    /// grid too small for `comm.size()` blocks of at least one cell; on every rank.
    pub fn new(grid: Grid<T>, model: M, config: &Config, comm: Comm) -> Result<Self> {
        Self::build(
            RunState {
                grid,
                model,
                config: *config,
                steps: 0,
                epoch_time: 0.0,
                epoch_step: 0,
            },
            comm,
        )
    }

    /// The run of `s` (a new one, or one resumed from a checkpoint) on this rank.
    fn build(s: RunState<T, M>, comm: Comm) -> Result<Self> {
        let RunState {
            grid,
            model,
            config,
            ..
        } = &s;
        comm.agree(
            config
                .validate()
                .and_then(|()| check_model(model, grid))
                .and_then(|()| check_dt(model, grid, &config.stepping)),
        )?;
        // Everything the ranks must agree on, as a checkpoint stores it.
        let encoded = comm.agree(encode_checkpoint(&s))?;
        comm.agree_inputs(&encoded, "DistributedRd inputs")?;
        drop(encoded);
        let RunState {
            grid,
            model,
            config,
            steps,
            epoch_time,
            epoch_step,
        } = s;
        let (gnx, gny) = (grid.nx(), grid.ny());
        let bc = grid.boundaries().clone();
        let periodic = [
            bc.west == Boundary::Periodic,
            bc.south == Boundary::Periodic,
        ];
        let decomposition =
            comm.agree(CartDecomposition::new([gnx, gny], comm.size(), periodic))?;
        let block = decomposition.block(comm.rank());
        let gplane = (gnx + 2) * (gny + 2);
        let mut all = grid.padded();
        for (s, f) in all.chunks_mut(gplane).enumerate() {
            fill_ghosts(f, gnx, gny, s, &bc);
        }
        let cur = window(&all, gnx, gny, &block);
        drop(all);
        let coef_fields: Vec<Vec<T>> = model
            .coefficients()
            .iter()
            .map(|c| c.iter().map(|&v| T::from_f64(v)).collect())
            .collect();
        let mut coef = pad(&coef_fields, gnx, gny);
        let cbc = bc.for_coefficients();
        for f in coef.chunks_mut(gplane) {
            fill_ghosts(f, gnx, gny, 0, &cbc);
        }
        let coef = window(&coef, gnx, gny, &block);
        Ok(Self {
            comm,
            decomposition,
            block,
            model,
            config,
            epoch_time,
            epoch_step,
            h: grid.h(),
            boundaries: bc,
            tmp: cur.clone(),
            good: cur.clone(),
            good_steps: 0,
            cur,
            coef,
            steps,
        })
    }

    /// How the grid is cut over the ranks.
    pub fn decomposition(&self) -> &CartDecomposition {
        &self.decomposition
    }

    /// This rank's block of the grid.
    pub fn block(&self) -> Block {
        self.block
    }

    /// The model.
    pub fn model(&self) -> &M {
        &self.model
    }

    /// The time-stepping settings.
    pub fn stepping(&self) -> Stepping {
        self.config.stepping
    }

    /// The values of the whole grid, species after species, on rank 0 (`Some`), `None` on
    /// the other ranks. Collective.
    fn gather_fields(&self) -> Result<Option<Vec<T>>> {
        let [nx, ny] = self.block.len;
        let w = nx + 2;
        let plane = w * (ny + 2);
        let mut local = Vec::with_capacity(self.cur.len() / plane * nx * ny);
        for p in self.cur.chunks(plane) {
            for j in 1..=ny {
                local.extend_from_slice(&p[j * w + 1..j * w + 1 + nx]);
            }
        }
        self.decomposition.gather(&self.comm, &local)
    }

    /// The grid of the values [`DistributedRd::gather_fields`] gathered.
    fn grid_of(&self, all: &[T]) -> Result<Grid<T>> {
        let [gnx, gny] = self.decomposition.global();
        let fields = all.chunks(gnx * gny).map(<[T]>::to_vec).collect();
        Grid::new(gnx, gny, self.h, self.boundaries.clone(), fields)
    }

    /// The model's largest effective diffusivity over the whole grid (NaN if any rank's is).
    fn max_diffusivity(&self) -> Result<f64> {
        let [nx, ny] = self.block.len;
        let local = padded_max_diffusivity(&self.model, nx, ny, &self.cur, &self.coef);
        self.comm.all_max(local)
    }

    /// Advances `steps` steps, one stencil pass per stage, ghosts refreshed after each.
    fn advance(&mut self, steps: u32) -> Result<()> {
        let mut cur = std::mem::take(&mut self.cur);
        let mut tmp = std::mem::take(&mut self.tmp);
        let mut r = Ok(());
        for _ in 0..steps {
            r = match self.config.stepping.integrator {
                Integrator::Euler => self.pass(&cur, &mut tmp, false).map(|()| {
                    std::mem::swap(&mut cur, &mut tmp);
                }),
                Integrator::Heun => self
                    .pass(&cur, &mut tmp, false)
                    .and_then(|()| self.pass(&tmp, &mut cur, true)),
            };
            if r.is_err() {
                break;
            }
        }
        self.cur = cur;
        self.tmp = tmp;
        r
    }

    /// One stencil pass over the block from `src` into `dst`, then `dst`'s ghosts: halo
    /// exchange with the neighbours, the boundary rule on the domain edges.
    fn pass(&self, src: &[T], dst: &mut [T], average: bool) -> Result<()> {
        let [nx, ny] = self.block.len;
        let ih2 = 1.0 / (self.h * self.h);
        let dt = self.config.stepping.dt;
        interior_pass(&self.model, nx, ny, &self.coef, src, dst, dt, ih2, average);
        self.decomposition.exchange_halo(&self.comm, dst, 1)?;
        let nb = self.decomposition.neighbors(self.comm.rank());
        let w = nx + 2;
        let bc = &self.boundaries;
        for (s, f) in dst.chunks_mut(w * (ny + 2)).enumerate() {
            // A side without a neighbour is a domain edge that is not periodic: the
            // opposite cell is never read there.
            let g = |b: &Boundary, inner: T| ghost_value(b, s, inner, inner);
            for j in 1..=ny {
                let r = j * w;
                if nb.west.is_none() {
                    f[r] = g(&bc.west, f[r + 1]);
                }
                if nb.east.is_none() {
                    f[r + nx + 1] = g(&bc.east, f[r + nx]);
                }
            }
            for i in 1..=nx {
                if nb.south.is_none() {
                    f[i] = g(&bc.south, f[w + i]);
                }
                if nb.north.is_none() {
                    f[(ny + 1) * w + i] = g(&bc.north, f[ny * w + i]);
                }
            }
        }
        Ok(())
    }

    /// This rank's first non-finite value (see [`BadCell`]).
    fn local_bad_cell(&self) -> BadCell {
        let none = [2.0, 0.0, 0.0, 0.0, 0.0];
        if first_non_finite(&self.cur).is_none() {
            return none;
        }
        let [nx, ny] = self.block.len;
        let [x0, y0] = self.block.start;
        let [gnx, gny] = self.decomposition.global();
        let w = nx + 2;
        let plane = w * (ny + 2);
        let bad = |v: T| !v.to_f64().is_finite();
        // Interior cells in species, row, column order: the rank's first is its smallest
        // in the global order too.
        for (s, p) in self.cur.chunks(plane).enumerate() {
            for j in 1..=ny {
                for i in 1..=nx {
                    let v = p[j * w + i];
                    if bad(v) {
                        let (x, y) = (x0 + i - 1, y0 + j - 1);
                        return [0.0, s as f64, y as f64, x as f64, v.to_f64()];
                    }
                }
            }
        }
        // Ghost cells on the domain edge, corners excepted (padded global coordinates; the
        // other ghosts are copies of neighbours' cells, which those ranks report).
        for (s, p) in self.cur.chunks(plane).enumerate() {
            for j in 0..ny + 2 {
                for i in 0..w {
                    let (gx, gy) = (x0 + i, y0 + j);
                    let (side_x, side_y) = (gx == 0 || gx == gnx + 1, gy == 0 || gy == gny + 1);
                    // The domain's corner ghosts are never read (the single-process run
                    // leaves them at 0); here they may hold copies from a y-shift.
                    if (side_x != side_y) && bad(p[j * w + i]) {
                        return [1.0, s as f64, gy as f64, gx as f64, p[j * w + i].to_f64()];
                    }
                }
            }
        }
        none
    }

    /// The first non-finite value over all ranks, described as the single-process check
    /// does; the same on every rank. Collective.
    fn first_bad_cell(&self) -> Result<Option<String>> {
        let all = self.comm.all_gather(&self.local_bad_cell())?;
        let first = all.chunks(5).filter(|c| c[0] < 2.0).min_by(|a, b| {
            a[..4]
                .partial_cmp(&b[..4])
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        let Some(c) = first else {
            return Ok(None);
        };
        let (s, y, x, v) = (
            c[1] as usize,
            c[2] as usize,
            c[3] as usize,
            T::from_f64(c[4]),
        );
        Ok(Some(if c[0] == 0.0 {
            format!("species {s} at cell ({x}, {y}) = {v}")
        } else {
            let [gnx, gny] = self.decomposition.global();
            let (x, y) = (x.clamp(1, gnx) - 1, y.clamp(1, gny) - 1);
            format!("species {s} in the ghost cell next to cell ({x}, {y}) = {v}")
        }))
    }
}

impl<T: Real, M: Model> Simulation for DistributedRd<T, M> {
    type State = Grid<T>;

    /// Advances `steps` steps with the checks of [`crate::Rd`] (same steps checked, same
    /// errors, same rollback), decided together by all ranks. Collective.
    fn step(&mut self, steps: u32) -> Result<()> {
        self.comm.agree_steps(steps)?;
        simkit_backend::guard::end_step(self.steps, steps)?;
        if self.model.field_dependent_diffusivity() {
            let d = self.max_diffusivity()?;
            check_dt_with(self.model.name(), d, self.h, &self.config.stepping)?;
        }
        let every = self.config.check_every;
        run_guarded(&mut Checked(self), steps, every)
    }

    /// The whole grid, gathered on rank 0 and sent to every rank: bit-identical to
    /// [`crate::Rd`]'s state on the CPU after the same steps. Collective.
    fn state(&mut self) -> Result<Grid<T>> {
        let all = self.comm.share_from_root(self.gather_fields())?;
        self.grid_of(&all)
    }

    fn steps_done(&self) -> u64 {
        self.steps
    }

    /// `"cpu (P ranks)"`.
    fn backend_name(&self) -> String {
        format!("cpu ({} ranks, {})", self.comm.size(), self.comm.name())
    }
}

impl<T: Real, M: Model> Distributed for DistributedRd<T, M> {
    fn comm(&self) -> &Comm {
        &self.comm
    }

    /// The checkpoint of the run in the format of [`crate::Rd`]'s checkpoints, on every
    /// rank: resume it with `Rd::resume` in one process or with [`Distributed::resume`] on
    /// any number of ranks. Collective (the grid is gathered on rank 0, encoded there and
    /// sent to every rank).
    fn checkpoint(&mut self) -> Result<Vec<u8>> {
        let encode = |all: Vec<T>| {
            encode_checkpoint(&RunState {
                grid: self.grid_of(&all)?,
                model: self.model.clone(),
                config: self.config,
                steps: self.steps,
                epoch_time: self.epoch_time,
                epoch_step: self.epoch_step,
            })
        };
        let bytes = self.gather_fields().and_then(|a| a.map(encode).transpose());
        self.comm.share_from_root(bytes)
    }

    /// Resumes from checkpoint bytes of [`crate::Rd`] (`Restart::checkpoint`) or of
    /// [`Distributed::checkpoint`], on any number of ranks: the run goes on bit for bit
    /// (steps, simulated time and fields). Every rank passes the same bytes (checked;
    /// [`Distributed::resume_file`] reads a file on rank 0 and sends it). Collective.
    ///
    /// Errors: those of `Rd::resume` (corrupt bytes, another crate, version, model or
    /// precision) and of [`DistributedRd::new`], on every rank.
    fn resume(bytes: &[u8], comm: Comm) -> Result<Self> {
        let s = comm.agree(decode_checkpoint::<T, M>(bytes))?;
        Self::build(s, comm)
    }
}

/// The blow-up guard's view of a distributed run (see [`simkit_backend::guard`]): the
/// checks of [`crate::Rd`], each decided by all ranks together.
struct Checked<'a, T: Real, M: Model>(&'a mut DistributedRd<T, M>);

impl<T: Real, M: Model> Guarded for Checked<'_, T, M> {
    fn steps_done(&self) -> u64 {
        self.0.steps
    }

    fn keep(&mut self) -> Result<()> {
        let r = &mut *self.0;
        r.good.copy_from_slice(&r.cur);
        r.good_steps = r.steps;
        Ok(())
    }

    fn advance(&mut self, n: u32) -> std::result::Result<(), Halt> {
        self.0.advance(n)?;
        self.0.steps += u64::from(n);
        Ok(())
    }

    fn check(&mut self) -> std::result::Result<(), Halt> {
        let r = &*self.0;
        let Some(what) = r.first_bad_cell()? else {
            return Ok(());
        };
        // The bound of the state the run goes back to, over all ranks.
        let [nx, ny] = r.block.len;
        let d = r
            .comm
            .all_max(padded_max_diffusivity(&r.model, nx, ny, &r.good, &r.coef))?;
        let bound = dt_bound(d, r.h);
        Err(Halt::BlowUp {
            step: r.steps,
            what,
            cause: divergence_cause(r.model.name(), &r.config.stepping, bound),
        })
    }

    fn restore(&mut self) -> Result<()> {
        let r = &mut *self.0;
        r.cur.copy_from_slice(&r.good);
        r.steps = r.good_steps;
        Ok(())
    }

    fn between(&mut self) -> Result<()> {
        let r = &*self.0;
        if r.model.field_dependent_diffusivity() {
            let d = r.max_diffusivity()?;
            recheck_bound(r.model.name(), d, r.h, &r.config.stepping, r.steps)?;
        }
        Ok(())
    }
}
