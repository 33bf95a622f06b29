//! Diagnostics of a state: energies, momentum, overlaps, contacts, granular temperature.

use simkit_backend::{Error, Result, max_or_nan};

use crate::ContactLaw;
use crate::prepared::Prepared;

/// Scalar observables of one state (computed on the host from a [`crate::State`], so they
/// are identical for both backends). For a state with a non-finite position or velocity
/// (`finite == false`) every energy, the momentum, the overlaps, the temperature and the
/// centre-of-mass height are NaN, and the contact counts 0.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Diagnostics {
    /// Simulation time.
    pub time: f64,
    /// Kinetic energy of the translation `sum m v^2 / 2`.
    pub kinetic: f64,
    /// Kinetic energy of the rotation `sum I w^2 / 2` (0 in a scene without rotation).
    pub rotational: f64,
    /// Elastic energy stored in the normal springs (pairs and walls; linear law:
    /// `sum k delta^2 / 2`, see [`crate::ContactLaw::elastic_energy`]).
    pub elastic: f64,
    /// Potential energy in gravity `sum m g h` (h along the vertical axis from the box floor).
    pub potential: f64,
    /// Total momentum.
    pub momentum: [f64; 3],
    /// Deepest particle–particle or particle–wall overlap.
    pub max_overlap: f64,
    /// Deepest overlap divided by the radius of the (smaller) particle involved.
    pub max_overlap_ratio: f64,
    /// Number of particle–particle contacts.
    pub contacts: usize,
    /// Number of particle–wall contacts.
    pub wall_contacts: usize,
    /// Granular temperature: `sum m |v - <v>|^2 / (N D)` with the mass-weighted mean `<v>`.
    pub granular_temperature: f64,
    /// Centre-of-mass height (vertical coordinate).
    pub com_height: f64,
    /// Whether every position and velocity is finite.
    pub finite: bool,
}

/// Calls `f(i, j, sep, r2)` once per unordered pair closer than the largest contact
/// distance, with minimum-image separations `x_i - x_j`.
///
/// Works for any valid box, however sparse: particles are sorted by the key of a cell one
/// contact distance wide (periodic axes: the box split into whole cells), and each looks up
/// its neighbour cells by binary search, so the cost is `O(N log N)` in time and `O(N)` in
/// memory whatever the box size. Positions outside the box (no walls) are fine.
pub(crate) fn for_each_close_pair<L: ContactLaw>(
    p: &Prepared<L>,
    positions: &[[f64; 3]],
    mut f: impl FnMut(usize, usize, [f64; 3], f64),
) {
    let cut = p.cutoff;
    let axes = p.axes;
    // Cells per periodic axis (at least one contact distance wide); non-periodic axes are
    // unbounded (keys may be any i64).
    let mut cells = [1i64; 3];
    let mut width = [cut; 3];
    for d in 0..axes {
        if p.periodic[d] {
            let c = (p.len[d] / cut).floor().clamp(1.0, (1u64 << 40) as f64);
            cells[d] = c as i64;
            width[d] = p.len[d] / c;
        }
    }
    let key = |x: &[f64; 3]| -> [i64; 3] {
        let mut k = [0i64; 3];
        for d in 0..axes {
            let t = x[d] - p.lo[d];
            k[d] = if p.periodic[d] {
                ((t.rem_euclid(p.len[d]) / width[d]).floor() as i64).min(cells[d] - 1)
            } else {
                // Saturating conversion: keys stay ordered even for far-away positions.
                (t / width[d]).floor() as i64
            };
        }
        k
    };
    let mut sorted: Vec<([i64; 3], u32)> = positions
        .iter()
        .enumerate()
        .map(|(i, x)| (key(x), i as u32))
        .collect();
    sorted.sort_unstable();
    let cut2 = cut * cut;
    for &(ki, i) in &sorted {
        let i = i as usize;
        let xi = positions[i];
        // The distinct neighbour keys along each axis.
        let mut near = [[0i64; 3]; 3];
        let mut count = [1usize; 3];
        for d in 0..axes {
            let c = ki[d];
            let (list, k): ([i64; 3], usize) = if p.periodic[d] {
                match cells[d] {
                    1 => ([c, 0, 0], 1),
                    2 => ([c, 1 - c, 0], 2),
                    n => ([(c + n - 1) % n, c, (c + 1) % n], 3),
                }
            } else {
                let mut out = [c; 3];
                let mut k = 0;
                for o in [c.checked_sub(1), Some(c), c.checked_add(1)]
                    .into_iter()
                    .flatten()
                {
                    out[k] = o;
                    k += 1;
                }
                (out, k)
            };
            near[d] = list;
            count[d] = k;
        }
        for a in 0..count[0] {
            for b in 0..count[1] {
                for c in 0..count[2] {
                    let cell = [
                        near[0][a],
                        near[1][b],
                        if axes == 3 { near[2][c] } else { 0 },
                    ];
                    let from = sorted.partition_point(|e| e.0 < cell);
                    for &(kj, j) in &sorted[from..] {
                        if kj != cell {
                            break;
                        }
                        let j = j as usize;
                        if j <= i {
                            continue;
                        }
                        let mut sep = [0.0; 3];
                        let mut r2 = 0.0;
                        for d in 0..axes {
                            let mut s = xi[d] - positions[j][d];
                            if p.periodic[d] {
                                s -= p.len[d] * (s / p.len[d]).round();
                            }
                            sep[d] = s;
                            r2 += s * s;
                        }
                        if r2 < cut2 {
                            f(i, j, sep, r2);
                        }
                    }
                }
            }
        }
    }
}

