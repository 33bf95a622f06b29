//! CPU backend: a half Verlet list (each pair evaluated once, Newton's third law) in fixed
//! blocks of consecutive particles ([`simkit_neighbor::BlockedHalfList`], pairs within
//! `max r_c + skin`), rayon over the blocks, and a lane-wise pair kernel compiled for
//! AVX-512, AVX2 and the baseline target, picked at run time ([`kernel`]).
//!
//! The list is rebuilt when a particle has moved more than `skin / 2` since the last build
//! (the largest displacement is NaN-propagating, so a blown-up particle triggers a rebuild
//! too). A rebuild wraps the periodic coordinates into the box, sorts the particles by cell
//! (every per-particle array is permuted, so neighbours are close in memory; `order` keeps
//! the system index of each slot, and the state is reported in the system order) and lists
//! every pair with the periodic image it has then. Between builds the periodic coordinates
//! are not wrapped and the force loop needs no minimum-image test; closed axes reflect at
//! every drift.
//!
//! Per force pass each block writes its particles' forces, and the reactions it owes to
//! later slots, into buffers of its own ([`buffers`]: a dense one over the block and its
//! same-image partners, about one layer of cells, and a queue for the cross-image
//! reactions beyond it); the total force on a slot is its own block's entry plus the dense
//! entries of the earlier blocks that reach it, added in block order, then their queued
//! reactions, in block order. Block boundaries depend only on the particle count and the
//! box, so results are bit for bit independent of the number of threads.
//!
//! Without a thermostat a step makes two passes over the particle arrays besides the force
//! kernel: the opening kick, the drift and the largest displacement since the build in one,
//! the force totals, `a = F / m` and the closing kick in the other (the same operations per
//! particle, in the same order, as separate passes: fusing them saves memory traffic, not
//! rounding).
//!
//! The summation order depends on the list, hence on the positions at the last build: a
//! checkpoint stores them (and the slot order), and a resumed run rebuilds the identical
//! list and continues bit for bit. The results depend on the skin through the rebuild
//! schedule, by rounding only.

mod buffers;
mod kernel;

use rayon::prelude::*;

use simkit_backend::guard::{Guarded, Halt, first_non_finite, run_guarded, verdict};
use simkit_backend::particles::Dynamics;
use simkit_backend::{Error, Real, Result, max_or_nan};
use simkit_neighbor::{BlockedHalfList, wrap_periodic};

use buffers::BlockForces;

use crate::config::Integrator;
use crate::diagnostics::assemble;
use crate::engine::Engine;
use crate::thermostat::{gaussians, ou_coefficients};
use crate::{Config, Diagnostics, PairLaw, State, System};

pub(crate) use kernel::Kernel;

pub(crate) const AXES: [&str; 3] = ["x", "y", "z"];

/// Particles per rayon task in the per-particle passes (kick, drift, displacement).
const MIN_LEN: usize = 4096;

/// The state at the last check that passed.
struct Snapshot<T, const D: usize> {
    pos: Vec<[T; D]>,
    vel: Vec<[T; D]>,
    acc: Vec<[T; D]>,
    force: Vec<[T; D]>,
    ew: Vec<[T; 2]>,
    reference: Vec<[T; D]>,
    order: Vec<u32>,
    steps: u64,
}

