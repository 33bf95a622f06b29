//! Scene description: particles, species-pair materials, walls, gravity, vibration, box.

use serde::{Deserialize, Serialize};
use simkit_backend::vector::IntoVec3;
use simkit_backend::{Error, Result};

use crate::ContactLaw;

/// Spatial dimension of a scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Dim {
    /// Discs in the x-y plane; the vertical axis is y.
    Two,
    /// Spheres; the vertical axis is z.
    Three,
}

impl Dim {
    /// Number of axes (2 or 3).
    pub fn axes(self) -> usize {
        match self {
            Dim::Two => 2,
            Dim::Three => 3,
        }
    }

    /// Index of the vertical axis (gravity and vibration act along it): 1 in 2D, 2 in 3D.
    pub fn vertical(self) -> usize {
        self.axes() - 1
    }
}

/// Contact parameters of a species pair or of a wall: the requested normal restitution
/// `e` and contact time `t_c`, and the friction coefficients.
///
/// The linear spring–dashpot coefficients follow from `(e, t_c)` with the reduced mass
/// (see [`crate::ContactCoefficients`]), so the requested `e` and `t_c` hold for any mass pair.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Material {
    /// Normal coefficient of restitution, in (0, 1].
    pub restitution: f64,
    /// Duration of a binary normal contact, > 0.
    pub contact_time: f64,
    /// Coulomb (static) friction coefficient: tangential force `<= mu_s |F_n|`. 0 = off.
    pub mu_s: f64,
    /// Viscous tangential coefficient: tangential force `<= mu_k m_ij |v_t|` (units of 1/time).
    pub mu_k: f64,
}

impl Material {
    /// A frictionless material with restitution `e` and contact time `t_c`.
    pub fn new(restitution: f64, contact_time: f64) -> Self {
        Self {
            restitution,
            contact_time,
            mu_s: 0.0,
            mu_k: 0.0,
        }
    }

    /// The same material with friction: tangential force
    /// `min(mu_s |F_n|, mu_k m_ij |v_t|)` opposing the tangential relative velocity.
    pub fn with_friction(mut self, mu_s: f64, mu_k: f64) -> Self {
        self.mu_s = mu_s;
        self.mu_k = mu_k;
        self
    }

    /// The checks of [`ContactLaw::validate`](crate::ContactLaw::validate).
    pub(crate) fn check(&self, what: &str) -> Result<()> {
        let e = self.restitution;
        if !(e.is_finite() && e > 0.0 && e <= 1.0) {
            return Err(Error::invalid(
                format!("{what}: restitution"),
                e,
                "must be in (0, 1]; e = 0 would need infinite damping",
            ));
        }
        let t = self.contact_time;
        if !(t.is_finite() && t > 0.0) {
            return Err(Error::invalid(
                format!("{what}: contact_time"),
                t,
                "must be finite and > 0",
            ));
        }
        for (name, v) in [("mu_s", self.mu_s), ("mu_k", self.mu_k)] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::invalid(
                    format!("{what}: {name}"),
                    v,
                    "must be finite and >= 0",
                ));
            }
        }
        Ok(())
    }
}

/// One particle: a solid disc (2D) or sphere (3D); it spins only in a scene with
/// [`Scene::set_rotation`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Particle {
    /// Position (in 2D the z component must be 0).
    pub position: [f64; 3],
    /// Velocity (in 2D the z component must be 0).
    pub velocity: [f64; 3],
    /// Radius, > 0.
    pub radius: f64,
    /// Mass, > 0.
    pub mass: f64,
    /// Species index, < the scene's species count.
    pub species: u32,
    /// Angular velocity (in 2D only z; read only in a rotating scene).
    #[serde(default)]
    pub angular_velocity: [f64; 3],
}

impl Particle {
    /// A particle at rest of species 0. `position` is any [`IntoVec3`]: a `glam` vector
    /// (`DVec3`, `Vec3`, `DVec2`, `Vec2`) or an array; 2D values get `z = 0`.
    pub fn new(position: impl IntoVec3, radius: f64, mass: f64) -> Self {
        Self {
            position: position.into_vec3(),
            velocity: [0.0; 3],
            radius,
            mass,
            species: 0,
            angular_velocity: [0.0; 3],
        }
    }

    /// The same particle spinning at `omega` (any [`IntoVec3`]; in 2D only z may be
    /// non-zero).
    pub fn with_angular_velocity(mut self, omega: impl IntoVec3) -> Self {
        self.angular_velocity = omega.into_vec3();
        self
    }

