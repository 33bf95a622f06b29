//! GPU backend: device-resident sorted cell lists and CSR neighbour lists (wgpu, WGSL in
//! this crate's `shaders/`, loaded with `simkit_backend::wgsl!`).
//!
//! See [`GpuCellList`] for the buffers other kernels can bind.

use std::sync::atomic::{AtomicU64, Ordering};

use bytemuck::{Pod, Zeroable};

use simkit_backend::gpu::{DISPATCH_WGSL, ScanPlan, Uniform, run_pass};
use simkit_backend::{Error, GpuBuffer, GpuContext, GpuScan, Kernel, KernelDesc, Result};

use crate::{CellGrid, ListKind, NeighborLists, NeighborSearch, OutOfBox};

/// WGSL helpers for kernels that use a [`GpuCellList`]: the `NbGrid` struct and
/// `nb_wrap`, `nb_cell_coord`, `nb_cell_index`, `nb_shell_lo`, `nb_shell_hi`,
/// `nb_neighbor_cell`, `nb_min_image`, `nb_not_finite`, `nb_outside`. Declares no bindings.
pub const CELLS_WGSL: &str = simkit_backend::wgsl!("cells.wgsl");
const CLEAR_WGSL: &str = simkit_backend::wgsl!("clear.wgsl");
const ASSIGN_WGSL: &str = simkit_backend::wgsl!("assign.wgsl");
const SCATTER_WGSL: &str = simkit_backend::wgsl!("scatter.wgsl");
const SORT_WGSL: &str = simkit_backend::wgsl!("sort_cells.wgsl");
const LIST_WGSL: &str = simkit_backend::wgsl!("list.wgsl");

/// The most cells per axis a GPU grid may have: beyond it, `f32` rounding of the cell
/// assignment could exceed the cell margin ([`crate::CELL_MARGIN`]).
pub const GPU_MAX_CELLS_PER_AXIS: usize = 4096;

/// The most particles one cell of a [`GpuCellList`] may hold on any adapter: the per-cell
/// sort that fixes the order inside a cell is quadratic in the cell population, and with
/// cells at least the cutoff wide such a cell means a cutoff far too large for the density.
/// Adapters with a shader loop limit allow fewer ([`GpuCellList::max_per_cell`]).
pub const GPU_MAX_PER_CELL: usize = 65_536;

/// Loop iterations per invocation that [`GpuCellList::max_per_cell`] leaves, on an adapter
/// with a shader loop limit ([`GpuContext::shader_loop_limit`]), to a kernel's own loops
/// beside one full-shell walk over the cells (wall loops, small fixed loops).
pub const GPU_LOOP_RESERVE: u64 = 1024;

static NEXT_ID: AtomicU64 = AtomicU64::new(1);

/// Grid parameters as the WGSL struct `NbGrid` of [`CELLS_WGSL`] sees them (112 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuGridParams {
    /// Box origin (`w` unused).
    pub origin: [f32; 4],
    /// Box lengths (1 for unused axes).
    pub length: [f32; 4],
    /// Cells per unit length.
    pub inv_cell: [f32; 4],
    /// Cells per axis (1 for unused axes).
    pub cells: [u32; 4],
    /// 1 for periodic axes.
    pub periodic: [u32; 4],
    /// Particles in the cell list.
    pub n_particles: u32,
    /// Total cells.
    pub n_cells: u32,
    /// 1 when out-of-box positions are clamped ([`OutOfBox::Clamp`]).
    pub clamp_out: u32,
    /// 2 or 3.
    pub dim: u32,
    /// Cutoff squared.
    pub cutoff2: f32,
    /// Padding to a multiple of 16 bytes.
    pub pad: [f32; 3],
}

