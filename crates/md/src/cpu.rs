//! CPU backend: a full Verlet list ([`simkit_neighbor::VerletList`], pairs within
//! `max r_c + skin`, rebuilt automatically when a particle has moved more than `skin / 2`
//! since the last build), forces gathered per particle in parallel (rayon; each task writes
//! only its own particle, every pair is evaluated from both ends, so there are no write
//! conflicts and the sums do not depend on the thread count), positions wrapped or
//! reflected after every drift.
//!
//! Results do not depend on when the list was built: a particle's neighbours are visited in
//! ascending index order and filtered by the cutoff, so the same pairs are summed in the
//! same order whatever extra pairs the skin holds. A resumed run therefore rebuilds its list
//! from the current positions and continues bit for bit.

use rayon::prelude::*;

use simkit_backend::guard::{blow_up, chunks, first_non_finite};
use simkit_backend::{Error, Real, Result};
use simkit_neighbor::{CellGrid, ListKind, OutOfBox, VerletList};

use crate::config::Integrator;
use crate::diagnostics::assemble;
use crate::engine::{Engine, EngineState};
use crate::table::{PairCoeff, pair_force_energy};
use crate::thermostat::{gaussians, ou_coefficients};
use crate::{Config, Diagnostics, State, System};

const AXES: [&str; 3] = ["x", "y", "z"];

/// What the force pass accumulates per particle.
#[derive(Clone, Copy)]
struct Acc<T, const D: usize> {
    f: [T; D],
    /// `sum_j phi_ij` (twice the particle's share of the potential energy).
    e: T,
    /// `sum_j r_ij . F_ij` (twice its share of the virial).
    w: T,
}

impl<T: Real, const D: usize> Acc<T, D> {
    const ZERO: Self = Self {
        f: [T::ZERO; D],
        e: T::ZERO,
        w: T::ZERO,
    };
}

/// The state at the last check that passed.
struct Snapshot<T, const D: usize> {
    pos: Vec<[T; D]>,
    vel: Vec<[T; D]>,
    acc: Vec<[T; D]>,
    out: Vec<Acc<T, D>>,
    order: Vec<u32>,
    steps: u64,
}

/// The CPU engine for dimension `D` and precision `T`.
pub(crate) struct CpuEngine<const D: usize, T: Real> {
    system: System,
    dt: f64,
    integrator: Integrator,
    check_every: u32,
    n_species: usize,
    coeff: Vec<PairCoeff<T>>,
    /// `1 / m` per species, `0` for a frozen species (its forces are not integrated).
    inv_mass: Vec<T>,
    /// The Langevin thermostat: seed and `(c1, amplitude)` per species.
    langevin: Option<(u32, Vec<(T, T)>)>,
    /// Species of the particle in each slot.
    species: Vec<u32>,
    /// The system index of the particle in each slot (identity unless reordered).
    order: Vec<u32>,
    /// Reorder the slots in cell order every this many steps (0: never).
    reorder_every: u32,
    lo: [T; D],
    hi: [T; D],
    len: [T; D],
    periodic: [bool; D],
    pos: Vec<[T; D]>,
    /// Velocity Verlet: `v(t)`; leapfrog: `v(t + dt/2)`.
    vel: Vec<[T; D]>,
    acc: Vec<[T; D]>,
    out: Vec<Acc<T, D>>,
    list: VerletList<D>,
    /// Positions in `f64` for the list.
    wide: Vec<[f64; D]>,
    steps: u64,
    snap: Snapshot<T, D>,
}

