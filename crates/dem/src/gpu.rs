//! GPU backend (wgpu, `f32`): the whole velocity-Verlet step on the device.
//!
//! Per step, recorded into one command buffer (64 steps per submission) without host
//! round trips: `dem_drift` (half kick,
//! drift, periodic wrap, predicted velocity), `neighbor`'s [`GpuCellList`] build,
//! `dem_force` (one invocation per particle gathering contact forces over the full shell
//! of neighbour cells, walls, gravity, second half kick) and `dem_tick` (device step
//! counter for the wall motion). [`Engine::state`] downloads the state.
//!
//! Rotation: the drift kernel opens the angular velocity's step as the velocity's (half
//! kick, predicted angular velocity), the force kernel sums each particle's torques and
//! closes it. Contact history (a law with [`ContactLaw::HISTORY`] values per contact):
//! each particle keeps [`history_slots`] slots of `(partner, values)` for its own contacts,
//! in two halves of one buffer; a force evaluation looks the partner up in the half the
//! last one wrote and writes the other, so the history is keyed by particle index and
//! survives every rebuild of the device's cell list. A pair's two copies are mirror images
//! (each particle integrates its own; the arithmetic is symmetric under exchanging `i` and
//! `j`). A particle with more contacts than slots is a blow-up naming it.
//!
//! Blow-up check: at every check step (`Config::check_every`, and at the end of a call)
//! `dem_check` (shaders/check.wgsl) tests every particle for non-finite positions and
//! velocities, a centre more than its radius outside the box along a closed axis, and a
//! contact deeper than `Config::max_overlap` (the force kernel leaves the deepest overlap
//! ratio of each particle in `acc.w`); then a [`GpuGuard`] checks the state buffers and the
//! check's alarm for non-finite values and snapshots them while all is well. One small
//! download per `step(n)` call reads the outcome; after a failure the evidence is read and
//! the snapshots are copied back.

use bytemuck::{Pod, Zeroable};

use simkit_neighbor::{
    AnyGpuCellList, CELLS_WGSL, CellGrid, GPU_LOOP_RESERVE, GpuCellBuffers, GpuCellList, MAX_CELLS,
    OutOfBox,
};

use simkit_backend::gpu::{
    DISPATCH_WGSL, GUARD_WGSL, GpuGuard, GuardedRun, Uniform, Watch, record_pass,
};
use simkit_backend::guard::blow_up;
use simkit_backend::{Error, GpuBuffer, GpuContext, Kernel, KernelDesc, Precision, Result};

use crate::engine::Engine;
use crate::law::LAW_PRELUDE_WGSL;
use crate::prepared::Prepared;
use crate::{ContactLaw, State};
use simkit_backend::particles::Dynamics;

const PARAMS_WGSL: &str = simkit_backend::wgsl!("params.wgsl");
const DRIFT_WGSL: &str = simkit_backend::wgsl!("drift.wgsl");
const FORCE_WGSL: &str = simkit_backend::wgsl!("force.wgsl");
const TICK_WGSL: &str = simkit_backend::wgsl!("tick.wgsl");
const CHECK_WGSL: &str = simkit_backend::wgsl!("check.wgsl");
/// The reduced mass (twin of [`crate::reduced_mass`]).
const MASS_WGSL: &str = simkit_backend::wgsl!("mass.wgsl");
/// The wall geometry (twin of [`crate::plane_overlap`], [`crate::cylinder_overlap`],
/// [`crate::wall_motion`]).
const WALLS_WGSL: &str = simkit_backend::wgsl!("walls.wgsl");

/// History values a contact keeps on the device (`DemHistory` in `shaders/law.wgsl`).
pub(crate) const GPU_HISTORY: usize = 7;
/// Words per history slot: the partner and [`GPU_HISTORY`] values.
const SLOT_WORDS: usize = 8;

/// History slots per particle on the GPU: the most contacts a particle keeps a history for
/// (12 discs in 2D, 20 spheres in 3D: the kissing numbers are 6 and 12; the rest leaves
/// room for neighbours up to about half the particle's size).
pub fn history_slots(axes: usize) -> usize {
    if axes == 2 { 12 } else { 20 }
}

/// Steps recorded into one command buffer.
const STEPS_PER_SUBMIT: u32 = 64;
/// Storage buffers the force kernel binds.
const STORAGE_BUFFERS_NEEDED: u32 = 13;