impl GpuGridParams {
    /// Parameters of `grid` for `n_particles` particles.
    ///
    /// Errors: more than [`GPU_MAX_CELLS_PER_AXIS`] cells along an axis, an origin that is
    /// not a finite `f32`, or a box length, cell density or cutoff squared that is not a
    /// normal `f32`.
    pub fn new<const D: usize>(grid: &CellGrid<D>, n_particles: u32) -> Result<Self> {
        let mut p = Self {
            origin: [0.0; 4],
            length: [1.0; 4],
            inv_cell: [1.0; 4],
            cells: [1; 4],
            periodic: [0; 4],
            n_particles,
            n_cells: grid.n_cells() as u32,
            clamp_out: u32::from(grid.out_of_box() == OutOfBox::Clamp),
            dim: D as u32,
            cutoff2: f32_param("cutoff^2", grid.cutoff() * grid.cutoff(), true)?,
            pad: [0.0; 3],
        };
        for d in 0..D {
            let n = grid.cells_per_axis()[d];
            if n > GPU_MAX_CELLS_PER_AXIS {
                return Err(Error::Unsupported(format!(
                    "the GPU cell list allows at most {GPU_MAX_CELLS_PER_AXIS} cells per axis \
                     (f32 positions), the grid has {n} along axis {d}; use a larger cutoff or \
                     the CPU backend"
                )));
            }
            p.origin[d] = f32_param(format!("origin along axis {d}"), grid.origin()[d], false)?;
            p.length[d] = f32_param(
                format!("box length along axis {d}"),
                grid.lengths()[d],
                true,
            )?;
            p.inv_cell[d] = f32_param(
                format!("cells per unit length along axis {d}"),
                n as f64 / grid.lengths()[d],
                true,
            )?;
            p.cells[d] = n as u32;
            p.periodic[d] = u32::from(grid.periodic()[d]);
        }
        Ok(p)
    }
}

/// `value` as the `f32` the GPU computes with: finite, and normal if it must be `positive`.
fn f32_param(name: impl Into<String>, value: f64, positive: bool) -> Result<f32> {
    let v = value as f32;
    let ok = if positive {
        v.is_normal()
    } else {
        v.is_finite()
    };
    if ok {
        Ok(v)
    } else {
        Err(Error::invalid(
            name,
            value,
            format!(
                "is {v} in f32, which the GPU computes in (normal f32 magnitudes are {:e} to \
                 {:e}); rescale the length unit or use the CPU backend",
                f32::MIN_POSITIVE,
                f32::MAX
            ),
        ))
    }
}

fn kernel(
    ctx: &GpuContext,
    src: &str,
    entry: &str,
    wg: u32,
    consts: &[(&str, f64)],
) -> Result<Kernel> {
    Kernel::new(
        ctx,
        &KernelDesc {
            label: entry,
            sources: &[DISPATCH_WGSL, CELLS_WGSL, src],
            entry,
            workgroup_size: wg,
            constants: consts,
        },
    )
}

/// Positions converted for the GPU: `[x, y, z, 0]` in `f32`.
pub fn positions_to_f32<const D: usize>(positions: &[[f64; D]]) -> Vec<[f32; 4]> {
    positions
        .iter()
        .map(|p| {
            let mut q = [0.0f32; 4];
            for d in 0..D {
                q[d] = p[d] as f32;
            }
            q
        })
        .collect()
}