/// The CPU engine for dimension `D` and precision `T`.
pub(crate) struct CpuEngine<const D: usize, T: Real, L: PairLaw> {
    system: System<L>,
    dt: f64,
    integrator: Integrator,
    check_every: u32,
    n_species: usize,
    coeff: Vec<L::Coeff<T>>,
    /// `1 / m` per species, `0` for a frozen species (its forces are not integrated).
    inv_mass: Vec<T>,
    /// The Langevin thermostat: seed and `(c1, amplitude)` per species.
    langevin: Option<(u32, Vec<(T, T)>)>,
    /// Species of the particle in each slot.
    species: Vec<u32>,
    /// The system index of the particle in each slot.
    order: Vec<u32>,
    lo: [T; D],
    hi: [T; D],
    len: [T; D],
    periodic: [bool; D],
    /// Positions, periodic coordinates unwrapped since the last list build.
    pos: Vec<[T; D]>,
    /// Velocity Verlet: `v(t)`; leapfrog: `v(t + dt/2)`.
    vel: Vec<[T; D]>,
    acc: Vec<[T; D]>,
    /// Total force per slot.
    force: Vec<[T; D]>,
    /// Per slot, `sum phi` and `sum r . F` over the pairs it lists (each pair once), at
    /// the positions of the last step of each checked chunk (the state `check`, the
    /// snapshot and the diagnostics see; the other steps leave them out).
    ew: Vec<[T; 2]>,
    /// The positions at the last list build (wrapped, in slot order).
    reference: Vec<[T; D]>,
    /// `(skin / 2)^2` (the skin of the list range, see [`CpuEngine::new`]): a larger
    /// squared displacement since the build triggers a rebuild.
    rebuild2: f64,
    list: BlockedHalfList<T, D>,
    /// Per block, its forces and the reactions it owes.
    local: Vec<BlockForces<T, D>>,
    kernel: Kernel,
    /// A separation beyond every cutoff, `2 max r_c` (the kernel's unused lanes).
    pad: T,
    steps: u64,
    snap: Snapshot<T, D>,
}

impl<const D: usize, T: Real, L: PairLaw> CpuEngine<D, T, L> {
    /// Builds the engine from a validated system at `dt`; `saved` is a checkpointed state
    /// (columns in slot order, with the positions of its last list build).
    pub fn new(
        system: &System<L>,
        config: &Config,
        dt: f64,
        saved: Option<&Dynamics>,
    ) -> Result<Self> {
        let n = system.particle_count();
        let lo3 = system.lo();
        let len3 = system.lengths();
        let per3 = system.periodic();
        let lo: [f64; D] = std::array::from_fn(|d| lo3[d]);
        let len: [f64; D] = std::array::from_fn(|d| len3[d]);
        let periodic: [bool; D] = std::array::from_fn(|d| per3[d]);
        let r_c = system.table().max_cutoff();
        let range = list_range(system, config.skin);
        let list = BlockedHalfList::new(lo, len, periodic, range, n)?;
        // The lengths and the f64 values were checked by `Dynamics::check`; in `f32` a
        // finite f64 may still overflow.
        let unflat = |v: &[f64], what: &str| -> Result<Vec<[T; D]>> {
            let out: Vec<[T; D]> = v
                .chunks_exact(D)
                .map(|c| std::array::from_fn(|d| T::from_f64(c[d])))
                .collect();
            if out.iter().flatten().any(|x| !x.to_f64().is_finite()) {
                return Err(Error::checkpoint(format!(
                    "the stored {what} overflow {}",
                    T::WGSL
                )));
            }
            Ok(out)
        };
        let (steps, pos, vel, reference) = match saved {
            None => (
                0,
                system
                    .positions()
                    .iter()
                    .map(|p| std::array::from_fn(|d| T::from_f64(p[d])))
                    .collect(),
                system
                    .velocities()
                    .iter()
                    .map(|v| std::array::from_fn(|d| T::from_f64(v[d])))
                    .collect(),
                Vec::new(),
            ),
            Some(s) => {
                s.check(n, D, &["pos", "vel", "reference"])?;
                (
                    s.steps,
                    unflat(&s.pos, "positions")?,
                    unflat(&s.vel, "velocities")?,
                    unflat(&s.reference, "list-build positions")?,
                )
            }
        };
        let half_skin = 0.5 * (range - r_c);
        let mut e = Self {
            system: system.clone(),
            dt,
            integrator: config.integrator,
            check_every: config.check_every,
            n_species: system.table().n_species(),
            coeff: system.table().coefficients::<T>(config.shift),
            inv_mass: system
                .masses()
                .iter()
                .zip(system.frozen())
                .map(|(&m, &f)| if f { T::ZERO } else { T::from_f64(1.0 / m) })
                .collect(),
            langevin: config.thermostat.map(|l| {
                let c = ou_coefficients(system, &l, dt);
                (
                    l.seed,
                    c.iter()
                        .map(|&(a, b)| (T::from_f64(a), T::from_f64(b)))
                        .collect(),
                )
            }),
            order: match saved {
                Some(s) if !s.order.is_empty() => s.order.clone(),
                _ => (0..n as u32).collect(),
            },
            species: Vec::new(),
            lo: lo.map(T::from_f64),
            hi: std::array::from_fn(|d| T::from_f64(lo[d] + len[d])),
            len: len.map(T::from_f64),
            periodic,
            pos,
            vel,
            acc: vec![[T::ZERO; D]; n],
            force: vec![[T::ZERO; D]; n],
            ew: vec![[T::ZERO; 2]; n],
            reference,
            rebuild2: half_skin * half_skin,
            local: vec![BlockForces::default(); list.blocks().len()],
            list,
            kernel: Kernel::detect(),
            pad: T::from_f64(2.0 * system.table().max_cutoff()),
            steps,
            snap: Snapshot {
                pos: Vec::new(),
                vel: Vec::new(),
                acc: Vec::new(),
                force: Vec::new(),
                ew: Vec::new(),
                reference: Vec::new(),
                order: Vec::new(),
                steps: 0,
            },
        };
        let all = system.species();
        e.species = e.order.iter().map(|&i| all[i as usize]).collect();
        // Frozen particles stand still.
        let frozen = system.frozen();
        for (v, &sp) in e.vel.iter_mut().zip(&e.species) {
            if frozen[sp as usize] {
                *v = [T::ZERO; D];
            }
        }
        match saved {
            None => {
                // A position just below the upper face may round up onto it in f32.
                for x in &mut e.pos {
                    for (d, c) in x.iter_mut().enumerate() {
                        if e.periodic[d] && *c >= e.hi[d] {
                            *c = e.lo[d];
                        }
                    }
                }
                e.rebuild()?;
            }
            Some(_) => {
                e.relist()?;
                // A stored position must be one the run could have produced.
                if let Some((what, _)) = e.first_failure() {
                    return Err(Error::checkpoint(format!(
                        "the stored state is not valid: {what}"
                    )));
                }
            }
        }
        e.forces(true)?;
        if saved.is_none() && e.integrator == Integrator::Leapfrog {
            let h = T::from_f64(0.5 * dt);
            kick(&mut e.vel, &e.acc, h);
        }
        if let Some((what, cause)) = e.first_failure() {
            return Err(Error::invalid(
                "initial state",
                what,
                format!("{cause}; move the particles apart or lower dt"),
            ));
        }
        Ok(e)
    }

