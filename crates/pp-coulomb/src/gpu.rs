//! The GPU backend: tiled all-pairs field kernel and integrator passes, all on the device.

use simkit_backend::gpu::{DISPATCH_WGSL, GpuGuard, Watch};
use simkit_backend::guard::chunks;
use simkit_backend::{Error, GpuBuffer, GpuContext, Kernel, KernelDesc, Precision, Real, Result};

use crate::config::{Config, ForceLaw, GpuTile, Integrator, coincident_error};
use crate::engine::{Engine, pad_coordinate};
use crate::guard::{
    Checks, Energy, coincident_blow_up, energy_blow_up, energy_jump, jump_fails, non_finite_blow_up,
};
use crate::laws;
use crate::particles::Particles;
use crate::particles::PositionsVelocities;

const ACCEL_WGSL: &str = simkit_backend::wgsl!("accel.wgsl");
const UPDATE_WGSL: &str = simkit_backend::wgsl!("update.wgsl");
const KICK_WGSL: &str = simkit_backend::wgsl!("kick.wgsl");
const ENERGY_WGSL: &str = simkit_backend::wgsl!("energy.wgsl");
/// Workgroup size of the energy and integrator kernels (their `WG` constant).
const WG: usize = 128;

/// The most particles the GPU backend takes on `ctx`'s adapter with the default tile
/// ([`GpuTile::default`]; [`GpuTile::max_particles`] for another).
pub fn gpu_max_particles(ctx: &GpuContext) -> usize {
    GpuTile::default().max_particles(ctx)
}

impl GpuTile {
    /// The most particles the GPU backend takes on `ctx`'s adapter with this tile: unlimited
    /// (`usize::MAX`) except where the driver ends shader loops early
    /// ([`GpuContext::shader_loop_limit`]). The force kernel walks all padded sources in
    /// tiles of `workgroup`, `workgroup + 2` loop iterations per tile (its targets are
    /// unrolled, not looped over), the energy kernel likewise in tiles of 128; and the
    /// padded count is a multiple of `workgroup * targets` and of 128. With the default tile
    /// llvmpipe (65,535 iterations) takes at most 64,512 particles.
    pub fn max_particles(&self, ctx: &GpuContext) -> usize {
        let Some(limit) = ctx.shader_loop_limit() else {
            return usize::MAX;
        };
        let limit = limit.saturating_sub(1) as usize;
        let walks = |wg: usize| limit / (wg + 2) * wg;
        let most = walks(self.workgroup as usize).min(walks(WG));
        let step = self.padding();
        most / step * step
    }

    /// The padded particle count is a multiple of this: the force kernel's targets per
    /// workgroup and the other kernels' workgroup (all powers of two).
    fn padding(&self) -> usize {
        ((self.workgroup * self.targets) as usize).max(WG)
    }
}

/// Builds the engine for the configured precision (f64 needs `SHADER_F64`); `accelerations`
/// are the kept accelerations of a resumed run (leapfrog), if any.
pub(crate) fn engine(
    ctx: &GpuContext,
    p: &Particles,
    c: &Config,
    accelerations: Option<&[[f64; 3]]>,
) -> Result<Box<dyn Engine>> {
    if c.mixed {
        return Err(Error::Unsupported(format!(
            "mixed precision (Config::mixed) on adapter '{}': the GPU backend computes and sums \
             in one precision; use Backend::Cpu for the mixed mode, or Config::with_mixed(false) \
             for f32 or f64 on the GPU",
            ctx.adapter_info().name
        )));
    }
    let tile = c.gpu_tile.unwrap_or_default();
    tile.validate()?;
    let most = ctx.limits().max_compute_invocations_per_workgroup;
    if tile.workgroup > most {
        return Err(Error::invalid(
            "gpu_tile.workgroup",
            tile.workgroup,
            format!(
                "over the {most} invocations per workgroup of adapter '{}'; use a smaller one",
                ctx.adapter_info().name
            ),
        ));
    }
    let max = tile.max_particles(ctx);
    if p.len() > max {
        return Err(Error::Unsupported(format!(
            "{} particles on adapter '{}': it ends a shader's loops after {} iterations per \
             invocation, which allows at most {max} particles in the all-pairs kernel; use the \
             CPU backend (faster than this software driver on the same processor) or a \
             hardware GPU",
            p.len(),
            ctx.adapter_info().name,
            ctx.shader_loop_limit().unwrap_or(0),
        )));
    }
    Ok(match c.precision {
        Precision::F32 => Box::new(GpuEngine::<f32>::new(ctx, p, c, tile, accelerations)?),
        Precision::F64 => {
            if !ctx.has_f64() {
                return Err(Error::Unsupported(format!(
                    "f64 shaders (SHADER_F64) on adapter '{}'; use Precision::F32 or the CPU \
                     backend",
                    ctx.adapter_info().name
                )));
            }
            Box::new(GpuEngine::<f64>::new(ctx, p, c, tile, accelerations)?)
        }
    })
}

