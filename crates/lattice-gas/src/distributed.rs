//! [`DistributedLatticeGas`]: one lattice cut into blocks over the ranks of a [`Comm`], each
//! rank stepping its block on the CPU, bit-identical to the single-process run.

use rayon::prelude::*;
use simkit_backend::comm::{Block, CartDecomposition, Comm};
use simkit_backend::{Backend, Distributed, Result, Simulation};

use crate::cpu::lut::LutRule;
use crate::sim::{decode_checkpoint, encode_checkpoint};
use crate::{Config, Lattice};

/// An FHP lattice gas whose lattice is block-decomposed over the ranks of a [`Comm`] (CPU
/// only, lookup-table rule).
///
/// The `width x height` lattice is cut by [`CartDecomposition::new`] (blocks as even as the
/// rank count allows, uneven splits included; a periodic axis makes the blocks wrap). Each
/// rank keeps its block with one ghost layer of sites. A step runs the row update of
/// the lookup-table backend ([`crate::CpuMethod::Lut`]) on the block's rows, each row knowing its global row (whose parity sets
/// the neighbour offsets of the shifted rows, so blocks may start on odd rows) and the
/// global index of its first site (which keys the chirality and body-force bits of
/// [`crate::laws`]); the inflow and outflow columns act on the ranks that hold the
/// lattice's first and last columns. Then the ghosts are refreshed by a halo exchange in
/// the shift pattern (x, then y with whole padded rows, so the diagonal neighbours of the
/// hexagonal lattice arrive in the corners; 4 messages). Ghosts on a non-periodic edge of
/// the lattice stay empty, as the single-process run pads it. Every site therefore sees the
/// inputs and random bits of the single-process run, and [`Simulation::state`]
/// returns a lattice bit-identical to [`crate::LatticeGas`] (any backend) for every rank
/// count, lattice size, boundary setting, obstacle and body force.
///
/// It implements [`Distributed`]: its checkpoints are those of [`crate::LatticeGas`], so a
/// run moves between one process and any rank count. Every method that takes `&mut self`
/// or returns a `Result` is collective: all ranks call it, in the same order. Each rank
/// builds the run from the whole lattice (one byte per site, so a copy of the whole
/// lattice, and its encoding for the check that the ranks agree, on every rank while the
/// run is built); [`Simulation::state`] and [`Distributed::checkpoint`] return the whole
/// lattice on every rank.
///
/// ```
/// use simkit_backend::comm::Comm;
/// use simkit_lattice_gas::{Backend, Config, DistributedLatticeGas, Lattice, LatticeGas};
/// use simkit_lattice_gas::{Obstacle, Simulation};
/// # fn main() -> simkit_backend::Result<()> {
/// let mut lattice = Lattice::new(37, 22)?;
/// lattice.fill_random(0.3, 4)?;
/// lattice.add_obstacle(&Obstacle::Disc { cx: 18.0, cy: 9.0, radius: 4.0 })?;
/// let config = Config { body_force: 0.02, ..Config::default() };
/// // `Comm::mpi()?` under `mpirun -np P` (feature `mpi`); here one process.
/// let mut dist = DistributedLatticeGas::new(lattice.clone(), &config, Comm::serial())?;
/// dist.step(25)?;
/// let mut one = LatticeGas::new(lattice, &config, Backend::Cpu)?;
/// one.step(25)?;
/// assert_eq!(dist.state()?, one.state()?); // on every rank
/// # Ok(())
/// # }
/// ```
pub struct DistributedLatticeGas {
    comm: Comm,
    decomposition: CartDecomposition,
    block: Block,
    config: Config,
    rule: LutRule,
    /// This rank's block with one ghost layer: `(len_x + 2) x (len_y + 2)` site bytes,
    /// row-major, the block's site `(0, 0)` at padded `(1, 1)` (with a GPU stepper only
    /// its edge sites and ghosts are kept current here: the state lives on the device).
    cur: Vec<u8>,
    /// The buffer the next step writes (same layout; its ghosts on the lattice's
    /// non-periodic edges stay 0; unused with a GPU stepper).
    next: Vec<u8>,
    /// With `Backend::Gpu`: the block on this rank's GPU.
    #[cfg(feature = "gpu")]
    gpu: Option<Box<crate::gpu_block::GpuBlock>>,
    steps: u64,
}

impl std::fmt::Debug for DistributedLatticeGas {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DistributedLatticeGas")
            .field("comm", &self.comm)
            .field("decomposition", &self.decomposition)
            .field("block", &self.block)
            .field("config", &self.config)
            .field("steps", &self.steps)
            .finish()
    }
}

