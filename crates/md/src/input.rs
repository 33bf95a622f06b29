//! The input: box, species, pair table and particles.

use serde::{Deserialize, Serialize};
use simkit_backend::vector::IntoVec3;
use simkit_backend::{Error, Result};

use crate::{LennardJones, PairLaw, PairTable};

/// Most particles a [`System`] holds (indices are `u32`).
pub const MAX_PARTICLES: usize = 1 << 28;

/// Dimension of the box.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Dim {
    /// Two dimensions (`z` coordinates and velocities must be 0).
    Two,
    /// Three dimensions (default).
    #[default]
    Three,
}

impl Dim {
    /// 2 or 3.
    pub fn axes(self) -> usize {
        match self {
            Dim::Two => 2,
            Dim::Three => 3,
        }
    }
}

const AXES: [&str; 3] = ["x", "y", "z"];

/// A box `[lo, lo + len)` with periodic or closed (reflecting) axes, the species (masses
/// and the [`PairTable`]) and the particles (species, position, velocity).
///
/// ```
/// use simkit_md::{Dim, LennardJones, PairTable, System};
/// # fn main() -> simkit_backend::Result<()> {
/// let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5))?;
/// let mut sys = System::new(Dim::Three, [0.0; 3], [6.0; 3], [true; 3], vec![1.0], table)?;
/// sys.add_particle(0, [1.0, 1.0, 1.0], [0.0; 3])?;
/// assert!(sys.add_particle(0, [7.0, 1.0, 1.0], [0.0; 3]).is_err()); // outside the box
/// assert!(sys.add_particle(1, [2.0, 1.0, 1.0], [0.0; 3]).is_err()); // no species 1
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct System<L = LennardJones> {
    dim: Dim,
    lo: [f64; 3],
    len: [f64; 3],
    periodic: [bool; 3],
    masses: Vec<f64>,
    table: PairTable<L>,
    frozen: Vec<bool>,
    species_langevin: Vec<Option<[f64; 2]>>,
    species: Vec<u32>,
    positions: Vec<[f64; 3]>,
    velocities: Vec<[f64; 3]>,
}

impl<L: PairLaw> System<L> {
    /// An empty system. In 2D only `x` and `y` of `lo`, `len` and `periodic` are used;
    /// `lo` and `len` are any [`IntoVec3`] (`glam` vectors or arrays).
    ///
    /// Errors: non-finite `lo`, non-positive or non-finite lengths, a mass count other than
    /// the table's species count, a non-positive or non-finite mass, or a periodic length
    /// shorter than twice the largest cutoff (a pair would then interact through two
    /// images).
    pub fn new(
        dim: Dim,
        lo: impl IntoVec3,
        len: impl IntoVec3,
        periodic: [bool; 3],
        masses: Vec<f64>,
        table: PairTable<L>,
    ) -> Result<Self> {
        let (lo, len) = (lo.into_vec3(), len.into_vec3());
        let n_species = masses.len();
        let mut s = Self {
            dim,
            lo,
            len,
            periodic,
            masses,
            table,
            frozen: vec![false; n_species],
            species_langevin: vec![None; n_species],
            species: Vec::new(),
            positions: Vec::new(),
            velocities: Vec::new(),
        };
        if dim == Dim::Two {
            s.lo[2] = 0.0;
            s.len[2] = 1.0;
            s.periodic[2] = false;
        }
        s.validate_setup()?;
        Ok(s)
    }

