//! Particles with per-particle charge and mass, species, and seeded initial conditions.

use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};
use simkit_backend::vector::IntoVec3;
use simkit_backend::{Error, Result, require_finite, require_positive};

/// Positions and velocities of a state, in f64.
pub(crate) type PositionsVelocities = (Vec<[f64; 3]>, Vec<[f64; 3]>);

/// A particle species: normalised charge and mass.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Species {
    /// Name, e.g. `"electron"`.
    pub name: String,
    /// Normalised charge (units of the charge unit; may be negative).
    pub charge: f64,
    /// Normalised mass (> 0).
    pub mass: f64,
}

impl Species {
    /// A species with the given name, charge and mass.
    pub fn new(name: impl Into<String>, charge: f64, mass: f64) -> Self {
        Self {
            name: name.into(),
            charge,
            mass,
        }
    }
}

/// Where [`Particles::fill`] places particles (uniformly at random).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Region {
    /// The cube `[min, min + length)^3`.
    Cube {
        /// Lower corner.
        min: [f64; 3],
        /// Edge length (> 0).
        length: f64,
    },
    /// The ball of the given centre and radius.
    Sphere {
        /// Centre.
        center: [f64; 3],
        /// Radius (> 0).
        radius: f64,
    },
}

/// Velocity distribution of [`Particles::fill`]; the mean of each fill is removed exactly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Velocities {
    /// All velocities zero.
    Cold,
    /// Maxwellian: each component normal with standard deviation `thermal_speed`.
    Maxwellian {
        /// Standard deviation of each component.
        thermal_speed: f64,
    },
    /// Each component uniform in `[-half_width, half_width)`.
    Uniform {
        /// Half-width of the interval.
        half_width: f64,
    },
}

/// The most particles one [`Particles`] may hold: 2^26 = 67,108,864, about 4.6 GB of host
/// arrays at 68 bytes a particle. The all-pairs force sum costs `N^2` pair terms a step, so
/// this is already far past any practical run; [`Particles::fill`] and
/// [`Particles::push`] refuse to grow past it.
pub const MAX_PARTICLES: usize = 1 << 26;

/// Host bytes per particle: position, velocity, charge, mass and species index.
const BYTES_PER_PARTICLE: usize =
    2 * size_of::<[f64; 3]>() + 2 * size_of::<f64>() + size_of::<u32>();

/// Particles in structure-of-arrays form (host side, f64).
///
/// The columns are public for direct building and editing; everything that takes a
/// `Particles` (the simulations' constructors, [`potential_energy`](crate::potential_energy),
/// [`reference_accelerations`](crate::reference_accelerations) and
/// [`diagnostics`](fn@crate::diagnostics)) checks it with [`Particles::validate`] first, so
/// columns of different lengths or a bad value are an error there, never an index out of
/// bounds.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Particles {
    /// Positions.
    pub position: Vec<[f64; 3]>,
    /// Velocities.
    pub velocity: Vec<[f64; 3]>,
    /// Per-particle charge.
    pub charge: Vec<f64>,
    /// Per-particle mass.
    pub mass: Vec<f64>,
    /// Per-particle index into `species_table`.
    pub species: Vec<u32>,
    /// The species.
    pub species_table: Vec<Species>,
}

impl Particles {
    /// The positions as `glam::DVec3` values (a view, no copy).
    pub fn positions_dvec3(&self) -> &[glam::DVec3] {
        simkit_backend::vector::as_dvec3(&self.position)
    }

    /// The velocities as `glam::DVec3` values (a view, no copy).
    pub fn velocities_dvec3(&self) -> &[glam::DVec3] {
        simkit_backend::vector::as_dvec3(&self.velocity)
    }

