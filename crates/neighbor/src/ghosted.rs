//! [`GhostedList`]: the neighbour list of one rank's particles in a spatial decomposition,
//! with ghost copies of the particles of the neighbouring regions.

use bytemuck::Pod;
use rayon::prelude::*;

use simkit_backend::comm::{Comm, GhostPlan, ParticleDomain};
use simkit_backend::{Error, Result};

use crate::{CellGrid, SortedCells};

/// Owned particles per rayon task of the list build.
const CHUNK: usize = 1024;

/// One rank's particles in a spatial decomposition ([`ParticleDomain`]) and their full
/// neighbour list, for distributed particle codes whose results must not depend on the rank
/// count (`dem`'s and `md`'s distributed runs).
///
/// [`GhostedList::build`] takes the rank's owned particles (their positions at the list
/// build and their global indices), fetches ghost copies of every particle and periodic
/// image within the list range (interaction cutoff plus skin) of the rank's region ([`ParticleDomain::ghosts`]:
/// the shift pattern over x and y; a periodic axis beyond them, z in 3D, gets its images
/// on the rank itself), and lists for every owned particle all local entries within the
/// list range, **sorted by global index**. A force loop that adds each particle's pair
/// terms in list order therefore adds them in an order no decomposition changes.
/// [`GhostedList::refresh`] replays the exchange with new values (positions every step,
/// or any other per-particle quantity a pair term reads).
///
/// Local entries are the owned particles first (in the order given), then the ghosts.
///
/// ```
/// use simkit_backend::comm::{Comm, ParticleDomain};
/// use simkit_neighbor::GhostedList;
/// # fn main() -> simkit_backend::Result<()> {
/// let comm = Comm::serial();
/// // A periodic 8 x 8 square, list range 1.2.
/// let domain = ParticleDomain::new([0.0; 2], [8.0; 2], [true; 2], 1.2, None, 1)?;
/// let mut list = GhostedList::<2>::new(domain, None, 1.2)?;
/// let x = [[0.3, 4.0], [7.8, 4.0], [4.0, 4.0]];
/// list.build(&comm, &x, &[10, 11, 12])?;
/// // Particle 10 sees 11 through the periodic face (a ghost image at x = -0.2).
/// let partners: Vec<u32> = list.partners(0).iter().map(|&j| list.ids()[j as usize]).collect();
/// assert_eq!(partners, [11]);
/// let mut values = x.to_vec();
/// values.resize(list.len(), [0.0; 2]);
/// list.refresh(&comm, &mut values, true)?;
/// assert!(values[3..].contains(&[-0.20000000000000018, 4.0]));
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug)]
pub struct GhostedList<const D: usize> {
    domain: ParticleDomain,
    /// A periodic axis beyond x and y: its lower corner and length.
    z: Option<(f64, f64)>,
    /// The list range (interaction cutoff plus skin).
    range: f64,
    plan: GhostPlan,
    /// Images along the periodic z, after the exchanged ghosts: the entry each copies and
    /// its shift.
    z_images: Vec<(u32, f64)>,
    owned: usize,
    ids: Vec<u32>,
    offsets: Vec<u32>,
    partners: Vec<u32>,
}