/// Mirror of `DemParams` in `shaders/params.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct GpuParams {
    gravity: [f32; 4],
    dt: f32,
    half_dt: f32,
    omega_dt: f32,
    amplitude: f32,
    omega: f32,
    n: u32,
    n_walls: u32,
    n_species: u32,
    vertical: u32,
    dim: u32,
    _pad0: u32,
    _pad1: u32,
}

/// Mirror of `DemCheck` in `shaders/check.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct GpuCheck {
    lo: [f32; 4],
    hi: [f32; 4],
    closed: [u32; 4],
    max_overlap: f32,
    epoch: u32,
    begin: u32,
    pad: u32,
}

/// Mirror of `DemWall` in `shaders/params.wgsl`: one wall's geometry.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct GpuWall {
    /// Unit normal and offset of a plane wall, relative to the grid origin.
    plane: [f32; 4],
    /// Axis `(x, y)` relative to the grid origin, radius, kind (1 = cylinder, 0 = plane).
    cylinder: [f32; 4],
    /// `(vibrates, spin, 0, 0)`: 1 for a vibrating wall (else 0), the angular velocity of a
    /// cylinder wall.
    motion: [f32; 4],
}

/// The device cell list of the scene's dimension, cells at least a contact distance wide.
fn cell_list<L: ContactLaw>(
    ctx: &GpuContext,
    p: &Prepared<L>,
    pos: &GpuBuffer<[f32; 4]>,
) -> Result<AnyGpuCellList> {
    fn grid<const D: usize, L: ContactLaw>(p: &Prepared<L>) -> Result<CellGrid<D>> {
        let lo: [f64; D] = std::array::from_fn(|d| p.lo[d]);
        let len: [f64; D] = std::array::from_fn(|d| p.len[d]);
        let per: [bool; D] = std::array::from_fn(|d| p.periodic[d]);
        // Cells at least a contact distance wide; a sparse box gets wider cells (at most
        // about 8 n + 4096 of them), which only costs distance tests.
        let limit = (8 * p.n + 4096).min(MAX_CELLS) as f64;
        let mut width = p.cutoff;
        while (0..D)
            .map(|d| (len[d] / width).floor().max(1.0))
            .product::<f64>()
            > limit
        {
            width *= 1.25;
        }
        Ok(CellGrid::new(lo, len, per, width)?.with_out_of_box(OutOfBox::Clamp))
    }
    Ok(if p.axes == 2 {
        AnyGpuCellList::Two(GpuCellList::new(ctx, &grid::<2, L>(p)?, pos)?)
    } else {
        AnyGpuCellList::Three(GpuCellList::new(ctx, &grid::<3, L>(p)?, pos)?)
    })
}

pub(crate) struct GpuEngine<L: ContactLaw> {
    ctx: GpuContext,
    prep: Prepared<L>,
    pos: GpuBuffer<[f32; 4]>,
    vel: GpuBuffer<[f32; 4]>,
    cells: AnyGpuCellList,
    drift: (Kernel, wgpu::BindGroup),
    force: (Kernel, wgpu::BindGroup),
    tick: (Kernel, wgpu::BindGroup),
    check: (Kernel, wgpu::BindGroup),
    guard: GpuGuard,
    check_params: Uniform<GpuCheck>,
    check_host: GpuCheck,
    acc: GpuBuffer<[f32; 4]>,
    /// Per particle `(w, 1 / I)`, `(angular acceleration, 0)`, `(predicted w, 0)` (one
    /// unused record without rotation).
    spin: GpuBuffer<[f32; 4]>,
    /// History slots (one unused word without history).
    hist: GpuBuffer<u32>,
    /// History slots per particle (0: none kept).
    slots: usize,
    evidence: GpuBuffer<[u32; 4]>,
    first: GpuBuffer<u32>,
    steps: u64,
    _bound: BoundOnly<L>,
}

/// Buffers only the kernels touch (held so they live as long as the bind groups).
struct BoundOnly<L: ContactLaw> {
    _alarm: GpuBuffer<u32>,
    _vpred: GpuBuffer<[f32; 4]>,
    _species: GpuBuffer<u32>,
    _coeff: GpuBuffer<L::Gpu>,
    _walls: GpuBuffer<GpuWall>,
    _clock: GpuBuffer<u32>,
    _params: Uniform<GpuParams>,
}

