//! Diagnostics of a state: energies, momentum, overlaps, contacts, granular temperature.

use simkit_neighbor::{CellGrid, OutOfBox, SortedCells};

use simkit_backend::{Error, Result};

use crate::prepared::Prepared;

/// Scalar observables of one state (computed on the host from a [`crate::State`], so they
/// are identical for both backends).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Diagnostics {
    /// Simulation time.
    pub time: f64,
    /// Kinetic energy `sum m v^2 / 2`.
    pub kinetic: f64,
    /// Elastic energy stored in the springs `sum k delta^2 / 2` (pairs and walls).
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
/// distance, with minimum-image separations, using `neighbor`'s sorted cells.
pub(crate) fn for_each_close_pair(
    p: &Prepared,
    positions: &[[f64; 3]],
    mut f: impl FnMut(usize, usize, [f64; 3], f64),
) -> Result<()> {
    fn run<const D: usize>(
        p: &Prepared,
        positions: &[[f64; 3]],
        f: &mut dyn FnMut(usize, usize, [f64; 3], f64),
    ) -> Result<()> {
        let lo: [f64; D] = std::array::from_fn(|d| p.lo[d]);
        let len: [f64; D] = std::array::from_fn(|d| p.len[d]);
        let per: [bool; D] = std::array::from_fn(|d| p.periodic[d]);
        let grid = CellGrid::new(lo, len, per, p.cutoff)?.with_out_of_box(OutOfBox::Clamp);
        let mut cells = SortedCells::new(&grid);
        let pos: Vec<[f64; D]> = positions
            .iter()
            .map(|x| std::array::from_fn(|d| x[d]))
            .collect();
        cells.build(&pos)?;
        cells.for_each_pair(|i, j, sep, r2| {
            let mut s = [0.0; 3];
            s[..D].copy_from_slice(&sep);
            f(i, j, s, r2)
        });
        Ok(())
    }
    if p.axes == 2 {
        run::<2>(p, positions, &mut f)
    } else {
        run::<3>(p, positions, &mut f)
    }
}

/// Initial overlaps deeper than this fraction of the smaller radius are refused.
pub const MAX_INITIAL_OVERLAP: f64 = 0.1;

/// Refuses initial particle–particle overlaps deeper than [`MAX_INITIAL_OVERLAP`] of the
/// smaller radius (they would release a large elastic energy at once).
pub(crate) fn check_initial_overlaps(p: &Prepared) -> Result<()> {
    let worst = deepest_overlap(p, &p.positions)?;
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
pub(crate) fn deepest_overlap(
    p: &Prepared,
    positions: &[[f64; 3]],
) -> Result<Option<(usize, usize, f64)>> {
    let mut worst: Option<(usize, usize, f64)> = None;
    for_each_close_pair(p, positions, |i, j, _, r2| {
        let depth = p.radius[i] + p.radius[j] - r2.sqrt();
        if depth > 0.0 && worst.is_none_or(|w| depth > w.2) {
            worst = Some((i.min(j), i.max(j), depth));
        }
    })?;
    Ok(worst)
}

pub(crate) fn compute(
    p: &Prepared,
    time: f64,
    x: &[[f64; 3]],
    v: &[[f64; 3]],
) -> Result<Diagnostics> {
    let mut out = Diagnostics {
        time,
        finite: x
            .iter()
            .chain(v.iter())
            .all(|a| a.iter().all(|c| c.is_finite())),
        ..Default::default()
    };
    if !out.finite {
        return Ok(out);
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
    for_each_close_pair(p, x, |i, j, _, r2| {
        let depth = p.radius[i] + p.radius[j] - r2.sqrt();
        if depth > 0.0 {
            let c = &p.coeff[crate::pair_index(p.species[i], p.species[j], p.n_species)];
            let mij = crate::reduced_mass(p.mass[i], p.mass[j]);
            out.elastic += crate::spring_energy(c, mij, depth);
            out.contacts += 1;
            worst = worst.max(depth);
            worst_ratio = worst_ratio.max(depth / p.radius[i].min(p.radius[j]));
        }
    })?;
    let (zw, _) = p.wall_motion(time);
    for ((&xi, &r), &m) in x.iter().zip(&p.radius).zip(&p.mass) {
        for w in &p.walls {
            let depth = if p.axes == 2 {
                w.overlap(&[xi[0], xi[1]], r, zw, p.vertical)
            } else {
                w.overlap(&xi, r, zw, p.vertical)
            };
            if depth > 0.0 {
                out.elastic += crate::spring_energy(&w.coeff, m, depth);
                out.wall_contacts += 1;
                worst = worst.max(depth);
                worst_ratio = worst_ratio.max(depth / r);
            }
        }
    }
    out.max_overlap = worst;
    out.max_overlap_ratio = worst_ratio;
    Ok(out)
}
