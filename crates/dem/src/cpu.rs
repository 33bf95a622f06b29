//! CPU backend: Verlet list (from `neighbor`'s sorted cells) with a rayon gather per particle.
//!
//! Every particle sums its own contact forces in a fixed neighbour order (a full list), so
//! the result is bit-for-bit independent of the number of threads, with no atomics.

use rayon::prelude::*;

use neighbor::{CellGrid, ListKind, OutOfBox, VerletList};

use backend::Result;

use crate::prepared::Prepared;
use crate::real::Real;
use crate::{Integrator, State, pair_index};

#[derive(Clone, Copy)]
struct Coeff<T> {
    kappa: T,
    two_b: T,
    mu_s: T,
    mu_k: T,
}

impl<T: Real> Coeff<T> {
    fn of(c: &crate::ContactCoefficients) -> Self {
        Self {
            kappa: T::of(c.kappa),
            two_b: T::of(c.two_b),
            mu_s: T::of(c.mu_s),
            mu_k: T::of(c.mu_k),
        }
    }
}

#[derive(Clone, Copy)]
struct WallT<T> {
    cylinder: bool,
    normal: [T; 3],
    offset: T,
    center: [T; 2],
    radius: T,
    coeff: Coeff<T>,
    vibrating: bool,
}

/// Read-only particle data used by the force loop.
struct Body<T> {
    radius: Vec<T>,
    mass: Vec<T>,
    species: Vec<u32>,
    n_species: usize,
    coeff: Vec<Coeff<T>>,
    walls: Vec<WallT<T>>,
}

/// The CPU engine for dimension `D` and precision `T`.
pub(crate) struct CpuEngine<const D: usize, T: Real> {
    prep: Prepared,
    time: f64,
    started: bool,
    pos: Vec<[T; D]>,
    vel: Vec<[T; D]>,
    acc: Vec<[T; D]>,
    /// Velocity Verlet: predicted velocity at the force time. Position Verlet: last displacement.
    aux: Vec<[T; D]>,
    body: Body<T>,
    list: VerletList<D>,
    pos64: Vec<[f64; D]>,
    gravity: [T; D],
}

#[inline(always)]
fn tangential<T: Real, const D: usize, const FRICTION: bool>(
    f: &mut [T; D],
    n: [T; D],
    vn: T,
    vrel: [T; D],
    fnorm: T,
    mij: T,
    c: &Coeff<T>,
) {
    if FRICTION {
        let mut vt = [T::ZERO; D];
        let mut vt2 = T::ZERO;
        for d in 0..D {
            vt[d] = vrel[d] - vn * n[d];
            vt2 += vt[d] * vt[d];
        }
        if vt2 > T::ZERO {
            let vtn = vt2.sqrt();
            let fabs = if fnorm > T::ZERO { fnorm } else { -fnorm };
            let ft = (c.mu_s * fabs).min(c.mu_k * mij * vtn);
            let s = ft / vtn;
            for d in 0..D {
                f[d] += -(s * vt[d]);
            }
        }
    }
}

impl<const D: usize, T: Real> CpuEngine<D, T> {
    pub fn new(prep: Prepared) -> Result<Self> {
        let n = prep.n;
        let cv = |a: &[f64; 3]| -> [T; D] { std::array::from_fn(|d| T::of(a[d])) };
        let lo: [f64; D] = std::array::from_fn(|d| prep.lo[d]);
        let len: [f64; D] = std::array::from_fn(|d| prep.len[d]);
        let per: [bool; D] = std::array::from_fn(|d| prep.periodic[d]);
        let grid = CellGrid::new(lo, len, per, prep.cutoff)?.with_out_of_box(OutOfBox::Clamp);
        let list = VerletList::new(&grid, prep.skin, ListKind::Full)?;
        let mut gravity = [T::ZERO; D];
        gravity[prep.vertical] = T::of(-prep.gravity);
        let body = Body {
            radius: prep.radius.iter().map(|&r| T::of(r)).collect(),
            mass: prep.mass.iter().map(|&m| T::of(m)).collect(),
            species: prep.species.clone(),
            n_species: prep.n_species,
            coeff: prep.coeff.iter().map(Coeff::of).collect(),
            walls: prep
                .walls
                .iter()
                .map(|w| WallT {
                    cylinder: w.cylinder,
                    normal: w.normal.map(T::of),
                    offset: T::of(w.offset),
                    center: w.center.map(T::of),
                    radius: T::of(w.radius),
                    coeff: Coeff::of(&w.coeff),
                    vibrating: w.vibrating,
                })
                .collect(),
        };
        let mut e = Self {
            pos: prep.positions.iter().map(cv).collect(),
            vel: prep.velocities.iter().map(cv).collect(),
            acc: vec![[T::ZERO; D]; n],
            aux: vec![[T::ZERO; D]; n],
            body,
            list,
            // Only the f32 engine needs an f64 copy of the positions for the list.
            pos64: if std::any::TypeId::of::<T>() == std::any::TypeId::of::<f64>() {
                Vec::new()
            } else {
                vec![[0.0; D]; n]
            },
            gravity,
            prep,
            time: 0.0,
            started: false,
        };
        e.wrap();
        e.refresh_list()?;
        Ok(e)
    }