    /// The same particle with a velocity (any [`IntoVec3`]).
    pub fn with_velocity(mut self, velocity: impl IntoVec3) -> Self {
        self.velocity = velocity.into_vec3();
        self
    }

    /// The same particle with a species index.
    pub fn with_species(mut self, species: u32) -> Self {
        self.species = species;
        self
    }
}

/// Geometry of a wall.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum WallShape {
    /// The plane `normal . x = offset`; particles live on the side the unit `normal` points
    /// to (`normal . x > offset`).
    Plane {
        /// Unit normal pointing into the particle region.
        normal: [f64; 3],
        /// Plane offset along the normal.
        offset: f64,
    },
    /// A cylinder with its axis along z through `center`, particles inside: in 3D a
    /// vertical side wall (the contact treats the wall as a sphere of radius `radius`
    /// centred on the axis at the particle's height: overlap `rho + R - radius`), in 2D a
    /// circle (a drum whose axis is normal to the plane).
    Cylinder {
        /// Axis position (x, y).
        center: [f64; 2],
        /// Inner radius.
        radius: f64,
    },
}

/// A wall with its own contact material (parameters of the scene's [`ContactLaw`]); it may
/// follow the container vibration.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(bound = "L: ContactLaw")]
pub struct Wall<L = Material> {
    /// Geometry at rest (time 0 without vibration offset).
    pub shape: WallShape,
    /// Contact parameters against every species (wall mass is infinite: `m_ij = m_i`).
    pub material: L,
    /// Whether the wall moves with the scene's [`Vibration`].
    pub vibrating: bool,
    /// Angular velocity of a cylinder wall about its axis (counter-clockwise seen from +z;
    /// 0 for a plane): the wall keeps its place and its surface moves at
    /// `spin * radius` ([`crate::cylinder_surface_velocity`]), as the shell of a rotating
    /// drum.
    #[serde(default)]
    pub spin: f64,
}

impl<L: ContactLaw> Wall<L> {
    /// A fixed plane through `point` with unit inward `normal` (normalised here).
    pub fn plane(normal: [f64; 3], point: [f64; 3], material: L) -> Self {
        let len = (normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2]).sqrt();
        let n = if len > 0.0 {
            normal.map(|c| c / len)
        } else {
            normal
        };
        let offset = n[0] * point[0] + n[1] * point[1] + n[2] * point[2];
        Self {
            shape: WallShape::Plane { normal: n, offset },
            material,
            vibrating: false,
            spin: 0.0,
        }
    }

    /// A fixed cylinder wall with its axis along z through `center`, particles inside: a
    /// vertical side wall in 3D, a circle in 2D.
    pub fn cylinder(center: [f64; 2], radius: f64, material: L) -> Self {
        Self {
            shape: WallShape::Cylinder { center, radius },
            material,
            vibrating: false,
            spin: 0.0,
        }
    }

    /// The same cylinder wall turning about its axis at `spin` radians per time unit
    /// (counter-clockwise seen from +z): a rotating drum in 2D. [`Scene::add_wall`] refuses
    /// a spin on a plane or one that is not finite.
    pub fn spinning(mut self, spin: f64) -> Self {
        self.spin = spin;
        self
    }

    /// The same wall, moving with the container vibration.
    pub fn vibrating(mut self) -> Self {
        self.vibrating = true;
        self
    }
}

/// Sinusoidal vertical motion of the container: `z_w(t) = -A cos(omega t)`,
/// velocity `A omega sin(omega t)`; vibration strength `Gamma = A omega^2 / g`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Vibration {
    /// Amplitude `A`.
    pub amplitude: f64,
    /// Angular frequency `omega`.
    pub omega: f64,
}

impl Vibration {
    /// Displacement of the vibrating walls at time `t`.
    pub fn displacement(&self, t: f64) -> f64 {
        crate::wall_motion(self.amplitude, self.omega, self.omega * t).0
    }

    /// Velocity of the vibrating walls at time `t`.
    pub fn velocity(&self, t: f64) -> f64 {
        crate::wall_motion(self.amplitude, self.omega, self.omega * t).1
    }
}