    /// No particles, no species.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.position.len()
    }

    /// Whether there are no particles.
    pub fn is_empty(&self) -> bool {
        self.position.is_empty()
    }

    /// Registers a species and returns its index. Charge must be finite, mass finite and > 0.
    pub fn add_species(&mut self, species: Species) -> Result<u32> {
        require_finite(
            &format!("charge of species '{}'", species.name),
            species.charge,
        )?;
        require_positive(&format!("mass of species '{}'", species.name), species.mass)?;
        let index = u32::try_from(self.species_table.len()).map_err(|_| {
            Error::invalid(
                "species",
                &species.name,
                "more than 2^32 species cannot be indexed; reuse a species",
            )
        })?;
        self.species_table.push(species);
        Ok(index)
    }

    fn species_ref(&self, species: u32) -> Result<&Species> {
        self.species_table.get(species as usize).ok_or_else(|| {
            Error::invalid(
                "species",
                species,
                format!(
                    "no such species ({} registered); call add_species first",
                    self.species_table.len()
                ),
            )
        })
    }

    /// Checks that `count` more particles keep the total within [`MAX_PARTICLES`] (sizes in
    /// overflow-safe arithmetic) and reserves room for them without aborting when the host
    /// cannot provide it. Errors name `count`.
    fn reserve(&mut self, count: usize) -> Result<()> {
        let total = self.len().checked_add(count);
        let bytes = total.and_then(|t| t.checked_mul(BYTES_PER_PARTICLE));
        let (Some(total), Some(bytes)) = (total, bytes) else {
            return Err(Error::invalid(
                "particle count",
                count,
                format!(
                    "{} existing particles plus {count} overflow the address space; at most \
                     MAX_PARTICLES = {MAX_PARTICLES} particles are allowed",
                    self.len()
                ),
            ));
        };
        if total > MAX_PARTICLES {
            return Err(Error::invalid(
                "particle count",
                count,
                format!(
                    "{total} particles in all ({bytes} bytes of host arrays) exceed \
                     MAX_PARTICLES = {MAX_PARTICLES} (the all-pairs force sum is O(N^2)); \
                     use fewer particles"
                ),
            ));
        }
        let out_of_memory = |_| {
            Error::invalid(
                "particle count",
                count,
                format!("the host cannot allocate {bytes} bytes for {total} particles"),
            )
        };
        self.position.try_reserve(count).map_err(out_of_memory)?;
        self.velocity.try_reserve(count).map_err(out_of_memory)?;
        self.charge.try_reserve(count).map_err(out_of_memory)?;
        self.mass.try_reserve(count).map_err(out_of_memory)?;
        self.species.try_reserve(count).map_err(out_of_memory)?;
        Ok(())
    }

    /// Adds one particle of `species`. `position` and `velocity` are any [`IntoVec3`]:
    /// `glam` vectors (`DVec3`, `Vec3`, ...) or arrays.
    ///
    /// # Errors
    ///
    /// An unknown species, a non-finite component, or a particle beyond [`MAX_PARTICLES`].
    pub fn push(
        &mut self,
        species: u32,
        position: impl IntoVec3,
        velocity: impl IntoVec3,
    ) -> Result<()> {
        let (position, velocity) = (position.into_vec3(), velocity.into_vec3());
        let s = self.species_ref(species)?.clone();
        for (k, c) in position.iter().enumerate() {
            require_finite(&format!("position[{}][{k}]", self.len()), *c)?;
        }
        for (k, c) in velocity.iter().enumerate() {
            require_finite(&format!("velocity[{}][{k}]", self.len()), *c)?;
        }
        self.reserve(1)?;
        self.position.push(position);
        self.velocity.push(velocity);
        self.charge.push(s.charge);
        self.mass.push(s.mass);
        self.species.push(species);
        Ok(())
    }

    /// Adds `count` particles of `species`, uniform in `region`, with velocities drawn from
    /// `velocities` and their mean removed, from a `rand_pcg::Pcg64` seeded with `seed`.
    ///
    /// # Errors
    ///
    /// An unknown species, a bad region or velocity parameter (also one so large that the
    /// drawn values overflow: then nothing is added), or a `count` that would take the total
    /// past [`MAX_PARTICLES`] (checked before anything is allocated) or that the host cannot
    /// allocate; the error names `count` ("particle count").
    pub fn fill(
        &mut self,
        species: u32,
        count: usize,
        region: Region,
        velocities: Velocities,
        seed: u64,
    ) -> Result<()> {
        let s = self.species_ref(species)?.clone();
        match region {
            Region::Cube { min, length } => {
                require_positive("cube length", length)?;
                for (k, c) in min.iter().enumerate() {
                    require_finite(&format!("cube min[{k}]"), *c)?;
                }
            }
            Region::Sphere { center, radius } => {
                require_positive("sphere radius", radius)?;
                for (k, c) in center.iter().enumerate() {
                    require_finite(&format!("sphere center[{k}]"), *c)?;
                }
            }
        }
        match velocities {
            Velocities::Cold => {}
            Velocities::Maxwellian { thermal_speed } => {
                simkit_backend::require_non_negative("thermal_speed", thermal_speed)?;
            }
            Velocities::Uniform { half_width } => {
                simkit_backend::require_non_negative("half_width", half_width)?;
            }
        }
        self.reserve(count)?;
        let mut rng = Pcg64::seed_from_u64(seed);
        let start = self.len();
        for _ in 0..count {
            let p = match region {
                Region::Cube { min, length } => [
                    min[0] + length * rng.random::<f64>(),
                    min[1] + length * rng.random::<f64>(),
                    min[2] + length * rng.random::<f64>(),
                ],
                Region::Sphere { center, radius } => loop {
                    let d: [f64; 3] = std::array::from_fn(|_| 2.0 * rng.random::<f64>() - 1.0);
                    if d[0] * d[0] + d[1] * d[1] + d[2] * d[2] <= 1.0 {
                        break std::array::from_fn(|k| center[k] + radius * d[k]);
                    }
                },
            };
            let v = match velocities {
                Velocities::Cold => [0.0; 3],
                Velocities::Maxwellian { thermal_speed } => {
                    std::array::from_fn(|_| thermal_speed * normal(&mut rng))
                }
                Velocities::Uniform { half_width } => {
                    std::array::from_fn(|_| half_width * (2.0 * rng.random::<f64>() - 1.0))
                }
            };
            self.position.push(p);
            self.velocity.push(v);
            self.charge.push(s.charge);
            self.mass.push(s.mass);
            self.species.push(species);
        }
        if count > 0 {
            let mut mean = [0.0; 3];
            for v in &self.velocity[start..] {
                for k in 0..3 {
                    mean[k] += v[k] / count as f64;
                }
            }
            for v in &mut self.velocity[start..] {
                for k in 0..3 {
                    v[k] -= mean[k];
                }
            }
        }
        // A region or a speed near the largest float can overflow: refuse the fill whole.
        let bad = (start..self.len()).find_map(|i| {
            let (x, v) = (self.position[i], self.velocity[i]);
            if x.iter().any(|c| !c.is_finite()) {
                Some(("region", format!("{x:?}")))
            } else if v.iter().any(|c| !c.is_finite()) {
                Some(("velocities", format!("{v:?}")))
            } else {
                None
            }
        });
        if let Some((what, value)) = bad {
            self.position.truncate(start);
            self.velocity.truncate(start);
            self.charge.truncate(start);
            self.mass.truncate(start);
            self.species.truncate(start);
            return Err(Error::invalid(
                format!("fill {what}"),
                value,
                format!(
                    "the {what} parameters give non-finite values (too close to the largest \
                     float); use smaller ones. Nothing was added"
                ),
            ));
        }
        Ok(())
    }

    /// Checks lengths, finiteness, masses, species indices and the total against
    /// [`MAX_PARTICLES`]; errors name the first bad particle.
    pub fn validate(&self) -> Result<()> {
        if self.len() > MAX_PARTICLES {
            return Err(Error::invalid(
                "particle count",
                self.len(),
                format!("over MAX_PARTICLES = {MAX_PARTICLES}; use fewer particles"),
            ));
        }
        let n = self.len();
        for (name, len) in [
            ("velocity", self.velocity.len()),
            ("charge", self.charge.len()),
            ("mass", self.mass.len()),
            ("species", self.species.len()),
        ] {
            if len != n {
                return Err(Error::invalid(
                    format!("length of {name}"),
                    len,
                    format!("must equal the number of positions, {n}"),
                ));
            }
        }
        for i in 0..n {
            for k in 0..3 {
                require_finite(&format!("position[{i}][{k}]"), self.position[i][k])?;
                require_finite(&format!("velocity[{i}][{k}]"), self.velocity[i][k])?;
            }
            require_finite(&format!("charge[{i}]"), self.charge[i])?;
            require_positive(&format!("mass[{i}]"), self.mass[i])?;
            if self.species[i] as usize >= self.species_table.len() {
                return Err(Error::invalid(
                    format!("species[{i}]"),
                    self.species[i],
                    format!(
                        "no such species ({} registered); use an index from add_species",
                        self.species_table.len()
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// A standard normal deviate (Box–Muller).
fn normal(rng: &mut Pcg64) -> f64 {
    let u1 = 1.0 - rng.random::<f64>(); // (0, 1]
    let u2 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fill_is_seeded_centred_and_inside() {
        let mut p = Particles::new();
        let e = p.add_species(Species::new("e", -1.0, 1.0)).unwrap();
        let ion = p.add_species(Species::new("ion", 1.0, 1836.0)).unwrap();
        let sphere = Region::Sphere {
            center: [1.0, 2.0, 3.0],
            radius: 2.0,
        };
        p.fill(
            e,
            1000,
            sphere,
            Velocities::Maxwellian { thermal_speed: 0.5 },
            7,
        )
        .unwrap();
        p.fill(
            ion,
            1000,
            sphere,
            Velocities::Uniform { half_width: 0.1 },
            8,
        )
        .unwrap();
        assert_eq!(p.len(), 2000);
        assert_eq!(p.mass[1500], 1836.0);
        for x in &p.position {
            let r2: f64 = (0..3).map(|k| (x[k] - [1.0, 2.0, 3.0][k]).powi(2)).sum();
            assert!(r2 <= 4.0);
        }
        for range in [0..1000, 1000..2000] {
            for k in 0..3 {
                let m: f64 = p.velocity[range.clone()].iter().map(|v| v[k]).sum();
                assert!(m.abs() < 1e-12, "{m}");
            }
        }
        let var: f64 = p.velocity[..1000].iter().map(|v| v[0] * v[0]).sum::<f64>() / 1000.0;
        assert!((var.sqrt() - 0.5).abs() < 0.05, "{}", var.sqrt());
        let mut q = Particles::new();
        q.add_species(Species::new("e", -1.0, 1.0)).unwrap();
        q.add_species(Species::new("ion", 1.0, 1836.0)).unwrap();
        q.fill(
            e,
            1000,
            sphere,
            Velocities::Maxwellian { thermal_speed: 0.5 },
            7,
        )
        .unwrap();
        assert_eq!(q.position[..], p.position[..1000]);
    }

    #[test]
    fn bad_species_and_values() {
        let mut p = Particles::new();
        assert!(p.add_species(Species::new("x", 1.0, 0.0)).is_err());
        assert!(p.push(0, [0.0; 3], [0.0; 3]).is_err());
        let s = p.add_species(Species::new("x", 1.0, 1.0)).unwrap();
        let e = p.push(s, [f64::NAN, 0.0, 0.0], [0.0; 3]).unwrap_err();
        assert!(e.to_string().contains("position[0][0]"), "{e}");
        p.push(s, [0.0; 3], [0.0; 3]).unwrap();
        p.mass[0] = 0.0;
        assert!(p.validate().unwrap_err().to_string().contains("mass[0]"));
    }
}