    /// Reorders every per-particle array but `reference` into `slots` (slot `k` takes the
    /// particle in slot `slots[k]`).
    fn reslot(&mut self, slots: &[u32]) {
        fn take<X: Copy + Send + Sync>(v: &mut Vec<X>, slots: &[u32]) {
            *v = slots.par_iter().map(|&k| v[k as usize]).collect();
        }
        take(&mut self.pos, slots);
        take(&mut self.vel, slots);
        take(&mut self.acc, slots);
        take(&mut self.force, slots);
        take(&mut self.ew, slots);
        take(&mut self.species, slots);
        take(&mut self.order, slots);
    }

    /// Wraps the periodic coordinates into the box, sorts the slots by cell and rebuilds
    /// the half list (each pair with its periodic image, fixed until the next build).
    fn rebuild(&mut self) -> Result<()> {
        let (lo, hi, len, per) = (self.lo, self.hi, self.len, self.periodic);
        self.pos
            .par_iter_mut()
            .with_min_len(MIN_LEN)
            .for_each(|x| wrap_periodic(x, lo, hi, len, per));
        let slots = self.list.sort(&self.pos)?;
        self.reslot(&slots);
        self.reference.clone_from(&self.pos);
        self.list.build(&self.reference, true)?;
        self.size_buffers()
    }