fn kernel(
    ctx: &GpuContext,
    src: &[&str],
    entry: &str,
    wg: u32,
    consts: &[(&str, f64)],
) -> Result<Kernel> {
    let mut sources = vec![DISPATCH_WGSL, CELLS_WGSL, PARAMS_WGSL];
    sources.extend_from_slice(src);
    Kernel::new(
        ctx,
        &KernelDesc {
            label: entry,
            sources: &sources,
            entry,
            workgroup_size: wg,
            constants: consts,
        },
    )
}

impl<L: ContactLaw> GpuEngine<L> {
    /// The engine for `prep`, at its initial state or, with `saved`, at a checkpointed
    /// one.
    pub fn new(ctx: &GpuContext, prep: Prepared<L>, saved: Option<&Dynamics>) -> Result<Self> {
        let have = ctx.limits().max_storage_buffers_per_shader_stage;
        if have < STORAGE_BUFFERS_NEEDED {
            return Err(Error::Unsupported(format!(
                "the dem GPU force kernel binds {STORAGE_BUFFERS_NEEDED} storage buffers, this \
                 device allows {have} per stage; use the CPU backend"
            )));
        }
        let n = prep.n;
        if n >= u32::MAX as usize / 2 {
            return Err(Error::invalid(
                "particle count",
                n,
                "too large for the GPU backend",
            ));
        }
        // The force kernel's wall loop runs beside its shell walk; the cell list leaves
        // GPU_LOOP_RESERVE iterations for such loops on adapters that end shader loops early.
        let max_walls = GPU_LOOP_RESERVE as usize / 2;
        if ctx.shader_loop_limit().is_some() && prep.walls.len() > max_walls {
            return Err(Error::Unsupported(format!(
                "{} walls on adapter '{}', which ends shader loops after {} iterations per \
                 invocation: at most {max_walls} walls fit beside the neighbour walk; use the \
                 CPU backend",
                prep.walls.len(),
                ctx.adapter_info().name,
                ctx.shader_loop_limit().unwrap_or(0)
            )));
        }
        if L::HISTORY > GPU_HISTORY {
            return Err(Error::Unsupported(format!(
                "contact law '{}' keeps {} values per contact; the GPU backend keeps at most \
                 {GPU_HISTORY}; use the CPU backend",
                L::NAME,
                L::HISTORY
            )));
        }
        let slots = if L::HISTORY > 0 && prep.friction {
            history_slots(prep.axes)
        } else {
            0
        };
        let origin = prep.lo;
        let pos_h: Vec<[f32; 4]> = (0..n)
            .map(|i| {
                let x = prep.positions[i];
                [x[0] as f32, x[1] as f32, x[2] as f32, prep.radius[i] as f32]
            })
            .collect();
        let vel_h: Vec<[f32; 4]> = (0..n)
            .map(|i| {
                let v = prep.velocities[i];
                [v[0] as f32, v[1] as f32, v[2] as f32, prep.mass[i] as f32]
            })
            .collect();
        let mut spin_h: Vec<[f32; 4]> = if prep.rotation {
            (0..n)
                .flat_map(|i| {
                    let w = prep.omega[i].map(|x| x as f32);
                    let inv = (1.0 / prep.inertia[i]) as f32;
                    [[w[0], w[1], w[2], inv], [0.0; 4], [w[0], w[1], w[2], 0.0]]
                })
                .collect()
        } else {
            vec![[0.0; 4]]
        };
        let mut hist_h = vec![0u32; (2 * n * slots * SLOT_WORDS).max(1)];
        let (pos_h, vel_h, acc_h, steps) = match saved {
            None => (pos_h, vel_h, vec![[0.0f32; 4]; n], 0),
            Some(s) => {
                let (p, v, a) = load(s, n)?;
                prep.check_saved_extras(s)?;
                if prep.rotation {
                    load_spin(s, &mut spin_h);
                }
                if slots > 0 {
                    // The next force evaluation reads half (steps + 1) & 1.
                    let half = (s.steps as usize + 1) & 1;
                    let len = n * slots * SLOT_WORDS;
                    load_history::<L>(s, slots, &mut hist_h[half * len..(half + 1) * len])?;
                }
                // Radii and masses from the scene (the same numbers the run had).
                let p = p.iter().zip(&pos_h).map(|(x, h)| [x[0], x[1], x[2], h[3]]);
                let v = v.iter().zip(&vel_h).map(|(x, h)| [x[0], x[1], x[2], h[3]]);
                (p.collect(), v.collect(), a, s.steps)
            }
        };
        let spin = GpuBuffer::from_slice(ctx, "dem spin", &spin_h)?;
        let hist = GpuBuffer::from_slice(ctx, "dem contact history", &hist_h)?;
        drop((spin_h, hist_h));
        let pos = GpuBuffer::from_slice(ctx, "dem pos", &pos_h)?;
        let vel = GpuBuffer::from_slice(ctx, "dem vel", &vel_h)?;
        let acc = GpuBuffer::from_slice(ctx, "dem acc", &acc_h)?;
        let vpred = GpuBuffer::from_slice(ctx, "dem vpred", &vel_h)?;
        let species = GpuBuffer::from_slice(ctx, "dem species", &prep.species)?;
        // The kernel indexes the table by the WGSL struct's size: refuse a law whose mirror
        // differs.
        simkit_backend::testing::check_struct_size::<L::Gpu>(
            &[LAW_PRELUDE_WGSL, L::WGSL].concat(),
            "DemCoeff",
            &format!("contact law '{}'", L::NAME),
        )?;
        // The law's coefficients of the species pairs, then of the walls.
        let coeff: Vec<L::Gpu> = prep
            .pairs
            .iter()
            .chain(prep.walls.iter().map(|w| &w.material))
            .map(|m| L::gpu(&m.coefficients::<f32>()))
            .collect();
        let coeff = GpuBuffer::from_slice(ctx, "dem coefficients", &coeff)?;
        let mut walls = Vec::with_capacity(prep.walls.len().max(1));
        for w in &prep.walls {
            // Walls in wrapped coordinates (relative to the grid origin), as the kernel sees them.
            let n_dot_o: f64 = (0..3).map(|d| w.normal[d] * origin[d]).sum();
            let record = GpuWall {
                plane: [
                    w.normal[0] as f32,
                    w.normal[1] as f32,
                    w.normal[2] as f32,
                    (w.offset - n_dot_o) as f32,
                ],
                cylinder: [
                    (w.center[0] - origin[0]) as f32,
                    (w.center[1] - origin[1]) as f32,
                    w.radius as f32,
                    if w.cylinder { 1.0 } else { 0.0 },
                ],
                motion: [if w.vibrating { 1.0 } else { 0.0 }, w.spin as f32, 0.0, 0.0],
            };
            walls.push(record);
        }
        if walls.is_empty() {
            // Buffers hold at least one element; the kernel reads none (n_walls = 0).
            walls.push(GpuWall::zeroed());
        }
        let walls = GpuBuffer::from_slice(ctx, "dem walls", &walls)?;
        // The device step counter keys the wall phase (wrapping at 2^32 steps, as on the
        // device).
        // clock[1]: a particle whose history slots overflowed (none).
        let clock = GpuBuffer::from_slice(ctx, "dem clock", &[steps as u32, 0])?;
        let (amp, omega) = prep
            .vibration
            .map_or((0.0, 0.0), |v| (v.amplitude, v.omega));
        let mut gravity = [0.0f32; 4];
        gravity[prep.vertical] = -prep.gravity as f32;
        let pv = GpuParams {
            gravity,
            dt: prep.dt as f32,
            half_dt: (0.5 * prep.dt) as f32,
            omega_dt: (omega * prep.dt) as f32,
            amplitude: amp as f32,
            omega: omega as f32,
            n: n as u32,
            n_walls: prep.walls.len() as u32,
            n_species: prep.n_species as u32,
            vertical: prep.vertical as u32,
            dim: prep.axes as u32,
            _pad0: 0,
            _pad1: 0,
        };
        let params = Uniform::new(ctx, "dem params", &pv)?;
        let cells = cell_list(ctx, &prep, &pos)?;
        let GpuCellBuffers {
            grid,
            cell_start,
            sorted_ids,
            sorted_pos,
            wrapped,
        } = cells.buffers();
        let rotation = if prep.rotation { 1.0 } else { 0.0 };
        let k = kernel(
            ctx,
            &[DRIFT_WGSL],
            "dem_drift",
            64,
            &[("ROTATION", rotation)],
        )?;
        let b = k.bind(
            ctx,
            &[
                grid.binding(),
                params.binding(),
                pos.binding(),
                vel.binding(),
                acc.binding(),
                vpred.binding(),
                spin.binding(),
            ],
        )?;
        let drift = (k, b);
        let friction = if prep.friction { 1.0 } else { 0.0 };
        let force_resources = [
            grid.binding(),
            params.binding(),
            cell_start.binding(),
            sorted_ids.binding(),
            sorted_pos.binding(),
            wrapped.binding(),
            vpred.binding(),
            species.binding(),
            coeff.binding(),
            walls.binding(),
            acc.binding(),
            vel.binding(),
            clock.binding(),
            spin.binding(),
            hist.binding(),
        ];
        let sources = [MASS_WGSL, LAW_PRELUDE_WGSL, L::WGSL, WALLS_WGSL, FORCE_WGSL];
        let variant = |init: f64| {
            [
                ("FRICTION", friction),
                ("INIT", init),
                ("ROTATION", rotation),
                ("SLOTS", slots as f64),
            ]
        };
        let k = kernel(ctx, &sources, "dem_force", 64, &variant(0.0))?;
        let b = k.bind(ctx, &force_resources)?;
        let force = (k, b);
        let init = kernel(ctx, &sources, "dem_force", 64, &variant(1.0))?;
        let init_bind = init.bind(ctx, &force_resources)?;
        let k = kernel(ctx, &[TICK_WGSL], "dem_tick", 1, &[])?;
        let b = k.bind(ctx, &[clock.binding()])?;
        let tick = (k, b);
        let mut closed = [0u32; 4];
        let (mut lo, mut hi) = ([0.0f32; 4], [0.0f32; 4]);
        for d in 0..prep.axes {
            closed[d] = u32::from(!prep.periodic[d]);
            lo[d] = prep.lo[d] as f32;
            hi[d] = (prep.lo[d] + prep.len[d]) as f32;
        }
        closed[3] = u32::from(prep.max_overlap.is_finite());
        let check_host = GpuCheck {
            lo,
            hi,
            closed,
            max_overlap: if prep.max_overlap.is_finite() {
                prep.max_overlap as f32
            } else {
                0.0
            },
            epoch: 0,
            begin: 0,
            pad: 0,
        };
        let check_params = Uniform::new(ctx, "dem check params", &check_host)?;
        let evidence = GpuBuffer::<[u32; 4]>::zeroed(ctx, "dem check evidence", n)?;
        let first = GpuBuffer::<u32>::zeroed(ctx, "dem check first", 1)?;
        let alarm = GpuBuffer::<u32>::zeroed(ctx, "dem check alarm", 1)?;
        let k = kernel(ctx, &[GUARD_WGSL, CHECK_WGSL], "dem_check", 64, &[])?;
        let b = k.bind(
            ctx,
            &[
                params.binding(),
                check_params.binding(),
                pos.binding(),
                vel.binding(),
                acc.binding(),
                clock.binding(),
                evidence.binding(),
                first.binding(),
                alarm.binding(),
            ],
        )?;
        let check = (k, b);
        // Every buffer a step reads before writing it is state; vpred and the cell list
        // are rewritten from them every step.
        let mut watched = vec![
            Watch::checked(&pos, Precision::F32),
            Watch::checked(&vel, Precision::F32),
            Watch::checked(&acc, Precision::F32),
            Watch::checked(&alarm, Precision::F32),
            Watch::copied(&clock),
        ];
        if prep.rotation {
            watched.push(Watch::checked(&spin, Precision::F32));
        }
        if slots > 0 {
            watched.push(Watch::copied(&hist));
        }
        let guard = GpuGuard::new(ctx, &watched)?;
        if saved.is_none() {
            // Initial accelerations a(0) with the initial velocities.
            let mut encoder = ctx.encoder("dem init");
            record_pass(&mut encoder, "dem init forces", |pass| {
                cells.encode(ctx, pass)?;
                init.dispatch_items(ctx, pass, &init_bind, n as u64)
            })?;
            ctx.submit(encoder);
            cells.check(ctx)?;
        }
        Ok(Self {
            ctx: ctx.clone(),
            prep,
            pos,
            vel,
            cells,
            drift,
            force,
            tick,
            check,
            guard,
            check_params,
            check_host,
            acc,
            spin,
            hist,
            slots,
            evidence,
            first,
            steps,
            _bound: BoundOnly {
                _alarm: alarm,
                _vpred: vpred,
                _species: species,
                _coeff: coeff,
                _walls: walls,
                _clock: clock,
                _params: params,
            },
        })
    }
}

