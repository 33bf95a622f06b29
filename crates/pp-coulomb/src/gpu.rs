//! The GPU backend: tiled all-pairs field kernel and integrator passes, all on the device.

use simkit_backend::gpu::DISPATCH_WGSL;
use simkit_backend::{Error, GpuBuffer, GpuContext, Kernel, KernelDesc, Precision, Real, Result};

use crate::config::{Config, ForceLaw, Integrator, coincident_error};
use crate::engine::{Engine, PositionsVelocities, pad_coordinate};
use crate::laws;
use crate::particles::Particles;

const ACCEL_WGSL: &str = simkit_backend::wgsl!("accel.wgsl");
const UPDATE_WGSL: &str = simkit_backend::wgsl!("update.wgsl");
const KICK_WGSL: &str = simkit_backend::wgsl!("kick.wgsl");
/// Workgroup size and tile length (the `WG` constant of the shaders).
const WG: usize = 128;

/// The most particles the GPU backend takes on `ctx`'s adapter: unlimited (`usize::MAX`)
/// except where the driver ends shader loops early ([`GpuContext::shader_loop_limit`]):
/// every invocation walks all source tiles, `WG + 2` loop iterations per tile of `WG`
/// particles, so llvmpipe (65,535 iterations) takes at most 64,512 particles.
pub fn gpu_max_particles(ctx: &GpuContext) -> usize {
    match ctx.shader_loop_limit() {
        Some(limit) => (limit.saturating_sub(1) as usize / (WG + 2)) * WG,
        None => usize::MAX,
    }
}

/// Builds the engine for the configured precision (f64 needs `SHADER_F64`).
pub(crate) fn engine(ctx: &GpuContext, p: &Particles, c: &Config) -> Result<Box<dyn Engine>> {
    let max = gpu_max_particles(ctx);
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
        Precision::F32 => Box::new(GpuEngine::<f32>::new(ctx, p, c)?),
        Precision::F64 => {
            if !ctx.has_f64() {
                return Err(Error::Unsupported(format!(
                    "f64 shaders (SHADER_F64) on adapter '{}'; use Precision::F32 or the CPU \
                     backend",
                    ctx.adapter_info().name
                )));
            }
            Box::new(GpuEngine::<f64>::new(ctx, p, c)?)
        }
    })
}

/// Device state in precision `T`: positions (x, y, z, charge) double-buffered, velocities
/// (vx, vy, vz, q/m), accelerations, and the coincident-partner flags of the exact law.
struct GpuEngine<T: Real> {
    ctx: GpuContext,
    n: usize,
    npad: usize,
    pos: [GpuBuffer<[T; 4]>; 2],
    vel: GpuBuffer<[T; 4]>,
    acc: GpuBuffer<[T; 4]>,
    partner: GpuBuffer<u32>,
    drift_coef: GpuBuffer<T>,
    kick_coef: GpuBuffer<T>,
    accel: Kernel,
    drift: Kernel,
    kick: Kernel,
    accel_bind: [wgpu::BindGroup; 2],
    drift_bind: [wgpu::BindGroup; 2],
    kick_bind: wgpu::BindGroup,
    law: ForceLaw,
    integrator: Integrator,
    dt: f64,
    /// Which position buffer is current.
    cur: usize,
    /// Whether `acc` holds the accelerations at the current positions.
    a_valid: bool,
}