    /// Rebuilds the list of the last build from `reference` (after a rollback or a resume:
    /// the reference positions are in cell order, so the sort keeps the slots and the list
    /// is the one the run had).
    fn relist(&mut self) -> Result<()> {
        let slots = self.list.sort(&self.reference)?;
        if slots.iter().enumerate().any(|(k, &s)| s as usize != k) {
            // Not reached for a state this engine wrote; kept consistent all the same.
            self.reslot(&slots);
            self.reference = slots.iter().map(|&k| self.reference[k as usize]).collect();
        }
        self.list.build(&self.reference, true)?;
        self.size_buffers()
    }

    /// Sizes each block's force buffers to the list just built.
    /// Refuses a list that names a slot beyond the particles (the force kernel relies on it).
    fn size_buffers(&mut self) -> Result<()> {
        let n = self.pos.len();
        for (buf, nb) in self.local.iter_mut().zip(self.list.blocks()) {
            buf.fit(nb, n)?;
        }
        Ok(())
    }

    /// The largest squared displacement since the list build (NaN if any is NaN).
    fn max_displacement2(&self) -> f64 {
        self.pos
            .par_iter()
            .zip(self.reference.par_iter())
            .with_min_len(MIN_LEN)
            .map(|(x, r)| {
                let mut s2 = T::ZERO;
                for d in 0..D {
                    let s = x[d] - r[d];
                    s2 += s * s;
                }
                s2.to_f64()
            })
            .reduce(|| 0.0, max_or_nan)
    }

    /// Puts the arrays back into the system order.
    fn unslot<U: Copy + Default>(&self, v: &[U]) -> Vec<U> {
        let mut out = vec![U::default(); v.len()];
        for (x, &i) in v.iter().zip(&self.order) {
            out[i as usize] = *x;
        }
        out
    }

    /// Forces at the current positions, with the potential energy and virial when
    /// `energy` is set (the list rebuilt first if a particle moved more than `skin / 2`).
    fn forces(&mut self, energy: bool) -> Result<()> {
        let moved2 = self.max_displacement2();
        self.forces_then_kick(moved2, energy, None)
    }

    /// [`forces`](Self::forces) given the largest squared displacement since the list
    /// build, `moved2`; with `kick = Some(h)` it also adds `a h` to the velocities in the
    /// same pass over the particles (the closing kick of a step: the same operations, in
    /// the same order, as a separate [`kick`]).
    fn forces_then_kick(&mut self, moved2: f64, energy: bool, kick: Option<T>) -> Result<()> {
        if beyond(moved2, self.rebuild2) {
            self.rebuild()?;
        }
        let inp = kernel::Inputs::<T, D, L> {
            pos: &self.pos,
            species: &self.species,
            coeff: &self.coeff,
            n_species: self.n_species,
            pad: self.pad,
        };
        let kern = self.kernel;
        let bs = self.list.block_size();
        let blocks = self.list.blocks();
        blocks
            .par_iter()
            .zip(self.local.par_iter_mut())
            .zip(self.ew.par_chunks_mut(bs))
            .for_each(|((nb, local), ew)| {
                // SAFETY: `size_buffers` (after every build) checked that no block reaches
                // beyond `pos.len()` and fitted `local` to the block.
                unsafe {
                    kernel::block_forces(
                        kern,
                        &inp,
                        nb,
                        &mut local.near,
                        &mut local.far,
                        ew,
                        energy,
                    )
                }
            });
        // Totals: the own block's entry, then the earlier blocks' in block order.
        let local = &self.local;
        let (species, inv_mass) = (&self.species, &self.inv_mass);
        self.force
            .par_chunks_mut(bs)
            .zip(self.acc.par_chunks_mut(bs))
            .zip(self.vel.par_chunks_mut(bs))
            .enumerate()
            .for_each(|(t, ((f, a), v))| {
                let start = t * bs;
                f.copy_from_slice(&local[t].near[..f.len()]);
                for (b, buf) in local[..t].iter().enumerate() {
                    buf.add_dense(b * bs, start, f);
                }
                for buf in &local[..t] {
                    buf.add_far(start, f);
                }
                for (k, (a, f)) in a.iter_mut().zip(f.iter()).enumerate() {
                    let im = inv_mass[species[start + k] as usize];
                    *a = f.map(|x| x * im);
                }
                if let Some(h) = kick {
                    kick_slice(v, a, h);
                }
            });
        Ok(())
    }