impl<const D: usize> GhostedList<D>
where
    [f64; D]: Pod,
{
    /// A list over `domain` (whose halo must be at least `range`) of the pairs within the
    /// list range `range` (the interaction cutoff plus a skin); `periodic_z = Some((lo,
    /// len))` when the third axis of a 3D box is periodic.
    ///
    /// Errors: `D` other than 2 or 3, a `periodic_z` in 2D, a range that is not finite and
    /// positive, or a halo shorter than the range.
    pub fn new(domain: ParticleDomain, periodic_z: Option<(f64, f64)>, range: f64) -> Result<Self> {
        if D != 2 && D != 3 {
            return Err(Error::invalid("dimension", D, "must be 2 or 3"));
        }
        if D == 2 && periodic_z.is_some() {
            return Err(Error::invalid(
                "periodic_z",
                "Some",
                "a 2D box has no third axis; pass None",
            ));
        }
        if !(range.is_finite() && range > 0.0) {
            return Err(Error::invalid(
                "list range",
                range,
                "must be finite and > 0",
            ));
        }
        if domain.halo() < range {
            return Err(Error::invalid(
                "halo of the domain",
                domain.halo(),
                format!("must be at least the list range {range}"),
            ));
        }
        Ok(Self {
            domain,
            z: periodic_z,
            range,
            plan: GhostPlan::default(),
            z_images: Vec::new(),
            owned: 0,
            ids: Vec::new(),
            offsets: vec![0],
            partners: Vec::new(),
        })
    }

    /// The decomposition.
    pub fn domain(&self) -> &ParticleDomain {
        &self.domain
    }

    /// Owned particles (the first local entries).
    pub fn owned(&self) -> usize {
        self.owned
    }

    /// Local entries: owned particles, then ghosts.
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// Whether there are no local entries.
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// Global index of every local entry (a particle and its periodic images share one).
    pub fn ids(&self) -> &[u32] {
        &self.ids
    }

    /// The local entries within the list range of owned particle `i` at the last build,
    /// by increasing global index (empty for `i >= owned()`).
    pub fn partners(&self, i: usize) -> &[u32] {
        match (self.offsets.get(i), self.offsets.get(i + 1)) {
            (Some(&a), Some(&b)) => &self.partners[a as usize..b as usize],
            _ => &[],
        }
    }

    /// The lists in CSR form, `(offsets, partners)`: owned particle `i` has partners
    /// `partners[offsets[i]..offsets[i + 1]]` (local entries).
    pub fn csr(&self) -> (&[u32], &[u32]) {
        (&self.offsets, &self.partners)
    }

    /// Makes the ghosts and the lists anew from the owned particles' positions `reference`
    /// (inside this rank's region along x and y; wrapped on periodic axes) and global
    /// indices `ids`. Collective; an error on one rank is an error on every rank.
    ///
    /// Errors: `reference` and `ids` of different lengths, positions the list's cell grid
    /// cannot hold (non-finite), or a failed exchange.
    pub fn build(&mut self, comm: &Comm, reference: &[[f64; D]], ids: &[u32]) -> Result<()> {
        let lengths = if reference.len() == ids.len() {
            Ok(())
        } else {
            Err(Error::invalid(
                "owned particles",
                format!("{} positions, {} indices", reference.len(), ids.len()),
                "pass one global index per position",
            ))
        };
        comm.agree(lengths)?;
        // Position, then the global index, as one record.
        let mut seeds: Vec<[f64; 4]> = reference
            .iter()
            .zip(ids)
            .map(|(x, &i)| {
                let mut s = [0.0; 4];
                s[..D].copy_from_slice(x);
                s[3] = f64::from(i);
                s
            })
            .collect();
        self.owned = seeds.len();
        self.plan = self.domain.ghosts(
            comm,
            &mut seeds,
            |s| [s[0], s[1]],
            |s, sh| {
                s[0] += sh[0];
                s[1] += sh[1];
            },
        )?;
        self.z_images.clear();
        if let (3, Some((z0, lz))) = (D, self.z) {
            let range = self.range;
            for k in 0..seeds.len() {
                let z = seeds[k][2];
                for (near, shift) in [(z < z0 + range, lz), (z >= z0 + lz - range, -lz)] {
                    if near {
                        let mut img = seeds[k];
                        img[2] += shift;
                        seeds.push(img);
                        self.z_images.push((k as u32, shift));
                    }
                }
            }
        }
        self.ids = seeds.iter().map(|s| s[3] as u32).collect();
        let x: Vec<[f64; D]> = seeds
            .iter()
            .map(|s| std::array::from_fn(|d| s[d]))
            .collect();
        // Non-finite positions fail the cell grid on some ranks only: all stop together.
        comm.agree(self.build_lists(&x))
    }

    /// The full list of every owned particle within the list range at `x` (all local
    /// entries), partners sorted by global index: cells a list range wide over the local
    /// entries, and each owned particle's shell of cells searched directly (the ghosts
    /// need no lists).
    fn build_lists(&mut self, x: &[[f64; D]]) -> Result<()> {
        self.offsets.clear();
        self.offsets.push(0);
        self.partners.clear();
        let n = self.owned;
        if n == 0 {
            return Ok(());
        }
        if x.len() > u32::MAX as usize {
            return Err(Error::invalid(
                "local particles",
                x.len(),
                "owned plus ghosts must fit u32 indices; use more ranks",
            ));
        }
        let (mut lo, mut hi) = ([f64::INFINITY; D], [f64::NEG_INFINITY; D]);
        for p in x {
            for d in 0..D {
                lo[d] = lo[d].min(p[d]);
                hi[d] = hi[d].max(p[d]);
            }
        }
        let range = self.range;
        let lengths: [f64; D] = std::array::from_fn(|d| (hi[d] - lo[d]) + range);
        // Cells over where the entries are, at most 8 per entry (plus a few): a particle
        // flung far away (a blown-up run) widens the cells instead of costing gigabytes.
        let limit = x.len().saturating_mul(8).saturating_add(4096);
        let grid = CellGrid::new_sparse(lo, lengths, [false; D], range, limit)?;
        let mut cells = SortedCells::new(&grid);
        cells.build(x)?;
        let ids = &self.ids;
        let parts: Vec<(Vec<u32>, Vec<usize>)> = (0..n.div_ceil(CHUNK))
            .into_par_iter()
            .map(|c| {
                let (mut partners, mut ends, mut keys) = (Vec::new(), Vec::new(), Vec::new());
                for i in c * CHUNK..((c + 1) * CHUNK).min(n) {
                    // (global index, local index) packed into one integer.
                    keys.clear();
                    cells.for_each_neighbor_of(i, |j, _, _| {
                        keys.push((u64::from(ids[j]) << 32) | j as u64);
                    })?;
                    keys.sort_unstable();
                    partners.extend(keys.iter().map(|&k| k as u32));
                    ends.push(partners.len());
                }
                Ok((partners, ends))
            })
            .collect::<Result<_>>()?;
        for (partners, ends) in parts {
            let base = self.partners.len();
            self.partners.extend_from_slice(&partners);
            for e in ends {
                let end = u32::try_from(base + e).map_err(|_| {
                    Error::invalid(
                        "neighbour-list entries",
                        base + e,
                        "must fit u32 offsets; use more ranks or a smaller skin",
                    )
                })?;
                self.offsets.push(end);
            }
        }
        Ok(())
    }

    /// Sends the owned entries of `values` (`len()` entries, owned first) to the ranks that
    /// hold ghosts of them and overwrites the ghosts; with `positions` the periodic images
    /// get their box length added (along x and y by the sender, along z here), else the
    /// values are copied as they are (velocities, charges, ...). Collective.
    ///
    /// Errors: `values` of another length than `len()`, or a failed exchange.
    pub fn refresh(&self, comm: &Comm, values: &mut [[f64; D]], positions: bool) -> Result<()> {
        if values.len() != self.len() {
            return Err(Error::invalid(
                "length of the values to refresh",
                values.len(),
                format!("must equal the {} local entries", self.len()),
            ));
        }
        let exchanged = self.plan.owned() + self.plan.ghosts();
        let shift = |x: &mut [f64; D], s: [f64; 2]| {
            if positions {
                for a in 0..2 {
                    if s[a] != 0.0 {
                        x[a] += s[a];
                    }
                }
            }
        };
        self.plan.refresh(comm, &mut values[..exchanged], shift)?;
        for (k, &(src, dz)) in self.z_images.iter().enumerate() {
            let img = exchanged + k;
            values[img] = values[src as usize];
            if positions {
                values[img][D - 1] += dz;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every owned particle's list against brute force over all minimum images, in a
    /// periodic 3D box with one region (ghosts are all self-images).
    #[test]
    fn lists_are_every_image_in_range_sorted_by_index() {
        let comm = Comm::serial();
        let l = 6.0;
        let domain = ParticleDomain::new([0.0; 2], [l; 2], [true; 2], 1.5, None, 1).unwrap();
        let mut list = GhostedList::<3>::new(domain, Some((0.0, l)), 1.5).unwrap();
        let x: Vec<[f64; 3]> = (0..200u32)
            .map(|k| {
                let u = |s: u32| l * f64::from(simkit_backend::rng::rng_uniform(9, s, k));
                [u(0), u(1), u(2)]
            })
            .collect();
        let ids: Vec<u32> = (0..200).rev().collect();
        list.build(&comm, &x, &ids).unwrap();
        let mut values = x.clone();
        values.resize(list.len(), [0.0; 3]);
        list.refresh(&comm, &mut values, true).unwrap();
        let min_image = |a: f64, b: f64| {
            let d = a - b;
            d - l * (d / l).round()
        };
        for i in 0..200 {
            let mut want: Vec<u32> = (0..200)
                .filter(|&j| j != i)
                .filter(|&j| {
                    let r2: f64 = (0..3).map(|d| min_image(x[i][d], x[j][d]).powi(2)).sum();
                    r2 < 1.5f64.powi(2) - 1e-9
                })
                .map(|j| ids[j])
                .collect();
            want.sort_unstable();
            let got: Vec<u32> = list
                .partners(i)
                .iter()
                .map(|&j| list.ids()[j as usize])
                .filter(|&g| {
                    // Entries within rounding of the range may or may not be listed.
                    let j = ids.iter().position(|&k| k == g).unwrap();
                    let r2: f64 = (0..3).map(|d| min_image(x[i][d], x[j][d]).powi(2)).sum();
                    r2 < 1.5f64.powi(2) - 1e-9
                })
                .collect();
            assert_eq!(got, want, "particle {i}");
            // Every listed entry holds the image within range of particle i.
            for &j in list.partners(i) {
                let r2: f64 = (0..3)
                    .map(|d| (x[i][d] - values[j as usize][d]).powi(2))
                    .sum();
                assert!(r2 <= 1.5f64.powi(2) + 1e-9, "{i} {j}: {r2}");
            }
        }
    }

    #[test]
    fn bad_settings_are_refused() {
        let domain = ParticleDomain::new([0.0; 2], [6.0; 2], [false; 2], 1.0, None, 1).unwrap();
        assert!(GhostedList::<3>::new(domain.clone(), None, 1.2).is_err());
        assert!(GhostedList::<2>::new(domain.clone(), Some((0.0, 6.0)), 0.6).is_err());
        assert!(GhostedList::<2>::new(domain.clone(), None, f64::NAN).is_err());
        let mut ok = GhostedList::<2>::new(domain, None, 0.9).unwrap();
        let comm = Comm::serial();
        assert!(ok.build(&comm, &[[1.0, 1.0]], &[]).is_err());
        let mut v = vec![[0.0; 2]; 3];
        assert!(ok.refresh(&comm, &mut v, true).is_err());
    }
}