impl<T: Real> GpuEngine<T> {
    fn new(ctx: &GpuContext, p: &Particles, c: &Config) -> Result<Self> {
        let prelude = laws::wgsl_prelude(T::PRECISION);
        let n = p.len();
        let npad = n.next_multiple_of(WG).max(WG);
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
        let pos = [
            GpuBuffer::from_slice(ctx, "pp-coulomb positions A", &pos)?,
            GpuBuffer::from_slice(ctx, "pp-coulomb positions B", &pos)?,
        ];
        let vel = GpuBuffer::from_slice(ctx, "pp-coulomb velocities", &vel)?;
        let acc = GpuBuffer::<[T; 4]>::zeroed(ctx, "pp-coulomb accelerations", npad)?;
        let partner = GpuBuffer::<u32>::zeroed(ctx, "pp-coulomb coincident partners", npad)?;
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
        let accel = Kernel::new(
            ctx,
            &KernelDesc {
                label: "pp-coulomb accel",
                sources: &[prelude, DISPATCH_WGSL, law_wgsl, ACCEL_WGSL],
                entry: "accel",
                workgroup_size: WG as u32,
                constants: &[("N", n as f64), ("NPAD", npad as f64), ("EXACT", exact)],
            },
        )?;
        let drift = Kernel::new(
            ctx,
            &KernelDesc {
                label: "pp-coulomb kick_drift",
                sources: &[prelude, DISPATCH_WGSL, UPDATE_WGSL],
                entry: "kick_drift",
                workgroup_size: WG as u32,
                constants: &[("N", n as f64)],
            },
        )?;
        let kick = Kernel::new(
            ctx,
            &KernelDesc {
                label: "pp-coulomb kick",
                sources: &[prelude, DISPATCH_WGSL, KICK_WGSL],
                entry: "kick",
                workgroup_size: WG as u32,
                constants: &[("N", n as f64)],
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
        let kick_bind = kick.bind(ctx, &[vel.binding(), acc.binding(), kick_coef.binding()])?;
        let mut engine = Self {
            ctx: ctx.clone(),
            n,
            npad,
            pos,
            vel,
            acc,
            partner,
            drift_coef,
            kick_coef,
            accel,
            drift,
            kick,
            accel_bind: [a0?, a1?],
            drift_bind: [d0?, d1?],
            kick_bind,
            law: c.force,
            integrator: c.integrator,
            dt: c.dt,
            cur: 0,
            a_valid: false,
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

    /// Under the exact law, reads the partner flags and reports the first coincident pair.
    fn check_coincident(&self) -> Result<()> {
        if self.law != ForceLaw::Exact {
            return Ok(());
        }
        let partner = self.partner.download(&self.ctx)?;
        if let Some((i, &j)) = partner.iter().enumerate().find(|(_, j)| **j != 0) {
            let j = j as usize - 1;
            let x = self.pos[self.cur].download(&self.ctx)?;
            let at = [0, 1, 2].map(|k| x[i][k].to_f64());
            return Err(coincident_error(i.min(j), i.max(j), at));
        }
        Ok(())
    }

    /// Records one accel dispatch on the current positions.
    fn encode_accel(&self, pass: &mut wgpu::ComputePass<'_>, cur: usize) -> Result<()> {
        self.accel.dispatch_workgroups(
            &self.ctx,
            pass,
            &self.accel_bind[cur],
            (self.npad / WG) as u64,
        )
    }

    fn to_f64(v: &[[T; 4]]) -> Vec<[f64; 3]> {
        v.iter()
            .map(|a| [a[0].to_f64(), a[1].to_f64(), a[2].to_f64()])
            .collect()
    }
}

impl<T: Real> Engine for GpuEngine<T> {
    fn step(&mut self, steps: u32) -> Result<()> {
        let mut cur = self.cur;
        let mut a_valid = self.a_valid;
        let n = self.n as u64;
        simkit_backend::gpu::run_pass(&self.ctx, "pp-coulomb steps", |pass| {
            for _ in 0..steps {
                match self.integrator {
                    Integrator::SymplecticEuler => {
                        self.encode_accel(pass, cur)?;
                        self.drift
                            .dispatch_items(&self.ctx, pass, &self.drift_bind[cur], n)?;
                        cur = 1 - cur;
                        a_valid = false;
                    }
                    Integrator::Leapfrog => {
                        if !a_valid {
                            self.encode_accel(pass, cur)?;
                        }
                        self.drift
                            .dispatch_items(&self.ctx, pass, &self.drift_bind[cur], n)?;
                        cur = 1 - cur;
                        self.encode_accel(pass, cur)?;
                        self.kick
                            .dispatch_items(&self.ctx, pass, &self.kick_bind, n)?;
                        a_valid = true;
                    }
                }
            }
            Ok(())
        })?;
        self.cur = cur;
        self.a_valid = a_valid;
        self.check_coincident()
    }

    fn state(&mut self) -> Result<PositionsVelocities> {
        let mut encoder = self.ctx.encoder("pp-coulomb state");
        let x = self.pos[self.cur].encode_download(&self.ctx, &mut encoder);
        let v = self.vel.encode_download(&self.ctx, &mut encoder);
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
            self.check_coincident()?;
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
