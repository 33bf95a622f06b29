//! Ready-made scenes from the source and the benchmarks, and piles under gravity (a
//! heap from a collapsing column, a rotating drum) with the angle of their surface.

use std::f64::consts::PI;

use simkit_backend::Result;

use crate::{ContactLaw, Dim, LinearHistory, Material, Particle, Scene, Units, Wall};

mod piles;
pub use piles::{
    DrumParams, Flank, HeapParams, column_heap, heap_flank, rotating_drum, surface_angle,
};

/// Parameters of the 2D vibrated bed (source chapter 1) in physical units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BedParams {
    /// Number of discs.
    pub n: usize,
    /// Box width in grain diameters.
    pub width: usize,
    /// Vibration strength `Gamma = A omega^2 / g`.
    pub gamma: f64,
    /// Vibration frequency in Hz.
    pub freq_hz: f64,
    /// Particle–particle restitution.
    pub e_pp: f64,
    /// Particle–wall restitution.
    pub e_pw: f64,
    /// Coulomb friction coefficient (0 = frictionless).
    pub mu: f64,
    /// Contact time in seconds.
    pub contact_time_s: f64,
}

impl Default for BedParams {
    /// The source's bed: 2048 discs of 0.6 cm and 0.2 g, 64 wide, `Gamma = 3` at 20 Hz,
    /// `e_pp = 0.9`, `e_pw = 0.8`, `mu = 0.3`, `t_c = 5e-5 s`.
    fn default() -> Self {
        Self {
            n: 2048,
            width: 64,
            gamma: 3.0,
            freq_hz: 20.0,
            e_pp: 0.9,
            e_pw: 0.8,
            mu: 0.3,
            contact_time_s: 5e-5,
        }
    }
}

/// The viscous tangential coefficient used with a Coulomb coefficient in the ready-made
/// scenes: `mu_k = 2 / t_c`, so that the viscous branch is stiff and the Coulomb cap
/// usually applies.
fn friction(m: Material, mu: f64) -> Material {
    if mu > 0.0 {
        m.with_friction(mu, 2.0 / m.contact_time)
    } else {
        m
    }
}

/// The 2D vibrated bed in the source's reduced units ([`Units`] with `d0 = 0.6 cm`,
/// `m0 = 0.2 g`): discs of diameter 1 and mass 1 on a square lattice (spacing 1.05, rows
/// shifted alternately), in a box whose floor and lid (3x the bed height up) vibrate with
/// `z_w(t) = -A cos(t)`. Returns the scene and the units.
pub fn vibrating_bed(p: &BedParams) -> Result<(Scene, Units)> {
    let u = Units::new(0.6, 0.2, p.freq_hz)?;
    simkit_backend::require_positive("bed width", p.width as f64)?;
    simkit_backend::require_positive("bed particle count", p.n as f64)?;
    let tc = u.time(p.contact_time_s);
    let rows = p.n.div_ceil((p.width.max(2) - 1).max(1));
    let height = (3.0 * 1.05 * rows as f64).max(10.0);
    let pp = friction(Material::new(p.e_pp, tc), p.mu);
    let pw = friction(Material::new(p.e_pw, tc), p.mu);
    let mut s = Scene::new(Dim::Two, [0.0; 3], [p.width as f64, height, 0.0], pp)?;
    s.set_gravity(u.gravity())?
        .set_vibration(u.amplitude(p.gamma), 1.0)?;
    s.set_periodic([false; 3]);
    s.add_box_walls(pw, true)?;
    // Rows of `width - 1` discs 1.0 + a small gap apart, alternate rows shifted by half
    // the gap: no initial overlap, no perfect columns.
    let per_row = (p.width - 1).max(1);
    let gap = (p.width as f64 - 1.2) / per_row as f64;
    for k in 0..p.n {
        let (i, j) = (k % per_row, k / per_row);
        let shift = if j % 2 == 0 {
            0.0
        } else {
            0.5 * (gap - 1.0).max(0.0)
        };
        let x = 0.6 + i as f64 * gap + shift;
        let y = 0.6 + 1.05 * j as f64;
        s.add_particle(Particle::new([x, y, 0.0], 0.5, 1.0))?;
    }
    Ok((s, u))
}

/// The 3D granular box of the LAMMPS comparison (`benches/peers/dem_gran3d.lmp` in the simkit repository): spheres of
/// diameter 1 and density 1 on a simple-cubic lattice of spacing 1.05 (`nx * ny * nz`),
/// Gaussian random velocities of unit variance per component, gravity 1, a frictional
/// floor at z = 0, periodic in x and y. Contact: `k_n = 2e5`, `gamma_n = 50` (LAMMPS
/// units: damping force `m_eff gamma_n v_n`), `mu = 0.5`. Returns the scene; use
/// `dt = 1e-4` as LAMMPS does.
pub fn granular_box(nx: usize, ny: usize, nz: usize, seed: u32) -> Result<Scene> {
    let m = PI / 6.0;
    // LAMMPS Hooke: F = k_n delta - m_eff gamma_n v_n. Ours: m_ij (kappa delta - 2b v_n).
    // For equal spheres m_ij = m/2: kappa = k_n / m_ij, 2b = gamma_n.
    let (e, tc) = hooke(m / 2.0);
    let mat = Material::new(e, tc).with_friction(0.5, 25.0);
    // Floor: same e and t_c against a wall (m_ij = m for a wall, so the floor contact is
    // softer in time than LAMMPS's; see docs/dem.md).
    lattice_box(nx, ny, nz, seed, mat, mat)
}

