//! [`RankHistory`]: the per-contact history of one rank's owned particles in a
//! [`super::DistributedDem`] run, kept per particle and partner so that it travels with the
//! particle.

use std::collections::HashMap;

use bytemuck::Pod;
use simkit_backend::{Error, Result};
use simkit_neighbor::RankParticles;

/// History values a [`Record`] holds: a law may keep at most this many per contact in a
/// distributed run.
pub(super) const MAX_HISTORY: usize = 12;

/// One contact's history as it travels between ranks: the particle's global index, the
/// partner (a particle's global index, or wall `w` as `particles + w`), the particle's
/// wrapped position along the two cut axes (where it migrates to), then the values.
pub(super) type Record = [f64; 4 + MAX_HISTORY];

/// The history of every contact of a rank's owned particles, from each particle's end: a
/// pair in contact has two copies, one with each particle, each advanced by the force
/// evaluation at its own end (so a copy never depends on where the partner is). Laid out
/// along the lists: particle `k`'s partners (in list order) at entries `at[k]..at[k + 1]`,
/// then every owned particle's walls in scene order. Empty for a law without history.
#[derive(Debug, Default)]
pub(super) struct RankHistory {
    /// Values per contact ([`crate::ContactLaw::HISTORY`]).
    h: usize,
    walls: usize,
    /// Particles of the run (wall `w` is partner `particles + w`).
    particles: u32,
    at: Vec<usize>,
    pairs: Vec<f64>,
    wall: Vec<f64>,
    /// The records at the blow-up guard's last snapshot.
    kept: Vec<Record>,
}

/// Where the force pass of one chunk of owned particles reads and writes its history.
pub(super) struct Chunk<'a> {
    h: usize,
    walls: usize,
    /// The first entries of the chunk's particles' partners, and the end.
    at: &'a [usize],
    pairs: &'a mut [f64],
    wall: &'a mut [f64],
}

impl Chunk<'_> {
    /// The history of the contact of the chunk's particle `k` with its `e`-th partner.
    #[inline(always)]
    pub fn pair(&mut self, k: usize, e: usize) -> &mut [f64] {
        if self.h == 0 {
            return &mut [];
        }
        let at = (self.at[k] - self.at[0] + e) * self.h;
        &mut self.pairs[at..at + self.h]
    }

    /// The history of the contact of the chunk's particle `k` with wall `w`.
    #[inline(always)]
    pub fn wall(&mut self, k: usize, w: usize) -> &mut [f64] {
        let at = (k * self.walls + w) * self.h;
        &mut self.wall[at..at + self.h]
    }
}

impl RankHistory {
    /// No contacts yet, for a law with `h` values per contact, `walls` walls and
    /// `particles` particles.
    ///
    /// Errors: `h` above [`MAX_HISTORY`].
    pub fn new(h: usize, walls: usize, particles: usize) -> Result<Self> {
        if h > MAX_HISTORY {
            return Err(Error::Unsupported(format!(
                "the contact law keeps {h} values per contact; DistributedDem carries at most \
                 {MAX_HISTORY} across ranks (run the scene with Dem)"
            )));
        }
        Ok(Self {
            h,
            walls,
            particles: particles as u32,
            ..Self::default()
        })
    }

    /// Whether the law keeps a history (otherwise every method is a no-op).
    pub fn on(&self) -> bool {
        self.h > 0
    }

    /// The contacts with a non-zero history, each a [`Record`] (the others restart from
    /// zero anyway).
    pub fn records<const D: usize, C: Copy + Send + Sync>(
        &self,
        p: &RankParticles<D, C>,
    ) -> Vec<Record>
    where
        [f64; D]: Pod,
    {
        let h = self.h;
        let mut out = Vec::new();
        if h == 0 || self.at.len() != p.owned() + 1 {
            // No history, or not laid out yet (the first list build): nothing to keep.
            return out;
        }
        let id = p.id();
        for k in 0..p.owned() {
            let mut x = p.pos()[k];
            p.wrap(&mut x);
            let mut keep = |partner: u32, v: &[f64]| {
                if v.iter().any(|&x| x != 0.0) {
                    let mut r = [0.0; 4 + MAX_HISTORY];
                    r[..4].copy_from_slice(&[f64::from(id[k]), f64::from(partner), x[0], x[1]]);
                    r[4..4 + h].copy_from_slice(v);
                    out.push(r);
                }
            };
            for (e, &j) in p.list().partners(k).iter().enumerate() {
                let at = (self.at[k] + e) * h;
                keep(id[j as usize], &self.pairs[at..at + h]);
            }
            for w in 0..self.walls {
                let at = (k * self.walls + w) * h;
                keep(self.particles + w as u32, &self.wall[at..at + h]);
            }
        }
        out
    }