/// A complete scene: box, particles, species-pair materials, walls and body forces.
///
/// Everything beyond bare particles is opt-in: friction (a material with `mu_s, mu_k > 0`),
/// gravity, walls, vibration and periodic axes cost nothing when absent (the backends
/// select kernel variants once).
///
/// ```
/// use simkit_dem::{Dim, Material, Particle, Scene};
/// # fn main() -> simkit_backend::Result<()> {
/// let mut scene = Scene::new(Dim::Two, [0.0; 3], [10.0, 10.0, 0.0], Material::new(0.9, 0.01))?;
/// scene.set_gravity(1.0)?;
/// scene.add_box_walls(Material::new(0.8, 0.01), true)?;
/// scene.add_particle(Particle::new([5.0, 1.0, 0.0], 0.5, 1.0))?;
/// assert_eq!(scene.particles().len(), 1);
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Scene<L = Material> {
    dim: Dim,
    lo: [f64; 3],
    hi: [f64; 3],
    periodic: [bool; 3],
    n_species: usize,
    pairs: Vec<L>,
    particles: Vec<Particle>,
    walls: Vec<Wall<L>>,
    gravity: f64,
    vibration: Option<Vibration>,
    rotation: bool,
}

const AXES: [&str; 3] = ["x", "y", "z"];

/// The fields of a [`Scene`] as a checkpoint stores them; [`Scene::from_record`] rebuilds
/// the scene through the validating builders.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(bound = "L: ContactLaw")]
pub(crate) struct SceneRecord<L> {
    dim: Dim,
    lo: [f64; 3],
    hi: [f64; 3],
    periodic: [bool; 3],
    n_species: usize,
    pairs: Vec<L>,
    particles: Vec<Particle>,
    walls: Vec<Wall<L>>,
    gravity: f64,
    vibration: Option<Vibration>,
    #[serde(default)]
    rotation: bool,
}

impl<L: ContactLaw> Scene<L> {
    /// An empty scene in the box `[lo, hi]` (z ignored in 2D) with one species whose
    /// particle–particle contacts use `material` (the parameters of the contact law `L`:
    /// [`Material`] for the linear spring–dashpot). No axis is periodic, there are no walls
    /// (add them, or particles leaving the box are clamped into its edge cells for the
    /// neighbour search only) and no gravity. The corners are any [`IntoVec3`] (`glam`
    /// vectors or arrays).
    pub fn new(dim: Dim, lo: impl IntoVec3, hi: impl IntoVec3, material: L) -> Result<Self> {
        let (lo, hi) = (lo.into_vec3(), hi.into_vec3());
        let is_default = std::any::TypeId::of::<L>() == std::any::TypeId::of::<Material>();
        simkit_backend::checkpoint::check_law_name(L::NAME, Material::NAME, is_default)?;
        material.validate("particle material")?;
        for d in 0..dim.axes() {
            if !(lo[d].is_finite() && hi[d].is_finite() && hi[d] > lo[d]) {
                return Err(Error::invalid(
                    format!("box along {}", AXES[d]),
                    format!("[{}, {}]", lo[d], hi[d]),
                    "bounds must be finite with hi > lo",
                ));
            }
        }
        Ok(Self {
            dim,
            lo,
            hi,
            periodic: [false; 3],
            n_species: 1,
            pairs: vec![material],
            particles: Vec::new(),
            walls: Vec::new(),
            gravity: 0.0,
            vibration: None,
            rotation: false,
        })
    }

    /// Lets the particles spin: each gets an angular velocity (2D: about z; 3D: three
    /// components) driven by the torques of its contacts, integrated with the velocity
    /// Verlet scheme of the translation (half kick, predicted angular velocity at the force
    /// time, second half kick, as LAMMPS `fix nve/sphere`), with the moment of inertia of a
    /// solid disc or sphere ([`crate::moment_of_inertia`]). Off by default: a scene without
    /// it pays nothing for rotation. Both backends of [`crate::Dem`] and
    /// [`crate::DistributedDem`]; velocity Verlet only.
    pub fn set_rotation(&mut self, on: bool) -> &mut Self {
        self.rotation = on;
        self
    }

    /// Whether the particles spin ([`set_rotation`](Self::set_rotation)).
    pub fn rotation(&self) -> bool {
        self.rotation
    }

    /// Makes the given axes periodic (in 2D the z flag is ignored). Periodic axes must not
    /// be the vertical axis of a vibrating scene.
    pub fn set_periodic(&mut self, periodic: [bool; 3]) -> &mut Self {
        self.periodic = periodic;
        if self.dim == Dim::Two {
            self.periodic[2] = false;
        }
        self
    }

