//! Piles under gravity: a heap from a column released onto a floor and a rotating drum,
//! with the angle of their free surface.

use simkit_backend::rng::rng_uniform;
use simkit_backend::{Error, Result, require_positive};

use crate::{ContactLaw, Dim, Particle, Scene, Wall};

/// A radius drawn uniformly from `0.5 (1 - spread) .. 0.5 (1 + spread)` (mean diameter 1)
/// with the mass of a disc (2D) or sphere (3D) of unit density per unit diameter: mass 1
/// at diameter 1.
fn grain(dim: Dim, spread: f64, seed: u32, k: usize, at: [f64; 3]) -> Particle {
    let u = f64::from(rng_uniform(seed, 0, k as u32));
    let r = 0.5 * (1.0 + spread * (2.0 * u - 1.0));
    let power = match dim {
        Dim::Two => 2,
        Dim::Three => 3,
    };
    Particle::new(at, r, (2.0 * r).powi(power))
}

fn check_spread(spread: f64) -> Result<()> {
    if !(0.0..0.5).contains(&spread) {
        return Err(Error::invalid(
            "polydispersity",
            spread,
            "must be in [0, 0.5): radii are drawn from 0.5 (1 - spread) .. 0.5 (1 + spread)",
        ));
    }
    Ok(())
}

/// Parameters of [`column_heap`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeapParams {
    /// Discs (2D) or spheres (3D).
    pub dim: Dim,
    /// Number of grains.
    pub n: usize,
    /// Width of the falling column, in grains (a square of `column x column` in 3D).
    pub column: usize,
    /// Half-width of the floor (the box runs from `-floor` to `floor` about the column).
    pub floor: f64,
    /// Relative spread of the radii (0: all of diameter 1).
    pub polydispersity: f64,
    /// Seed of the radii and of the small offsets that keep the column from stacking in
    /// perfect rows.
    pub seed: u32,
}

impl Default for HeapParams {
    /// 1500 discs from a column 40 wide onto a floor 120 wide, radii within ±10 %.
    fn default() -> Self {
        Self {
            dim: Dim::Two,
            n: 1500,
            column: 40,
            floor: 60.0,
            polydispersity: 0.2,
            seed: 1,
        }
    }
}

/// A heap released onto a floor: grains of mean diameter 1 (mass 1 at diameter 1, `g = 1`)
/// stacked in a column (rows and columns the largest diameter + 0.12 apart, random offsets
/// of up to 0.05) standing on the middle of a floor, released at rest. The column collapses
/// into a heap whose flanks [`surface_angle`] measures. This is a column-collapse (or
/// cylinder-lift) test, not a slow pour: the grains arrive with the speed of the collapse
/// and spread inertially, so the flanks settle below the angle of repose of a slowly poured
/// heap, the more so the taller the column (a column about as tall as wide, the default,
/// spreads least). The floor (`y = 0` in 2D, `z = 0` in 3D, the particle–particle material
/// unless `floor` is given) is flanked by walls at `±HeapParams::floor` about the column's
/// axis, which is at the origin. Rotation is on: a heap of grains that cannot roll is not
/// what a user expects.
/// Use a law with static friction ([`crate::HertzMindlin`], [`crate::LinearHistory`]);
/// rolling resistance raises the angle.
///
/// ```
/// use simkit_dem::scenes::{HeapParams, column_heap};
/// use simkit_dem::LinearHistory;
/// # fn main() -> simkit_backend::Result<()> {
/// let law = LinearHistory::new(0.5, 0.03, 0.5).with_rolling_friction(0.1);
/// let scene = column_heap(law, None, &HeapParams { n: 200, ..HeapParams::default() })?;
/// assert_eq!(scene.particles().len(), 200);
/// # Ok(())
/// # }
/// ```
pub fn column_heap<L: ContactLaw>(law: L, floor: Option<L>, p: &HeapParams) -> Result<Scene<L>> {
    require_positive("heap particle count", p.n as f64)?;
    require_positive("heap column width", p.column as f64)?;
    check_spread(p.polydispersity)?;
    // The largest diameter, 2 % of room, and the offsets.
    let pitch = 1.02 * (1.0 + p.polydispersity) + 0.1;
    let half = 0.5 * pitch * p.column as f64;
    if !(p.floor.is_finite() && p.floor >= half + 1.0) {
        return Err(Error::invalid(
            "heap floor half-width",
            p.floor,
            format!(
                "must be finite and at least the column's half-width + 1 = {}",
                half + 1.0
            ),
        ));
    }
    let per_layer = match p.dim {
        Dim::Two => p.column,
        Dim::Three => p.column * p.column,
    };
    let layers = p.n.div_ceil(per_layer);
    let up = p.dim.vertical();
    let mut lo = [-p.floor, -p.floor, 0.0];
    let mut hi = [p.floor, p.floor, 0.0];
    lo[up] = 0.0;
    hi[up] = pitch * layers as f64 + 2.0;
    let mut s = Scene::new(p.dim, lo, hi, law)?;
    s.set_gravity(1.0)?.set_rotation(true);
    let wall = floor.unwrap_or(law);
    for d in 0..p.dim.axes() {
        let mut n = [0.0; 3];
        n[d] = 1.0;
        s.add_wall(Wall::plane(n, lo, wall))?;
        if d != up {
            n[d] = -1.0;
            s.add_wall(Wall::plane(n, hi, wall))?;
        }
    }
    for k in 0..p.n {
        let (layer, spot) = (k / per_layer, k % per_layer);
        let jitter = |stream: u32| 0.1 * (f64::from(rng_uniform(p.seed, stream, k as u32)) - 0.5);
        let mut at = [0.0; 3];
        at[0] = -half + pitch * ((spot % p.column) as f64 + 0.5) + jitter(1);
        if p.dim == Dim::Three {
            at[1] = -half + pitch * ((spot / p.column) as f64 + 0.5) + jitter(2);
        }
        at[up] = pitch * (layer as f64 + 0.5) + 0.05;
        s.add_particle(grain(p.dim, p.polydispersity, p.seed, k, at))?;
    }
    Ok(s)
}