/// Positions, velocities and accelerations of a GPU checkpoint (4 values per particle).
type Loaded = (Vec<[f32; 4]>, Vec<[f32; 4]>, Vec<[f32; 4]>);

/// The device arrays of a checkpoint, checked against the particle count.
fn load(s: &Dynamics, n: usize) -> Result<Loaded> {
    s.check(n, 4, &["pos", "vel", "acc"])?;
    if let Some(k) = (0..n).find(|&k| s.particle(k) != k) {
        return Err(Error::checkpoint(format!(
            "slot {k} holds particle {}, not {k}: a GPU state is in scene order; resume a CPU \
             checkpoint on the CPU",
            s.particle(k)
        )));
    }
    let arrays = |v: &[f64]| -> Vec<[f32; 4]> {
        v.chunks_exact(4)
            .map(|c| std::array::from_fn(|d| c[d] as f32))
            .collect()
    };
    Ok((arrays(&s.pos), arrays(&s.vel), arrays(&s.acc)))
}

/// The rotation columns of a checked checkpoint (9 values per particle: `w`, the angular
/// acceleration, the predicted `w`) into the device layout, keeping each `1 / I`.
fn load_spin(s: &Dynamics, spin: &mut [[f32; 4]]) {
    for (v, rec) in s.spin.chunks_exact(9).zip(spin.chunks_exact_mut(3)) {
        for (c, r) in rec.iter_mut().enumerate() {
            for d in 0..3 {
                r[d] = v[3 * c + d] as f32;
            }
        }
    }
}