/// Initial overlaps deeper than this fraction of the smaller radius are refused.
pub const MAX_INITIAL_OVERLAP: f64 = 0.1;

/// Refuses initial particle–particle overlaps deeper than [`MAX_INITIAL_OVERLAP`] of the
/// smaller radius, and particle–wall overlaps deeper than that fraction of the radius
/// (they would release a large elastic energy at once).
pub(crate) fn check_initial_overlaps<L: ContactLaw>(p: &Prepared<L>) -> Result<()> {
    let (zw, _) = p.wall_motion(0.0);
    for (i, (x, &r)) in p.positions.iter().zip(&p.radius).enumerate() {
        for (k, w) in p.walls.iter().enumerate() {
            let depth = if p.axes == 2 {
                w.overlap(&[x[0], x[1]], r, zw, p.vertical)
            } else {
                w.overlap(x, r, zw, p.vertical)
            };
            // Positions are finite here (validated), so the depth is a number.
            if depth > MAX_INITIAL_OVERLAP * r {
                return Err(Error::invalid(
                    format!("initial position of particle {i} against wall {k}"),
                    format!("overlap {depth:e}"),
                    format!(
                        "deeper than {MAX_INITIAL_OVERLAP} of its radius ({r}); place the \
                         particle inside the walls, at least a radius from each"
                    ),
                ));
            }
        }
    }
    let worst = deepest_overlap(p, &p.positions);
    if let Some((i, j, depth)) = worst {
        let rmin = p.radius[i].min(p.radius[j]);
        if depth > MAX_INITIAL_OVERLAP * rmin {
            return Err(Error::invalid(
                format!("initial positions of particles {i} and {j}"),
                format!("overlap {depth:e}"),
                format!(
                    "deeper than {MAX_INITIAL_OVERLAP} of the smaller radius ({rmin}); \
                     separate the particles (e.g. a lattice spacing above the diameter)"
                ),
            ));
        }
    }
    Ok(())
}

/// The deepest particle–particle overlap `(i, j, depth)`, if any pair overlaps.
pub(crate) fn deepest_overlap<L: ContactLaw>(
    p: &Prepared<L>,
    positions: &[[f64; 3]],
) -> Option<(usize, usize, f64)> {
    let mut worst: Option<(usize, usize, f64)> = None;
    for_each_close_pair(p, positions, |i, j, _, r2| {
        let depth = p.radius[i] + p.radius[j] - r2.sqrt();
        if depth > 0.0 && worst.is_none_or(|w| depth > w.2) {
            worst = Some((i.min(j), i.max(j), depth));
        }
    });
    worst
}

