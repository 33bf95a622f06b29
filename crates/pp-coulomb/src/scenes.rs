//! Ready-made initial conditions: the source's plasma box and a cold uniform sphere for the
//! Coulomb explosion, plus the expansion measurement used to validate the latter.

use simkit_backend::{Error, Result, require_positive};

use crate::config::ForceLaw;
use crate::particles::{Particles, Region, Species, Velocities};
use crate::units::{Normalised, PhysicalInputs, normalise};

/// The source's plasma in normalised units: `inputs.particles` electrons (or the species
/// given by `inputs`) uniform in the box, Maxwellian at the thermal speed with zero mean,
/// and the exclusion law with radius = Debye length.
///
/// Errors: inputs [`normalise`] refuses, a Debye length the law refuses
/// ([`ForceLaw::validate`]: its square must be a normal `f64`), those of
/// [`Particles::fill`].
pub fn plasma_box(inputs: &PhysicalInputs, seed: u64) -> Result<(Particles, ForceLaw, Normalised)> {
    let u = normalise(inputs)?;
    let law = ForceLaw::Exclusion {
        radius: u.debye_length,
    };
    // A Debye length the kernels cannot square (e.g. 1e-248 in normalised units) is refused
    // before the particles are made.
    law.validate()?;
    let mut p = Particles::new();
    let s = p.add_species(Species::new("electron", u.charge, u.mass))?;
    let cube = Region::Cube {
        min: [0.0; 3],
        length: u.box_length,
    };
    let v = Velocities::Maxwellian {
        thermal_speed: u.thermal_speed,
    };
    p.fill(s, inputs.particles, cube, v, seed)?;
    Ok((p, law, u))
}

/// A cold uniform sphere of `n` equal positive charges centred at the origin, with total
/// charge 1 and total mass 1, so that `omega = sqrt(q Q / (m R^3)) = R^(-3/2)`.
pub fn cold_sphere(n: usize, radius: f64, seed: u64) -> Result<Particles> {
    require_positive("sphere radius", radius)?;
    let mut p = Particles::new();
    let w = 1.0 / n.max(1) as f64;
    let s = p.add_species(Species::new("ion", w, w))?;
    let sphere = Region::Sphere {
        center: [0.0; 3],
        radius,
    };
    p.fill(s, n, sphere, Velocities::Cold, seed)?;
    Ok(p)
}

/// Measures the expansion factor `xi(t) = R(t) / R(0)` of a sphere centred at the origin.
///
/// The estimate is the median, over the particles that start in the outer shell
/// (`r > 0.8 R`), of `|r_i(t)| / |r_i(0)|`. A cold uniform sphere expands homologously, so
/// every particle, the outermost included, follows the same `xi(t)`; the median over the
/// outer shell is insensitive to the few particles kicked by close encounters.
#[derive(Clone, Debug)]
pub struct Expansion {
    outer: Vec<(usize, f64)>,
}

impl Expansion {
    /// Records the initial radii of the particles in the outer shell of a sphere of `radius`.
    pub fn new(initial: &[[f64; 3]], radius: f64) -> Self {
        let outer = initial
            .iter()
            .enumerate()
            .map(|(i, x)| (i, norm(*x)))
            .filter(|&(_, r)| r > 0.8 * radius)
            .collect();
        Self { outer }
    }

    /// The expansion factor of the positions `x` (NaN if the outer shell is empty, or if `x`
    /// has fewer particles than the initial positions).
    pub fn factor(&self, x: &[[f64; 3]]) -> f64 {
        let ratios: Option<Vec<f64>> = self
            .outer
            .iter()
            .map(|&(i, r0)| x.get(i).map(|x| norm(*x) / r0))
            .collect();
        let Some(mut ratios) = ratios.filter(|r| !r.is_empty()) else {
            return f64::NAN;
        };
        ratios.sort_by(f64::total_cmp);
        ratios[ratios.len() / 2]
    }
}

fn norm(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

/// The most steps [`run_explosion`] takes (10^7: hours of a large run, and a bound that
/// turns a step far too small for `t_max` into an error instead of a loop without end).
pub const MAX_EXPLOSION_STEPS: u64 = 10_000_000;

/// One sample of an explosion run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExplosionSample {
    /// Simulated time.
    pub time: f64,
    /// Measured expansion factor [`Expansion::factor`].
    pub xi: f64,
}

/// Steps a sphere explosion until the expansion factor reaches `xi_max` (or the time
/// `t_max`), with the step `dt = courant xi^(3/2) / omega` that follows the growing dynamical
/// time. `on_step` sees every state (for frames); the samples start with `(0, 1)`.
///
/// Errors: `omega` or `courant` not finite and > 0, `xi_max` not finite, `t_max` not finite
/// and > 0 (the loop must end), a run that would take more than [`MAX_EXPLOSION_STEPS`]
/// steps (at `xi = 1`, `t_max omega / courant` steps; checked before the first and again as
/// the run goes, since `xi` may shrink), or an error of the simulation (e.g. a blow-up).
pub fn run_explosion(
    sim: &mut crate::PpCoulomb,
    expansion: &Expansion,
    omega: f64,
    courant: f64,
    xi_max: f64,
    t_max: f64,
    mut on_step: impl FnMut(&Particles, ExplosionSample) -> Result<()>,
) -> Result<Vec<ExplosionSample>> {
    use simkit_backend::Simulation;
    require_positive("omega", omega)?;
    require_positive("courant", courant)?;
    simkit_backend::require_finite("xi_max", xi_max)?;
    require_positive("t_max", t_max)?;
    let too_long = |steps: f64| {
        Error::invalid(
            "explosion run length t_max omega / courant",
            format!("{steps:e} steps"),
            format!("at most {MAX_EXPLOSION_STEPS} steps: raise courant or lower t_max or omega"),
        )
    };
    let planned = t_max * omega / courant;
    // Finite or +inf: the inputs are finite and positive.
    if planned > MAX_EXPLOSION_STEPS as f64 {
        return Err(too_long(planned));
    }
    let mut samples = vec![ExplosionSample {
        time: sim.time(),
        xi: 1.0,
    }];
    let mut xi = 1.0_f64;
    while xi < xi_max && sim.time() < t_max {
        if samples.len() as u64 > MAX_EXPLOSION_STEPS {
            return Err(too_long(samples.len() as f64));
        }
        sim.set_dt(courant * xi.powf(1.5) / omega)?;
        sim.step(1)?;
        let state = sim.state()?;
        xi = expansion.factor(&state.position);
        let s = ExplosionSample {
            time: sim.time(),
            xi,
        };
        samples.push(s);
        on_step(&state, s)?;
    }
    Ok(samples)
}

/// The time at which the samples first reach `xi` (linear interpolation), if they do.
pub fn crossing_time(samples: &[ExplosionSample], xi: f64) -> Option<f64> {
    samples.windows(2).find_map(|w| {
        (w[0].xi < xi && w[1].xi >= xi)
            .then(|| w[0].time + (w[1].time - w[0].time) * (xi - w[0].xi) / (w[1].xi - w[0].xi))
    })
}