/// The contact history of a checked checkpoint into one half of the device's slots
/// (`slots` per particle). A contact stored in one orientation only gives its partner
/// particle the mirror image ([`ContactLaw::swap_history`]).
///
/// Errors: a particle with more contacts than `slots`.
fn load_history<L: ContactLaw>(s: &Dynamics, slots: usize, out: &mut [u32]) -> Result<()> {
    let h = L::HISTORY;
    let n = out.len() / (slots * SLOT_WORDS);
    let stored: std::collections::HashSet<[u32; 2]> = s.contacts.iter().copied().collect();
    let mut used = vec![0usize; n];
    let mut put = |a: u32, b: u32, values: &[f32]| -> Result<()> {
        let a = a as usize;
        if used[a] == slots {
            return Err(Error::checkpoint(format!(
                "particle {a} has more than {slots} contacts with a history, the most the GPU \
                 backend keeps; resume this checkpoint on the CPU"
            )));
        }
        let at = (a * slots + used[a]) * SLOT_WORDS;
        out[at] = b + 1;
        for (w, v) in out[at + 1..at + 1 + h].iter_mut().zip(values) {
            *w = v.to_bits();
        }
        used[a] += 1;
        Ok(())
    };
    for (c, v) in s.contacts.iter().zip(s.history.chunks_exact(h.max(1))) {
        let mut values: Vec<f32> = v.iter().map(|&x| x as f32).collect();
        put(c[0], c[1], &values)?;
        if (c[1] as usize) < n && !stored.contains(&[c[1], c[0]]) {
            L::swap_history(&mut values);
            put(c[1], c[0], &values)?;
        }
    }
    Ok(())
}