/// A sorted cell list that lives on the GPU: cell per particle, atomic counts, the shared
/// prefix sum ([`GpuScan`]), a scatter into cell order and a per-cell sort that makes the
/// order inside each cell ascending (deterministic, equal to [`crate::SortedCells`]).
///
/// It reads positions from a caller's `array<vec4<f32>>` buffer (`w` is carried along, e.g.
/// a radius) and keeps every result on the device (buffers and WGSL types below). Build every step with [`encode`](Self::encode) inside the
/// caller's compute pass, or with [`build`](Self::build) (own submission plus a status
/// check).
///
/// # Buffers other kernels can bind (all `var<storage>` unless noted)
/// | getter | WGSL type | content |
/// |---|---|---|
/// | [`GpuCellList::params`] | `var<uniform> grid: NbGrid` | grid parameters ([`GpuGridParams`]) |
/// | [`GpuCellList::wrapped`] | `array<vec4<f32>>` | wrapped position by particle id (`w` copied from the input; a rejected particle keeps its raw input) |
/// | [`GpuCellList::cell_of`] | `array<u32>` | linear cell index by particle id |
/// | [`GpuCellList::cell_start`] | `array<u32>` | `n_cells + 1` offsets into the sorted arrays |
/// | [`GpuCellList::sorted_ids`] | `array<u32>` | particle ids in cell order (ascending inside a cell) |
/// | [`GpuCellList::sorted_pos`] | `array<vec4<f32>>` | wrapped positions in cell order |
/// | [`GpuCellList::status`] | `array<u32>` | `[bad particle count, smallest bad index, cells over max_per_cell]` |
///
/// Prepend [`CELLS_WGSL`] to a kernel's source for `NbGrid` and the cell/shell/minimum-image
/// helpers (its header shows the full-shell loop).
pub struct GpuCellList<const D: usize> {
    id: u64,
    grid: CellGrid<D>,
    n: usize,
    max_per_cell: usize,
    params_value: GpuGridParams,
    params: Uniform<GpuGridParams>,
    wrapped: GpuBuffer<[f32; 4]>,
    cell_of: GpuBuffer<u32>,
    cell_start: GpuBuffer<u32>,
    // Fill cursors per cell and the unsorted scatter output; bound by kernels only.
    _fill: GpuBuffer<u32>,
    _scattered: GpuBuffer<u32>,
    sorted_ids: GpuBuffer<u32>,
    sorted_pos: GpuBuffer<[f32; 4]>,
    status: GpuBuffer<u32>,
    clear: (Kernel, wgpu::BindGroup),
    assign: (Kernel, wgpu::BindGroup),
    scatter: (Kernel, wgpu::BindGroup),
    sort: (Kernel, wgpu::BindGroup),
    scan: GpuScan,
    plan: ScanPlan,
}

impl<const D: usize> GpuCellList<D> {
    /// A cell list for all `positions.len()` particles of `positions`.
    pub fn new(
        ctx: &GpuContext,
        grid: &CellGrid<D>,
        positions: &GpuBuffer<[f32; 4]>,
    ) -> Result<Self> {
        Self::with_count(ctx, grid, positions, positions.len())
    }