impl<const D: usize, T: Real> CpuEngine<D, T> {
    /// Builds the engine from a validated system at `dt`; `saved` is a checkpointed state.
    pub fn new(
        system: &System,
        config: &Config,
        dt: f64,
        saved: Option<&EngineState>,
    ) -> Result<Self> {
        let n = system.particle_count();
        let lo3 = system.lo();
        let len3 = system.lengths();
        let per3 = system.periodic();
        let lo: [f64; D] = std::array::from_fn(|d| lo3[d]);
        let len: [f64; D] = std::array::from_fn(|d| len3[d]);
        let periodic: [bool; D] = std::array::from_fn(|d| per3[d]);
        // Closed axes: the engine's own check keeps particles in the box (in its precision,
        // whose rounded bounds may differ from the f64 ones by an ulp), so the grid only
        // clamps cell indices.
        let grid = CellGrid::<D>::new(lo, len, periodic, system.table().max_cutoff())?
            .with_out_of_box(OutOfBox::Clamp);
        let list = VerletList::new(&grid, config.skin, ListKind::Full)?;
        let (steps, pos, vel) = match saved {
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
            ),
            Some(s) => {
                let unflat = |v: &[f64], what: &str| -> Result<Vec<[T; D]>> {
                    if Some(v.len()) != n.checked_mul(D) {
                        return Err(Error::checkpoint(format!(
                            "the stored {what} have {} values for {n} particles in {D}D",
                            v.len()
                        )));
                    }
                    let out: Vec<[T; D]> = v
                        .chunks_exact(D)
                        .map(|c| std::array::from_fn(|d| T::from_f64(c[d])))
                        .collect();
                    if out.iter().flatten().any(|x| !x.to_f64().is_finite()) {
                        return Err(Error::checkpoint(format!(
                            "the stored {what} are not finite"
                        )));
                    }
                    Ok(out)
                };
                (
                    s.steps,
                    unflat(&s.pos, "positions")?,
                    unflat(&s.vel, "velocities")?,
                )
            }
        };
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
            species: system.species().to_vec(),
            order: (0..n as u32).collect(),
            reorder_every: config.reorder_every,
            lo: lo.map(T::from_f64),
            hi: std::array::from_fn(|d| T::from_f64(lo[d] + len[d])),
            len: len.map(T::from_f64),
            periodic,
            pos,
            vel,
            acc: vec![[T::ZERO; D]; n],
            out: vec![Acc::ZERO; n],
            list,
            wide: vec![[0.0; D]; n],
            steps,
            snap: Snapshot {
                pos: Vec::new(),
                vel: Vec::new(),
                acc: Vec::new(),
                out: Vec::new(),
                order: Vec::new(),
                steps: 0,
            },
        };
        if let Some(s) = saved
            && !s.order.is_empty()
        {
            e.permute(&s.order)?;
        }
        // Frozen particles stand still.
        let frozen = system.frozen();
        for (v, &sp) in e.vel.iter_mut().zip(&e.species) {
            if frozen[sp as usize] {
                *v = [T::ZERO; D];
            }
        }
        if saved.is_none() {
            // A position just below the upper face may round up onto it in f32.
            for x in &mut e.pos {
                for (d, c) in x.iter_mut().enumerate() {
                    if e.periodic[d] && *c >= e.hi[d] {
                        *c = e.lo[d];
                    }
                }
            }
        } else {
            // A stored position must be one the run could have produced.
            if let Some((what, _)) = e.check() {
                return Err(Error::checkpoint(format!(
                    "the stored state is not valid: {what}"
                )));
            }
        }
        e.forces()?;
        if saved.is_none() && e.integrator == Integrator::Leapfrog {
            let h = T::from_f64(0.5 * dt);
            kick(&mut e.vel, &e.acc, h);
        }
        if let Some((what, cause)) = e.check() {
            return Err(Error::invalid(
                "initial state",
                what,
                format!("{cause}; move the particles apart or lower dt"),
            ));
        }
        Ok(e)
    }

    /// Puts the particle of system index `order[k]` into slot `k`, from the system order
    /// (a checkpoint's `order`).
    fn permute(&mut self, order: &[u32]) -> Result<()> {
        let n = self.pos.len();
        let mut seen = vec![false; n];
        let valid = order.len() == n
            && order.iter().all(|&i| {
                let fresh = (i as usize) < n && !seen[i as usize];
                if fresh {
                    seen[i as usize] = true;
                }
                fresh
            });
        if !valid {
            return Err(Error::checkpoint(format!(
                "the stored particle order is not a permutation of 0..{n}"
            )));
        }
        let take = |v: &[[T; D]]| -> Vec<[T; D]> { order.iter().map(|&i| v[i as usize]).collect() };
        self.pos = take(&self.pos);
        self.vel = take(&self.vel);
        self.species = order.iter().map(|&i| self.species[i as usize]).collect();
        self.order = order.to_vec();
        Ok(())
    }

    /// Sorts the slots by cell of the neighbour grid (stable, so the order within a cell
    /// is the current one) for cache locality, and rebuilds the list for the new slots.
    fn reorder(&mut self) -> Result<()> {
        let grid = self.list.grid();
        let cell: Vec<usize> = self
            .pos
            .iter()
            .map(|p| grid.cell_of(p.map(T::to_f64)))
            .collect();
        let mut slots: Vec<u32> = (0..self.pos.len() as u32).collect();
        slots.sort_by_key(|&k| cell[k as usize]);
        let take = |v: &[[T; D]]| -> Vec<[T; D]> { slots.iter().map(|&k| v[k as usize]).collect() };
        self.pos = take(&self.pos);
        self.vel = take(&self.vel);
        self.acc = take(&self.acc);
        self.out = slots.iter().map(|&k| self.out[k as usize]).collect();
        self.species = slots.iter().map(|&k| self.species[k as usize]).collect();
        self.order = slots.iter().map(|&k| self.order[k as usize]).collect();
        self.rebuild_list()
    }

    /// Builds the Verlet list afresh (after the slots changed).
    fn rebuild_list(&mut self) -> Result<()> {
        for (w, p) in self.wide.iter_mut().zip(&self.pos) {
            *w = p.map(T::to_f64);
        }
        self.list.build(&self.wide)
    }

    /// Puts the arrays back into the system order.
    fn unslot<U: Copy + Default>(&self, v: &[U]) -> Vec<U> {
        let mut out = vec![U::default(); v.len()];
        for (x, &i) in v.iter().zip(&self.order) {
            out[i as usize] = *x;
        }
        out
    }

    /// Forces, potential energy and virial at the current positions.
    fn forces(&mut self) -> Result<()> {
        for (w, p) in self.wide.iter_mut().zip(&self.pos) {
            *w = p.map(T::to_f64);
        }
        self.list.update(&self.wide)?;
        self.out.fill(Acc::ZERO);
        let coeff = &self.coeff;
        let species = &self.species;
        let ns = self.n_species;
        self.list
            .par_for_each_particle(&mut self.out, |o, i, j, sep, _| {
                let c = &coeff[species[i] as usize * ns + species[j] as usize];
                let s: [T; D] = sep.map(T::from_f64);
                let mut r2 = T::ZERO;
                for x in s {
                    r2 += x * x;
                }
                let (fr, e) = pair_force_energy(c, r2);
                for (f, x) in o.f.iter_mut().zip(s) {
                    *f += fr * x;
                }
                o.e += e;
                o.w += fr * r2;
            })?;
        let inv_mass = &self.inv_mass;
        self.acc
            .par_iter_mut()
            .zip(self.out.par_iter())
            .zip(species.par_iter())
            .with_min_len(4096)
            .for_each(|((a, o), &s)| {
                let im = inv_mass[s as usize];
                *a = o.f.map(|f| f * im);
            });
        Ok(())
    }

    /// `x += v dt` with the boundary rule of each axis.
    fn drift(&mut self) {
        let dt = T::from_f64(self.dt);
        let (lo, hi, len, per) = (self.lo, self.hi, self.len, self.periodic);
        self.pos
            .par_iter_mut()
            .zip(self.vel.par_iter_mut())
            .with_min_len(4096)
            .for_each(|(x, v)| {
                for d in 0..D {
                    x[d] += v[d] * dt;
                    boundary(&mut x[d], &mut v[d], lo[d], hi[d], len[d], per[d]);
                }
            });
    }

    /// The thermostatted drift `A O A` of BAOAB: `v' = c1 v + amplitude R`,
    /// `x += (v + v') dt / 2`, `v = v'`, then the boundary rule (the twin of
    /// `md_drift_langevin` in `shaders/langevin.wgsl`). The normal numbers `R` are keyed by
    /// `(seed, step, particle)`, the step being the one this drift starts (mod 2^32).
    fn drift_langevin(&mut self) {
        let Some((seed, ou)) = &self.langevin else {
            return;
        };
        let (seed, h) = (*seed, T::from_f64(0.5 * self.dt));
        let step = self.steps as u32;
        let (lo, hi, len, per) = (self.lo, self.hi, self.len, self.periodic);
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
                    boundary(&mut x[d], &mut v[d], lo[d], hi[d], len[d], per[d]);
                }
            });
    }

    /// The drift of a step: Newtonian, or thermostatted when a thermostat is on.
    fn move_particles(&mut self) {
        if self.langevin.is_some() {
            self.drift_langevin();
        } else {
            self.drift();
        }
    }

    fn one_step(&mut self) -> Result<()> {
        if self.reorder_every > 0 && self.steps.is_multiple_of(u64::from(self.reorder_every)) {
            self.reorder()?;
        }
        match self.integrator {
            Integrator::VelocityVerlet => {
                let h = T::from_f64(0.5 * self.dt);
                kick(&mut self.vel, &self.acc, h);
                self.move_particles();
                self.forces()?;
                kick(&mut self.vel, &self.acc, h);
            }
            Integrator::Leapfrog => {
                self.move_particles();
                self.forces()?;
                kick(&mut self.vel, &self.acc, T::from_f64(self.dt));
            }
        }
        self.steps += 1;
        Ok(())
    }

    /// The first non-finite value or particle outside the box, with the likely cause.
    fn check(&self) -> Option<(String, String)> {
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
        for (i, x) in self.pos.iter().enumerate() {
            for d in 0..D {
                let out = if self.periodic[d] {
                    !(x[d] >= self.lo[d] && x[d] < self.hi[d])
                } else {
                    !(x[d] >= self.lo[d] && x[d] <= self.hi[d])
                };
                if out {
                    return Some((
                        format!(
                            "particle {}: position {} = {} left the box [{}, {}] (it moved \
                             more than a box length in one step)",
                            self.order[i], AXES[d], x[d], self.lo[d], self.hi[d]
                        ),
                        cause.to_string(),
                    ));
                }
            }
        }
        // The energies the diagnostics sum must be finite too: a finite velocity can still
        // have an infinite kinetic energy in f64 (|v| > 1e154), and a particle's pair
        // energy or virial can overflow while its force does not.
        let masses = self.system.masses();
        let mut total = 0.0f64;
        for (i, ((v, o), &s)) in self
            .vel
            .iter()
            .zip(&self.out)
            .zip(&self.species)
            .enumerate()
        {
            let v2: f64 = v.iter().map(|x| x.to_f64() * x.to_f64()).sum();
            let ke = 0.5 * masses[s as usize] * v2;
            total += ke;
            let bad = [
                ("kinetic energy", ke),
                ("pair energy", o.e.to_f64()),
                ("virial", o.w.to_f64()),
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

    fn keep(&mut self) {
        self.snap.pos.clone_from(&self.pos);
        self.snap.vel.clone_from(&self.vel);
        self.snap.acc.clone_from(&self.acc);
        self.snap.out.clone_from(&self.out);
        if self.reorder_every > 0 {
            self.snap.order.clone_from(&self.order);
        }
        self.snap.steps = self.steps;
    }

    fn restore(&mut self) -> Result<()> {
        self.pos.clone_from(&self.snap.pos);
        self.vel.clone_from(&self.snap.vel);
        self.acc.clone_from(&self.snap.acc);
        self.out.clone_from(&self.snap.out);
        self.steps = self.snap.steps;
        if self.reorder_every > 0 && self.order != self.snap.order {
            // The slots changed since the snapshot: the list refers to the new ones.
            self.order.clone_from(&self.snap.order);
            let order = &self.order;
            self.species = order
                .iter()
                .map(|&i| self.system.species()[i as usize])
                .collect();
            self.rebuild_list()
        } else {
            Ok(())
        }
    }

    fn guarded(&mut self, steps: u32) -> Result<()> {
        for n in chunks(self.steps, steps, self.check_every) {
            self.keep();
            let mut failed = None;
            for _ in 0..n {
                if let Err(e) = self.one_step() {
                    failed = Some((self.steps + 1, e.to_string()));
                    break;
                }
            }
            let found = match failed {
                Some((step, what)) => Some((
                    step,
                    what,
                    "a time step too large for the stiffest pair (see time_step_guide); \
                     lower Config::dt"
                        .to_string(),
                )),
                None => self.check().map(|(w, c)| (self.steps, w, c)),
            };
            if let Some((step, what, cause)) = found {
                self.restore()?;
                return Err(blow_up(step, self.steps, what, cause));
            }
        }
        Ok(())
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
}

/// The boundary rule of one axis after a move: a periodic axis wraps by one box length, a
/// closed one mirrors the coordinate back into the box and flips the velocity component.
#[inline(always)]
fn boundary<T: Real>(x: &mut T, v: &mut T, lo: T, hi: T, len: T, periodic: bool) {
    if periodic {
        if *x < lo {
            *x += len;
            if *x >= hi {
                *x = lo;
            }
        } else if *x >= hi {
            *x = *x - len;
        }
    } else if *x < lo {
        *x = lo + lo - *x;
        *v = -*v;
    } else if *x > hi {
        *x = hi + hi - *x;
        *v = -*v;
    }
}

/// `v += a h`.
fn kick<T: Real, const D: usize>(v: &mut [[T; D]], a: &[[T; D]], h: T) {
    v.par_iter_mut()
        .zip(a.par_iter())
        .with_min_len(4096)
        .for_each(|(v, a)| {
            for d in 0..D {
                v[d] += a[d] * h;
            }
        });
}

fn widen<T: Real, const D: usize>(v: &[[T; D]]) -> Vec<[f64; 3]> {
    v.iter()
        .map(|x| std::array::from_fn(|d| if d < D { x[d].to_f64() } else { 0.0 }))
        .collect()
}

impl<const D: usize, T: Real> Engine for CpuEngine<D, T> {
    fn step(&mut self, steps: u32) -> Result<()> {
        simkit_backend::pool::on_pool(|| self.guarded(steps))
    }

    fn state(&mut self) -> Result<State> {
        Ok(State {
            time: self.steps as f64 * self.dt,
            positions: self.unslot(&widen(&self.pos)),
            velocities: self.unslot(&widen(&self.synced_velocities())),
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
        let potential = 0.5 * self.out.iter().map(|o| o.e.to_f64()).sum::<f64>();
        let virial = 0.5 * self.out.iter().map(|o| o.w.to_f64()).sum::<f64>();
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
            .out
            .iter()
            .zip(&self.species)
            .map(|(o, &s)| {
                std::array::from_fn(|d| {
                    if d < D && !frozen[s as usize] {
                        o.f[d].to_f64()
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
            "cpu (rayon, {} threads, {})",
            rayon::current_num_threads(),
            T::WGSL
        )
    }

    fn steps_done(&self) -> u64 {
        self.steps
    }

    fn model(&self) -> String {
        crate::sim::model_name(false, T::PRECISION, D)
    }

    fn save(&mut self) -> Result<EngineState> {
        let flat = |v: &[[T; D]]| -> Vec<f64> {
            let mut out = vec![0.0; v.len() * D];
            for (x, &i) in v.iter().zip(&self.order) {
                for d in 0..D {
                    out[i as usize * D + d] = x[d].to_f64();
                }
            }
            out
        };
        let reordered = self.order.iter().enumerate().any(|(k, &i)| k != i as usize);
        Ok(EngineState {
            steps: self.steps,
            pos: flat(&self.pos),
            vel: flat(&self.vel),
            order: if reordered {
                self.order.clone()
            } else {
                Vec::new()
            },
        })
    }
}