    /// Sets the number of species; every pair starts with `material` (replace pairs with
    /// [`set_pair`](Self::set_pair)).
    pub fn set_species(&mut self, count: usize, material: L) -> Result<&mut Self> {
        if count == 0 || count > 64 {
            return Err(Error::invalid("species count", count, "must be in 1..=64"));
        }
        material.validate("species material")?;
        self.n_species = count;
        self.pairs = vec![material; count * count];
        Ok(self)
    }

    /// Sets the material of species pair `(a, b)` (and `(b, a)`: the table is symmetric).
    pub fn set_pair(&mut self, a: u32, b: u32, material: L) -> Result<&mut Self> {
        let n = self.n_species;
        if a as usize >= n || b as usize >= n {
            return Err(Error::invalid(
                "species pair",
                format!("({a}, {b})"),
                format!("species must be < {n}; call set_species first"),
            ));
        }
        material.validate(&format!("material of pair ({a}, {b})"))?;
        self.pairs[pair_index(a, b, n)] = material;
        self.pairs[pair_index(b, a, n)] = material;
        Ok(self)
    }

    /// Gravity of magnitude `g` along minus the vertical axis (y in 2D, z in 3D).
    pub fn set_gravity(&mut self, g: f64) -> Result<&mut Self> {
        simkit_backend::require_non_negative("gravity", g)?;
        self.gravity = g;
        Ok(self)
    }

    /// Vibrates the walls marked [`Wall::vibrating`]: `z_w(t) = -A cos(omega t)`.
    pub fn set_vibration(&mut self, amplitude: f64, omega: f64) -> Result<&mut Self> {
        simkit_backend::require_non_negative("vibration amplitude", amplitude)?;
        simkit_backend::require_positive("vibration omega", omega)?;
        self.vibration = Some(Vibration { amplitude, omega });
        Ok(self)
    }

    /// Adds a wall.
    pub fn add_wall(&mut self, wall: Wall<L>) -> Result<&mut Self> {
        wall.material
            .validate(&format!("wall {} material", self.walls.len()))?;
        match wall.shape {
            WallShape::Plane { normal, offset } => {
                let len2: f64 = normal.iter().map(|c| c * c).sum();
                if !(len2.is_finite() && (len2 - 1.0).abs() < 1e-9 && offset.is_finite()) {
                    return Err(Error::invalid(
                        "wall plane normal",
                        format!("{normal:?}"),
                        "must be a finite non-zero vector (Wall::plane normalises it)",
                    ));
                }
                if self.dim == Dim::Two && normal[2] != 0.0 {
                    return Err(Error::invalid(
                        "wall plane normal",
                        format!("{normal:?}"),
                        "z must be 0 in 2D",
                    ));
                }
            }
            WallShape::Cylinder { center, radius } => {
                if !(center[0].is_finite()
                    && center[1].is_finite()
                    && radius.is_finite()
                    && radius > 0.0)
                {
                    return Err(Error::invalid(
                        "cylinder wall",
                        format!("center {center:?}, radius {radius}"),
                        "must be finite with radius > 0",
                    ));
                }
            }
        }
        if !wall.spin.is_finite() {
            return Err(Error::invalid(
                "wall spin",
                wall.spin,
                "must be finite (radians per time unit)",
            ));
        }
        if wall.spin != 0.0 && matches!(wall.shape, WallShape::Plane { .. }) {
            return Err(Error::invalid(
                "wall spin",
                wall.spin,
                "only a cylinder wall can spin (Wall::cylinder(..).spinning(spin)); a plane \
                 must have spin 0",
            ));
        }
        self.walls.push(wall);
        Ok(self)
    }

    /// Adds plane walls on every non-periodic face of the box (2 per axis), vibrating with
    /// the container when `vibrating`.
    pub fn add_box_walls(&mut self, material: L, vibrating: bool) -> Result<&mut Self> {
        for d in 0..self.dim.axes() {
            if self.periodic[d] {
                continue;
            }
            let mut n = [0.0; 3];
            n[d] = 1.0;
            let mut w = Wall::plane(n, self.lo, material);
            w.vibrating = vibrating;
            self.add_wall(w)?;
            n[d] = -1.0;
            let mut w = Wall::plane(n, self.hi, material);
            w.vibrating = vibrating;
            self.add_wall(w)?;
        }
        Ok(self)
    }