    /// A cell list for the first `n` particles of `positions` (a buffer may have spare
    /// capacity). `positions` must hold at least one element even when `n == 0`.
    pub fn with_count(
        ctx: &GpuContext,
        grid: &CellGrid<D>,
        positions: &GpuBuffer<[f32; 4]>,
        n: usize,
    ) -> Result<Self> {
        if n > positions.len() || positions.is_empty() {
            return Err(Error::invalid(
                "GPU cell list particle count",
                n,
                format!(
                    "must be <= the positions buffer length ({}), which must be >= 1",
                    positions.len()
                ),
            ));
        }
        if n >= u32::MAX as usize {
            return Err(Error::invalid(
                "particle count",
                n,
                "must be below 2^32 - 1",
            ));
        }
        let params_value = GpuGridParams::new(grid, n as u32)?;
        let max_per_cell = Self::max_per_cell(ctx);
        let params = Uniform::new(ctx, "neighbor grid", &params_value)?;
        let m = n.max(1);
        let nc = grid.n_cells();
        let wrapped = GpuBuffer::zeroed(ctx, "neighbor wrapped", m)?;
        let cell_of = GpuBuffer::zeroed(ctx, "neighbor cell_of", m)?;
        let cell_start = GpuBuffer::zeroed(ctx, "neighbor cell_start", nc + 1)?;
        let fill = GpuBuffer::zeroed(ctx, "neighbor fill", nc)?;
        let sorted_ids = GpuBuffer::zeroed(ctx, "neighbor sorted_ids", m)?;
        let scattered = GpuBuffer::zeroed(ctx, "neighbor scattered ids", m)?;
        let sorted_pos = GpuBuffer::zeroed(ctx, "neighbor sorted_pos", m)?;
        let status = GpuBuffer::zeroed(ctx, "neighbor status", 3)?;
        let k = kernel(ctx, CLEAR_WGSL, "nb_clear", 256, &[])?;
        let b = k.bind(
            ctx,
            &[
                params.binding(),
                cell_start.binding(),
                fill.binding(),
                status.binding(),
            ],
        )?;
        let clear = (k, b);
        let k = kernel(
            ctx,
            ASSIGN_WGSL,
            "nb_assign",
            256,
            &[("MAX_PER_CELL", max_per_cell as f64)],
        )?;
        let b = k.bind(
            ctx,
            &[
                params.binding(),
                positions.binding(),
                wrapped.binding(),
                cell_of.binding(),
                cell_start.binding(),
                status.binding(),
            ],
        )?;
        let assign = (k, b);
        let k = kernel(ctx, SCATTER_WGSL, "nb_scatter", 256, &[])?;
        let b = k.bind(
            ctx,
            &[
                params.binding(),
                cell_of.binding(),
                cell_start.binding(),
                fill.binding(),
                scattered.binding(),
            ],
        )?;
        let scatter = (k, b);
        let k = kernel(ctx, SORT_WGSL, "nb_sort_cells", 64, &[])?;
        let b = k.bind(
            ctx,
            &[
                params.binding(),
                cell_start.binding(),
                cell_of.binding(),
                scattered.binding(),
                sorted_ids.binding(),
                wrapped.binding(),
                sorted_pos.binding(),
            ],
        )?;
        let sort = (k, b);
        let scan = GpuScan::new(ctx)?;
        let plan = scan.plan(ctx, &cell_start)?;
        Ok(Self {
            id: NEXT_ID.fetch_add(1, Ordering::Relaxed),
            grid: grid.clone(),
            n,
            max_per_cell,
            params_value,
            params,
            wrapped,
            cell_of,
            cell_start,
            _fill: fill,
            _scattered: scattered,
            sorted_ids,
            sorted_pos,
            status,
            clear,
            assign,
            scatter,
            sort,
            scan,
            plan,
        })
    }

    /// Records the whole build (clear, assign + count, prefix sum, scatter, per-cell sort)
    /// into `pass`. Does not check the status: call [`check`](Self::check) when convenient.
    pub fn encode(&self, ctx: &GpuContext, pass: &mut wgpu::ComputePass<'_>) -> Result<()> {
        let nc = self.grid.n_cells() as u64;
        self.clear
            .0
            .dispatch_items(ctx, pass, &self.clear.1, nc + 1)?;
        self.assign
            .0
            .dispatch_items(ctx, pass, &self.assign.1, self.n as u64)?;
        self.scan.encode(ctx, pass, &self.plan)?;
        self.scatter
            .0
            .dispatch_items(ctx, pass, &self.scatter.1, self.n as u64)?;
        self.sort
            .0
            .dispatch_items(ctx, pass, &self.sort.1, self.n as u64)?;
        Ok(())
    }

    /// Builds in its own submission, then [`check`](Self::check)s the status.
    pub fn build(&self, ctx: &GpuContext) -> Result<()> {
        run_pass(ctx, "neighbor cell list", |pass| self.encode(ctx, pass))?;
        self.check(ctx)
    }

    /// The most particles one cell may hold on `ctx`'s adapter: [`GPU_MAX_PER_CELL`], or on
    /// an adapter with a shader loop limit (llvmpipe: 65,535 iterations per invocation,
    /// all loops together) the population at which a full-shell walk over 3^D cells, each
    /// costing its population plus one exit test, stays within the limit with
    /// [`GPU_LOOP_RESERVE`] iterations to spare: 2,388 in 3D and 7,166 in 2D on llvmpipe.
    /// Kernels that walk the shell with [`CELLS_WGSL`] are then safe from truncation.
    pub fn max_per_cell(ctx: &GpuContext) -> usize {
        let shell = 3usize.pow(D as u32);
        match ctx.shader_loop_limit() {
            Some(limit) => {
                let walk = limit.saturating_sub(GPU_LOOP_RESERVE) as usize;
                (walk / shell).saturating_sub(1).min(GPU_MAX_PER_CELL)
            }
            None => GPU_MAX_PER_CELL,
        }
    }

