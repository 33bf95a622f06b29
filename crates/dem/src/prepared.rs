//! Scene data resolved for the backends: coefficients, time step, grid geometry.

use simkit_backend::{Error, Result};

use crate::{
    Config, ContactLaw, Integrator, Scene, Vibration, WallShape, cylinder_overlap, plane_overlap,
    safe_dt, wall_motion,
};

/// Largest magnitude of any length, speed, mass or coefficient the `f64` engines accept:
/// far beyond any unit system, it keeps squares and products of the inputs finite.
const F64_LIMIT: f64 = 1e100;
/// The same for engines that compute in `f32` (the GPU, the CPU with `Precision::F32`).
const F32_LIMIT: f64 = 1e30;

/// Refuses a value whose magnitude is beyond `limit` or, if non-zero, below `1 / limit`
/// (it would overflow or vanish in the engine's precision).
fn in_range(name: &str, v: f64, limit: f64, precision: &str) -> Result<()> {
    check_magnitude(name, v, limit, precision, true)
}

/// Like [`in_range`] for values that may be arbitrarily small (speeds, offsets).
fn not_huge(name: &str, v: f64, limit: f64, precision: &str) -> Result<()> {
    check_magnitude(name, v, limit, precision, false)
}

fn check_magnitude(name: &str, v: f64, limit: f64, precision: &str, lower: bool) -> Result<()> {
    let a = v.abs();
    let floor = if lower { 1.0 / limit } else { 0.0 };
    if a.is_finite() && (a == 0.0 || (a <= limit && a >= floor)) {
        Ok(())
    } else {
        Err(Error::invalid(
            name,
            v,
            format!(
                "its magnitude must be 0 or within [{floor:e}, {limit:e}] for a run in \
                 {precision}; rescale the units (e.g. lengths in particle diameters)"
            ),
        ))
    }
}

/// A wall with its material, in a backend-neutral form.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PreparedWall<L> {
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
    pub material: L,
    pub vibrating: bool,
    /// Angular velocity of a cylinder wall about its axis.
    pub spin: f64,
}