impl<L: ContactLaw> GpuEngine<L> {
    /// The half of the history slots that the last force evaluation wrote.
    fn current_history(&self) -> Result<Vec<u32>> {
        let len = self.prep.n * self.slots * SLOT_WORDS;
        let half = (self.steps as usize + 1) & 1;
        let all = self.hist.download(&self.ctx)?;
        Ok(all[half * len..(half + 1) * len].to_vec())
    }

    /// Records one step into `encoder`.
    fn record_step(&self, encoder: &mut wgpu::CommandEncoder) -> Result<()> {
        let ctx = &self.ctx;
        let n = self.prep.n as u64;
        record_pass(encoder, "dem step", |pass| {
            self.drift.0.dispatch_items(ctx, pass, &self.drift.1, n)?;
            self.cells.encode(ctx, pass)?;
            self.force.0.dispatch_items(ctx, pass, &self.force.1, n)?;
            self.tick.0.dispatch_workgroups(ctx, pass, &self.tick.1, 1)
        })
    }

    /// What the check that failed found: `(what, cause)` from the evidence of the first
    /// failing check, or from the guard's report when the check kernel saw nothing (a
    /// non-finite acceleration alone).
    fn explain(&self, label: &str, index: u32) -> Result<(String, String)> {
        const AXES: [&str; 3] = ["x", "y", "z"];
        let first = self.first.download(&self.ctx)?[0];
        let epoch = self.check_host.epoch;
        let found = if first == u32::MAX {
            None
        } else {
            let ev = self.evidence.download(&self.ctx)?;
            ev.iter()
                .position(|e| e[3] == epoch && e[2] == first)
                .map(|i| (i, ev[i]))
        };
        let p = &self.prep;
        Ok(match found {
            Some((i, e)) => {
                let (kind, axis) = (e[0] / 4, AXES[(e[0] % 4).min(2) as usize]);
                let value = f32::from_bits(e[1]);
                match kind {
                    1 => (
                        format!("particle {i}: position {axis} = {value}"),
                        p.non_finite_cause(),
                    ),
                    2 => (
                        format!("particle {i}: velocity {axis} = {value}"),
                        p.non_finite_cause(),
                    ),
                    3 => {
                        let d = (e[0] % 4).min(2) as usize;
                        let (lo, hi) = (p.lo[d], p.lo[d] + p.len[d]);
                        (
                            format!(
                                "particle {i}: position {axis} = {value}, outside the box \
                                 [{lo}, {hi}] by more than its radius {}",
                                p.radius[i]
                            ),
                            p.escape_cause(),
                        )
                    }
                    5 => (
                        format!(
                            "particle {i} has more than {} contacts with a history, the most \
                             the GPU backend keeps per particle",
                            self.slots
                        ),
                        "grains far smaller than their neighbours, or grains pressed \
                         together much deeper than usual; run the scene on the CPU backend, \
                         which keeps any number"
                            .to_string(),
                    ),
                    _ => (
                        format!(
                            "particle {i} has a contact deeper than {value} of the smaller \
                             radius (limit Config::max_overlap = {})",
                            p.max_overlap
                        ),
                        p.overlap_cause(),
                    ),
                }
            }
            None => (
                format!(
                    "{label}: value {index} (particle {}) is not finite",
                    index / 4
                ),
                p.non_finite_cause(),
            ),
        })
    }
}