/// Labels of the watched state buffers (the guard reports them).
const POS_LABELS: [&str; 2] = ["pp-coulomb positions A", "pp-coulomb positions B"];
const VEL_LABEL: &str = "pp-coulomb velocities";
const ACC_LABEL: &str = "pp-coulomb accelerations";
const FLAG_LABEL: &str = "pp-coulomb coincident flags";

/// Host-side counters at one recorded guard check: the step, the current position buffer,
/// whether the accelerations are valid, and the energy reference.
type Record = (u64, usize, bool, Option<Energy>);

/// Device state in precision `T`: positions (x, y, z, charge) double-buffered, velocities
/// (vx, vy, vz, q/m), accelerations, the coincident flags and partners of the exact law;
/// the guard watches every state buffer.
struct GpuEngine<T: Real> {
    ctx: GpuContext,
    n: usize,
    npad: usize,
    /// Targets per workgroup of the force kernel (its tile's `workgroup * targets`).
    per_group: usize,
    pos: [GpuBuffer<[T; 4]>; 2],
    vel: GpuBuffer<[T; 4]>,
    acc: GpuBuffer<[T; 4]>,
    partner: GpuBuffer<u32>,
    flags: GpuBuffer<u32>,
    partials: GpuBuffer<T>,
    drift_coef: GpuBuffer<T>,
    kick_coef: GpuBuffer<T>,
    accel: Kernel,
    drift: Kernel,
    kick: Kernel,
    energy: Kernel,
    accel_bind: [wgpu::BindGroup; 2],
    drift_bind: [wgpu::BindGroup; 2],
    kick_bind: wgpu::BindGroup,
    energy_bind: [wgpu::BindGroup; 2],
    guard: GpuGuard,
    law: ForceLaw,
    integrator: Integrator,
    dt: f64,
    /// Which position buffer is current.
    cur: usize,
    /// Whether `acc` holds the accelerations at the current positions.
    a_valid: bool,
}