    /// `v += a h` when `kick = Some(h)`, then `x += v dt`, reflecting at closed faces
    /// (periodic coordinates are wrapped at the next list build), in one pass over the
    /// particles; returns the largest squared displacement since the list build (NaN if
    /// any is NaN), which [`max_displacement2`](Self::max_displacement2) would give.
    fn kick_drift(&mut self, kick: Option<T>) -> f64 {
        let dt = T::from_f64(self.dt);
        let (lo, hi, per) = (self.lo, self.hi, self.periodic);
        self.pos
            .par_iter_mut()
            .zip(self.vel.par_iter_mut())
            .zip(self.acc.par_iter())
            .zip(self.reference.par_iter())
            .with_min_len(MIN_LEN)
            .map(|(((x, v), a), r)| {
                let mut s2 = T::ZERO;
                for d in 0..D {
                    if let Some(h) = kick {
                        v[d] += a[d] * h;
                    }
                    x[d] += v[d] * dt;
                    if !per[d] {
                        reflect(&mut x[d], &mut v[d], lo[d], hi[d]);
                    }
                    let s = x[d] - r[d];
                    s2 += s * s;
                }
                s2.to_f64()
            })
            .reduce(|| 0.0, max_or_nan)
    }

    /// The thermostatted drift `A O A` of BAOAB: `v' = c1 v + amplitude R`,
    /// `x += (v + v') dt / 2`, `v = v'`, then the reflection at closed faces (the twin of
    /// `md_drift_langevin` in `shaders/langevin.wgsl`). The normal numbers `R` are keyed by
    /// `(seed, step, particle)`, the step being the one this drift starts (mod 2^32).
    fn drift_langevin(&mut self) {
        let Some((seed, ou)) = &self.langevin else {
            return;
        };
        let (seed, h) = (*seed, T::from_f64(0.5 * self.dt));
        let step = self.steps as u32;
        let (lo, hi, per) = (self.lo, self.hi, self.periodic);
        let (species, order) = (&self.species, &self.order);
        self.pos
            .par_iter_mut()
            .zip(self.vel.par_iter_mut())
            .enumerate()
            .with_min_len(1024)
            .for_each(|(k, (x, v))| {
                let (c1, amp) = ou[species[k] as usize];
                // Keyed by the system index, so the noise does not depend on the slots.
                let g = gaussians::<D>(seed, step, order[k]);
                for d in 0..D {
                    let w = c1 * v[d] + amp * T::from_f64(g[d]);
                    x[d] += (v[d] + w) * h;
                    v[d] = w;
                    if !per[d] {
                        reflect(&mut x[d], &mut v[d], lo[d], hi[d]);
                    }
                }
            });
    }

    /// The opening kick `v += a h` (when `kick = Some(h)`) and the drift of a step:
    /// Newtonian, or thermostatted when a thermostat is on; returns the largest squared
    /// displacement since the list build.
    fn move_particles(&mut self, kick: Option<T>) -> f64 {
        if self.langevin.is_some() {
            if let Some(h) = kick {
                self::kick(&mut self.vel, &self.acc, h);
            }
            self.drift_langevin();
            self.max_displacement2()
        } else {
            self.kick_drift(kick)
        }
    }

    /// One step; `energy`: compute the potential energy and virial at its end. The
    /// kicks ride on the passes over the particles that the drift and the force totals
    /// make anyway.
    fn one_step(&mut self, energy: bool) -> Result<()> {
        let (open, close) = match self.integrator {
            Integrator::VelocityVerlet => {
                let h = T::from_f64(0.5 * self.dt);
                (Some(h), h)
            }
            Integrator::Leapfrog => (None, T::from_f64(self.dt)),
        };
        let moved2 = self.move_particles(open);
        self.forces_then_kick(moved2, energy, Some(close))?;
        self.steps += 1;
        Ok(())
    }