    fn wrap(&mut self) {
        let p = &self.prep;
        let lo: [T; D] = std::array::from_fn(|d| T::of(p.lo[d]));
        let len: [T; D] = std::array::from_fn(|d| T::of(p.len[d]));
        let per: [bool; D] = std::array::from_fn(|d| p.periodic[d]);
        if !per.iter().any(|&b| b) {
            return;
        }
        self.pos.par_iter_mut().with_min_len(4096).for_each(|x| {
            for d in 0..D {
                if per[d] {
                    if x[d] < lo[d] {
                        x[d] += len[d];
                    } else if x[d] >= lo[d] + len[d] {
                        x[d] = x[d] - len[d];
                    }
                }
            }
        });
    }

    fn refresh_list(&mut self) -> Result<()> {
        // In f64 the list reads the positions directly; in f32 through an f64 copy.
        let any: &dyn std::any::Any = &self.pos;
        let pos64: &[[f64; D]] = match any.downcast_ref::<Vec<[f64; D]>>() {
            Some(p) => p,
            None => {
                self.pos64
                    .par_iter_mut()
                    .zip(self.pos.par_iter())
                    .with_min_len(4096)
                    .for_each(|(a, b)| *a = std::array::from_fn(|d| b[d].to_f64()));
                &self.pos64
            }
        };
        // The force loop reads our own (wrapped) positions, so the list only needs a
        // rebuild check, not its stored copy of the positions.
        if self.list.needs_rebuild(pos64)? {
            self.list.build(pos64)?;
        }
        Ok(())
    }

    /// Accelerations at time `t` from positions `self.pos` and velocities `v` into `self.acc`.
    fn accelerations(&mut self, t: f64, use_aux: bool) -> Result<()> {
        if self.prep.friction {
            self.accelerations_variant::<true>(t, use_aux)
        } else {
            self.accelerations_variant::<false>(t, use_aux)
        }
    }

    fn accelerations_variant<const FRICTION: bool>(&mut self, t: f64, use_aux: bool) -> Result<()> {
        let (zw, vw) = self.prep.wall_motion(t);
        let (zw, vw) = (T::of(zw), T::of(vw));
        let vert = self.prep.vertical;
        let body = &self.body;
        let pos = &self.pos;
        let v: &[[T; D]] = if use_aux { &self.aux } else { &self.vel };
        let g = self.gravity;
        let list = &self.list;
        let per: [bool; D] = std::array::from_fn(|d| self.prep.periodic[d]);
        let len: [T; D] = std::array::from_fn(|d| T::of(self.prep.len[d]));
        let half: [T; D] = std::array::from_fn(|d| T::of(0.5 * self.prep.len[d]));
        // One pass per particle: gravity, walls, then the contact forces gathered over its
        // full neighbour list in a fixed order (each particle writes only its own
        // acceleration: no atomics, results independent of the thread count).
        self.acc
            .par_iter_mut()
            .enumerate()
            .with_min_len(256)
            .for_each(|(i, f)| {
                let m = body.mass[i];
                for d in 0..D {
                    f[d] = g[d] * m;
                }
                let r = body.radius[i];
                for w in &body.walls {
                    let mut n = [T::ZERO; D];
                    let delta;
                    let mut wv = [T::ZERO; D];
                    if w.cylinder {
                        let dx = pos[i][0] - w.center[0];
                        let dy = pos[i][1] - w.center[1];
                        let rho = (dx * dx + dy * dy).sqrt();
                        delta = rho + r - w.radius;
                        if delta <= T::ZERO || rho <= T::ZERO {
                            continue;
                        }
                        n[0] = -(dx / rho);
                        n[1] = -(dy / rho);
                    } else {
                        let mut h = -w.offset;
                        for d in 0..D {
                            n[d] = w.normal[d];
                            h += n[d] * pos[i][d];
                        }
                        if w.vibrating {
                            h = h - zw * n[vert];
                        }
                        delta = r - h;
                        if delta <= T::ZERO {
                            continue;
                        }
                    }
                    if w.vibrating {
                        wv[vert] = vw;
                    }
                    let mut vrel = [T::ZERO; D];
                    let mut vn = T::ZERO;
                    for d in 0..D {
                        vrel[d] = v[i][d] - wv[d];
                        vn += vrel[d] * n[d];
                    }
                    let fnorm = m * (w.coeff.kappa * delta - w.coeff.two_b * vn);
                    for d in 0..D {
                        f[d] += fnorm * n[d];
                    }
                    tangential::<T, D, FRICTION>(f, n, vn, vrel, fnorm, m, &w.coeff);
                }
                for &j in list.list_of(i) {
                    let j = j as usize;
                    let rsum = r + body.radius[j];
                    // Minimum-image separation (positions are wrapped into the box).
                    let mut sep = [T::ZERO; D];
                    let mut r2 = T::ZERO;
                    for d in 0..D {
                        let mut s = pos[i][d] - pos[j][d];
                        if per[d] {
                            if s > half[d] {
                                s = s - len[d];
                            } else if s < -half[d] {
                                s += len[d];
                            }
                        }
                        sep[d] = s;
                        r2 += s * s;
                    }
                    if r2 >= rsum * rsum {
                        continue;
                    }
                    let dist = r2.sqrt();
                    let delta = rsum - dist;
                    let inv = T::of(1.0) / dist;
                    let mut n = [T::ZERO; D];
                    let mut vrel = [T::ZERO; D];
                    let mut vn = T::ZERO;
                    for d in 0..D {
                        n[d] = sep[d] * inv;
                        vrel[d] = v[i][d] - v[j][d];
                        vn += vrel[d] * n[d];
                    }
                    let mj = body.mass[j];
                    let mij = m * mj / (m + mj);
                    let c =
                        &body.coeff[pair_index(body.species[i], body.species[j], body.n_species)];
                    let fnorm = mij * (c.kappa * delta - c.two_b * vn);
                    for d in 0..D {
                        f[d] += fnorm * n[d];
                    }
                    tangential::<T, D, FRICTION>(f, n, vn, vrel, fnorm, mij, c);
                }
                let inv = T::of(1.0) / m;
                for c in f.iter_mut() {
                    *c = *c * inv;
                }
            });
        Ok(())
    }

