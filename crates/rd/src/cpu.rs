//! CPU backend: cache-blocked tiles of the padded grid, processed in parallel with rayon.

use backend::{Result, Simulation};
use rayon::prelude::*;

use crate::boundary::fill_ghosts;
use crate::grid::{Grid, pad};
use crate::model::{Model, RowIn};
use crate::real::Real;
use crate::stepper::{Integrator, Stepping, check_dt, check_model, stable_dt};

/// Rows per band (the unit of parallel work).
const BAND_ROWS: usize = 16;
/// Columns per cache block: the three rows of every loaded field a block row needs stay in
/// L2 (f32 colony: 9 rows x 32 KiB). Shorter blocks (512 columns, L1-sized) measured up to
/// 2x slower at 4096^2: a row segment of 2 KiB is too short a stream for the hardware
/// prefetchers.
const BLOCK_COLS: usize = 8192;

/// Reaction–diffusion on the CPU (all cores of the current rayon pool).
///
/// Fields live in padded storage (one ghost layer). Each stencil pass splits the interior
/// into bands of rows processed in parallel; inside a band, columns are walked in cache
/// blocks and each row segment goes to the model's vectorised row kernel (compiled for
/// AVX-512, AVX2+FMA and baseline x86-64, chosen at run time).
#[derive(Debug)]
pub struct CpuRd<T: Real, M: Model> {
    model: M,
    grid: Grid<T>,
    stepping: Stepping,
    cur: Vec<T>,
    tmp: Vec<T>,
    coef: Vec<T>,
    steps: u64,
    snapshot_fresh: bool,
}

impl<T: Real, M: Model> CpuRd<T, M> {
    /// Builds the simulation; checks the model against the grid and `dt` against the
    /// stability bound (unless overridden).
    pub fn new(grid: Grid<T>, model: M, stepping: Stepping) -> Result<Self> {
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
        Ok(Self {
            model,
            grid,
            stepping,
            cur,
            tmp,
            coef,
            steps: 0,
            snapshot_fresh: true,
        })
    }

    /// The model.
    pub fn model(&self) -> &M {
        &self.model
    }

    /// Current time-stepping settings.
    pub fn stepping(&self) -> Stepping {
        self.stepping
    }

    /// Changes the time step (checked against the bound from the current fields).
    pub fn set_stepping(&mut self, stepping: Stepping) -> Result<()> {
        self.refresh_snapshot();
        check_dt(&self.model, &self.grid, &stepping)?;
        self.stepping = stepping;
        Ok(())
    }

    /// Largest stable `dt` for the current fields.
    pub fn stable_dt(&mut self) -> f64 {
        self.refresh_snapshot();
        stable_dt(&self.model, &self.grid)
    }

    /// Simulated time, `steps_done * dt` (for a constant `dt`).
    pub fn time(&self) -> f64 {
        self.steps as f64 * self.stepping.dt
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
        let w = nx + 2;
        let plane = w * (ny + 2);
        let dt = self.stepping.dt;
        let ih2 = 1.0 / (self.grid.h() * self.grid.h());
        let mut per_plane: Vec<_> = dst
            .chunks_mut(plane)
            .map(|p| p[w..(ny + 1) * w].chunks_mut(BAND_ROWS * w))
            .collect();
        let bands: Vec<Vec<&mut [T]>> = (0..ny.div_ceil(BAND_ROWS))
            .map(|_| per_plane.iter_mut().filter_map(|it| it.next()).collect())
            .collect();
        let coef = &self.coef[..];
        bands
            .into_par_iter()
            .enumerate()
            .for_each(|(b, mut chunks)| {
                let rows = (ny - b * BAND_ROWS).min(BAND_ROWS);
                for i0 in (1..=nx).step_by(BLOCK_COLS) {
                    let i1 = (i0 + BLOCK_COLS).min(nx + 1);
                    for r in 0..rows {
                        let input = RowIn {
                            species: src,
                            coefficients: coef,
                            plane,
                            width: w,
                            row: 1 + b * BAND_ROWS + r,
                            i0,
                            i1,
                        };
                        let mut outs: Vec<&mut [T]> = chunks
                            .iter_mut()
                            .map(|c| &mut c[r * w + i0..r * w + i1])
                            .collect();
                        self.model.update_row(&input, dt, ih2, &mut outs, average);
                    }
                }
            });
        for (s, f) in dst.chunks_mut(plane).enumerate() {
            fill_ghosts(f, nx, ny, s, self.grid.boundaries());
        }
    }

    fn one_step(&mut self) {
        let mut cur = std::mem::take(&mut self.cur);
        let mut tmp = std::mem::take(&mut self.tmp);
        match self.stepping.integrator {
            Integrator::Euler => {
                self.pass(&cur, &mut tmp, false);
                std::mem::swap(&mut cur, &mut tmp);
            }
            Integrator::Heun => {
                self.pass(&cur, &mut tmp, false);
                self.pass(&tmp, &mut cur, true);
            }
        }
        self.cur = cur;
        self.tmp = tmp;
    }
}

impl<T: Real, M: Model> Simulation for CpuRd<T, M> {
    type State = Grid<T>;

    /// Advances `steps` steps; the stability bound is re-checked first from the current
    /// fields when the model's diffusivity depends on them.
    fn step(&mut self, steps: u32) -> Result<()> {
        if self.model.field_dependent_diffusivity() {
            self.refresh_snapshot();
            check_dt(&self.model, &self.grid, &self.stepping)?;
        }
        for _ in 0..steps {
            self.one_step();
        }
        if steps > 0 {
            self.snapshot_fresh = false;
        }
        self.steps += u64::from(steps);
        Ok(())
    }

    fn state(&mut self) -> Result<Grid<T>> {
        self.refresh_snapshot();
        Ok(self.grid.clone())
    }

    fn steps_done(&self) -> u64 {
        self.steps
    }

    fn backend_name(&self) -> String {
        format!("cpu ({} threads)", rayon::current_num_threads())
    }
}