impl<L> PreparedWall<L> {
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
pub(crate) struct Prepared<L> {
    pub axes: usize,
    pub vertical: usize,
    pub n: usize,
    pub dt: f64,
    pub integrator: Integrator,
    pub skin: f64,
    pub positions: Vec<[f64; 3]>,
    pub velocities: Vec<[f64; 3]>,
    /// Whether the particles spin ([`Scene::set_rotation`]).
    pub rotation: bool,
    /// Angular velocities (read only with `rotation`).
    pub omega: Vec<[f64; 3]>,
    /// Moments of inertia ([`crate::moment_of_inertia`]).
    pub inertia: Vec<f64>,
    pub radius: Vec<f64>,
    pub mass: Vec<f64>,
    pub species: Vec<u32>,
    pub n_species: usize,
    /// The species-pair materials, `n_species^2` entries ([`crate::pair_index`]).
    pub pairs: Vec<L>,
    pub walls: Vec<PreparedWall<L>>,
    pub gravity: f64,
    pub vibration: Option<Vibration>,
    pub friction: bool,
    pub lo: [f64; 3],
    pub len: [f64; 3],
    pub periodic: [bool; 3],
    pub cutoff: f64,
    /// The safe time-step bound of the scene ([`safe_dt`]), for the blow-up messages.
    pub safe_dt: f64,
    /// Blow-up check interval ([`Config::check_every`]).
    pub check_every: u32,
    /// Overlap limit of the blow-up check ([`Config::max_overlap`]).
    pub max_overlap: f64,
    /// Whether the scene has walls (for the blow-up messages).
    pub has_walls: bool,
}

impl<L: ContactLaw> Prepared<L> {
    /// Validates `scene` and `config` for an engine that computes in `f32` (`single`) or
    /// `f64`: every check both backends share lives here, so they accept and refuse the
    /// same inputs.
    pub fn new(scene: &Scene<L>, config: &Config, single: bool) -> Result<Self> {
        scene.check_ready()?;
        let dt = config.resolve_dt(scene)?;
        let (limit, precision) = if single {
            (F32_LIMIT, "f32")
        } else {
            (F64_LIMIT, "f64")
        };
        Self::check_scene(scene, config, dt, limit, precision)?;
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
                let material = w.material;
                match w.shape {
                    WallShape::Plane { normal, offset } => PreparedWall {
                        cylinder: false,
                        normal,
                        offset,
                        center: [0.0; 2],
                        radius: 0.0,
                        material,
                        vibrating: w.vibrating,
                        spin: w.spin,
                    },
                    WallShape::Cylinder { center, radius } => PreparedWall {
                        cylinder: true,
                        normal: [0.0; 3],
                        offset: 0.0,
                        center,
                        radius,
                        material,
                        vibrating: w.vibrating,
                        spin: w.spin,
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
            rotation: scene.rotation(),
            omega: ps.iter().map(|p| p.angular_velocity).collect(),
            inertia: ps
                .iter()
                .map(|p| crate::moment_of_inertia(dim, p.mass, p.radius))
                .collect(),
            radius: ps.iter().map(|p| p.radius).collect(),
            mass: ps.iter().map(|p| p.mass).collect(),
            species: ps.iter().map(|p| p.species).collect(),
            n_species: scene.species_count(),
            pairs: scene.pair_table().to_vec(),
            walls,
            gravity: scene.gravity(),
            vibration,
            friction: scene.has_friction(),
            lo,
            len,
            periodic: scene.periodic(),
            cutoff: 2.0 * r_max,
            safe_dt: safe_dt(scene),
            check_every: config.check_every,
            max_overlap: config.max_overlap,
            has_walls: !scene.walls().is_empty(),
        };
        Ok(p)
    }

    /// The checks of [`Prepared::new`] beyond the builders': magnitudes the precision can
    /// hold, particles inside the box, periodic axes long enough for the neighbour lists.
    fn check_scene(
        scene: &Scene<L>,
        config: &Config,
        dt: f64,
        limit: f64,
        precision: &str,
    ) -> Result<()> {
        const AXES: [&str; 3] = ["x", "y", "z"];
        let axes = scene.dim().axes();
        let ps = scene.particles();
        if ps.len() >= (u32::MAX / 2) as usize {
            return Err(Error::invalid(
                "particle count",
                ps.len(),
                "must be below 2^31 (indices are 32-bit on both backends)",
            ));
        }
        let (lo, hi) = (scene.lo(), scene.hi());
        for d in 0..axes {
            not_huge(
                &format!("box lower corner .{}", AXES[d]),
                lo[d],
                limit,
                precision,
            )?;
            not_huge(
                &format!("box upper corner .{}", AXES[d]),
                hi[d],
                limit,
                precision,
            )?;
            in_range(
                &format!("box length along {}", AXES[d]),
                hi[d] - lo[d],
                limit,
                precision,
            )?;
        }
        in_range("dt", dt, limit, precision)?;
        if scene.rotation() && config.integrator != Integrator::VelocityVerlet {
            return Err(Error::Unsupported(
                "a rotating scene (Scene::set_rotation) integrates with velocity Verlet only; \
                 use Integrator::VelocityVerlet"
                    .into(),
            ));
        }
        not_huge("gravity", scene.gravity(), limit, precision)?;
        if let Some(v) = scene.vibration() {
            not_huge("vibration amplitude", v.amplitude, limit, precision)?;
            in_range("vibration omega", v.omega, limit, precision)?;
        }
        let materials = scene
            .pair_table()
            .iter()
            .chain(scene.walls().iter().map(|w| &w.material));
        for m in materials {
            for (name, v, positive) in m.scales() {
                check_magnitude(name, v, limit, precision, positive)?;
            }
        }
        for (i, p) in ps.iter().enumerate() {
            in_range(&format!("particle[{i}].radius"), p.radius, limit, precision)?;
            in_range(&format!("particle[{i}].mass"), p.mass, limit, precision)?;
            for d in 0..axes {
                let x = p.position[d];
                // A periodic axis takes positions up to one box length outside (both
                // backends wrap them once); a closed one only positions inside.
                let slack = if scene.periodic()[d] {
                    hi[d] - lo[d]
                } else {
                    0.0
                };
                if !(x >= lo[d] - slack && x <= hi[d] + slack) {
                    return Err(Error::invalid(
                        format!("particle[{i}].position.{}", AXES[d]),
                        x,
                        format!(
                            "outside the box [{}, {}] along {}{}; place every particle \
                             inside the box (its centre within [lo, hi])",
                            lo[d],
                            hi[d],
                            AXES[d],
                            if slack > 0.0 {
                                " by more than one box length"
                            } else {
                                ""
                            }
                        ),
                    ));
                }
                not_huge(
                    &format!("particle[{i}].velocity.{}", AXES[d]),
                    p.velocity[d],
                    limit,
                    precision,
                )?;
                not_huge(
                    &format!("particle[{i}].angular_velocity.{}", AXES[d]),
                    p.angular_velocity[d],
                    limit,
                    precision,
                )?;
            }
        }
        // Each neighbour-list pair keeps one periodic image between list builds: no pair
        // may be within reach in two images (both backends refuse the same boxes).
        let reach = 2.0 * scene.max_radius() * (1.0 + config.skin);
        let periodic = scene.periodic();
        for d in 0..axes {
            if periodic[d] && hi[d] - lo[d] < 2.0 * reach {
                return Err(Error::invalid(
                    format!("periodic box length along {}", AXES[d]),
                    hi[d] - lo[d],
                    format!(
                        "must be at least twice the largest diameter times (1 + skin), \
                         2 x {reach}; enlarge the box, make the axis closed or reduce \
                         Config::skin"
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The blow-up cause when the time step is over the safe bound (only possible with
    /// `Config::allow_unstable_dt`).
    fn unstable_cause(&self) -> Option<String> {
        (self.dt > self.safe_dt * (1.0 + 1e-12)).then(|| {
            format!(
                "time step too large for the contact stiffness: use dt <= {:e} (dt = {:e} \
                 was let through by Config::allow_unstable_dt)",
                self.safe_dt, self.dt
            )
        })
    }

    /// Likely cause of a non-finite position or velocity.
    pub fn non_finite_cause(&self) -> String {
        self.unstable_cause().unwrap_or_else(|| {
            format!(
                "a force overflowed although dt = {:e} is within the safe bound {:e}: check \
                 the masses, radii, velocities and contact times for extreme values",
                self.dt, self.safe_dt
            )
        })
    }

    /// Likely cause of a particle found outside the box.
    pub fn escape_cause(&self) -> String {
        let why = self.unstable_cause().unwrap_or_else(|| {
            if self.has_walls {
                "the wall contact is too soft for the impact speed (shorten the wall \
                 material's contact_time) or a wall is missing on that face \
                 (Scene::add_box_walls)"
                    .into()
            } else {
                "the scene has no walls: particles may not leave the box along a \
                 non-periodic axis; add walls (Scene::add_box_walls), make the axis \
                 periodic or enlarge the box"
                    .into()
            }
        });
        format!("particle escaped through a wall: {why}")
    }

    /// Likely cause of a contact deeper than `max_overlap`.
    pub fn overlap_cause(&self) -> String {
        self.unstable_cause().unwrap_or_else(|| {
            format!(
                "impact too fast for the contact time: a head-on impact at relative speed v \
                 reaches an overlap of about v t_c / pi; shorten the materials' contact_time \
                 or raise Config::max_overlap (now {})",
                self.max_overlap
            )
        })
    }

    /// Vertical wall displacement and velocity at time `t`.
    pub fn wall_motion(&self, t: f64) -> (f64, f64) {
        match self.vibration {
            Some(v) => wall_motion(v.amplitude, v.omega, v.omega * t),
            None => (0.0, 0.0),
        }
    }

    /// Checks the rotation and history columns of a checkpoint against the scene: 9
    /// rotation values per particle in a rotating scene (none otherwise), the law's count
    /// of history values per contact, contacts between a particle and another particle or a
    /// wall, every value finite.
    ///
    /// Errors: [`simkit_backend::Error::Checkpoint`] naming what does not fit.
    pub(crate) fn check_saved_extras(&self, s: &simkit_backend::particles::Dynamics) -> Result<()> {
        let (n, h) = (self.n, L::HISTORY);
        let bad = |what: String| {
            simkit_backend::Error::checkpoint(format!(
                "{what}; the file does not belong to this scene"
            ))
        };
        let spin = if self.rotation { 9 * n } else { 0 };
        if s.spin.len() != spin {
            return Err(bad(format!(
                "{} rotation values, expected {spin}",
                s.spin.len()
            )));
        }
        let partners = n + self.walls.len();
        if s.contacts.len().checked_mul(h) != Some(s.history.len())
            || (h == 0 && !s.contacts.is_empty())
        {
            return Err(bad(format!(
                "{} history values for {} contacts of a law with {h} per contact",
                s.history.len(),
                s.contacts.len()
            )));
        }
        if let Some(c) = s
            .contacts
            .iter()
            .find(|c| c[0] as usize >= n || c[1] as usize >= partners || c[0] == c[1])
        {
            return Err(bad(format!("contact {c:?} with {n} particles")));
        }
        if let Some(x) = s.spin.iter().chain(&s.history).find(|x| !x.is_finite()) {
            return Err(simkit_backend::Error::checkpoint(format!(
                "a stored rotation or history value is {x}; the file is corrupt"
            )));
        }
        Ok(())
    }
}