    fn validate_setup(&self) -> Result<()> {
        self.table.validate()?;
        let axes = self.dim.axes();
        let rc = self.table.max_cutoff();
        for (d, axis) in AXES.iter().enumerate().take(axes) {
            if !self.lo[d].is_finite() {
                return Err(Error::invalid(
                    format!("box origin {axis}"),
                    self.lo[d],
                    "must be finite",
                ));
            }
            let l = self.len[d];
            if !(l.is_finite() && l > 0.0 && (self.lo[d] + l).is_finite()) {
                return Err(Error::invalid(
                    format!("box length {axis}"),
                    l,
                    "must be finite and > 0",
                ));
            }
            if self.periodic[d] && l < 2.0 * rc {
                return Err(Error::invalid(
                    format!("periodic box length {axis}"),
                    l,
                    format!(
                        "must be at least twice the largest cutoff (2 x {rc}); enlarge the box \
                         or shorten the cutoffs"
                    ),
                ));
            }
        }
        if self.masses.len() != self.table.n_species() {
            return Err(Error::invalid(
                "mass count",
                self.masses.len(),
                format!(
                    "must equal the pair table's species count {}",
                    self.table.n_species()
                ),
            ));
        }
        for (s, &m) in self.masses.iter().enumerate() {
            if !(m.is_finite() && m > 0.0 && m < 1e30) {
                return Err(Error::invalid(
                    format!("mass of species {s}"),
                    m,
                    "must be finite, > 0 and < 1e30",
                ));
            }
        }
        if self.frozen.len() != self.masses.len()
            || self.species_langevin.len() != self.masses.len()
        {
            return Err(Error::invalid(
                "per-species settings",
                format!(
                    "{} frozen flags, {} thermostat targets",
                    self.frozen.len(),
                    self.species_langevin.len()
                ),
                format!("must be one per species ({})", self.masses.len()),
            ));
        }
        for (s, t) in self.species_langevin.iter().enumerate() {
            if let Some([t, g]) = *t {
                check_target(&format!("species {s}"), t, g)?;
            }
        }
        Ok(())
    }

    fn check_species(&self, species: u32) -> Result<usize> {
        let s = species as usize;
        if s >= self.masses.len() {
            return Err(Error::invalid(
                "species",
                species,
                format!("must be below the species count {}", self.masses.len()),
            ));
        }
        Ok(s)
    }

    /// Freezes (`true`) or releases a species: the particles of a frozen species do not
    /// move (positions fixed bit for bit, velocities zero whatever the system holds, the
    /// forces on them not integrated and no thermostat noise) but still exert forces on
    /// the others, like a solid substrate.
    ///
    /// Errors: an unknown species.
    pub fn set_frozen(&mut self, species: u32, frozen: bool) -> Result<()> {
        let s = self.check_species(species)?;
        self.frozen[s] = frozen;
        Ok(())
    }

    /// Gives species `species` its own Langevin target temperature and friction (used when
    /// [`crate::Config::thermostat`] is on, in place of its global target; `gamma = 0`
    /// leaves the species Newtonian). `None` returns it to the global target.
    ///
    /// Errors: an unknown species, a negative or non-finite temperature or friction (or
    /// above `1e30`).
    pub fn set_species_langevin(&mut self, species: u32, target: Option<[f64; 2]>) -> Result<()> {
        let s = self.check_species(species)?;
        if let Some([t, g]) = target {
            check_target(&format!("species {s}"), t, g)?;
        }
        self.species_langevin[s] = target;
        Ok(())
    }

    /// Per-species frozen flags ([`set_frozen`](Self::set_frozen)).
    pub fn frozen(&self) -> &[bool] {
        &self.frozen
    }

    /// Per-species Langevin targets `[temperature, gamma]`
    /// ([`set_species_langevin`](Self::set_species_langevin)).
    pub fn species_langevin(&self) -> &[Option<[f64; 2]>] {
        &self.species_langevin
    }

    fn check_particle(&self, i: usize, s: u32, x: [f64; 3], v: [f64; 3]) -> Result<()> {
        if s as usize >= self.masses.len() {
            return Err(Error::invalid(
                format!("species of particle {i}"),
                s,
                format!("must be below the species count {}", self.masses.len()),
            ));
        }
        for d in 0..3 {
            if d >= self.dim.axes() {
                if x[d] != 0.0 || v[d] != 0.0 {
                    return Err(Error::invalid(
                        format!("particle {i} z"),
                        format!("position {}, velocity {}", x[d], v[d]),
                        "must be 0 in a 2D system",
                    ));
                }
                continue;
            }
            let (lo, hi) = (self.lo[d], self.lo[d] + self.len[d]);
            if !(x[d] >= lo && x[d] < hi) {
                return Err(Error::invalid(
                    format!("particle {i} position {}", AXES[d]),
                    x[d],
                    format!("must lie in the box [{lo}, {hi})"),
                ));
            }
            if !(v[d].is_finite() && v[d].abs() < 1e15) {
                return Err(Error::invalid(
                    format!("particle {i} velocity {}", AXES[d]),
                    v[d],
                    "must be finite and below 1e15 in magnitude",
                ));
            }
        }
        Ok(())
    }