/// Parameters of [`rotating_drum`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DrumParams {
    /// Number of discs.
    pub n: usize,
    /// Inner radius of the drum, in mean diameters.
    pub radius: f64,
    /// Froude number `Fr = Omega^2 R / g` of the rotation (the drum turns at
    /// `Omega = sqrt(Fr g / R)`; `1e-4 .. 1e-2` rolling, about 1 centrifuging).
    pub froude: f64,
    /// Relative spread of the radii (2D monodisperse discs crystallise; 0.2 keeps them
    /// disordered).
    pub polydispersity: f64,
    /// Seed of the radii.
    pub seed: u32,
}

impl Default for DrumParams {
    /// 400 discs in a drum of radius 15 (about 40 % full), `Fr = 0.005`, radii within
    /// ±10 %.
    fn default() -> Self {
        Self {
            n: 400,
            radius: 15.0,
            froude: 0.005,
            polydispersity: 0.2,
            seed: 1,
        }
    }
}

impl DrumParams {
    /// The drum's angular velocity `Omega = sqrt(Fr g / R)` (`g = 1`).
    pub fn spin(&self) -> f64 {
        (self.froude / self.radius).sqrt()
    }
}

/// A 2D rotating drum: discs of mean diameter 1 (mass 1 at diameter 1, `g = 1`) in a
/// circle of radius `DrumParams::radius` centred at `(R, R)` (its shell of material
/// `shell`, or the particles' own) turning counter-clockwise at `Omega = sqrt(Fr g / R)`
/// ([`Wall::spinning`]). The discs start on a square lattice in the bottom of the drum, at
/// rest; the shell drags them up on the right until the surface avalanches, and after
/// about half a turn the flow is steady: a free surface rising to the right at the dynamic
/// angle of repose ([`surface_angle`]). Rotation is on.
///
/// ```
/// use simkit_dem::scenes::{DrumParams, rotating_drum};
/// use simkit_dem::LinearHistory;
/// # fn main() -> simkit_backend::Result<()> {
/// let law = LinearHistory::new(0.5, 0.03, 0.5);
/// let p = DrumParams::default();
/// let scene = rotating_drum(law, None, &p)?;
/// assert_eq!(scene.walls()[0].spin, p.spin());
/// # Ok(())
/// # }
/// ```
pub fn rotating_drum<L: ContactLaw>(law: L, shell: Option<L>, p: &DrumParams) -> Result<Scene<L>> {
    require_positive("drum particle count", p.n as f64)?;
    require_positive("drum radius", p.radius)?;
    require_positive("drum Froude number", p.froude)?;
    check_spread(p.polydispersity)?;
    let r = p.radius;
    let size = 2.0 * r;
    let mut s = Scene::new(Dim::Two, [0.0; 3], [size, size, 0.0], law)?;
    s.set_gravity(1.0)?.set_rotation(true);
    s.add_wall(Wall::cylinder([r, r], r, shell.unwrap_or(law)).spinning(p.spin()))?;
    // Lattice sites inside the circle (a margin of the largest radius), bottom row first.
    let pitch = 1.02 * (1.0 + p.polydispersity);
    let reach = r - 0.5 * pitch - 0.05;
    let mut placed = 0usize;
    let mut y = r - reach;
    while placed < p.n && y <= r + reach {
        let half = (reach * reach - (y - r) * (y - r)).max(0.0).sqrt();
        let count = ((2.0 * half) / pitch).floor() as usize + 1;
        let x0 = r - 0.5 * pitch * (count - 1) as f64;
        for i in 0..count.min(p.n - placed) {
            let at = [x0 + pitch * i as f64, y, 0.0];
            s.add_particle(grain(Dim::Two, p.polydispersity, p.seed, placed, at))?;
            placed += 1;
        }
        y += pitch;
    }
    if placed < p.n {
        return Err(Error::invalid(
            "drum particle count",
            p.n,
            format!("only {placed} discs fit in a drum of radius {r}"),
        ));
    }
    Ok(s)
}

