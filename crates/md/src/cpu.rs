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
    inv_mass: Vec<T>,
    species: Vec<u32>,
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
                        return Err(Error::Checkpoint {
                            source_name: "<bytes>".into(),
                            reason: format!(
                                "the stored {what} have {} values for {n} particles in {D}D",
                                v.len()
                            ),
                        });
                    }
                    let out: Vec<[T; D]> = v
                        .chunks_exact(D)
                        .map(|c| std::array::from_fn(|d| T::from_f64(c[d])))
                        .collect();
                    if out.iter().flatten().any(|x| !x.to_f64().is_finite()) {
                        return Err(Error::Checkpoint {
                            source_name: "<bytes>".into(),
                            reason: format!("the stored {what} are not finite"),
                        });
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
                .map(|&m| T::from_f64(1.0 / m))
                .collect(),
            species: system.species().to_vec(),
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
                steps: 0,
            },
        };
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
                return Err(Error::Checkpoint {
                    source_name: "<bytes>".into(),
                    reason: format!("the stored state is not valid: {what}"),
                });
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
                    if per[d] {
                        if x[d] < lo[d] {
                            x[d] += len[d];
                            if x[d] >= hi[d] {
                                x[d] = lo[d];
                            }
                        } else if x[d] >= hi[d] {
                            x[d] = x[d] - len[d];
                        }
                    } else if x[d] < lo[d] {
                        x[d] = lo[d] + lo[d] - x[d];
                        v[d] = -v[d];
                    } else if x[d] > hi[d] {
                        x[d] = hi[d] + hi[d] - x[d];
                        v[d] = -v[d];
                    }
                }
            });
    }

    fn one_step(&mut self) -> Result<()> {
        match self.integrator {
            Integrator::VelocityVerlet => {
                let h = T::from_f64(0.5 * self.dt);
                kick(&mut self.vel, &self.acc, h);
                self.drift();
                self.forces()?;
                kick(&mut self.vel, &self.acc, h);
            }
            Integrator::Leapfrog => {
                self.drift();
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
                    format!("particle {i}: {name} {} = {}", AXES[d], v[i][d]),
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
                            format!("particle {i}: velocity {} at the step = {u}", AXES[d]),
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
                            "particle {i}: position {} = {} left the box [{}, {}] (it moved \
                             more than a box length in one step)",
                            AXES[d], x[d], self.lo[d], self.hi[d]
                        ),
                        cause.to_string(),
                    ));
                }
            }
        }
        None
    }

    fn keep(&mut self) {
        self.snap.pos.clone_from(&self.pos);
        self.snap.vel.clone_from(&self.vel);
        self.snap.acc.clone_from(&self.acc);
        self.snap.out.clone_from(&self.out);
        self.snap.steps = self.steps;
    }

    fn restore(&mut self) {
        self.pos.clone_from(&self.snap.pos);
        self.vel.clone_from(&self.snap.vel);
        self.acc.clone_from(&self.snap.acc);
        self.out.clone_from(&self.snap.out);
        self.steps = self.snap.steps;
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
                self.restore();
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
            positions: widen(&self.pos),
            velocities: widen(&self.synced_velocities()),
            species: self.species.clone(),
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
        Ok(self
            .out
            .iter()
            .map(|o| std::array::from_fn(|d| if d < D { o.f[d].to_f64() } else { 0.0 }))
            .collect())
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
        Ok(EngineState {
            steps: self.steps,
            pos: self.pos.as_flattened().iter().map(|x| x.to_f64()).collect(),
            vel: self.vel.as_flattened().iter().map(|x| x.to_f64()).collect(),
        })
    }
}
