//! CPU backend: cache-blocked tiles of the padded grid, processed in parallel with rayon.

use rayon::prelude::*;
use simkit_backend::guard::{Guarded, Halt, end_step, run_guarded};
use simkit_backend::{Real, Result};

use crate::boundary::fill_ghosts;
use crate::config::Config;
use crate::engine::Engine;
use crate::grid::{Grid, first_bad_cell, pad};
use crate::model::{Model, RowIn};
use crate::stepper::{
    Integrator, Stepping, check_dt, check_dt_with, check_model, checked_bound, divergence_cause,
    dt_bound, recheck_bound,
};
use crate::sweep::{ScratchPool, Sweep, with_slices};
use simkit_backend::max_or_nan;

/// Rows per band (the unit of parallel work).
const BAND_ROWS: usize = 16;
/// Columns per cache block: the three rows of every loaded field a block row needs stay in
/// L2 (f32 colony: 9 rows x 32 KiB). Shorter blocks (512 columns, L1-sized) measured up to
/// 2x slower at 4096^2: a row segment of 2 KiB is too short a stream for the hardware
/// prefetchers.
const BLOCK_COLS: usize = 8192;
/// Rows per band in a fused sweep (each band recomputes `2 (k - 1)` halo rows per level).
const FUSED_BAND_ROWS: usize = 64;

/// One stencil pass of `model` over the interior of padded planes (`(nx + 2) x (ny + 2)`
/// each, one ghost layer, species after species) from `src` into `dst`; the ghosts of `dst`
/// are left to the caller. Bands of rows in parallel, columns in cache blocks, each row
/// segment through the model's row kernel. Every per-cell value depends only on the cell's
/// stencil in `src` and `coef`, so any caller that supplies the same stencil values (the
/// single-process backend, or one block of a distributed run) gets the same bits.
#[allow(clippy::too_many_arguments)]
pub(crate) fn interior_pass<T: Real, M: Model>(
    model: &M,
    nx: usize,
    ny: usize,
    coef: &[T],
    src: &[T],
    dst: &mut [T],
    dt: f64,
    ih2: f64,
    average: bool,
) {
    let w = nx + 2;
    let plane = w * (ny + 2);
    let mut per_plane: Vec<_> = dst
        .chunks_mut(plane)
        .map(|p| p[w..(ny + 1) * w].chunks_mut(BAND_ROWS * w))
        .collect();
    let bands: Vec<Vec<&mut [T]>> = (0..ny.div_ceil(BAND_ROWS))
        .map(|_| per_plane.iter_mut().filter_map(|it| it.next()).collect())
        .collect();
    bands
        .into_par_iter()
        .enumerate()
        .for_each(|(b, mut chunks)| {
            let rows = (ny - b * BAND_ROWS).min(BAND_ROWS);
            for i0 in (1..=nx).step_by(BLOCK_COLS) {
                let i1 = (i0 + BLOCK_COLS).min(nx + 1);
                for r in 0..rows {
                    let row = 1 + b * BAND_ROWS + r;
                    let input = RowIn {
                        species: src,
                        species_plane: plane,
                        species_row: row,
                        coefficients: coef,
                        coefficient_plane: plane,
                        row,
                        width: w,
                        i0,
                        i1,
                    };
                    let outs = chunks.iter_mut().map(|c| &mut c[r * w + i0..r * w + i1]);
                    with_slices(outs, |outs| {
                        model.update_row(&input, dt, ih2, outs, average)
                    });
                }
            }
        });
}

/// The model's largest effective diffusivity over the interior of padded planes `cur` (with
/// coefficient planes `coef`), read in place, rows in parallel; NaN if any row's is NaN.
pub(crate) fn padded_max_diffusivity<T: Real, M: Model>(
    model: &M,
    nx: usize,
    ny: usize,
    cur: &[T],
    coef: &[T],
) -> f64 {
    let w = nx + 2;
    let plane = w * (ny + 2);
    (1..=ny)
        .into_par_iter()
        .map(|row| {
            let at = row * w + 1;
            let species: Vec<&[T]> = cur.chunks(plane).map(|p| &p[at..at + nx]).collect();
            let coef: Vec<&[T]> = coef.chunks(plane).map(|p| &p[at..at + nx]).collect();
            model.max_cell_diffusivity(&species, &coef)
        })
        .reduce(|| 0.0, max_or_nan)
}