impl DistributedLatticeGas {
    /// Validates `config` against `lattice` ([`Config::validate_for`], the errors of
    /// [`crate::LatticeGas::new`] on every rank), checks that every rank passed the same
    /// lattice and config, cuts the lattice into `comm.size()` blocks and keeps this
    /// rank's (`config.cpu` and `config.gpu_layout` are not read). Collective.
    ///
    /// Errors: invalid settings, ranks whose inputs differ, or a lattice too small for
    /// `comm.size()` blocks of at least one site; on every rank.
    pub fn new(lattice: Lattice, config: &Config, comm: Comm) -> Result<Self> {
        Self::at_step(&lattice, config, comm, 0, Backend::Cpu)
    }

    /// [`DistributedLatticeGas::new`] on `backend`: `Backend::Cpu` as `new`, or
    /// `Backend::Gpu(ctx)` for this rank's GPU (pick it with
    /// `GpuContext::for_local_rank(comm.local_rank().0)`, so the ranks of a machine share
    /// its GPUs). On the GPU each rank steps its block with the byte rule of the
    /// single-process GPU kernel (the same site update) and exchanges the halo through the
    /// host every step (edge sites packed on the device and downloaded, ghosts uploaded):
    /// bit-identical to the CPU for every rank count, as the single-process GPU run is.
    /// Collective.
    ///
    /// Errors: those of `new`, and any GPU failure (on every rank).
    pub fn with_backend(
        lattice: Lattice,
        config: &Config,
        comm: Comm,
        backend: Backend<'_>,
    ) -> Result<Self> {
        Self::at_step(&lattice, config, comm, 0, backend)
    }

    /// [`Distributed::resume`] on `backend` (see
    /// [`DistributedLatticeGas::with_backend`]). Collective.
    ///
    /// Errors: those of `resume` and of `with_backend`.
    pub fn resume_with_backend(bytes: &[u8], comm: Comm, backend: Backend<'_>) -> Result<Self> {
        let (config, lattice, steps) = comm.agree(decode_checkpoint(bytes))?;
        Self::at_step(&lattice, &config, comm, steps, backend)
    }

    /// [`DistributedLatticeGas::new`] with `steps` steps already done (the step counter keys
    /// the random bits).
    fn at_step(
        lattice: &Lattice,
        config: &Config,
        comm: Comm,
        steps: u64,
        backend: Backend<'_>,
    ) -> Result<Self> {
        comm.agree(config.validate_for(lattice))?;
        // Everything the ranks must agree on, as a checkpoint stores it.
        let encoded = comm.agree(encode_checkpoint(config, lattice, steps))?;
        comm.agree_inputs(&encoded, "DistributedLatticeGas inputs")?;
        drop(encoded);
        let (gw, gh) = (lattice.width(), lattice.height());
        let decomposition = comm.agree(CartDecomposition::new(
            [gw, gh],
            comm.size(),
            [config.periodic_x, config.periodic_y],
        ))?;
        let block = decomposition.block(comm.rank());
        let [nx, ny] = block.len;
        let [x0, y0] = block.start;
        let pw = nx + 2;
        let mut cur = vec![0u8; pw * (ny + 2)];
        for (jl, row) in cur.chunks_mut(pw).skip(1).take(ny).enumerate() {
            let at = (y0 + jl) * gw + x0;
            row[1..=nx].copy_from_slice(&lattice.cells()[at..at + nx]);
        }
        decomposition.exchange_halo(&comm, &mut cur, 1)?;
        #[cfg(feature = "gpu")]
        let gpu = match backend {
            Backend::Cpu => None,
            Backend::Gpu(ctx) => Some(Box::new(comm.agree(crate::gpu_block::GpuBlock::new(
                ctx, config, block, gw, &cur,
            ))?)),
        };
        #[cfg(not(feature = "gpu"))]
        let Backend::Cpu = backend;
        Ok(Self {
            comm,
            decomposition,
            block,
            rule: LutRule::new(config),
            config: config.clone(),
            next: vec![0u8; cur.len()],
            cur,
            #[cfg(feature = "gpu")]
            gpu,
            steps,
        })
    }

    /// How the lattice is cut over the ranks (x = columns, y = rows).
    pub fn decomposition(&self) -> &CartDecomposition {
        &self.decomposition
    }

    /// This rank's block of sites.
    pub fn block(&self) -> Block {
        self.block
    }

    /// The settings the run was built with.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// One step of the block's rows from `cur` into `next` (rows in parallel; the ghosts
    /// of `next` are not written).
    fn step_block(&mut self) {
        let [nx, ny] = self.block.len;
        let [x0, y0] = self.block.start;
        let gw = self.decomposition.global()[0];
        let pw = nx + 2;
        // The single-process run keys its random bits with the step count as u32 too.
        let rows = self.rule.at_step(self.steps as u32);
        let cur = &self.cur;
        let edges = [x0 == 0, x0 + nx == gw];
        self.next[pw..(ny + 1) * pw]
            .par_chunks_mut(pw)
            .enumerate()
            .for_each(|(jl, out)| {
                let j = y0 + jl;
                let padded = |r: usize| &cur[r * pw..(r + 1) * pw];
                let (mid, up, down) = (padded(jl + 1), padded(jl + 2), padded(jl));
                rows.row(
                    j,
                    (j * gw + x0) as u32,
                    &mut out[1..=nx],
                    [mid, up, down],
                    edges,
                );
            });
    }