    /// Lays the history out along the current lists of `p` and fills every entry with
    /// `fetch(particle, partner, values)` (global indices; `values` zero on entry).
    pub fn assign<const D: usize, C: Copy + Send + Sync>(
        &mut self,
        p: &RankParticles<D, C>,
        fetch: impl Fn(u32, u32, &mut [f64]),
    ) where
        [f64; D]: Pod,
    {
        let (h, n) = (self.h, p.owned());
        if h == 0 {
            return;
        }
        let list = p.list();
        self.at.clear();
        self.at.push(0);
        for k in 0..n {
            self.at.push(self.at[k] + list.partners(k).len());
        }
        self.pairs.clear();
        self.pairs.resize(self.at[n] * h, 0.0);
        self.wall.clear();
        self.wall.resize(n * self.walls * h, 0.0);
        let id = p.id();
        for k in 0..n {
            for (e, &j) in list.partners(k).iter().enumerate() {
                let at = (self.at[k] + e) * h;
                fetch(id[k], id[j as usize], &mut self.pairs[at..at + h]);
            }
            for w in 0..self.walls {
                let at = (k * self.walls + w) * h;
                fetch(id[k], self.particles + w as u32, &mut self.wall[at..at + h]);
            }
        }
    }

    /// [`RankHistory::assign`] from records (each contact from the particle's end, as
    /// [`RankHistory::records`] made them); contacts without one start from zero.
    pub fn assign_records<const D: usize, C: Copy + Send + Sync>(
        &mut self,
        p: &RankParticles<D, C>,
        records: &[Record],
    ) where
        [f64; D]: Pod,
    {
        let h = self.h;
        let index: HashMap<[u32; 2], &Record> = records
            .iter()
            .map(|r| ([r[0] as u32, r[1] as u32], r))
            .collect();
        self.assign(p, |i, partner, out| {
            if let Some(r) = index.get(&[i, partner]) {
                out.copy_from_slice(&r[4..4 + h]);
            }
        });
    }

    /// Keeps the records of the current contacts (the blow-up guard's snapshot).
    pub fn keep<const D: usize, C: Copy + Send + Sync>(&mut self, p: &RankParticles<D, C>)
    where
        [f64; D]: Pod,
    {
        self.kept = self.records(p);
    }

    /// Puts the snapshot back along the lists of `p` (the lists of the snapshot).
    pub fn restore<const D: usize, C: Copy + Send + Sync>(&mut self, p: &RankParticles<D, C>)
    where
        [f64; D]: Pod,
    {
        let kept = std::mem::take(&mut self.kept);
        self.assign_records(p, &kept);
        self.kept = kept;
    }

    /// The history of each chunk of `chunk` owned particles (of `owned`), for a parallel
    /// force pass: one entry per chunk, empty slices without history.
    pub fn chunks(&mut self, owned: usize, chunk: usize) -> Vec<Chunk<'_>> {
        let count = owned.div_ceil(chunk);
        let (h, walls) = (self.h, self.walls);
        if h == 0 {
            return (0..count)
                .map(|_| Chunk {
                    h,
                    walls,
                    at: &[],
                    pairs: &mut [],
                    wall: &mut [],
                })
                .collect();
        }
        let (mut pairs, mut wall) = (self.pairs.as_mut_slice(), self.wall.as_mut_slice());
        (0..count)
            .map(|c| {
                let (start, end) = (c * chunk, ((c + 1) * chunk).min(owned));
                let (a, rest) =
                    std::mem::take(&mut pairs).split_at_mut((self.at[end] - self.at[start]) * h);
                let (b, rest_w) = std::mem::take(&mut wall).split_at_mut((end - start) * walls * h);
                (pairs, wall) = (rest, rest_w);
                Chunk {
                    h,
                    walls,
                    at: &self.at[start..=end],
                    pairs: a,
                    wall: b,
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_law_with_more_history_than_a_record_holds_is_refused() {
        let e = RankHistory::new(MAX_HISTORY + 1, 1, 10).expect_err("13 values");
        assert!(matches!(e, Error::Unsupported(_)), "{e}");
        assert!(e.to_string().contains("13 values"), "{e}");
        assert!(RankHistory::new(MAX_HISTORY, 1, 10).is_ok());
    }
}