    /// Downloads the status words of the last build: an error for a cell holding more than
    /// [`max_per_cell`](Self::max_per_cell) particles, or one that names the first particle
    /// with a NaN/infinite coordinate or (without [`OutOfBox::Clamp`]) outside a closed face.
    pub fn check(&self, ctx: &GpuContext) -> Result<()> {
        let s = self.status.download(ctx)?;
        if s[2] > 0 {
            let why = match ctx.shader_loop_limit() {
                Some(limit) => format!(
                    "adapter '{}' ends shader loops after {limit} iterations per invocation \
                     and a full-shell walk must stay below that",
                    ctx.adapter_info().name
                ),
                None => "the per-cell sort is quadratic in the cell population".to_string(),
            };
            return Err(Error::Unsupported(format!(
                "{} cell(s) of the GPU cell list hold more than {} particles (the limit here: \
                 {why}); use a smaller cutoff (cells are at least the cutoff wide) or the CPU \
                 SortedCells",
                s[2], self.max_per_cell
            )));
        }
        if s[0] == 0 {
            return Ok(());
        }
        // The assign kernel stores a rejected particle's raw input position in `wrapped`.
        let index = s[1] as usize;
        let raw = self.wrapped.download(ctx)?.get(index).copied();
        let p = &self.params_value;
        let axis = raw.and_then(|q| {
            (0..D).find(|&d| {
                let t = q[d] - p.origin[d];
                !q[d].is_finite()
                    || (p.periodic[d] == 0 && p.clamp_out == 0 && !(0.0..=p.length[d]).contains(&t))
            })
        });
        let more = format!(
            "{} particle(s) rejected by the GPU cell list (NaN/infinite, or outside a \
             non-periodic face); fix the positions or opt in to OutOfBox::Clamp for closed faces",
            s[0]
        );
        Err(match (raw, axis) {
            (Some(q), Some(d)) => Error::invalid(
                format!("position[{index}].{}", ["x", "y", "z"][d]),
                q[d],
                format!(
                    "must be finite and (non-periodic axis) within [{}, {}]; {more}",
                    p.origin[d],
                    p.origin[d] + p.length[d]
                ),
            ),
            _ => Error::invalid(format!("position[{index}]"), "rejected", more),
        })
    }

    /// The grid.
    pub fn grid(&self) -> &CellGrid<D> {
        &self.grid
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.n
    }

    /// Whether there are no particles.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The parameter values in the uniform buffer.
    pub fn params_value(&self) -> &GpuGridParams {
        &self.params_value
    }

    /// Uniform buffer with the `NbGrid` parameters.
    pub fn params(&self) -> &Uniform<GpuGridParams> {
        &self.params
    }

    /// Wrapped positions by particle id (`array<vec4<f32>>`, length `max(n, 1)`).
    pub fn wrapped(&self) -> &GpuBuffer<[f32; 4]> {
        &self.wrapped
    }

    /// Cell index by particle id (`array<u32>`).
    pub fn cell_of(&self) -> &GpuBuffer<u32> {
        &self.cell_of
    }

    /// `n_cells + 1` offsets: cell `c` holds sorted entries `cell_start[c]..cell_start[c+1]`.
    pub fn cell_start(&self) -> &GpuBuffer<u32> {
        &self.cell_start
    }

    /// Particle ids in cell order (`array<u32>`).
    pub fn sorted_ids(&self) -> &GpuBuffer<u32> {
        &self.sorted_ids
    }

    /// Wrapped positions in cell order (`array<vec4<f32>>`).
    pub fn sorted_pos(&self) -> &GpuBuffer<[f32; 4]> {
        &self.sorted_pos
    }

    /// `[bad particle count, smallest bad index, cells over max_per_cell]` of the last
    /// build.
    pub fn status(&self) -> &GpuBuffer<u32> {
        &self.status
    }