impl<T: Real> GpuEngine<T> {
    fn new(
        ctx: &GpuContext,
        p: &Particles,
        c: &Config,
        tile: GpuTile,
        accelerations: Option<&[[f64; 3]]>,
    ) -> Result<Self> {
        let prelude = laws::wgsl_prelude(T::PRECISION);
        let n = p.len();
        let per_group = (tile.workgroup * tile.targets) as usize;
        let npad = n.next_multiple_of(tile.padding()).max(tile.padding());
        let mut pos: Vec<[T; 4]> = (0..n)
            .map(|i| {
                let x = p.position[i];
                [x[0], x[1], x[2], p.charge[i]].map(T::from_f64)
            })
            .collect();
        let pad = pad_coordinate();
        pos.resize(npad, [pad, pad, pad, T::ZERO]);
        let mut vel: Vec<[T; 4]> = (0..n)
            .map(|i| {
                let v = p.velocity[i];
                [v[0], v[1], v[2], p.charge[i] / p.mass[i]].map(T::from_f64)
            })
            .collect();
        // Padding entries keep every buffer non-empty (and are never read back).
        vel.resize(npad, [T::ZERO; 4]);
        let mut mass: Vec<T> = p.mass.iter().map(|&m| T::from_f64(m)).collect();
        mass.resize(npad, T::ZERO);
        let (mut acc, a_valid) = match accelerations {
            Some(a) if a.len() == n => (
                a.iter()
                    .map(|a| [a[0], a[1], a[2], 0.0].map(T::from_f64))
                    .collect::<Vec<_>>(),
                true,
            ),
            _ => (Vec::new(), false),
        };
        acc.resize(npad, [T::ZERO; 4]);
        let pos = [
            GpuBuffer::from_slice(ctx, POS_LABELS[0], &pos)?,
            GpuBuffer::from_slice(ctx, POS_LABELS[1], &pos)?,
        ];
        let vel = GpuBuffer::from_slice(ctx, VEL_LABEL, &vel)?;
        let acc = GpuBuffer::from_slice(ctx, ACC_LABEL, &acc)?;
        let mass = GpuBuffer::from_slice(ctx, "pp-coulomb masses", &mass)?;
        let partner = GpuBuffer::<u32>::zeroed(ctx, "pp-coulomb coincident partners", npad)?;
        let flags = GpuBuffer::<u32>::zeroed(ctx, FLAG_LABEL, npad)?;
        let partials = GpuBuffer::<T>::zeroed(ctx, "pp-coulomb energy partials", 2 * npad / WG)?;
        let law_coef = GpuBuffer::from_slice(
            ctx,
            "pp-coulomb law parameter",
            &[T::from_f64(c.force.squared_parameter())],
        )?;
        let drift_coef = GpuBuffer::<T>::zeroed(ctx, "pp-coulomb drift coefficients", 2)?;
        let kick_coef = GpuBuffer::<T>::zeroed(ctx, "pp-coulomb kick coefficient", 1)?;
        let law_wgsl = match c.force {
            ForceLaw::Exact => laws::EXACT_WGSL,
            ForceLaw::Exclusion { .. } => laws::EXCLUSION_WGSL,
            ForceLaw::Plummer { .. } => laws::PLUMMER_WGSL,
        };
        let exact = if c.force == ForceLaw::Exact { 1.0 } else { 0.0 };
        let sizes = [("N", n as f64), ("NPAD", npad as f64)];
        let tile_wgsl = format!(
            "const WG: u32 = {}u;\nconst TPI: u32 = {}u;\n",
            tile.workgroup, tile.targets
        );
        let accel = Kernel::new(
            ctx,
            &KernelDesc {
                label: "pp-coulomb accel",
                sources: &[prelude, DISPATCH_WGSL, law_wgsl, &tile_wgsl, ACCEL_WGSL],
                entry: "accel",
                workgroup_size: tile.workgroup,
                constants: &[sizes[0], sizes[1], ("EXACT", exact)],
            },
        )?;
        let energy = Kernel::new(
            ctx,
            &KernelDesc {
                label: "pp-coulomb energy",
                sources: &[prelude, DISPATCH_WGSL, laws::EXACT_WGSL, ENERGY_WGSL],
                entry: "energy",
                workgroup_size: WG as u32,
                constants: &sizes,
            },
        )?;
        let drift = Kernel::new(
            ctx,
            &KernelDesc {
                label: "pp-coulomb kick_drift",
                sources: &[prelude, DISPATCH_WGSL, UPDATE_WGSL],
                entry: "kick_drift",
                workgroup_size: WG as u32,
                constants: &[sizes[0]],
            },
        )?;
        let kick = Kernel::new(
            ctx,
            &KernelDesc {
                label: "pp-coulomb kick",
                sources: &[prelude, DISPATCH_WGSL, KICK_WGSL],
                entry: "kick",
                workgroup_size: WG as u32,
                constants: &[sizes[0]],
            },
        )?;
        let accel_bind = [0, 1].map(|b| {
            accel.bind(
                ctx,
                &[
                    pos[b].binding(),
                    vel.binding(),
                    acc.binding(),
                    partner.binding(),
                    law_coef.binding(),
                    flags.binding(),
                ],
            )
        });
        let energy_bind = [0, 1].map(|b| {
            energy.bind(
                ctx,
                &[
                    pos[b].binding(),
                    vel.binding(),
                    mass.binding(),
                    partials.binding(),
                ],
            )
        });
        let drift_bind = [0, 1].map(|b| {
            drift.bind(
                ctx,
                &[
                    pos[b].binding(),
                    pos[1 - b].binding(),
                    vel.binding(),
                    acc.binding(),
                    drift_coef.binding(),
                ],
            )
        });
        let [a0, a1] = accel_bind;
        let [d0, d1] = drift_bind;
        let [e0, e1] = energy_bind;
        let kick_bind = kick.bind(ctx, &[vel.binding(), acc.binding(), kick_coef.binding()])?;
        let guard = GpuGuard::new(
            ctx,
            &[
                Watch::checked(&pos[0], T::PRECISION),
                Watch::checked(&pos[1], T::PRECISION),
                Watch::checked(&vel, T::PRECISION),
                Watch::checked(&acc, T::PRECISION),
                Watch::checked(&flags, Precision::F32),
            ],
        )?;
        let mut engine = Self {
            ctx: ctx.clone(),
            n,
            npad,
            per_group,
            pos,
            vel,
            acc,
            partner,
            flags,
            partials,
            drift_coef,
            kick_coef,
            accel,
            drift,
            kick,
            energy,
            accel_bind: [a0?, a1?],
            drift_bind: [d0?, d1?],
            kick_bind,
            energy_bind: [e0?, e1?],
            guard,
            law: c.force,
            integrator: c.integrator,
            dt: c.dt,
            cur: 0,
            a_valid,
        };
        engine.upload_coefficients()?;
        Ok(engine)
    }