    /// The first non-finite value or particle outside the box, with the likely cause.
    fn first_failure(&self) -> Option<(String, String)> {
        let cause = "a time step too large for the stiffest pair (see time_step_guide) or \
                     particles started (nearly) on top of each other; lower Config::dt";
        for (name, v) in [
            ("position", &self.pos),
            ("velocity", &self.vel),
            ("acceleration", &self.acc),
        ] {
            if let Some(k) = first_non_finite(v.as_flattened()) {
                let (i, d) = (k / D, k % D);
                return Some((
                    format!(
                        "particle {}: {name} {} = {}",
                        self.order[i], AXES[d], v[i][d]
                    ),
                    cause.to_string(),
                ));
            }
        }
        if self.integrator == Integrator::Leapfrog {
            // The reported velocities v(t + dt/2) - a(t) dt/2 must be finite too.
            let h = T::from_f64(0.5 * self.dt);
            for (i, (v, a)) in self.vel.iter().zip(&self.acc).enumerate() {
                for d in 0..D {
                    let u = v[d] - a[d] * h;
                    if !u.to_f64().is_finite() {
                        return Some((
                            format!(
                                "particle {}: velocity {} at the step = {u}",
                                self.order[i], AXES[d]
                            ),
                            cause.to_string(),
                        ));
                    }
                }
            }
        }
        // Closed axes: the position itself is in the box. Periodic axes: the position at
        // the list build was (a particle that moved more than a box length in one step
        // is still outside once wrapped), and the particle is within skin / 2 of it.
        for (i, (x, r)) in self.pos.iter().zip(&self.reference).enumerate() {
            for d in 0..D {
                let (y, out) = if self.periodic[d] {
                    (r[d], !(r[d] >= self.lo[d] && r[d] < self.hi[d]))
                } else {
                    (x[d], !(x[d] >= self.lo[d] && x[d] <= self.hi[d]))
                };
                if out {
                    return Some((
                        format!(
                            "particle {}: position {} = {y} left the box [{}, {}] (it moved \
                             more than a box length in one step)",
                            self.order[i], AXES[d], self.lo[d], self.hi[d]
                        ),
                        cause.to_string(),
                    ));
                }
            }
            let mut s2 = T::ZERO;
            for d in 0..D {
                let s = x[d] - r[d];
                s2 += s * s;
            }
            if beyond(s2.to_f64(), self.rebuild2) {
                return Some((
                    format!(
                        "particle {}: {} from its position at the last list build, more \
                         than skin / 2 = {}",
                        self.order[i],
                        s2.to_f64().sqrt(),
                        self.rebuild2.sqrt()
                    ),
                    cause.to_string(),
                ));
            }
        }
        // The energies the diagnostics sum must be finite too: a finite velocity can still
        // have an infinite kinetic energy in f64 (|v| > 1e154), and a pair energy or virial
        // can overflow while the force does not.
        let masses = self.system.masses();
        let mut total = 0.0f64;
        for (i, ((v, ew), &s)) in self.vel.iter().zip(&self.ew).zip(&self.species).enumerate() {
            let v2: f64 = v.iter().map(|x| x.to_f64() * x.to_f64()).sum();
            let ke = 0.5 * masses[s as usize] * v2;
            total += ke;
            let bad = [
                ("kinetic energy", ke),
                ("pair energy", ew[0].to_f64()),
                ("virial", ew[1].to_f64()),
            ]
            .into_iter()
            .find(|(_, x)| !x.is_finite());
            if let Some((what, x)) = bad {
                return Some((
                    format!("particle {}: {what} = {x}", self.order[i]),
                    cause.to_string(),
                ));
            }
        }
        if !total.is_finite() {
            return Some((format!("total kinetic energy = {total}"), cause.to_string()));
        }
        None
    }