/// Reaction–diffusion on the CPU (all cores of the current rayon pool).
///
/// Fields live in padded storage (one ghost layer). Each stencil pass splits the interior
/// into bands of rows processed in parallel; inside a band, columns are walked in cache
/// blocks and each row segment goes to the model's vectorised row kernel (compiled for
/// AVX-512, AVX2+FMA and baseline x86-64, chosen at run time).
///
/// Explicit Euler fuses [`Config::steps_per_sweep`] steps into one sweep over the grid
/// (temporal blocking: intermediate steps of a band of rows stay in a small per-thread
/// buffer), bit-identical to one pass per step, for every edge condition; Heun takes one
/// pass per stage.
///
/// The blow-up check keeps the padded fields as they were at the last check that passed
/// (`good`) and puts them back when a check fails. For Euler no copy is made: the state that
/// passed moves to `good` and the next sweep reads it from there.
#[derive(Debug)]
pub(crate) struct CpuRd<T: Real, M: Model> {
    model: M,
    grid: Grid<T>,
    stepping: Stepping,
    cur: Vec<T>,
    tmp: Vec<T>,
    coef: Vec<T>,
    /// The padded fields at the last check that passed.
    good: Vec<T>,
    /// The step count of `good`.
    good_steps: u64,
    steps: u64,
    snapshot_fresh: bool,
    steps_per_sweep: u32,
    check_every: u32,
    scratch: ScratchPool<T>,
    /// Largest effective diffusivity of the current fields, when the last sweep found it.
    next_dmax: Option<f64>,
}

impl<T: Real, M: Model> CpuRd<T, M> {
    /// Builds the simulation from a validated `config`, `steps` steps into the run; checks
    /// the model against the grid and `dt` against the stability bound (unless overridden).
    pub(crate) fn new(grid: Grid<T>, model: M, config: &Config, steps: u64) -> Result<Self> {
        let stepping = config.stepping;
        check_model(&model, &grid)?;
        check_dt(&model, &grid, &stepping)?;
        let (nx, ny) = (grid.nx(), grid.ny());
        let mut cur = grid.padded();
        let plane = (nx + 2) * (ny + 2);
        for (s, f) in cur.chunks_mut(plane).enumerate() {
            fill_ghosts(f, nx, ny, s, grid.boundaries());
        }
        let coef_fields: Vec<Vec<T>> = model
            .coefficients()
            .iter()
            .map(|c| c.iter().map(|&v| T::from_f64(v)).collect())
            .collect();
        let mut coef = pad(&coef_fields, nx, ny);
        let cbc = grid.boundaries().for_coefficients();
        for f in coef.chunks_mut(plane) {
            fill_ghosts(f, nx, ny, 0, &cbc);
        }
        let tmp = cur.clone();
        let good = cur.clone();
        Ok(Self {
            model,
            grid,
            stepping,
            cur,
            tmp,
            coef,
            good,
            good_steps: steps,
            steps,
            snapshot_fresh: true,
            steps_per_sweep: config.steps_per_sweep,
            check_every: config.check_every,
            scratch: ScratchPool::default(),
            next_dmax: None,
        })
    }

    fn refresh_snapshot(&mut self) {
        if !self.snapshot_fresh {
            self.grid.set_from_padded(&self.cur);
            self.snapshot_fresh = true;
        }
    }

    /// One stencil pass from `src` into `dst` (interior only), then `dst`'s ghosts.
    fn pass(&self, src: &[T], dst: &mut [T], average: bool) {
        let (nx, ny) = (self.grid.nx(), self.grid.ny());
        let ih2 = 1.0 / (self.grid.h() * self.grid.h());
        let (model, coef, dt) = (&self.model, &self.coef[..], self.stepping.dt);
        interior_pass(model, nx, ny, coef, src, dst, dt, ih2, average);
        let plane = (nx + 2) * (ny + 2);
        for (s, f) in dst.chunks_mut(plane).enumerate() {
            fill_ghosts(f, nx, ny, s, self.grid.boundaries());
        }
    }

    /// The model's largest effective diffusivity for the current fields (see
    /// [`padded_max_diffusivity`]).
    fn max_diffusivity(&self) -> f64 {
        let (nx, ny) = (self.grid.nx(), self.grid.ny());
        padded_max_diffusivity(&self.model, nx, ny, &self.cur, &self.coef)
    }

    /// `k` Euler steps in one sweep from `cur` into `tmp`, then the ghosts; with `want_max`,
    /// returns the model's largest effective diffusivity of the new fields (taken from each
    /// row right after it is written).
    fn fused(&self, k: usize, cur: &[T], tmp: &mut [T], want_max: bool) -> Option<f64> {
        let (nx, ny) = (self.grid.nx(), self.grid.ny());
        let plane = (nx + 2) * (ny + 2);
        let sweep = Sweep {
            model: &self.model,
            nx,
            ny,
            boundaries: self.grid.boundaries(),
            coef: &self.coef,
            dt: self.stepping.dt,
            inv_h2: 1.0 / (self.grid.h() * self.grid.h()),
            block_cols: BLOCK_COLS,
        };
        let d = sweep.run(k, FUSED_BAND_ROWS, cur, tmp, &self.scratch, want_max);
        for (s, f) in tmp.chunks_mut(plane).enumerate() {
            fill_ghosts(f, nx, ny, s, self.grid.boundaries());
        }
        d
    }