    /// Adds a particle (validated here: finite values, positive radius and mass, known
    /// species, z = 0 in 2D).
    pub fn add_particle(&mut self, p: Particle) -> Result<&mut Self> {
        let i = self.particles.len();
        for ((axis, &x), &v) in AXES.iter().zip(&p.position).zip(&p.velocity) {
            simkit_backend::require_finite(&format!("particle[{i}].position.{axis}"), x)?;
            simkit_backend::require_finite(&format!("particle[{i}].velocity.{axis}"), v)?;
        }
        if self.dim == Dim::Two && (p.position[2] != 0.0 || p.velocity[2] != 0.0) {
            return Err(Error::invalid(
                format!("particle[{i}] z"),
                p.position[2],
                "2D scenes need z = 0 and v_z = 0",
            ));
        }
        for (axis, &w) in AXES.iter().zip(&p.angular_velocity) {
            simkit_backend::require_finite(&format!("particle[{i}].angular_velocity.{axis}"), w)?;
        }
        if self.dim == Dim::Two && (p.angular_velocity[0] != 0.0 || p.angular_velocity[1] != 0.0) {
            return Err(Error::invalid(
                format!("particle[{i}] angular velocity"),
                format!("{:?}", p.angular_velocity),
                "discs in 2D spin about z only: x and y must be 0",
            ));
        }
        simkit_backend::require_positive(&format!("particle[{i}].radius"), p.radius)?;
        simkit_backend::require_positive(&format!("particle[{i}].mass"), p.mass)?;
        if p.species as usize >= self.n_species {
            return Err(Error::invalid(
                format!("particle[{i}].species"),
                p.species,
                format!("must be < the species count {}", self.n_species),
            ));
        }
        self.particles.push(p);
        Ok(self)
    }

    /// Replaces the particles' positions and velocities (e.g. to restart from a
    /// [`crate::State`]); counts must match.
    pub fn set_kinematics(
        &mut self,
        positions: &[[f64; 3]],
        velocities: &[[f64; 3]],
    ) -> Result<()> {
        let n = self.particles.len();
        if positions.len() != n || velocities.len() != n {
            return Err(Error::invalid(
                "kinematics length",
                format!(
                    "{} positions, {} velocities",
                    positions.len(),
                    velocities.len()
                ),
                format!("must both equal the particle count {n}"),
            ));
        }
        let old = std::mem::take(&mut self.particles);
        for (k, p) in old.into_iter().enumerate() {
            self.add_particle(Particle {
                position: positions[k],
                velocity: velocities[k],
                ..p
            })?;
        }
        Ok(())
    }

    /// Dimension.
    pub fn dim(&self) -> Dim {
        self.dim
    }
    /// Lower box corner.
    pub fn lo(&self) -> [f64; 3] {
        self.lo
    }
    /// Upper box corner.
    pub fn hi(&self) -> [f64; 3] {
        self.hi
    }
    /// Periodic axes.
    pub fn periodic(&self) -> [bool; 3] {
        self.periodic
    }
    /// Number of species.
    pub fn species_count(&self) -> usize {
        self.n_species
    }
    /// Material of species pair `(a, b)` (symmetric).
    ///
    /// # Errors
    ///
    /// [`Error::InvalidParameter`] naming the pair when `a` or `b` is not below
    /// [`species_count`](Self::species_count).
    pub fn pair(&self, a: u32, b: u32) -> Result<L> {
        let n = self.n_species;
        if a as usize >= n || b as usize >= n {
            return Err(Error::invalid(
                "species pair",
                format!("({a}, {b})"),
                format!("species must be < the species count {n}"),
            ));
        }
        Ok(self.pairs[pair_index(a, b, n)])
    }
    /// The full species-pair table, row-major `n x n`, symmetric.
    pub fn pair_table(&self) -> &[L] {
        &self.pairs
    }
    /// Particles.
    pub fn particles(&self) -> &[Particle] {
        &self.particles
    }
    /// Walls.
    pub fn walls(&self) -> &[Wall<L>] {
        &self.walls
    }
    /// Gravity magnitude (0 = off).
    pub fn gravity(&self) -> f64 {
        self.gravity
    }
    /// Container vibration, if any.
    pub fn vibration(&self) -> Option<Vibration> {
        self.vibration
    }

    /// Whether any pair or wall material has friction.
    pub fn has_friction(&self) -> bool {
        self.pairs.iter().any(L::has_friction)
            || self.walls.iter().any(|w| w.material.has_friction())
    }

    /// Largest particle radius (0 without particles).
    pub fn max_radius(&self) -> f64 {
        self.particles.iter().map(|p| p.radius).fold(0.0, f64::max)
    }

    /// Shortest contact time of any pair or wall material ([`ContactLaw::contact_time`] at
    /// each material's lightest reduced mass and smallest effective radius).
    pub fn min_contact_time(&self) -> f64 {
        self.contact_scales()
            .map(|(law, m, r)| law.contact_time(m, r))
            .fold(f64::INFINITY, f64::min)
    }