    /// Velocities at the step (leapfrog: `v(t + dt/2) - a(t) dt / 2`).
    fn synced_velocities(&self) -> Vec<[T; D]> {
        match self.integrator {
            Integrator::VelocityVerlet => self.vel.clone(),
            Integrator::Leapfrog => {
                let h = T::from_f64(0.5 * self.dt);
                self.vel
                    .iter()
                    .zip(&self.acc)
                    .map(|(v, a)| std::array::from_fn(|d| v[d] - a[d] * h))
                    .collect()
            }
        }
    }

    /// The positions with the periodic coordinates wrapped into the box.
    fn wrapped_positions(&self) -> Vec<[T; D]> {
        let (lo, hi, len, per) = (self.lo, self.hi, self.len, self.periodic);
        self.pos
            .iter()
            .map(|&x| {
                let mut x = x;
                wrap_periodic(&mut x, lo, hi, len, per);
                x
            })
            .collect()
    }
}

/// The neighbour-list range of `system` with `skin`: `max r_c + skin`, less where a
/// periodic length is below twice that (the system guarantees at least twice `max r_c`):
/// a pair must be within range in one image only. The list is rebuilt when a particle has
/// moved more than half of `range - max r_c`.
pub(crate) fn list_range<L: PairLaw>(system: &System<L>, skin: f64) -> f64 {
    let (len, per) = (system.lengths(), system.periodic());
    (0..system.dim().axes())
        .filter(|&d| per[d])
        .fold(system.table().max_cutoff() + skin, |r, d| {
            r.min(0.5 * len[d])
        })
}

/// Whether the squared displacement `d2` exceeds `limit` or is NaN.
#[inline]
pub(crate) fn beyond(d2: f64, limit: f64) -> bool {
    d2 > limit || d2.is_nan()
}

/// Mirrors a coordinate that crossed a closed face back into the box and flips the
/// velocity component.
#[inline(always)]
pub(crate) fn reflect<T: Real>(x: &mut T, v: &mut T, lo: T, hi: T) {
    if *x < lo {
        *x = lo + lo - *x;
        *v = -*v;
    } else if *x > hi {
        *x = hi + hi - *x;
        *v = -*v;
    }
}

/// `v += a h` on the rayon pool.
fn kick<T: Real, const D: usize>(v: &mut [[T; D]], a: &[[T; D]], h: T) {
    v.par_chunks_mut(MIN_LEN)
        .zip(a.par_chunks(MIN_LEN))
        .for_each(|(v, a)| kick_slice(v, a, h));
}

/// `v += a h` (the kick of every integrator).
pub(crate) fn kick_slice<T: Real, const D: usize>(v: &mut [[T; D]], a: &[[T; D]], h: T) {
    for (v, a) in v.iter_mut().zip(a) {
        for d in 0..D {
            v[d] += a[d] * h;
        }
    }
}

fn widen<T: Real, const D: usize>(v: &[[T; D]]) -> Vec<[f64; 3]> {
    v.iter()
        .map(|x| std::array::from_fn(|d| if d < D { x[d].to_f64() } else { 0.0 }))
        .collect()
}

/// The blow-up guard's view of the engine (see [`simkit_backend::guard`]).
impl<const D: usize, T: Real, L: PairLaw> Guarded for CpuEngine<D, T, L> {
    fn steps_done(&self) -> u64 {
        self.steps
    }

    fn keep(&mut self) -> Result<()> {
        let s = &mut self.snap;
        s.pos.clone_from(&self.pos);
        s.vel.clone_from(&self.vel);
        s.acc.clone_from(&self.acc);
        s.force.clone_from(&self.force);
        s.ew.clone_from(&self.ew);
        s.reference.clone_from(&self.reference);
        s.order.clone_from(&self.order);
        s.steps = self.steps;
        Ok(())
    }

    fn advance(&mut self, n: u32) -> std::result::Result<(), Halt> {
        for s in 0..n {
            // The energies only where the check (and the caller) looks: the last step.
            self.one_step(s + 1 == n).map_err(|e| Halt::BlowUp {
                step: self.steps + 1,
                what: e.to_string(),
                cause: "a time step too large for the stiffest pair (see time_step_guide); \
                        lower Config::dt"
                    .to_string(),
            })?;
        }
        Ok(())
    }