impl<L: ContactLaw> Engine<L> for GpuEngine<L> {
    fn forces(&mut self) -> Result<crate::Forces> {
        Err(Error::Unsupported(
            "Dem::forces reads the CPU engine's forces; run the scene on Backend::Cpu".into(),
        ))
    }

    fn step(&mut self, steps: u32) -> Result<()> {
        let ctx = &self.ctx;
        let n = self.prep.n as u64;
        self.check_host.epoch = self.check_host.epoch.wrapping_add(1).max(1);
        self.check_host.begin = self.steps as u32;
        self.check_params.set(ctx, &self.check_host);
        self.first.upload(ctx, &[u32::MAX])?;
        let (check, step) = (&self.check, self.steps);
        let run = self.guard.run(
            ctx,
            step,
            steps,
            self.prep.check_every,
            STEPS_PER_SUBMIT,
            |encoder, _| self.record_step(encoder),
            |encoder| {
                record_pass(encoder, "dem check", |pass| {
                    check.0.dispatch_items(ctx, pass, &check.1, n)
                })
            },
        )?;
        match run {
            GuardedRun::Passed { steps } => {
                self.steps = steps;
                Ok(())
            }
            GuardedRun::Failed {
                good,
                bad,
                label,
                index,
            } => {
                let (what, cause) = self.explain(&label, index)?;
                self.guard.rollback(ctx)?;
                // The cell list is derived state: rebuilt from the restored positions, so
                // that it (and its count of rejected particles) is that of the good state.
                let mut encoder = ctx.encoder("dem rollback cells");
                record_pass(&mut encoder, "dem rollback cells", |pass| {
                    self.cells.encode(ctx, pass)
                })?;
                ctx.submit(encoder);
                self.steps = good;
                Err(blow_up(bad, good, what, cause))
            }
        }
    }

    fn state(&mut self) -> Result<State> {
        self.cells.check(&self.ctx)?;
        let pos = self.pos.download(&self.ctx)?;
        let vel = self.vel.download(&self.ctx)?;
        let axes = self.prep.axes;
        let c = |a: &[f32; 4]| -> [f64; 3] {
            let mut o = [0.0; 3];
            for d in 0..axes {
                o[d] = f64::from(a[d]);
            }
            o
        };
        let angular_velocities = if self.prep.rotation {
            let spin = self.spin.download(&self.ctx)?;
            spin.iter()
                .step_by(3)
                .map(|w| [0, 1, 2].map(|d| f64::from(w[d])))
                .collect()
        } else {
            Vec::new()
        };
        Ok(State {
            time: self.steps as f64 * self.prep.dt,
            positions: pos.iter().map(c).collect(),
            velocities: vel.iter().map(c).collect(),
            angular_velocities,
            species: self.prep.species.clone(),
        })
    }

    fn prepared(&self) -> &Prepared<L> {
        &self.prep
    }