    fn upload_coefficients(&mut self) -> Result<()> {
        let kick = match self.integrator {
            Integrator::SymplecticEuler => self.dt,
            Integrator::Leapfrog => 0.5 * self.dt,
        };
        self.drift_coef
            .upload(&self.ctx, &[T::from_f64(kick), T::from_f64(self.dt)])?;
        self.kick_coef.upload(&self.ctx, &[T::from_f64(kick)])
    }

    /// The first particle flagged with a coincident partner: `(i, j)`, `i < j`.
    fn coincident_pair(&self, flags: &[u32]) -> Result<Option<(usize, usize)>> {
        let Some(i) = flags.iter().position(|f| *f != 0) else {
            return Ok(None);
        };
        let partner = self.partner.download(&self.ctx)?;
        let j = (partner[i] as usize).saturating_sub(1);
        Ok(Some((i.min(j), i.max(j))))
    }

    /// Records one accel dispatch on the current positions.
    fn encode_accel(&self, pass: &mut wgpu::ComputePass<'_>, cur: usize) -> Result<()> {
        self.accel.dispatch_workgroups(
            &self.ctx,
            pass,
            &self.accel_bind[cur],
            (self.npad / self.per_group) as u64,
        )
    }

    /// Records `steps` steps into `encoder` (one compute pass) and advances `cur`/`a_valid`.
    fn encode_steps(&mut self, encoder: &mut wgpu::CommandEncoder, steps: u32) -> Result<()> {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("pp-coulomb steps"),
            timestamp_writes: None,
        });
        let n = self.n as u64;
        for _ in 0..steps {
            let cur = self.cur;
            match self.integrator {
                Integrator::SymplecticEuler => {
                    self.encode_accel(&mut pass, cur)?;
                    self.drift
                        .dispatch_items(&self.ctx, &mut pass, &self.drift_bind[cur], n)?;
                    self.a_valid = false;
                }
                Integrator::Leapfrog => {
                    if !self.a_valid {
                        self.encode_accel(&mut pass, cur)?;
                    }
                    self.drift
                        .dispatch_items(&self.ctx, &mut pass, &self.drift_bind[cur], n)?;
                    self.encode_accel(&mut pass, 1 - cur)?;
                    self.kick
                        .dispatch_items(&self.ctx, &mut pass, &self.kick_bind, n)?;
                    self.a_valid = true;
                }
            }
            self.cur = 1 - cur;
        }
        Ok(())
    }

    /// Records the energy kernel on the current positions and a download of its partial
    /// sums, submits `encoder`, and returns the energy (partials added in f64).
    fn submit_energy(&self, mut encoder: wgpu::CommandEncoder) -> Result<Energy> {
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("pp-coulomb energy"),
                timestamp_writes: None,
            });
            self.energy.dispatch_workgroups(
                &self.ctx,
                &mut pass,
                &self.energy_bind[self.cur],
                (self.npad / WG) as u64,
            )?;
        }
        let download = self.partials.encode_download(&self.ctx, &mut encoder)?;
        self.ctx.submit(encoder);
        let partials = download.read(&self.ctx)?;
        let (mut kinetic, mut potential) = (0.0, 0.0);
        for pair in partials.chunks_exact(2) {
            kinetic += pair[0].to_f64();
            potential += pair[1].to_f64();
        }
        Ok(Energy { kinetic, potential })
    }

    /// Puts the device state back to the guard's last snapshot (record `records[passed - 1]`)
    /// and the host counters with it; returns that record.
    fn roll_back(
        &mut self,
        records: &[Record],
        passed: usize,
        checks: &mut Checks<'_>,
    ) -> Result<u64> {
        let Some(&(step, cur, a_valid, energy)) =
            passed.checked_sub(1).and_then(|k| records.get(k))
        else {
            return Err(Error::Gpu(
                "the blow-up guard found the starting state of the step call bad; nothing to \
                 roll back to"
                    .into(),
            ));
        };
        self.guard.rollback(&self.ctx)?;
        self.cur = cur;
        self.a_valid = a_valid;
        *checks.energy_ref = energy;
        Ok(step)
    }

    /// The blow-up for a failed finite check (guard report `passed`, `bad`).
    fn finite_failure(
        &mut self,
        records: &[Record],
        passed: usize,
        (label, index): (String, u32),
        checks: &mut Checks<'_>,
    ) -> Result<Error> {
        let step = records.get(passed).map_or(checks.done, |r| r.0);
        let index = index as usize;
        let what = if label == FLAG_LABEL {
            let flags = self.flags.download(&self.ctx)?;
            let pair = self.coincident_pair(&flags)?.unwrap_or((index, index));
            let x = self.pos[self.cur].download(&self.ctx)?;
            let at = [0, 1, 2].map(|k| x[pair.0][k].to_f64());
            let rolled = self.roll_back(records, passed, checks)?;
            return Ok(coincident_blow_up(step, rolled, pair.0, pair.1, at));
        } else {
            let buffer = if label == POS_LABELS[0] {
                &self.pos[0]
            } else if label == POS_LABELS[1] {
                &self.pos[1]
            } else if label == VEL_LABEL {
                &self.vel
            } else {
                &self.acc
            };
            let value = buffer
                .download(&self.ctx)?
                .get(index / 4)
                .map_or(f64::NAN, |v| v[index % 4].to_f64());
            let name = match label.as_str() {
                l if POS_LABELS.contains(&l) => "position",
                VEL_LABEL => "velocity",
                _ => "acceleration",
            };
            let axis = ["x", "y", "z", "w"][index % 4];
            format!(
                "particle {}: {name} {axis} = {value} (read at the end of the call)",
                index / 4
            )
        };
        let rolled = self.roll_back(records, passed, checks)?;
        Ok(non_finite_blow_up(step, rolled, what))
    }

    fn to_f64(v: &[[T; 4]]) -> Vec<[f64; 3]> {
        v.iter()
            .map(|a| [a[0].to_f64(), a[1].to_f64(), a[2].to_f64()])
            .collect()
    }
}