    fn step_velocity_verlet(&mut self) -> Result<()> {
        if !self.started {
            self.aux.clone_from(&self.vel);
            self.accelerations(self.time, true)?;
            self.started = true;
        }
        let dt = T::of(self.prep.dt);
        let h = T::of(0.5 * self.prep.dt);
        self.pos
            .par_iter_mut()
            .zip(self.vel.par_iter_mut())
            .zip(self.aux.par_iter_mut())
            .zip(self.acc.par_iter())
            .with_min_len(4096)
            .for_each(|(((x, v), vp), a)| {
                for d in 0..D {
                    let vh = v[d] + a[d] * h;
                    x[d] += vh * dt;
                    v[d] = vh;
                    vp[d] = vh + a[d] * h;
                }
            });
        self.wrap();
        self.time += self.prep.dt;
        self.refresh_list()?;
        self.accelerations(self.time, true)?;
        self.vel
            .par_iter_mut()
            .zip(self.acc.par_iter())
            .with_min_len(4096)
            .for_each(|(v, a)| {
                for d in 0..D {
                    v[d] += a[d] * h;
                }
            });
        Ok(())
    }

    fn step_position_verlet(&mut self) -> Result<()> {
        self.accelerations(self.time, false)?;
        let dt = T::of(self.prep.dt);
        let h = T::of(0.5 * self.prep.dt);
        let inv_dt = T::of(1.0 / self.prep.dt);
        let first = !self.started;
        self.pos
            .par_iter_mut()
            .zip(self.vel.par_iter_mut())
            .zip(self.aux.par_iter_mut())
            .zip(self.acc.par_iter())
            .with_min_len(4096)
            .for_each(|(((x, v), dx), a)| {
                for d in 0..D {
                    let step = if first {
                        v[d] * dt + a[d] * h * dt
                    } else {
                        dx[d] + a[d] * dt * dt
                    };
                    dx[d] = step;
                    x[d] += step;
                    v[d] = step * inv_dt + a[d] * h;
                }
            });
        self.started = true;
        self.wrap();
        self.time += self.prep.dt;
        self.refresh_list()
    }
}

impl<const D: usize, T: Real> crate::engine::Engine for CpuEngine<D, T> {
    fn advance(&mut self, steps: u32) -> Result<()> {
        for _ in 0..steps {
            match self.prep.integrator {
                Integrator::VelocityVerlet => self.step_velocity_verlet()?,
                Integrator::PositionVerlet => self.step_position_verlet()?,
            }
        }
        Ok(())
    }

    fn snapshot(&mut self) -> Result<State> {
        let c = |a: &[T; D]| -> [f64; 3] {
            let mut o = [0.0; 3];
            for d in 0..D {
                o[d] = a[d].to_f64();
            }
            o
        };
        Ok(State {
            time: self.time,
            positions: self.pos.iter().map(c).collect(),
            velocities: self.vel.iter().map(c).collect(),
        })
    }

    fn prepared(&self) -> &Prepared {
        &self.prep
    }

    fn name(&self) -> String {
        format!(
            "cpu {} ({} threads)",
            if std::mem::size_of::<T>() == 4 {
                "f32"
            } else {
                "f64"
            },
            rayon::current_num_threads()
        )
    }
}