pub(crate) fn compute<L: ContactLaw>(
    p: &Prepared<L>,
    time: f64,
    x: &[[f64; 3]],
    v: &[[f64; 3]],
    w: &[[f64; 3]],
) -> Result<Diagnostics> {
    let mut out = Diagnostics {
        time,
        finite: x
            .iter()
            .chain(v.iter())
            .chain(w.iter())
            .all(|a| a.iter().all(|c| c.is_finite())),
        ..Default::default()
    };
    if !out.finite {
        // A blown-up state has no meaningful energy: NaN, never a plausible 0.
        let nan = f64::NAN;
        return Ok(Diagnostics {
            kinetic: nan,
            rotational: nan,
            elastic: nan,
            potential: nan,
            momentum: [nan; 3],
            max_overlap: nan,
            max_overlap_ratio: nan,
            granular_temperature: nan,
            com_height: nan,
            ..out
        });
    }
    let mut mtot = 0.0;
    let mut mz = 0.0;
    for ((&m, xi), vi) in p.mass.iter().zip(x).zip(v) {
        mtot += m;
        mz += m * xi[p.vertical];
        for (mom, c) in out.momentum.iter_mut().zip(vi) {
            *mom += m * c;
        }
        out.kinetic += 0.5 * m * vi.iter().map(|c| c * c).sum::<f64>();
        out.potential += m * p.gravity * (xi[p.vertical] - p.lo[p.vertical]);
    }
    out.com_height = mz / mtot;
    out.rotational = p
        .inertia
        .iter()
        .zip(w)
        .map(|(&i, wi)| 0.5 * i * wi.iter().map(|c| c * c).sum::<f64>())
        .sum();
    let vmean = out.momentum.map(|c| c / mtot);
    let mut t = 0.0;
    for (&m, vi) in p.mass.iter().zip(v) {
        t += m * vi[..p.axes]
            .iter()
            .zip(&vmean)
            .map(|(c, mean)| (c - mean).powi(2))
            .sum::<f64>();
    }
    out.granular_temperature = t / (p.n * p.axes) as f64;
    let mut worst = 0.0f64;
    let mut worst_ratio = 0.0f64;
    let coeff: Vec<L::Coeff<f64>> = p.pairs.iter().map(L::coefficients).collect();
    for_each_close_pair(p, x, |i, j, _, r2| {
        let depth = p.radius[i] + p.radius[j] - r2.sqrt();
        if depth > 0.0 {
            let c = &coeff[crate::pair_index(p.species[i], p.species[j], p.n_species)];
            let mij = crate::reduced_mass(p.mass[i], p.mass[j]);
            let r_eff = p.radius[i] * p.radius[j] / (p.radius[i] + p.radius[j]);
            out.elastic += L::elastic_energy(c, mij, r_eff, depth);
            out.contacts += 1;
            worst = max_or_nan(worst, depth);
            worst_ratio = max_or_nan(worst_ratio, depth / p.radius[i].min(p.radius[j]));
        }
    });
    let (zw, _) = p.wall_motion(time);
    for ((&xi, &r), &m) in x.iter().zip(&p.radius).zip(&p.mass) {
        for wall in &p.walls {
            let depth = if p.axes == 2 {
                wall.overlap(&[xi[0], xi[1]], r, zw, p.vertical)
            } else {
                wall.overlap(&xi, r, zw, p.vertical)
            };
            if depth > 0.0 {
                let c = wall.material.coefficients::<f64>();
                out.elastic += L::elastic_energy(&c, m, r, depth);
                out.wall_contacts += 1;
                worst = max_or_nan(worst, depth);
                worst_ratio = max_or_nan(worst_ratio, depth / r);
            }
        }
    }
    out.max_overlap = worst;
    out.max_overlap_ratio = worst_ratio;
    Ok(out)
}