    /// This rank's sites without ghosts, row-major `len_x x len_y` (downloaded from the
    /// GPU stepper).
    fn interior(&self) -> Result<Vec<u8>> {
        #[cfg(feature = "gpu")]
        if let Some(g) = &self.gpu {
            let padded = self.comm.agree(g.padded())?;
            return Ok(self.interior_of(&padded));
        }
        Ok(self.interior_of(&self.cur))
    }

    /// The interior sites of a padded block.
    fn interior_of(&self, padded: &[u8]) -> Vec<u8> {
        let [nx, ny] = self.block.len;
        let pw = nx + 2;
        padded
            .chunks(pw)
            .skip(1)
            .take(ny)
            .flat_map(|row| &row[1..=nx])
            .copied()
            .collect()
    }

    /// The sites of the whole lattice on rank 0 (`Some`), `None` on the other ranks.
    /// Collective.
    fn gather_cells(&self) -> Result<Option<Vec<u8>>> {
        self.decomposition.gather(&self.comm, &self.interior()?)
    }

    /// The lattice of the sites [`DistributedLatticeGas::gather_cells`] gathered.
    fn lattice_of(&self, cells: Vec<u8>) -> Lattice {
        let [w, h] = self.decomposition.global();
        Lattice::from_raw(w, h, cells)
    }

    /// Total number of particles over all ranks, on every rank (no gather). Collective.
    pub fn particle_count(&self) -> Result<u64> {
        let mine: u64 = self
            .interior()?
            .iter()
            .map(|c| u64::from((c & 0x3f).count_ones()))
            .sum();
        Ok(self.comm.all_gather(&[mine])?.iter().sum())
    }
}

impl Simulation for DistributedLatticeGas {
    type State = Lattice;

    /// Advances `steps` steps, with one halo exchange after each. Collective.
    ///
    /// Errors: a step counter that would overflow, or a failed exchange.
    fn step(&mut self, steps: u32) -> Result<()> {
        self.comm.agree_steps(steps)?;
        simkit_backend::guard::end_step(self.steps, steps)?;
        for _ in 0..steps {
            #[cfg(feature = "gpu")]
            if let Some(g) = &mut self.gpu {
                // The single-process run keys its random bits with the step count as u32.
                let stepped = g.step_and_read_edges(&mut self.cur, self.steps as u32);
                // A GPU failure on one rank stops every rank before the exchange.
                self.comm.agree(stepped)?;
                self.decomposition
                    .exchange_halo(&self.comm, &mut self.cur, 1)?;
                self.comm.agree(g.write_ghosts(&self.cur))?;
                self.steps += 1;
                continue;
            }
            self.step_block();
            std::mem::swap(&mut self.cur, &mut self.next);
            self.decomposition
                .exchange_halo(&self.comm, &mut self.cur, 1)?;
            self.steps += 1;
        }
        Ok(())
    }

    /// The whole lattice, gathered on rank 0 and sent to every rank: the state the
    /// single-process run has after the same steps (bit for bit). Collective.
    fn state(&mut self) -> Result<Lattice> {
        let cells = self.comm.share_from_root(self.gather_cells())?;
        Ok(self.lattice_of(cells))
    }

    /// Steps taken so far (the same on every rank).
    fn steps_done(&self) -> u64 {
        self.steps
    }

    /// `"cpu lookup table (P ranks)"` or `"gpu bytes (<adapter>) (P ranks)"`: how each rank
    /// steps its block.
    fn backend_name(&self) -> String {
        #[cfg(feature = "gpu")]
        if let Some(g) = &self.gpu {
            return format!("gpu bytes ({}) ({} ranks)", g.adapter(), self.comm.size());
        }
        format!("cpu lookup table ({} ranks)", self.comm.size())
    }
}

impl Distributed for DistributedLatticeGas {
    fn comm(&self) -> &Comm {
        &self.comm
    }

    /// The checkpoint of the whole run in the format of [`crate::LatticeGas`]'s
    /// `Restart::checkpoint`, on every rank: it resumes bit for bit as a single-process run
    /// on any backend, or with [`Distributed::resume`] on any rank count. Collective (the
    /// lattice is gathered and encoded on rank 0, the bytes sent to every rank).
    fn checkpoint(&mut self) -> Result<Vec<u8>> {
        let encode = |cells| encode_checkpoint(&self.config, &self.lattice_of(cells), self.steps);
        let bytes = self.gather_cells().and_then(|c| c.map(encode).transpose());
        self.comm.share_from_root(bytes)
    }