impl<T: Real> Engine for GpuEngine<T> {
    fn step(&mut self, steps: u32, c: &mut Checks<'_>) -> Result<()> {
        self.guard.begin(&self.ctx)?;
        let mut encoder = self.ctx.encoder("pp-coulomb steps");
        self.guard.record(&self.ctx, &mut encoder)?;
        let mut records: Vec<Record> = vec![(c.done, self.cur, self.a_valid, *c.energy_ref)];
        let mut at = c.done;
        for n in chunks(c.done, steps, c.every) {
            self.encode_steps(&mut encoder, n)?;
            at += u64::from(n);
            if let (true, Some(tol)) = (c.is_interval(at), c.energy_tolerance) {
                // One small read-back per interval: the energy, before this state's check
                // and snapshot are recorded.
                let submitted =
                    std::mem::replace(&mut encoder, self.ctx.encoder("pp-coulomb steps"));
                let now = self.submit_energy(submitted)?;
                let jump = c.energy_ref.map_or(0.0, |r| energy_jump(r, now));
                if !now.is_finite() || jump_fails(jump, tol) {
                    let report = self.guard.report(&self.ctx)?;
                    let passed = report.passed as usize;
                    if let Some(bad) = report.bad {
                        return Err(self.finite_failure(&records, passed, bad, c)?);
                    }
                    let bad = self.state()?;
                    let rolled = self.roll_back(&records, passed, c)?;
                    let good = self.state()?;
                    return Err(energy_blow_up(at, rolled, c, jump, &good, &bad));
                }
                *c.energy_ref = Some(now);
            }
            self.guard.record(&self.ctx, &mut encoder)?;
            records.push((at, self.cur, self.a_valid, *c.energy_ref));
        }
        self.ctx.submit(encoder);
        let report = self.guard.report(&self.ctx)?;
        if let Some(bad) = report.bad {
            return Err(self.finite_failure(&records, report.passed as usize, bad, c)?);
        }
        Ok(())
    }

