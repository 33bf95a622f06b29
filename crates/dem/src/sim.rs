//! The user-facing simulation object and its state snapshot.

use simkit_backend::{Backend, Error, Result, Simulation};

#[cfg(feature = "gpu")]
use crate::Integrator;
use crate::cpu::CpuEngine;
use crate::diagnostics;
use crate::engine::Engine;
use crate::prepared::Prepared;
use crate::{Config, Diagnostics, Precision, Scene};

/// Host-side snapshot: time, positions and velocities (`[x, y, 0]` in 2D), in the scene's
/// particle order.
#[derive(Clone, Debug, PartialEq)]
pub struct State {
    /// Simulation time.
    pub time: f64,
    /// Positions (periodic axes wrapped into the box).
    pub positions: Vec<[f64; 3]>,
    /// Velocities at `time`.
    pub velocities: Vec<[f64; 3]>,
}

/// A granular DEM simulation of a [`Scene`] on a chosen backend.
///
/// ```
/// use simkit_backend::{Backend, Simulation};
/// use simkit_dem::{Config, Dem, Dim, Material, Particle, Scene};
/// # fn main() -> simkit_backend::Result<()> {
/// let mut scene = Scene::new(Dim::Two, [0.0; 3], [4.0, 4.0, 0.0], Material::new(0.9, 0.05))?;
/// scene.add_particle(Particle::new([1.0, 2.0, 0.0], 0.5, 1.0).with_velocity([1.0, 0.0, 0.0]))?;
/// scene.add_particle(Particle::new([2.5, 2.0, 0.0], 0.5, 1.0))?;
/// let mut sim = Dem::new(&scene, &Config::default(), Backend::Cpu)?;
/// // dt = t_c / 30: the gap of 0.5 closes after 300 steps, the contact lasts 30 more.
/// sim.step(400)?;
/// let v = sim.state()?.velocities;
/// // Equal masses, e = 0.9: v0' = (1 - e) / 2, v1' = (1 + e) / 2.
/// assert!((v[0][0] - 0.05).abs() < 0.01 && (v[1][0] - 0.95).abs() < 0.01);
/// # Ok(())
/// # }
/// ```
pub struct Dem {
    engine: Box<dyn Engine>,
    steps: u64,
}

impl Dem {
    /// Validates the scene and settings and builds the backend.
    ///
    /// Errors: an empty scene, a time step over the safe bound (see
    /// [`crate::resolve_dt`]), initial overlaps deeper than a tenth of a radius, position
    /// Verlet on the GPU, or any GPU failure.
    pub fn new(scene: &Scene, config: &Config, backend: Backend<'_>) -> Result<Self> {
        let prep = Prepared::new(scene, config)?;
        diagnostics::check_initial_overlaps(&prep)?;
        let engine: Box<dyn Engine> = match backend {
            Backend::Cpu => match (prep.axes, config.precision) {
                (2, Precision::F64) => Box::new(CpuEngine::<2, f64>::new(prep)?),
                (2, Precision::F32) => Box::new(CpuEngine::<2, f32>::new(prep)?),
                (_, Precision::F64) => Box::new(CpuEngine::<3, f64>::new(prep)?),
                (_, Precision::F32) => Box::new(CpuEngine::<3, f32>::new(prep)?),
            },
            #[cfg(feature = "gpu")]
            Backend::Gpu(ctx) => {
                if config.integrator != Integrator::VelocityVerlet {
                    return Err(Error::Unsupported(
                        "the GPU backend integrates with velocity Verlet only; use \
                         Integrator::VelocityVerlet or the CPU backend"
                            .into(),
                    ));
                }
                Box::new(crate::gpu::GpuEngine::new(ctx, prep)?)
            }
        };
        Ok(Self { engine, steps: 0 })
    }

    /// The time step in use.
    pub fn dt(&self) -> f64 {
        self.engine.prepared().dt
    }

    /// Diagnostics of the current state (downloads it on the GPU).
    pub fn diagnostics(&mut self) -> Result<Diagnostics> {
        let s = self.engine.state()?;
        self.diagnostics_of(&s)
    }

    /// Diagnostics of a state of this simulation's scene.
    pub fn diagnostics_of(&self, state: &State) -> Result<Diagnostics> {
        let p = self.engine.prepared();
        if state.positions.len() != p.n || state.velocities.len() != p.n {
            return Err(Error::invalid(
                "state length",
                state.positions.len(),
                format!("must equal the particle count {}", p.n),
            ));
        }
        crate::diagnostics::compute(p, state.time, &state.positions, &state.velocities)
    }

    /// Vertical displacement of the vibrating walls at time `t`.
    pub fn wall_displacement(&self, t: f64) -> f64 {
        self.engine.prepared().wall_motion(t).0
    }
}

impl Simulation for Dem {
    type State = State;

    fn step(&mut self, steps: u32) -> Result<()> {
        self.engine.step(steps)?;
        self.steps += u64::from(steps);
        Ok(())
    }

    fn state(&mut self) -> Result<State> {
        self.engine.state()
    }

    fn steps_done(&self) -> u64 {
        self.steps
    }

    fn backend_name(&self) -> String {
        self.engine.name()
    }
}