/// The box of [`granular_box`] with the physics of LAMMPS `pair gran/hooke/history` and
/// `fix wall/gran hooke/history` under `fix nve/sphere` (`benches/peers/dem_gran3d.lmp
/// -var model hooke/history`): rotation on, [`LinearHistory`] with the deck's `k_n = 2e5`,
/// `gamma_n = 50`, `k_t = 2/7 k_n`, `gamma_t = gamma_n / 2` and `mu = 0.5` between spheres
/// (`m_ij = m / 2`) and against the floor (`m_ij = m`: a material of its own, so that both
/// contacts have LAMMPS's stiffness `k_n`). Differences that remain: LAMMPS turns the
/// tangential spring into the contact plane without keeping its length, and takes the
/// torque's lever at the full radius (ours: `R - delta / 2`).
pub fn granular_box_history(
    nx: usize,
    ny: usize,
    nz: usize,
    seed: u32,
) -> Result<Scene<LinearHistory>> {
    let m = PI / 6.0;
    let law = |m_ij: f64| {
        let (e, tc) = hooke(m_ij);
        LinearHistory::new(e, tc, 0.5)
    };
    let mut s = lattice_box(nx, ny, nz, seed, law(m / 2.0), law(m))?;
    s.set_rotation(true);
    Ok(s)
}

/// `(e, t_c)` of the linear law whose spring and dashpot are LAMMPS's `k_n = 2e5`,
/// `gamma_n = 50` (damping force `m_ij gamma_n v_n`) at reduced mass `m_ij`:
/// `kappa = k_n / m_ij`, `b = gamma_n / 2`.
fn hooke(m_ij: f64) -> (f64, f64) {
    let kappa = 2.0e5 / m_ij;
    let b = 25.0;
    let tc = PI / (kappa - b * b).sqrt();
    ((-b * tc).exp(), tc)
}

/// The lattice, velocities, gravity, periodic sides and floor of [`granular_box`], with
/// material `pair` between spheres and `floor` against the floor.
fn lattice_box<L: ContactLaw>(
    nx: usize,
    ny: usize,
    nz: usize,
    seed: u32,
    pair: L,
    floor: L,
) -> Result<Scene<L>> {
    let m = PI / 6.0;
    let l = 1.05;
    let hi = [nx as f64 * l, ny as f64 * l, (nz as f64 * l * 2.0).max(4.0)];
    let mut s = Scene::new(Dim::Three, [0.0; 3], hi, pair)?;
    s.set_periodic([true, true, false]);
    s.set_gravity(1.0)?;
    s.add_wall(Wall::plane([0.0, 0.0, 1.0], [0.0; 3], floor))?;
    let mut k = 0u32;
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                k += 1;
                let g = |a: u32| gaussian(seed, a, k);
                let p = [
                    (x as f64 + 0.5) * l,
                    (y as f64 + 0.5) * l,
                    (z as f64 + 0.5) * l,
                ];
                s.add_particle(Particle::new(p, 0.5, m).with_velocity([g(0), g(2), g(4)]))?;
            }
        }
    }
    Ok(s)
}

/// A standard normal deviate from the counter-based RNG (Box–Muller).
fn gaussian(seed: u32, stream: u32, index: u32) -> f64 {
    let u1 = (simkit_backend::rng::rng_uniform(seed, stream, index) as f64).max(1e-12);
    let u2 = simkit_backend::rng::rng_uniform(seed, stream + 1, index) as f64;
    (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos()
}

/// Parameters of the segregating binary monolayer (source chapter 2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MonolayerParams {
    /// Number of spheres (half of each species).
    pub n: usize,
    /// Cylinder radius in diameters.
    pub radius: f64,
    /// Restitution among species A.
    pub e_aa: f64,
    /// Restitution among species B.
    pub e_bb: f64,
    /// Restitution between A and B.
    pub e_ab: f64,
    /// Restitution against the walls.
    pub e_wall: f64,
    /// Coulomb friction coefficient (default 0: without rotation, a sphere sliding on the
    /// plates is stopped by friction where a real one would roll, and the layer freezes).
    pub mu: f64,
    /// Vibration strength `Gamma`.
    pub gamma: f64,
    /// Vibration frequency in Hz.
    pub freq_hz: f64,
    /// Contact time in seconds.
    pub contact_time_s: f64,
    /// Seed of the random swaps.
    pub seed: u32,
}