    /// Resumes on the CPU from checkpoint bytes of [`crate::LatticeGas`]
    /// (`Restart::checkpoint`) or of [`Distributed::checkpoint`], on any rank count: the
    /// run continues bit for bit. Every rank passes the same bytes (checked;
    /// [`Distributed::resume_file`] reads a file on rank 0 and sends it). Collective.
    ///
    /// Errors: those of `LatticeGas::resume` (corrupt bytes, another crate, version or
    /// model, invalid settings) and of [`DistributedLatticeGas::new`], on every rank.
    fn resume(bytes: &[u8], comm: Comm) -> Result<Self> {
        Self::resume_with_backend(bytes, comm, Backend::Cpu)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpu::lut::LutCpu;
    use crate::{Obstacle, RuleSet};
    use simkit_backend::Simulation;

    /// The block of `rank` of `decomposition`, its ghosts filled from `lattice` as the halo
    /// exchange fills them: wrapped on a periodic axis, empty past a closed edge.
    fn block_of(
        lattice: &Lattice,
        config: &Config,
        decomposition: &CartDecomposition,
        rank: usize,
        steps: u64,
    ) -> DistributedLatticeGas {
        let block = decomposition.block(rank);
        let [nx, ny] = block.len;
        let (w, h) = (lattice.width() as isize, lattice.height() as isize);
        let mut cur = vec![0u8; (nx + 2) * (ny + 2)];
        for (k, c) in cur.iter_mut().enumerate() {
            let x = (block.start[0] + k % (nx + 2)) as isize - 1;
            let y = (block.start[1] + k / (nx + 2)) as isize - 1;
            let x = if config.periodic_x {
                x.rem_euclid(w)
            } else {
                x
            };
            let y = if config.periodic_y {
                y.rem_euclid(h)
            } else {
                y
            };
            if (0..w).contains(&x) && (0..h).contains(&y) {
                *c = lattice.cells()[(y * w + x) as usize];
            }
        }
        DistributedLatticeGas {
            comm: Comm::serial(),
            decomposition: decomposition.clone(),
            block,
            config: config.clone(),
            rule: LutRule::new(config),
            next: vec![0u8; cur.len()],
            cur,
            #[cfg(feature = "gpu")]
            gpu: None,
            steps,
        }
    }

    /// Steps every block of a P-way cut (2 x 1 to 3 x 3, uneven, blocks on odd rows and
    /// one-site-thin blocks) in one process, one step at a time with the ghosts taken from
    /// the assembled lattice, and compares with the single-process run after each step: the
    /// global row parity, site indices, edges and open columns of the block step without
    /// MPI.
    #[test]
    fn every_block_of_a_cut_steps_like_the_whole_lattice() {
        let (w, h) = (37, 22);
        let mut lattice = Lattice::new(w, h).unwrap();
        lattice.fill_random(0.3, 9).unwrap();
        lattice.add_wall_rows();
        lattice
            .add_obstacle(&Obstacle::Disc {
                cx: 14.0,
                cy: 9.0,
                radius: 4.0,
            })
            .unwrap();
        let open = Config {
            rules: RuleSet::Full,
            periodic_x: false,
            periodic_y: false,
            inflow: true,
            outflow: true,
            body_force: 0.05,
            seed: 3,
            ..Config::default()
        };
        let periodic = Config {
            body_force: 0.1,
            seed: 4,
            ..Config::default()
        };
        for config in [open, periodic] {
            for dims in [[2, 1], [1, 2], [3, 2], [2, 3], [3, 3], [37, 1], [1, 22]] {
                let d = CartDecomposition::with_dims(
                    [w, h],
                    dims,
                    [config.periodic_x, config.periodic_y],
                )
                .unwrap();
                let mut one = LutCpu::new(lattice.clone(), &config).unwrap();
                let mut state = lattice.clone();
                for step in 0..6u64 {
                    let mut cells = vec![0u8; w * h];
                    for r in 0..d.ranks() {
                        let mut b = block_of(&state, &config, &d, r, step);
                        b.step_block();
                        std::mem::swap(&mut b.cur, &mut b.next);
                        let [nx, _] = b.block.len;
                        let [x0, y0] = b.block.start;
                        for (jl, row) in b.interior().unwrap().chunks(nx).enumerate() {
                            let at = (y0 + jl) * w + x0;
                            cells[at..at + nx].copy_from_slice(row);
                        }
                    }
                    one.step(1).unwrap();
                    state = one.state().unwrap();
                    assert!(
                        cells == state.cells(),
                        "{dims:?} {config:?}: step {step} differs"
                    );
                }
                assert!(state != lattice);
            }
        }
    }
}