    /// Adds a particle of species `species` and returns its index. `position` and
    /// `velocity` are any [`IntoVec3`]: `glam` vectors (`DVec3`, `Vec3`, `DVec2`, `Vec2`) or
    /// arrays; 2D values get `z = 0`.
    ///
    /// Errors: an unknown species, a position outside the box (or non-finite), a
    /// non-finite velocity, non-zero `z` in 2D, more than [`MAX_PARTICLES`] particles.
    pub fn add_particle(
        &mut self,
        species: u32,
        position: impl IntoVec3,
        velocity: impl IntoVec3,
    ) -> Result<usize> {
        let (position, velocity) = (position.into_vec3(), velocity.into_vec3());
        let i = self.species.len();
        if i >= MAX_PARTICLES {
            return Err(Error::invalid(
                "particle count",
                i + 1,
                format!("at most {MAX_PARTICLES}"),
            ));
        }
        self.check_particle(i, species, position, velocity)?;
        self.species.push(species);
        self.positions.push(position);
        self.velocities.push(velocity);
        Ok(i)
    }

    /// Replaces all particles (lengths are checked before anything is allocated).
    ///
    /// Errors: slices of different lengths, more than [`MAX_PARTICLES`], or any particle
    /// [`add_particle`](Self::add_particle) refuses; the system is unchanged on error.
    pub fn set_particles(
        &mut self,
        species: &[u32],
        positions: &[[f64; 3]],
        velocities: &[[f64; 3]],
    ) -> Result<()> {
        let n = species.len();
        if positions.len() != n || velocities.len() != n {
            return Err(Error::invalid(
                "particle arrays",
                format!(
                    "{n} species, {} positions, {} velocities",
                    positions.len(),
                    velocities.len()
                ),
                "must have the same length",
            ));
        }
        if n > MAX_PARTICLES {
            return Err(Error::invalid(
                "particle count",
                n,
                format!("at most {MAX_PARTICLES}"),
            ));
        }
        for i in 0..n {
            self.check_particle(i, species[i], positions[i], velocities[i])?;
        }
        self.species = species.to_vec();
        self.positions = positions.to_vec();
        self.velocities = velocities.to_vec();
        Ok(())
    }

    /// Checks everything (used on checkpoint resume).
    pub(crate) fn validate(&self) -> Result<()> {
        self.validate_setup()?;
        let n = self.species.len();
        if self.positions.len() != n || self.velocities.len() != n || n > MAX_PARTICLES {
            return Err(Error::invalid(
                "particle arrays",
                n,
                "lengths differ or exceed MAX_PARTICLES",
            ));
        }
        for i in 0..n {
            self.check_particle(i, self.species[i], self.positions[i], self.velocities[i])?;
        }
        Ok(())
    }

    /// The dimension.
    pub fn dim(&self) -> Dim {
        self.dim
    }
    /// Lower box corner.
    pub fn lo(&self) -> [f64; 3] {
        self.lo
    }
    /// Box lengths.
    pub fn lengths(&self) -> [f64; 3] {
        self.len
    }
    /// Periodic axes (the others reflect).
    pub fn periodic(&self) -> [bool; 3] {
        self.periodic
    }
    /// Box volume (area in 2D).
    pub fn volume(&self) -> f64 {
        self.len[..self.dim.axes()].iter().product()
    }
    /// Species masses.
    pub fn masses(&self) -> &[f64] {
        &self.masses
    }
    /// The pair table.
    pub fn table(&self) -> &PairTable<L> {
        &self.table
    }
    /// Number of particles.
    pub fn particle_count(&self) -> usize {
        self.species.len()
    }
    /// Whether the system holds no particle.
    pub fn is_empty(&self) -> bool {
        self.species.is_empty()
    }
    /// Species of every particle.
    pub fn species(&self) -> &[u32] {
        &self.species
    }
    /// Positions.
    pub fn positions(&self) -> &[[f64; 3]] {
        &self.positions
    }
    /// Velocities.
    pub fn velocities(&self) -> &[[f64; 3]] {
        &self.velocities
    }
}

/// Checks a target temperature and friction.
pub(crate) fn check_target(what: &str, temperature: f64, gamma: f64) -> Result<()> {
    if !(temperature.is_finite() && (0.0..=1e30).contains(&temperature)) {
        return Err(Error::invalid(
            format!("{what} temperature"),
            temperature,
            "must be finite, >= 0 and <= 1e30",
        ));
    }
    if !(gamma.is_finite() && (0.0..=1e30).contains(&gamma)) {
        return Err(Error::invalid(
            format!("{what} friction gamma"),
            gamma,
            "must be finite, >= 0 and <= 1e30",
        ));
    }
    Ok(())
}