    fn name(&self) -> String {
        format!("gpu f32 ({})", self.ctx.adapter_info().name)
    }

    fn steps_done(&self) -> u64 {
        self.steps
    }

    fn model(&self) -> String {
        crate::engine::model_name::<L>(true, Precision::F32, self.prep.axes)
    }

    fn save(&mut self) -> Result<Dynamics> {
        self.cells.check(&self.ctx)?;
        let flat = |v: Vec<[f32; 4]>| -> Vec<f64> {
            v.as_flattened().iter().map(|&x| f64::from(x)).collect()
        };
        let spin = if self.prep.rotation {
            let s = self.spin.download(&self.ctx)?;
            s.chunks_exact(3)
                .flat_map(|r| r.iter().flat_map(|v| v[..3].iter().map(|&x| f64::from(x))))
                .collect()
        } else {
            Vec::new()
        };
        // Both copies of every contact (each particle's own), as the device has them, so
        // a resumed run continues with the same bits; contacts with an all-zero history
        // are left out (they restart from zero anyway).
        let (mut contacts, mut history) = (Vec::new(), Vec::new());
        if self.slots > 0 {
            let h = L::HISTORY;
            let slots = self.current_history()?;
            for (i, particle) in slots.chunks_exact(self.slots * SLOT_WORDS).enumerate() {
                for slot in particle.chunks_exact(SLOT_WORDS) {
                    if slot[0] == 0 {
                        break;
                    }
                    let values = &slot[1..1 + h];
                    if values.iter().any(|&w| f32::from_bits(w) != 0.0) {
                        contacts.push([i as u32, slot[0] - 1]);
                        history.extend(values.iter().map(|&w| f64::from(f32::from_bits(w))));
                    }
                }
            }
        }
        Ok(Dynamics {
            steps: self.steps,
            time: self.steps as f64 * self.prep.dt,
            started: true,
            width: 4,
            pos: flat(self.pos.download(&self.ctx)?),
            vel: flat(self.vel.download(&self.ctx)?),
            acc: flat(self.acc.download(&self.ctx)?),
            spin,
            contacts,
            history,
            ..Dynamics::default()
        })
    }
}

#[cfg(test)]
mod tests {
    use std::mem::offset_of;

    use simkit_backend::testing::assert_mirrors;

    use super::*;

    #[test]
    fn gpu_params_mirror_dem_params() {
        assert_mirrors::<GpuParams>(
            PARAMS_WGSL,
            "DemParams",
            &[
                ("gravity", offset_of!(GpuParams, gravity)),
                ("dt", offset_of!(GpuParams, dt)),
                ("half_dt", offset_of!(GpuParams, half_dt)),
                ("omega_dt", offset_of!(GpuParams, omega_dt)),
                ("amplitude", offset_of!(GpuParams, amplitude)),
                ("omega", offset_of!(GpuParams, omega)),
                ("n", offset_of!(GpuParams, n)),
                ("n_walls", offset_of!(GpuParams, n_walls)),
                ("n_species", offset_of!(GpuParams, n_species)),
                ("vertical", offset_of!(GpuParams, vertical)),
                ("dim", offset_of!(GpuParams, dim)),
                ("_pad0", offset_of!(GpuParams, _pad0)),
                ("_pad1", offset_of!(GpuParams, _pad1)),
            ],
        );
    }

    #[test]
    fn gpu_check_mirrors_dem_check() {
        let source = [DISPATCH_WGSL, PARAMS_WGSL, GUARD_WGSL, CHECK_WGSL].concat();
        assert_mirrors::<GpuCheck>(
            &source,
            "DemCheck",
            &[
                ("lo", offset_of!(GpuCheck, lo)),
                ("hi", offset_of!(GpuCheck, hi)),
                ("closed", offset_of!(GpuCheck, closed)),
                ("max_overlap", offset_of!(GpuCheck, max_overlap)),
                ("epoch", offset_of!(GpuCheck, epoch)),
                ("begin", offset_of!(GpuCheck, begin)),
                ("pad", offset_of!(GpuCheck, pad)),
            ],
        );
    }

    #[test]
    fn gpu_wall_mirrors_dem_wall() {
        assert_mirrors::<GpuWall>(
            PARAMS_WGSL,
            "DemWall",
            &[
                ("plane", offset_of!(GpuWall, plane)),
                ("cylinder", offset_of!(GpuWall, cylinder)),
                ("motion", offset_of!(GpuWall, motion)),
            ],
        );
    }
}
