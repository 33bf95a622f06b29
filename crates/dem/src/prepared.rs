//! Scene data resolved for the backends: coefficients, time step, grid geometry.

use simkit_backend::Result;

use crate::{
    Config, ContactCoefficients, Integrator, Scene, Vibration, WallShape, cylinder_overlap,
    plane_overlap, resolve_dt, wall_motion,
};

/// A wall with its coefficients, in a backend-neutral form.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PreparedWall {
    /// 0 = plane, 1 = cylinder.
    pub cylinder: bool,
    /// Plane normal (into the particle region).
    pub normal: [f64; 3],
    /// Plane offset.
    pub offset: f64,
    /// Cylinder axis (x, y).
    pub center: [f64; 2],
    /// Cylinder radius.
    pub radius: f64,
    pub coeff: ContactCoefficients,
    pub vibrating: bool,
}

impl PreparedWall {
    /// Overlap (negative: minus the gap) of a particle at `x` with radius `r` with this
    /// wall when the vibrating walls are displaced by `zw` along the `vertical` axis
    /// ([`plane_overlap`] or [`cylinder_overlap`], as the force loops use them).
    pub fn overlap<const D: usize>(&self, x: &[f64; D], r: f64, zw: f64, vertical: usize) -> f64 {
        if self.cylinder {
            cylinder_overlap(self.center, self.radius, [x[0], x[1]], r).0
        } else {
            let normal: [f64; D] = std::array::from_fn(|d| self.normal[d]);
            let lift = if self.vibrating {
                zw * self.normal[vertical]
            } else {
                0.0
            };
            plane_overlap(&normal, self.offset, lift, x, r)
        }
    }
}

/// Everything the backends need, validated.
#[derive(Clone, Debug)]
pub(crate) struct Prepared {
    pub axes: usize,
    pub vertical: usize,
    pub n: usize,
    pub dt: f64,
    pub integrator: Integrator,
    pub skin: f64,
    pub positions: Vec<[f64; 3]>,
    pub velocities: Vec<[f64; 3]>,
    pub radius: Vec<f64>,
    pub mass: Vec<f64>,
    pub species: Vec<u32>,
    pub n_species: usize,
    pub coeff: Vec<ContactCoefficients>,
    pub walls: Vec<PreparedWall>,
    pub gravity: f64,
    pub vibration: Option<Vibration>,
    pub friction: bool,
    pub lo: [f64; 3],
    pub len: [f64; 3],
    pub periodic: [bool; 3],
    pub cutoff: f64,
}

impl Prepared {
    pub fn new(scene: &Scene, config: &Config) -> Result<Self> {
        scene.check_ready()?;
        let dt = resolve_dt(scene, config)?;
        let dim = scene.dim();
        let axes = dim.axes();
        let vertical = dim.vertical();
        let ps = scene.particles();
        let r_max = scene.max_radius();
        let vibration = scene.vibration().filter(|v| v.amplitude > 0.0);
        let mut lo = scene.lo();
        let mut hi = scene.hi();
        if let Some(v) = vibration {
            lo[vertical] -= v.amplitude;
            hi[vertical] += v.amplitude;
        }
        let mut len = [1.0; 3];
        for d in 0..axes {
            len[d] = hi[d] - lo[d];
        }
        if axes == 2 {
            lo[2] = 0.0;
        }
        let walls = scene
            .walls()
            .iter()
            .map(|w| {
                let coeff = ContactCoefficients::new(&w.material);
                match w.shape {
                    WallShape::Plane { normal, offset } => PreparedWall {
                        cylinder: false,
                        normal,
                        offset,
                        center: [0.0; 2],
                        radius: 0.0,
                        coeff,
                        vibrating: w.vibrating,
                    },
                    WallShape::Cylinder { center, radius } => PreparedWall {
                        cylinder: true,
                        normal: [0.0; 3],
                        offset: 0.0,
                        center,
                        radius,
                        coeff,
                        vibrating: w.vibrating,
                    },
                }
            })
            .collect();
        let p = Self {
            axes,
            vertical,
            n: ps.len(),
            dt,
            integrator: config.integrator,
            skin: config.skin * 2.0 * r_max,
            positions: ps.iter().map(|p| p.position).collect(),
            velocities: ps.iter().map(|p| p.velocity).collect(),
            radius: ps.iter().map(|p| p.radius).collect(),
            mass: ps.iter().map(|p| p.mass).collect(),
            species: ps.iter().map(|p| p.species).collect(),
            n_species: scene.species_count(),
            coeff: scene
                .pair_table()
                .iter()
                .map(ContactCoefficients::new)
                .collect(),
            walls,
            gravity: scene.gravity(),
            vibration,
            friction: scene.has_friction(),
            lo,
            len,
            periodic: scene.periodic(),
            cutoff: 2.0 * r_max,
        };
        Ok(p)
    }

    /// Vertical wall displacement and velocity at time `t`.
    pub fn wall_motion(&self, t: f64) -> (f64, f64) {
        match self.vibration {
            Some(v) => wall_motion(v.amplitude, v.omega, v.omega * t),
            None => (0.0, 0.0),
        }
    }
}