    /// The buffers a kernel binds to walk the cells.
    pub fn buffers(&self) -> GpuCellBuffers<'_> {
        GpuCellBuffers {
            grid: &self.params,
            cell_start: &self.cell_start,
            sorted_ids: &self.sorted_ids,
            sorted_pos: &self.sorted_pos,
            wrapped: &self.wrapped,
        }
    }
}

/// The buffers of a [`GpuCellList`] that a kernel binds to walk the cells (see the table on
/// [`GpuCellList`]).
#[derive(Clone, Copy)]
pub struct GpuCellBuffers<'a> {
    /// The grid parameters (`NbGrid` in [`CELLS_WGSL`]).
    pub grid: &'a Uniform<GpuGridParams>,
    /// First sorted index of every cell, plus the total.
    pub cell_start: &'a GpuBuffer<u32>,
    /// Particle ids in cell order.
    pub sorted_ids: &'a GpuBuffer<u32>,
    /// Wrapped positions in cell order.
    pub sorted_pos: &'a GpuBuffer<[f32; 4]>,
    /// Wrapped positions in particle order.
    pub wrapped: &'a GpuBuffer<[f32; 4]>,
}

/// A [`GpuCellList`] of a dimension chosen at run time (2 or 3), for simulations whose
/// dimension is an input: builds and checks the list and hands its buffers to the kernels
/// without a `match` on the dimension at every use.
pub enum AnyGpuCellList {
    /// A 2D cell list.
    Two(GpuCellList<2>),
    /// A 3D cell list.
    Three(GpuCellList<3>),
}

impl AnyGpuCellList {
    /// Records the build ([`GpuCellList::encode`]).
    pub fn encode(&self, ctx: &GpuContext, pass: &mut wgpu::ComputePass<'_>) -> Result<()> {
        match self {
            Self::Two(c) => c.encode(ctx, pass),
            Self::Three(c) => c.encode(ctx, pass),
        }
    }

    /// Checks the last build ([`GpuCellList::check`]).
    pub fn check(&self, ctx: &GpuContext) -> Result<()> {
        match self {
            Self::Two(c) => c.check(ctx),
            Self::Three(c) => c.check(ctx),
        }
    }

    /// The buffers a kernel binds.
    pub fn buffers(&self) -> GpuCellBuffers<'_> {
        match self {
            Self::Two(c) => c.buffers(),
            Self::Three(c) => c.buffers(),
        }
    }
}

/// A CSR neighbour list computed on the GPU from a [`GpuCellList`]: a count pass, a prefix
/// sum of the counts ([`GpuScan`]), then a fill pass into a buffer that is grown to the exact
/// total whenever it is too small (nothing is ever truncated). Lists use the cell list's
/// cutoff (build the grid with `cutoff + skin` for a Verlet list).
///
/// Entries of particle `i` are `neighbors[offsets[i]..offsets[i + 1]]` (ids; in cell order).
pub struct GpuNeighborList {
    cells_id: u64,
    kind: ListKind,
    n: usize,
    entries: usize,
    offsets: GpuBuffer<u32>,
    neighbors: GpuBuffer<u32>,
    // [low, high] words of the entry total, accumulated by the count pass.
    total: GpuBuffer<u32>,
    count: (Kernel, wgpu::BindGroup),
    fill: (Kernel, wgpu::BindGroup),
    scan: GpuScan,
    plan: ScanPlan,
}