    /// Advances `steps >= 1` steps from the state in `good` (which is left as it is) into
    /// `cur`.
    fn advance_from_good(&mut self, steps: u32) {
        let mut cur = std::mem::take(&mut self.cur);
        let mut tmp = std::mem::take(&mut self.tmp);
        match self.stepping.integrator {
            Integrator::Euler => {
                let mut left = steps;
                while left > 0 {
                    let k = left.min(self.steps_per_sweep);
                    let src = if left == steps { &self.good } else { &cur };
                    left -= k;
                    self.next_dmax = None;
                    if k == 1 {
                        self.pass(src, &mut tmp, false);
                    } else {
                        // The last sweep of the call also finds the next call's stability bound.
                        let want = left == 0 && self.model.field_dependent_diffusivity();
                        self.next_dmax = self.fused(k as usize, src, &mut tmp, want);
                    }
                    std::mem::swap(&mut cur, &mut tmp);
                }
            }
            Integrator::Heun => {
                // The second stage averages with the state it overwrites.
                cur.copy_from_slice(&self.good);
                self.next_dmax = None;
                for _ in 0..steps {
                    self.pass(&cur, &mut tmp, false);
                    self.pass(&tmp, &mut cur, true);
                }
            }
        }
        self.cur = cur;
        self.tmp = tmp;
    }
}

/// The blow-up guard's view (see [`simkit_backend::guard`]): keeping is a swap of `good`
/// and `cur` (the next stretch reads the state that passed from `good`), checking looks for
/// non-finite cells, and between stretches the stability bound of the current fields is
/// checked again when the model's diffusivity depends on them.
impl<T: Real, M: Model> Guarded for CpuRd<T, M> {
    fn steps_done(&self) -> u64 {
        self.steps
    }

    fn keep(&mut self) -> Result<()> {
        std::mem::swap(&mut self.good, &mut self.cur);
        self.good_steps = self.steps;
        Ok(())
    }

    fn advance(&mut self, n: u32) -> std::result::Result<(), Halt> {
        self.advance_from_good(n);
        self.snapshot_fresh = false;
        self.steps += u64::from(n);
        Ok(())
    }

    fn check(&mut self) -> std::result::Result<(), Halt> {
        let (nx, ny) = (self.grid.nx(), self.grid.ny());
        match first_bad_cell(&self.cur, nx, ny) {
            None => Ok(()),
            Some(what) => {
                // The bound of the state the run goes back to.
                let d = padded_max_diffusivity(&self.model, nx, ny, &self.good, &self.coef);
                let bound = dt_bound(d, self.grid.h());
                Err(Halt::BlowUp {
                    step: self.steps,
                    what,
                    cause: divergence_cause(self.model.name(), &self.stepping, bound),
                })
            }
        }
    }

    fn restore(&mut self) -> Result<()> {
        self.cur.copy_from_slice(&self.good);
        self.steps = self.good_steps;
        self.next_dmax = None;
        Ok(())
    }

    fn between(&mut self) -> Result<()> {
        if self.model.field_dependent_diffusivity() {
            let d = match self.next_dmax {
                Some(d) => d,
                None => self.max_diffusivity(),
            };
            recheck_bound(
                self.model.name(),
                d,
                self.grid.h(),
                &self.stepping,
                self.steps,
            )?;
        }
        Ok(())
    }
}

impl<T: Real, M: Model> Engine<T, M> for CpuRd<T, M> {
    fn step(&mut self, steps: u32) -> Result<()> {
        end_step(self.steps, steps)?;
        if self.model.field_dependent_diffusivity() {
            let d = match self.next_dmax {
                Some(d) => d,
                None => self.max_diffusivity(),
            };
            check_dt_with(self.model.name(), d, self.grid.h(), &self.stepping)?;
        }
        if steps == 0 {
            return Ok(());
        }
        // The whole loop on a pool thread: no hand-over to the pool per sweep.
        let every = self.check_every;
        simkit_backend::pool::on_pool(|| run_guarded(self, steps, every))
    }
    fn state(&mut self) -> Result<Grid<T>> {
        self.refresh_snapshot();
        Ok(self.grid.clone())
    }

    fn steps_done(&self) -> u64 {
        self.steps
    }

    fn name(&self) -> String {
        format!("cpu ({} threads)", rayon::current_num_threads())
    }

    fn model(&self) -> &M {
        &self.model
    }

    fn stepping(&self) -> Stepping {
        self.stepping
    }

    fn set_stepping(&mut self, stepping: Stepping) -> Result<()> {
        check_dt_with(
            self.model.name(),
            self.max_diffusivity(),
            self.grid.h(),
            &stepping,
        )?;
        self.stepping = stepping;
        Ok(())
    }

    fn stable_dt(&self) -> Result<f64> {
        checked_bound(self.model.name(), self.max_diffusivity(), self.grid.h())
    }
}