    /// Every material of the scene with the reduced mass and effective radius of its
    /// lightest and smallest contact: for species pair `(a, b)` those of the lightest and
    /// the smallest particles of `a` and `b`; for a wall, of the lightest and the smallest
    /// particle (species without particles are skipped).
    pub(crate) fn contact_scales(&self) -> impl Iterator<Item = (&L, f64, f64)> {
        let n = self.n_species;
        let mut lightest = vec![f64::INFINITY; n];
        let mut smallest = vec![f64::INFINITY; n];
        for p in &self.particles {
            let s = p.species as usize;
            lightest[s] = lightest[s].min(p.mass);
            smallest[s] = smallest[s].min(p.radius);
        }
        let m_min = lightest.iter().copied().fold(f64::INFINITY, f64::min);
        let r_min = smallest.iter().copied().fold(f64::INFINITY, f64::min);
        let pairs = (0..n * n).filter_map(move |k| {
            let (a, b) = (k / n, k % n);
            let (ma, mb, ra, rb) = (lightest[a], lightest[b], smallest[a], smallest[b]);
            (ma.is_finite() && mb.is_finite())
                .then(|| (&self.pairs[k], ma * mb / (ma + mb), ra * rb / (ra + rb)))
        });
        let walls = self
            .walls
            .iter()
            .filter(move |_| m_min.is_finite())
            .map(move |w| (&w.material, m_min, r_min));
        pairs.chain(walls)
    }

    /// The scene as a checkpoint stores it.
    pub(crate) fn to_record(&self) -> SceneRecord<L> {
        SceneRecord {
            dim: self.dim,
            lo: self.lo,
            hi: self.hi,
            periodic: self.periodic,
            n_species: self.n_species,
            pairs: self.pairs.clone(),
            particles: self.particles.clone(),
            walls: self.walls.clone(),
            gravity: self.gravity,
            vibration: self.vibration,
            rotation: self.rotation,
        }
    }

    /// Rebuilds a scene from a checkpoint record through the builders, so it is validated
    /// exactly as one built by hand.
    pub(crate) fn from_record(r: SceneRecord<L>) -> Result<Self> {
        let first = *r.pairs.first().ok_or_else(|| {
            Error::invalid(
                "species-pair table",
                "empty",
                "must hold n_species^2 materials",
            )
        })?;
        let n = r.n_species;
        if n.checked_mul(n) != Some(r.pairs.len()) {
            return Err(Error::invalid(
                "species-pair table",
                format!("{} materials for {n} species", r.pairs.len()),
                "must hold n_species^2 materials",
            ));
        }
        let mut s = Scene::new(r.dim, r.lo, r.hi, first)?;
        s.set_periodic(r.periodic);
        s.set_species(n, first)?;
        for a in 0..n {
            for b in a..n {
                let m = r.pairs[pair_index(a as u32, b as u32, n)];
                if m != r.pairs[pair_index(b as u32, a as u32, n)] {
                    return Err(Error::invalid(
                        format!("species pair ({a}, {b})"),
                        "asymmetric",
                        "the pair table must be symmetric",
                    ));
                }
                s.set_pair(a as u32, b as u32, m)?;
            }
        }
        s.set_gravity(r.gravity)?;
        s.set_rotation(r.rotation);
        if let Some(v) = r.vibration {
            s.set_vibration(v.amplitude, v.omega)?;
        }
        for w in r.walls {
            s.add_wall(w)?;
        }
        for p in r.particles {
            s.add_particle(p)?;
        }
        Ok(s)
    }

    pub(crate) fn check_ready(&self) -> Result<()> {
        if self.particles.is_empty() {
            return Err(Error::invalid(
                "particle count",
                0,
                "add at least one particle",
            ));
        }
        if let Some(v) = self.vibration
            && self.periodic[self.dim.vertical()]
            && v.amplitude > 0.0
        {
            return Err(Error::invalid(
                "periodic axes",
                format!("{:?}", self.periodic),
                "the vertical axis of a vibrating scene cannot be periodic",
            ));
        }
        Ok(())
    }
}

/// Index of species pair `(a, b)` in the row-major `n x n` table. The table is stored
/// symmetric (both triangles), so the lookup needs no `min`/`max` or branch.
#[inline(always)]
pub fn pair_index(a: u32, b: u32, n: usize) -> usize {
    a as usize * n + b as usize
}