    fn energy(&mut self) -> Result<Energy> {
        let encoder = self.ctx.encoder("pp-coulomb energy");
        self.submit_energy(encoder)
    }

    fn kept_accelerations(&mut self) -> Result<Option<Vec<[f64; 3]>>> {
        if !self.a_valid {
            return Ok(None);
        }
        Ok(Some(Self::to_f64(&self.acc.download(&self.ctx)?[..self.n])))
    }

    fn state(&mut self) -> Result<PositionsVelocities> {
        let mut encoder = self.ctx.encoder("pp-coulomb state");
        let x = self.pos[self.cur].encode_download(&self.ctx, &mut encoder)?;
        let v = self.vel.encode_download(&self.ctx, &mut encoder)?;
        self.ctx.submit(encoder);
        let x = x.read(&self.ctx)?;
        let v = v.read(&self.ctx)?;
        Ok((Self::to_f64(&x[..self.n]), Self::to_f64(&v[..self.n])))
    }

    fn accelerations(&mut self) -> Result<Vec<[f64; 3]>> {
        if !self.a_valid {
            let cur = self.cur;
            simkit_backend::gpu::run_pass(&self.ctx, "pp-coulomb accel", |pass| {
                self.encode_accel(pass, cur)
            })?;
            if self.law == ForceLaw::Exact {
                let flags = self.flags.download(&self.ctx)?;
                if let Some((i, j)) = self.coincident_pair(&flags)? {
                    // Clear the flags: the state did not change, and a good state has none.
                    self.flags.upload(&self.ctx, &vec![0; self.npad])?;
                    let x = self.pos[cur].download(&self.ctx)?;
                    let at = [0, 1, 2].map(|k| x[i][k].to_f64());
                    return Err(coincident_error(i, j, at));
                }
            }
            self.a_valid = true;
        }
        Ok(Self::to_f64(&self.acc.download(&self.ctx)?[..self.n]))
    }

    fn set_dt(&mut self, dt: f64) -> Result<()> {
        self.dt = dt;
        self.upload_coefficients()
    }

    fn name(&self) -> String {
        format!(
            "gpu-{} ({})",
            std::any::type_name::<T>(),
            self.ctx.adapter_info().name
        )
    }
}