impl GpuNeighborList {
    /// A list over `cells` (the same cell list must be passed to [`build`](Self::build)).
    pub fn new<const D: usize>(
        ctx: &GpuContext,
        cells: &GpuCellList<D>,
        kind: ListKind,
    ) -> Result<Self> {
        let half = if kind == ListKind::Half { 1.0 } else { 0.0 };
        let consts = [("HALF", half)];
        let count_k = kernel(ctx, LIST_WGSL, "nb_list_count", 64, &consts)?;
        let fill_k = kernel(ctx, LIST_WGSL, "nb_list_fill", 64, &consts)?;
        let offsets = GpuBuffer::zeroed(ctx, "neighbor list offsets", cells.len() + 1)?;
        let neighbors = GpuBuffer::zeroed(ctx, "neighbor list entries", 1)?;
        let total = GpuBuffer::zeroed(ctx, "neighbor list total", 2)?;
        let base = [
            cells.params().binding(),
            cells.cell_start().binding(),
            cells.sorted_ids().binding(),
            cells.sorted_pos().binding(),
            offsets.binding(),
            neighbors.binding(),
        ];
        let fill_b = fill_k.bind(ctx, &base)?;
        let mut with_total = base.to_vec();
        with_total.push(total.binding());
        let count_b = count_k.bind(ctx, &with_total)?;
        let scan = GpuScan::new(ctx)?;
        let plan = scan.plan(ctx, &offsets)?;
        Ok(Self {
            cells_id: cells.id,
            kind,
            n: cells.len(),
            entries: 0,
            offsets,
            neighbors,
            total,
            count: (count_k, count_b),
            fill: (fill_k, fill_b),
            scan,
            plan,
        })
    }

    /// Counts, scans, reads the total back (one small download), grows the entry buffer if
    /// needed and fills it. The cell list must have been built. Returns the number of
    /// entries.
    ///
    /// Errors: another cell list than the one of [`new`](Self::new), a total of 2^32 or more
    /// entries (counted in 64 bits on the device, never wrapped), or an entry buffer beyond
    /// the device's storage-binding limit.
    pub fn build<const D: usize>(
        &mut self,
        ctx: &GpuContext,
        cells: &GpuCellList<D>,
    ) -> Result<usize> {
        if cells.id != self.cells_id {
            return Err(Error::invalid(
                "GpuNeighborList::build: cell list",
                "a different GpuCellList",
                "pass the cell list this neighbour list was created with",
            ));
        }
        let n = self.n as u64;
        self.total.upload(ctx, &[0, 0])?;
        run_pass(ctx, "neighbor list count", |pass| {
            self.count
                .0
                .dispatch_items(ctx, pass, &self.count.1, n.max(1))
        })?;
        run_pass(ctx, "neighbor list scan", |pass| {
            self.scan.encode(ctx, pass, &self.plan)
        })?;
        let words = self.total.download(ctx)?;
        if words[1] != 0 {
            return Err(Error::invalid(
                "GPU neighbour list entries",
                format!("{} or more", u64::from(words[1]) << 32),
                "exceed the u32 offsets of the GPU list (2^32 - 1 entries); use a smaller \
                 cutoff or skin, fewer particles, or the CPU VerletList",
            ));
        }
        let total = words[0] as usize;
        if total > self.neighbors.len() {
            // Headroom for later builds, within the device's binding limit (the exact total
            // must fit, else GpuBuffer::zeroed reports BufferTooLarge).
            let limit = (ctx.max_storage_bytes() / 4) as usize;
            let cap = (total + total / 4 + 1).min(limit).max(total);
            self.neighbors = GpuBuffer::zeroed(ctx, "neighbor list entries", cap)?;
            self.fill.1 = self.fill.0.bind(
                ctx,
                &[
                    cells.params().binding(),
                    cells.cell_start().binding(),
                    cells.sorted_ids().binding(),
                    cells.sorted_pos().binding(),
                    self.offsets.binding(),
                    self.neighbors.binding(),
                ],
            )?;
        }
        run_pass(ctx, "neighbor list fill", |pass| {
            self.fill.0.dispatch_items(ctx, pass, &self.fill.1, n)
        })?;
        self.entries = total;
        Ok(total)
    }

    /// Half or full.
    pub fn kind(&self) -> ListKind {
        self.kind
    }

    /// Entries of the last build.
    pub fn entries(&self) -> usize {
        self.entries
    }

    /// `n + 1` CSR offsets (`array<u32>`).
    pub fn offsets(&self) -> &GpuBuffer<u32> {
        &self.offsets
    }