/// The angle in degrees of a pile's free surface, from `(abscissa, height)` of every grain
/// (its centre's horizontal coordinate, or its distance from a heap's axis in 3D, and its
/// top `y + r` or `z + r`): the abscissae from `from` to `to` are cut into bins `bin`
/// wide, each bin's surface is the highest top in it, and the angle is `atan` of the
/// least-squares slope through the bins' centres and surfaces (positive: rising with the
/// abscissa). Fit one flank of a heap at a time, between its toe and its crest.
///
/// Errors: `bin <= 0`, `to <= from`, or fewer than 3 bins holding grains.
///
/// ```
/// use simkit_dem::scenes::surface_angle;
/// # fn main() -> simkit_backend::Result<()> {
/// // Grains stacked under the line y = x tan(30°).
/// let t = 30f64.to_radians().tan();
/// let grains: Vec<(f64, f64)> = (0..200)
///     .map(|k| (0.05 * k as f64, 0.05 * k as f64 * t - 0.1 * (k % 3) as f64))
///     .collect();
/// let angle = surface_angle(&grains, 0.0, 10.0, 1.0)?;
/// assert!((angle - 30.0).abs() < 1.0, "{angle}");
/// # Ok(())
/// # }
/// ```
pub fn surface_angle(grains: &[(f64, f64)], from: f64, to: f64, bin: f64) -> Result<f64> {
    require_positive("surface bin width", bin)?;
    if to.partial_cmp(&from) != Some(std::cmp::Ordering::Greater) {
        return Err(Error::invalid(
            "surface fit range",
            format!("{from} .. {to}"),
            "must run from a smaller to a larger abscissa",
        ));
    }
    let bins = ((to - from) / bin).ceil() as usize;
    let mut top = vec![f64::NEG_INFINITY; bins];
    for &(x, h) in grains {
        if x >= from && x < to {
            let b = (((x - from) / bin) as usize).min(bins - 1);
            top[b] = top[b].max(h);
        }
    }
    let points: Vec<(f64, f64)> = top
        .iter()
        .enumerate()
        .filter(|(_, h)| h.is_finite())
        .map(|(b, &h)| (from + bin * (b as f64 + 0.5), h))
        .collect();
    if points.len() < 3 {
        return Err(Error::invalid(
            "surface fit range",
            format!("{from} .. {to}"),
            format!(
                "holds grains in only {} bins of width {bin}; 3 are needed",
                points.len()
            ),
        ));
    }
    let m = points.len() as f64;
    let (sx, sy) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), p| (a + p.0, b + p.1));
    let (mx, my) = (sx / m, sy / m);
    let (sxy, sxx) = points.iter().fold((0.0, 0.0), |(a, b), p| {
        (a + (p.0 - mx) * (p.1 - my), b + (p.0 - mx) * (p.0 - mx))
    });
    Ok((sxy / sxx).atan().to_degrees())
}

/// One flank of a heap ([`heap_flank`]): its angle in degrees (positive: falling away from
/// the axis), the abscissae between which it was fitted, and the grains' tops as
/// `(distance from the axis, height)`.
#[derive(Clone, Debug, PartialEq)]
pub struct Flank {
    /// Flank angle in degrees.
    pub angle: f64,
    /// Start of the fit (15 % of the toe's distance from the axis).
    pub from: f64,
    /// End of the fit (85 % of the toe's distance).
    pub to: f64,
    /// Every grain's `(distance from the axis, top)` (its centre's height plus its radius).
    pub grains: Vec<(f64, f64)>,
}

/// The flank angle of a heap built about the vertical axis through `x = 0` (`x = y = 0` in
/// 3D), as [`column_heap`] builds it: each grain's distance from the axis and its top,
/// the toe at the distance 95 % of the grains stay within, and [`surface_angle`] fitted
/// from 15 % to 85 % of the toe (clear of the crest's rounding and the toe's scattered
/// grains).
///
/// Errors: `positions` and `radii` of different lengths or empty, and those of
/// [`surface_angle`].
pub fn heap_flank(dim: Dim, positions: &[[f64; 3]], radii: &[f64]) -> Result<Flank> {
    if positions.len() != radii.len() || positions.is_empty() {
        return Err(Error::invalid(
            "heap grains",
            format!("{} positions, {} radii", positions.len(), radii.len()),
            "must be as many positions as radii, at least one",
        ));
    }
    let up = dim.vertical();
    let grains: Vec<(f64, f64)> = positions
        .iter()
        .zip(radii)
        .map(|(p, r)| {
            let away = match dim {
                Dim::Two => p[0].abs(),
                Dim::Three => p[0].hypot(p[1]),
            };
            (away, p[up] + r)
        })
        .collect();
    let mut reach: Vec<f64> = grains.iter().map(|g| g.0).collect();
    reach.sort_by(f64::total_cmp);
    let toe = reach[(0.95 * (reach.len() - 1) as f64) as usize];
    let (from, to) = (0.15 * toe, 0.85 * toe);
    let angle = -surface_angle(&grains, from, to, 1.0)?;
    Ok(Flank {
        angle,
        from,
        to,
        grains,
    })
}