    fn check(&mut self) -> std::result::Result<(), Halt> {
        verdict(self.steps, self.first_failure())
    }

    fn restore(&mut self) -> Result<()> {
        let s = &self.snap;
        self.pos.clone_from(&s.pos);
        self.vel.clone_from(&s.vel);
        self.acc.clone_from(&s.acc);
        self.force.clone_from(&s.force);
        self.ew.clone_from(&s.ew);
        self.reference.clone_from(&s.reference);
        self.order.clone_from(&s.order);
        self.steps = s.steps;
        let all = self.system.species();
        self.species = self.order.iter().map(|&i| all[i as usize]).collect();
        // The list refers to the slots of the last build: rebuild the snapshot's.
        self.relist()
    }
}

impl<const D: usize, T: Real, L: PairLaw> Engine for CpuEngine<D, T, L> {
    fn step(&mut self, steps: u32) -> Result<()> {
        let every = self.check_every;
        simkit_backend::pool::on_pool(|| run_guarded(self, steps, every))
    }

    fn state(&mut self) -> Result<State> {
        Ok(State {
            time: self.steps as f64 * self.dt,
            positions: self.unslot(&widen(&self.wrapped_positions())),
            velocities: self.unslot(&widen(&self.synced_velocities())),
            angular_velocities: Vec::new(),
            species: self.unslot(&self.species),
        })
    }

    fn diagnostics(&mut self) -> Result<Diagnostics> {
        let ns = self.n_species;
        let masses = self.system.masses();
        let mut kin = vec![0.0f64; ns];
        let mut count = vec![0usize; ns];
        for (v, &s) in self.synced_velocities().iter().zip(&self.species) {
            let v2: f64 = v.iter().map(|x| x.to_f64() * x.to_f64()).sum();
            kin[s as usize] += 0.5 * masses[s as usize] * v2;
            count[s as usize] += 1;
        }
        let potential = self.ew.iter().map(|x| x[0].to_f64()).sum::<f64>();
        let virial = self.ew.iter().map(|x| x[1].to_f64()).sum::<f64>();
        Ok(assemble(
            self.steps as f64 * self.dt,
            D,
            self.system.volume(),
            &kin,
            &count,
            potential,
            virial,
        ))
    }

    fn forces(&mut self) -> Result<Vec<[f64; 3]>> {
        // The forces on a frozen particle are not integrated and reported as 0, as on the
        // GPU, which keeps only the accelerations.
        let frozen = self.system.frozen();
        let f: Vec<[f64; 3]> = self
            .force
            .iter()
            .zip(&self.species)
            .map(|(f, &s)| {
                std::array::from_fn(|d| {
                    if d < D && !frozen[s as usize] {
                        f[d].to_f64()
                    } else {
                        0.0
                    }
                })
            })
            .collect();
        Ok(self.unslot(&f))
    }

    fn name(&self) -> String {
        format!(
            "cpu (rayon, {} threads, {}, {})",
            rayon::current_num_threads(),
            T::WGSL,
            self.kernel.name()
        )
    }

    fn steps_done(&self) -> u64 {
        self.steps
    }

    fn model(&self) -> String {
        crate::engine::model_name::<L>(false, T::PRECISION, D)
    }

    /// The slots as they are (cell order of the last list build), with that build's
    /// positions: a resume rebuilds the identical list, hence the same order of the force
    /// sums.
    fn save(&mut self) -> Result<Dynamics> {
        let flat =
            |v: &[[T; D]]| -> Vec<f64> { v.as_flattened().iter().map(|x| x.to_f64()).collect() };
        Ok(Dynamics {
            steps: self.steps,
            time: self.steps as f64 * self.dt,
            width: D as u32,
            order: self.order.clone(),
            pos: flat(&self.pos),
            vel: flat(&self.vel),
            reference: flat(&self.reference),
            ..Dynamics::default()
        })
    }
}