impl Default for MonolayerParams {
    /// 400 spheres in a cylinder of radius 14 d (area fraction about 0.5), `e_AA = 0.95`,
    /// `e_BB = 0.6`, `e_AB = 0.775`, no friction, `Gamma = 3` at 50 Hz, `t_c = 5e-4 s`
    /// (chapter 3's).
    fn default() -> Self {
        Self {
            n: 400,
            radius: 14.0,
            e_aa: 0.95,
            e_bb: 0.6,
            e_ab: 0.775,
            e_wall: 0.8,
            mu: 0.0,
            gamma: 3.0,
            freq_hz: 50.0,
            contact_time_s: 5e-4,
            seed: 11,
        }
    }
}

/// The vibrated binary monolayer: equal spheres (d = 1, m = 1) of two species with
/// different restitution in a vertical cylinder of height 1.5 d whose floor, lid and side
/// wall vibrate. Spheres are placed on rings from the wall inwards, species alternating,
/// then shuffled by random swaps, with small random horizontal velocities (up to the plate
/// speed `A omega`) that break the symmetry of the in-phase vertical bouncing.
pub fn segregation_monolayer(p: &MonolayerParams) -> Result<(Scene, Units)> {
    let u = Units::new(0.6, 0.2, p.freq_hz)?;
    let tc = u.time(p.contact_time_s);
    let r = p.radius;
    let m = |e: f64| friction(Material::new(e, tc), p.mu);
    let mut s = Scene::new(
        Dim::Three,
        [-r - 1.0, -r - 1.0, 0.0],
        [r + 1.0, r + 1.0, 1.5],
        m(p.e_aa),
    )?;
    s.set_species(2, m(p.e_aa))?;
    s.set_pair(1, 1, m(p.e_bb))?;
    s.set_pair(0, 1, m(p.e_ab))?;
    s.set_gravity(u.gravity())?
        .set_vibration(u.amplitude(p.gamma), 1.0)?;
    let w = m(p.e_wall);
    s.add_wall(Wall::plane([0.0, 0.0, 1.0], [0.0; 3], w).vibrating())?;
    s.add_wall(Wall::plane([0.0, 0.0, -1.0], [0.0, 0.0, 1.5], w).vibrating())?;
    s.add_wall(Wall::cylinder([0.0, 0.0], r, w).vibrating())?;
    // Rings from the wall inwards.
    let mut spots = Vec::new();
    let mut ring = r - 0.55;
    while spots.len() < p.n && ring > 0.0 {
        let count = ((2.0 * PI * ring / 1.1).floor() as usize).max(1);
        for k in 0..count {
            let a = 2.0 * PI * k as f64 / count as f64;
            spots.push([ring * a.cos(), ring * a.sin()]);
        }
        ring -= 1.1;
    }
    if spots.len() < p.n {
        return Err(simkit_backend::Error::invalid(
            "monolayer particle count",
            p.n,
            format!(
                "only {} spheres fit on rings in a cylinder of radius {r}",
                spots.len()
            ),
        ));
    }
    spots.truncate(p.n);
    let mut species: Vec<u32> = (0..p.n as u32).map(|k| k % 2).collect();
    for k in 0..(4 * p.n) as u32 {
        let a = simkit_backend::rng::rng_u32(p.seed, 0, k) as usize % p.n;
        let b = simkit_backend::rng::rng_u32(p.seed, 1, k) as usize % p.n;
        species.swap(a, b);
    }
    // Small random horizontal velocities (up to the plate speed A omega) break the symmetry:
    // without them every sphere bounces vertically in phase and nothing mixes or separates.
    let vmax = u.amplitude(p.gamma);
    for (k, xy) in spots.iter().enumerate() {
        let h = |stream: u32| {
            vmax * (2.0 * simkit_backend::rng::rng_uniform(p.seed, 2 + stream, k as u32) as f64
                - 1.0)
        };
        s.add_particle(
            Particle::new([xy[0], xy[1], 0.5], 0.5, 1.0)
                .with_species(species[k])
                .with_velocity([h(0), h(1), 0.0]),
        )?;
    }
    Ok((s, u))
}

/// Segregation order parameter: the fraction of like-species pairs among all pairs closer
/// than `range` (centre distance). About 0.5 when two equal species are well mixed (a bit
/// less for finite N), rising towards 1 as they separate.
pub fn like_neighbor_fraction(scene: &Scene, positions: &[[f64; 3]], range: f64) -> f64 {
    let sp: Vec<u32> = scene.particles().iter().map(|p| p.species).collect();
    let (mut like, mut all) = (0usize, 0usize);
    let r2 = range * range;
    for i in 0..positions.len() {
        for j in i + 1..positions.len() {
            let d2: f64 = (0..3)
                .map(|d| (positions[i][d] - positions[j][d]).powi(2))
                .sum();
            if d2 < r2 {
                all += 1;
                like += usize::from(sp[i] == sp[j]);
            }
        }
    }
    if all == 0 {
        0.0
    } else {
        like as f64 / all as f64
    }
}