    /// CSR entries (`array<u32>`; capacity may exceed [`entries`](Self::entries)).
    pub fn neighbors(&self) -> &GpuBuffer<u32> {
        &self.neighbors
    }

    /// Downloads the list (entries of each particle sorted ascending).
    pub fn download(&self, ctx: &GpuContext) -> Result<NeighborLists> {
        let mut encoder = ctx.encoder("neighbor list download");
        let off = self.offsets.encode_download(ctx, &mut encoder)?;
        let nb = self.neighbors.encode_download(ctx, &mut encoder)?;
        ctx.submit(encoder);
        let offsets: Vec<usize> = off.read(ctx)?.into_iter().map(|o| o as usize).collect();
        let mut neighbors = nb.read(ctx)?;
        neighbors.truncate(self.entries);
        for w in offsets.windows(2) {
            neighbors[w[0]..w[1]].sort_unstable();
        }
        Ok(NeighborLists { offsets, neighbors })
    }
}

/// The [`NeighborSearch`] trait on the GPU: host positions are validated, uploaded as `f32`,
/// sorted into cells and turned into a half list on the device, which is downloaded for
/// enumeration. Pair membership is decided in `f32` on the device; the separations handed
/// to the callback are recomputed in `f64` from the host positions.
pub struct GpuNeighborSearch<const D: usize> {
    ctx: GpuContext,
    grid: CellGrid<D>,
    wrapped: Vec<[f64; D]>,
    device: Option<(GpuBuffer<[f32; 4]>, GpuCellList<D>, GpuNeighborList)>,
    list: NeighborLists,
}

impl<const D: usize> GpuNeighborSearch<D> {
    /// A GPU search over `grid`.
    pub fn new(ctx: &GpuContext, grid: &CellGrid<D>) -> Result<Self> {
        GpuGridParams::new(grid, 0)?;
        Ok(Self {
            ctx: ctx.clone(),
            grid: grid.clone(),
            wrapped: Vec::new(),
            device: None,
            list: NeighborLists::default(),
        })
    }

    /// The device-side cell list of the last build (`None` before the first).
    pub fn cells(&self) -> Option<&GpuCellList<D>> {
        self.device.as_ref().map(|d| &d.1)
    }

    /// The downloaded half list of the last build.
    pub fn half_list(&self) -> &NeighborLists {
        &self.list
    }
}

impl<const D: usize> NeighborSearch<D> for GpuNeighborSearch<D> {
    fn name(&self) -> String {
        format!("GPU sorted cells ({})", self.ctx.adapter_info().name)
    }

    fn build(&mut self, positions: &[[f64; D]]) -> Result<()> {
        self.wrapped = self.grid.wrap_all(positions)?;
        let ctx = &self.ctx;
        let n = positions.len();
        let host = positions_to_f32(positions);
        let reuse = matches!(&self.device, Some((_, cells, _)) if cells.len() == n);
        if !reuse {
            let buf = GpuBuffer::zeroed(ctx, "neighbor positions", n.max(1))?;
            let cells = GpuCellList::with_count(ctx, &self.grid, &buf, n)?;
            let list = GpuNeighborList::new(ctx, &cells, ListKind::Half)?;
            self.device = Some((buf, cells, list));
        }
        let (buf, cells, list) = self
            .device
            .as_mut()
            .ok_or_else(|| Error::Gpu("no device state".into()))?;
        buf.upload(ctx, &host)?;
        cells.build(ctx)?;
        list.build(ctx, cells)?;
        self.list = list.download(ctx)?;
        Ok(())
    }

    fn particle_count(&self) -> usize {
        self.wrapped.len()
    }

    fn for_each_pair<F: FnMut(usize, usize, [f64; D], f64)>(&mut self, mut f: F) -> Result<()> {
        for i in 0..self.list.len() {
            // `i < len()`, so `of` always has the list.
            for &j in self.list.of(i).unwrap_or_default() {
                let (sep, r2) = self
                    .grid
                    .separation(self.wrapped[i], self.wrapped[j as usize]);
                f(i, j as usize, sep, r2);
            }
        }
        Ok(())
    }
}
