//! CPU backend: particles sorted by cell at every list rebuild, a half Verlet list (each
//! pair evaluated once, Newton's third law) in fixed blocks of consecutive particles, rayon
//! over the blocks (on the calling thread below [`PARALLEL_MIN`] particles).
//!
//! Per velocity Verlet step two passes over the blocks: the force pass (each block sums the
//! forces on its own particles and queues the reactions it owes to later blocks, per target
//! block), then [`CpuEngine::finish`], which adds the queued reactions in block order, turns
//! forces into accelerations, closes the step with the half kick and opens the next one
//! (half kick, drift, wrap, rebuild check). Block boundaries depend only on the particle
//! count, so the result is bit-for-bit independent of the number of threads, with no
//! atomics and no locks.

use multiversion::multiversion;
use rayon::prelude::*;

use backend::Result;

use crate::pairs::{Block, CellBins, PARALLEL_MIN, block_size, make_blocks};
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

/// Per-particle data in sorted order (permuted at every list rebuild).
struct Particles<T, const D: usize> {
    pos: Vec<[T; D]>,
    vel: Vec<[T; D]>,
    acc: Vec<[T; D]>,
    /// Velocity Verlet: predicted velocity at the force time. Position Verlet: last displacement.
    aux: Vec<[T; D]>,
    radius: Vec<T>,
    mass: Vec<T>,
    inv_mass: Vec<T>,
    species: Vec<u32>,
    /// Scene index of each sorted slot.
    id: Vec<u32>,
    /// Positions at the last list build.
    reference: Vec<[T; D]>,
}

/// The CPU engine for dimension `D` and precision `T`.
pub(crate) struct CpuEngine<const D: usize, T: Real> {
    prep: Prepared,
    time: f64,
    started: bool,
    p: Particles<T, D>,
    n_species: usize,
    coeff: Vec<Coeff<T>>,
    walls: Vec<WallT<T>>,
    bins: CellBins<D>,
    blocks: Vec<Block<T, D>>,
    block: usize,
    /// Whether the passes run on the rayon pool ([`PARALLEL_MIN`] particles or more);
    /// smaller systems run on the calling thread, with the same blocks and the same bits.
    parallel: bool,
    gravity: [T; D],
    /// Rebuild when a particle moved farther than this squared distance since the build.
    rebuild_dist2: f64,
    periodic: [bool; D],
    len: [T; D],
    half: [T; D],
    /// Square of twice the largest radius, in `T` (no pair `r_i + r_j` exceeds it).
    cut2: T,
}

/// Read-only inputs of the force pass.
struct ForceInput<'a, T, const D: usize> {
    pos: &'a [[T; D]],
    vel: &'a [[T; D]],
    radius: &'a [T],
    mass: &'a [T],
    species: &'a [u32],
    n_species: usize,
    coeff: &'a [Coeff<T>],
    walls: &'a [WallT<T>],
    gravity: [T; D],
    zw: T,
    vw: T,
    vert: usize,
    periodic: [bool; D],
    len: [T; D],
    half: [T; D],
    /// Square of the largest contact distance (twice the largest radius).
    cut2: T,
    block: usize,
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

/// Wall forces on particle `i` added to `f`.
#[inline(always)]
fn wall_forces<T: Real, const D: usize, const FRICTION: bool>(
    inp: &ForceInput<'_, T, D>,
    i: usize,
    f: &mut [T; D],
) {
    let (pos, v, m, r) = (&inp.pos[i], &inp.vel[i], inp.mass[i], inp.radius[i]);
    for w in inp.walls {
        let mut n = [T::ZERO; D];
        let delta;
        let mut wv = [T::ZERO; D];
        if w.cylinder {
            let dx = pos[0] - w.center[0];
            let dy = pos[1] - w.center[1];
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
                h += n[d] * pos[d];
            }
            if w.vibrating {
                h = h - inp.zw * n[inp.vert];
            }
            delta = r - h;
            if delta <= T::ZERO {
                continue;
            }
        }
        if w.vibrating {
            wv[inp.vert] = inp.vw;
        }
        let mut vrel = [T::ZERO; D];
        let mut vn = T::ZERO;
        for d in 0..D {
            vrel[d] = v[d] - wv[d];
            vn += vrel[d] * n[d];
        }
        let fnorm = m * (w.coeff.kappa * delta - w.coeff.two_b * vn);
        for d in 0..D {
            f[d] += fnorm * n[d];
        }
        tangential::<T, D, FRICTION>(f, n, vn, vrel, fnorm, m, &w.coeff);
    }
}

/// Forces on the particles of block `b` into `f` (its slice of the force array): gravity,
/// walls and every pair of its half list; reactions on later blocks go to `b.ghosts`.
fn block_forces<T: Real, const D: usize, const FRICTION: bool>(
    inp: &ForceInput<'_, T, D>,
    b: &mut Block<T, D>,
    f: &mut [[T; D]],
) {
    for g in b.ghosts.iter_mut() {
        g.clear();
    }
    f.fill([T::ZERO; D]);
    let (pos, vel, radius, mass) = (inp.pos, inp.vel, inp.radius, inp.mass);
    for k in 0..f.len() {
        let i = b.start + k;
        // Reactions already received from earlier particles of this block.
        let mut fi = f[k];
        let m = mass[i];
        for (c, g) in fi.iter_mut().zip(inp.gravity) {
            *c += g * m;
        }
        wall_forces::<T, D, FRICTION>(inp, i, &mut fi);
        let (xi, vi, r) = (pos[i], vel[i], radius[i]);
        for &j in &b.idx[b.offsets[k] as usize..b.offsets[k + 1] as usize] {
            let j = j as usize;
            // Minimum-image separation (positions are wrapped into the box).
            let mut sep = [T::ZERO; D];
            let mut r2 = T::ZERO;
            for d in 0..D {
                let mut s = xi[d] - pos[j][d];
                if inp.periodic[d] {
                    if s > inp.half[d] {
                        s = s - inp.len[d];
                    } else if s < -inp.half[d] {
                        s += inp.len[d];
                    }
                }
                sep[d] = s;
                r2 += s * s;
            }
            // Most list entries are not in contact: test against the largest contact
            // distance before loading the partner's radius.
            if r2 >= inp.cut2 {
                continue;
            }
            let rsum = r + radius[j];
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
                vrel[d] = vi[d] - vel[j][d];
                vn += vrel[d] * n[d];
            }
            let mj = mass[j];
            let mij = m * mj / (m + mj);
            let c = &inp.coeff[pair_index(inp.species[i], inp.species[j], inp.n_species)];
            let fnorm = mij * (c.kappa * delta - c.two_b * vn);
            let mut fp = [T::ZERO; D];
            for d in 0..D {
                fp[d] = fnorm * n[d];
            }
            tangential::<T, D, FRICTION>(&mut fp, n, vn, vrel, fnorm, mij, c);
            for d in 0..D {
                fi[d] += fp[d];
            }
            if j < b.end {
                let fj = &mut f[j - b.start];
                for d in 0..D {
                    fj[d] = fj[d] - fp[d];
                }
            } else {
                b.ghosts[j / inp.block].push((j as u32, fp));
            }
        }
        f[k] = fi;
    }
}

/// One block's slices of accelerations, velocities, positions, `aux` and reference
/// positions, as the drift passes receive them.
type Chunks<'a, T, const D: usize> = (
    (
        ((&'a mut [[T; D]], &'a mut [[T; D]]), &'a mut [[T; D]]),
        &'a mut [[T; D]],
    ),
    &'a [[T; D]],
);

/// The per-particle arrays a drift pass walks: accelerations, velocities, positions, `aux`
/// and reference positions.
type Arrays<'a, T, const D: usize> = (
    &'a mut [[T; D]],
    &'a mut [[T; D]],
    &'a mut [[T; D]],
    &'a mut [[T; D]],
    &'a [[T; D]],
);

/// Runs `body` on every block's slices of `arrays` (block index and [`Chunks`]), on the
/// rayon pool when `parallel`, and returns the largest value it returned (0 if none).
fn max_over_blocks<T: Real, const D: usize, F>(
    bs: usize,
    parallel: bool,
    arrays: Arrays<'_, T, D>,
    body: F,
) -> f64
where
    F: Fn((usize, Chunks<'_, T, D>)) -> f64 + Sync + Send,
{
    let (acc, vel, pos, aux, reference) = arrays;
    if parallel {
        acc.par_chunks_mut(bs)
            .zip(vel.par_chunks_mut(bs))
            .zip(pos.par_chunks_mut(bs))
            .zip(aux.par_chunks_mut(bs))
            .zip(reference.par_chunks(bs))
            .enumerate()
            .map(body)
            .reduce(|| 0.0, f64::max)
    } else {
        acc.chunks_mut(bs)
            .zip(vel.chunks_mut(bs))
            .zip(pos.chunks_mut(bs))
            .zip(aux.chunks_mut(bs))
            .zip(reference.chunks(bs))
            .enumerate()
            .map(body)
            .fold(0.0, f64::max)
    }
}

/// Reorders `v` so that slot `k` holds the element at `order[k]`.
fn permute<X: Copy + Send + Sync>(v: &mut Vec<X>, order: &[u32], parallel: bool) {
    let sorted: Vec<X> = if parallel {
        order.par_iter().map(|&o| v[o as usize]).collect()
    } else {
        order.iter().map(|&o| v[o as usize]).collect()
    };
    *v = sorted;
}

impl<const D: usize, T: Real> CpuEngine<D, T> {
    pub fn new(prep: Prepared) -> Result<Self> {
        let n = prep.n;
        let cv = |a: &[f64; 3]| -> [T; D] { std::array::from_fn(|d| T::of(a[d])) };
        let lo: [f64; D] = std::array::from_fn(|d| prep.lo[d]);
        let len: [f64; D] = std::array::from_fn(|d| prep.len[d]);
        let periodic: [bool; D] = std::array::from_fn(|d| prep.periodic[d]);
        let bins = CellBins::new(lo, len, periodic, prep.cutoff + prep.skin, n)?;
        let mut gravity = [T::ZERO; D];
        gravity[prep.vertical] = T::of(-prep.gravity);
        let p = Particles {
            pos: prep.positions.iter().map(cv).collect(),
            vel: prep.velocities.iter().map(cv).collect(),
            acc: vec![[T::ZERO; D]; n],
            aux: vec![[T::ZERO; D]; n],
            radius: prep.radius.iter().map(|&r| T::of(r)).collect(),
            mass: prep.mass.iter().map(|&m| T::of(m)).collect(),
            inv_mass: prep.mass.iter().map(|&m| T::of(1.0 / m)).collect(),
            species: prep.species.clone(),
            id: (0..n as u32).collect(),
            reference: Vec::new(),
        };
        let r_max = p
            .radius
            .iter()
            .fold(T::ZERO, |m, &r| if r > m { r } else { m });
        let walls = prep
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
            .collect();
        let mut e = Self {
            p,
            n_species: prep.n_species,
            coeff: prep.coeff.iter().map(Coeff::of).collect(),
            walls,
            bins,
            blocks: make_blocks(n),
            block: block_size(n),
            parallel: n >= PARALLEL_MIN,
            gravity,
            rebuild_dist2: 0.25 * prep.skin * prep.skin,
            periodic,
            len: len.map(T::of),
            half: len.map(|l| T::of(0.5 * l)),
            cut2: (r_max + r_max) * (r_max + r_max),
            prep,
            time: 0.0,
            started: false,
        };
        let per = e.periodic;
        let (lo, len) = (lo.map(T::of), e.len);
        e.p.pos.par_iter_mut().for_each(|x| wrap(x, per, lo, len));
        e.rebuild();
        Ok(e)
    }

    /// Sorts the particles by cell and rebuilds the half lists.
    fn rebuild(&mut self) {
        let order = self.bins.sort(&self.p.pos);
        let p = &mut self.p;
        let par = self.parallel;
        permute(&mut p.pos, &order, par);
        permute(&mut p.vel, &order, par);
        permute(&mut p.acc, &order, par);
        permute(&mut p.aux, &order, par);
        permute(&mut p.radius, &order, par);
        permute(&mut p.mass, &order, par);
        permute(&mut p.inv_mass, &order, par);
        permute(&mut p.species, &order, par);
        permute(&mut p.id, &order, par);
        p.reference.clone_from(&p.pos);
        self.bins.build_lists(&p.pos, &mut self.blocks, par);
    }

    /// Forces at time `t` from the positions and `self.p.aux` (predicted velocities) or
    /// `self.p.vel` into `self.p.acc` (per block; reactions owed to later blocks queued);
    /// [`finish`](Self::finish) completes them.
    fn forces(&mut self, t: f64, use_aux: bool) {
        if self.prep.friction {
            self.forces_variant::<true>(t, use_aux);
        } else {
            self.forces_variant::<false>(t, use_aux);
        }
    }

    fn forces_variant<const FRICTION: bool>(&mut self, t: f64, use_aux: bool) {
        let (zw, vw) = self.prep.wall_motion(t);
        let p = &mut self.p;
        let bs = self.block;
        let inp = ForceInput {
            pos: &p.pos,
            vel: if use_aux { &p.aux } else { &p.vel },
            radius: &p.radius,
            mass: &p.mass,
            species: &p.species,
            n_species: self.n_species,
            coeff: &self.coeff,
            walls: &self.walls,
            gravity: self.gravity,
            zw: T::of(zw),
            vw: T::of(vw),
            vert: self.prep.vertical,
            periodic: self.periodic,
            len: self.len,
            half: self.half,
            cut2: self.cut2,
            block: bs,
        };
        let force = |(b, f): (&mut Block<T, D>, &mut [[T; D]])| {
            block_forces::<T, D, FRICTION>(&inp, b, f);
        };
        if self.parallel {
            self.blocks
                .par_iter_mut()
                .zip(p.acc.par_chunks_mut(bs))
                .for_each(force);
        } else {
            self.blocks
                .iter_mut()
                .zip(p.acc.chunks_mut(bs))
                .for_each(force);
        }
    }

    /// Completes the force pass per block: adds the reactions owed by earlier blocks (in
    /// block order), turns forces into accelerations, and with `kick` applies the closing
    /// half kick `v += a dt / 2`. With `drift` it goes straight on with the next velocity
    /// Verlet step's opening half kick, drift and wrap (the same arithmetic as
    /// [`drift_velocity_verlet`], so the same bits) and returns the largest squared
    /// displacement since the list build; otherwise 0.
    fn finish(&mut self, kick: bool, drift: bool) -> f64 {
        let bs = self.block;
        let dt = T::of(self.prep.dt);
        let h = T::of(0.5 * self.prep.dt);
        let (per, len, half) = (self.periodic, self.len, self.half);
        let lo: [T; D] = std::array::from_fn(|d| T::of(self.prep.lo[d]));
        let blocks = &self.blocks;
        let p = &mut self.p;
        let inv_mass = &p.inv_mass;
        let body = |(t, ((((f, v), x), vp), r)): (usize, Chunks<'_, T, D>)| -> f64 {
            let s = t * bs;
            for b in &blocks[..t] {
                for &(j, fp) in &b.ghosts[t] {
                    let fj = &mut f[j as usize - s];
                    for d in 0..D {
                        fj[d] = fj[d] - fp[d];
                    }
                }
            }
            for (k, (a, v)) in f.iter_mut().zip(v.iter_mut()).enumerate() {
                let im = inv_mass[s + k];
                for c in a.iter_mut() {
                    *c = *c * im;
                }
                if kick {
                    for d in 0..D {
                        v[d] += a[d] * h;
                    }
                }
            }
            if drift {
                drift_velocity_verlet(
                    x.as_flattened_mut(),
                    v.as_flattened_mut(),
                    vp.as_flattened_mut(),
                    f.as_flattened(),
                    h,
                    dt,
                );
                wrap_and_measure(x, r, per, lo, len, half).to_f64()
            } else {
                0.0
            }
        };
        let (acc, vel, pos, aux) = (&mut p.acc, &mut p.vel, &mut p.pos, &mut p.aux);
        max_over_blocks(bs, self.parallel, (acc, vel, pos, aux, &p.reference), body)
    }

    /// Rebuilds the lists when the largest displacement `max2` (squared) exceeds skin / 2.
    fn after_drift(&mut self, max2: f64) {
        if max2 > self.rebuild_dist2 {
            self.rebuild();
        }
    }

    /// The opening half kick, drift and wrap of a velocity Verlet step on its own (the
    /// first step of a call; later ones are fused into [`finish`](Self::finish)); returns
    /// the largest squared displacement since the list build.
    fn drift_velocity_verlet(&mut self) -> f64 {
        let dt = T::of(self.prep.dt);
        let h = T::of(0.5 * self.prep.dt);
        let (per, len, half) = (self.periodic, self.len, self.half);
        let lo: [T; D] = std::array::from_fn(|d| T::of(self.prep.lo[d]));
        let bs = self.block;
        let p = &mut self.p;
        let drift = |((((a, v), x), vp), r): Chunks<'_, T, D>| {
            drift_velocity_verlet(
                x.as_flattened_mut(),
                v.as_flattened_mut(),
                vp.as_flattened_mut(),
                a.as_flattened(),
                h,
                dt,
            );
            wrap_and_measure(x, r, per, lo, len, half).to_f64()
        };
        let (acc, vel, pos, aux) = (&mut p.acc, &mut p.vel, &mut p.pos, &mut p.aux);
        max_over_blocks(
            bs,
            self.parallel,
            (acc, vel, pos, aux, &p.reference),
            |(_, c)| drift(c),
        )
    }

    /// `steps` velocity Verlet steps: per step one force pass and one pass that finishes
    /// the forces, closes this step and (except after the last) opens the next.
    fn advance_velocity_verlet(&mut self, steps: u32) {
        if steps == 0 {
            return;
        }
        if !self.started {
            self.p.aux.clone_from(&self.p.vel);
            self.forces(self.time, true);
            self.finish(false, false);
            self.started = true;
        }
        let mut max2 = self.drift_velocity_verlet();
        for s in 0..steps {
            self.time += self.prep.dt;
            self.after_drift(max2);
            self.forces(self.time, true);
            max2 = self.finish(true, s + 1 < steps);
        }
    }

    fn step_position_verlet(&mut self) {
        self.forces(self.time, false);
        self.finish(false, false);
        let dt = T::of(self.prep.dt);
        let h = T::of(0.5 * self.prep.dt);
        let inv_dt = T::of(1.0 / self.prep.dt);
        let first = !self.started;
        let (per, len, half) = (self.periodic, self.len, self.half);
        let lo: [T; D] = std::array::from_fn(|d| T::of(self.prep.lo[d]));
        let bs = self.block;
        let p = &mut self.p;
        let drift = |((((a, v), x), dx), r): Chunks<'_, T, D>| {
            drift_position_verlet(
                x.as_flattened_mut(),
                v.as_flattened_mut(),
                dx.as_flattened_mut(),
                a.as_flattened(),
                [h, dt, inv_dt],
                first,
            );
            wrap_and_measure(x, r, per, lo, len, half).to_f64()
        };
        let (acc, vel, pos, aux) = (&mut p.acc, &mut p.vel, &mut p.pos, &mut p.aux);
        let max2 = max_over_blocks(
            bs,
            self.parallel,
            (acc, vel, pos, aux, &p.reference),
            |(_, c)| drift(c),
        );
        self.started = true;
        self.time += self.prep.dt;
        self.after_drift(max2);
    }
}

/// Velocity Verlet drift (flat component arrays): half kick, drift, and the predicted
/// velocity `vp` at the end of the step for the damping term.
#[multiversion(
    targets("x86_64+avx512f+avx512vl+avx2+fma", "x86_64+avx2+fma"),
    dispatcher = "direct"
)]
fn drift_velocity_verlet<T: Real>(x: &mut [T], v: &mut [T], vp: &mut [T], a: &[T], h: T, dt: T) {
    let n = x.len().min(v.len()).min(vp.len()).min(a.len());
    let (x, v, vp, a) = (&mut x[..n], &mut v[..n], &mut vp[..n], &a[..n]);
    for k in 0..n {
        let vh = v[k] + a[k] * h;
        x[k] += vh * dt;
        v[k] = vh;
        vp[k] = vh + a[k] * h;
    }
}

/// Position Verlet drift (flat component arrays): `dx` is the last displacement; `c` holds
/// `[dt / 2, dt, 1 / dt]`.
#[multiversion(
    targets("x86_64+avx512f+avx512vl+avx2+fma", "x86_64+avx2+fma"),
    dispatcher = "direct"
)]
fn drift_position_verlet<T: Real>(
    x: &mut [T],
    v: &mut [T],
    dx: &mut [T],
    a: &[T],
    c: [T; 3],
    first: bool,
) {
    let [h, dt, inv_dt] = c;
    let n = x.len().min(v.len()).min(dx.len()).min(a.len());
    let (x, v, dx, a) = (&mut x[..n], &mut v[..n], &mut dx[..n], &a[..n]);
    for k in 0..n {
        let step = if first {
            v[k] * dt + a[k] * h * dt
        } else {
            dx[k] + a[k] * dt * dt
        };
        dx[k] = step;
        x[k] += step;
        v[k] = step * inv_dt + a[k] * h;
    }
}

/// Wraps the periodic coordinates of `x` into `[lo, lo + len)` and returns the largest
/// squared displacement (minimum image) from the reference positions `r`.
#[multiversion(
    targets("x86_64+avx512f+avx512vl+avx2+fma", "x86_64+avx2+fma"),
    dispatcher = "direct"
)]
fn wrap_and_measure<T: Real, const D: usize>(
    x: &mut [[T; D]],
    r: &[[T; D]],
    per: [bool; D],
    lo: [T; D],
    len: [T; D],
    half: [T; D],
) -> T {
    let mut m2 = T::ZERO;
    for (x, r) in x.iter_mut().zip(r) {
        let mut s2 = T::ZERO;
        for d in 0..D {
            let mut c = x[d];
            let mut s = c - r[d];
            if per[d] {
                c = if c < lo[d] {
                    c + len[d]
                } else if c >= lo[d] + len[d] {
                    c - len[d]
                } else {
                    c
                };
                x[d] = c;
                s = c - r[d];
                s = if s > half[d] {
                    s - len[d]
                } else if s < -half[d] {
                    s + len[d]
                } else {
                    s
                };
            }
            s2 += s * s;
        }
        if s2 > m2 {
            m2 = s2;
        }
    }
    m2
}

/// Wraps the periodic coordinates of `x` into `[lo, lo + len)`.
fn wrap<T: Real, const D: usize>(x: &mut [T; D], per: [bool; D], lo: [T; D], len: [T; D]) {
    for d in 0..D {
        if per[d] {
            if x[d] < lo[d] {
                x[d] += len[d];
            } else if x[d] >= lo[d] + len[d] {
                x[d] = x[d] - len[d];
            }
        }
    }
}

impl<const D: usize, T: Real> crate::engine::Engine for CpuEngine<D, T> {
    fn advance(&mut self, steps: u32) -> Result<()> {
        match self.prep.integrator {
            Integrator::VelocityVerlet => self.advance_velocity_verlet(steps),
            Integrator::PositionVerlet => {
                for _ in 0..steps {
                    self.step_position_verlet();
                }
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
        let n = self.p.pos.len();
        let mut positions = vec![[0.0; 3]; n];
        let mut velocities = vec![[0.0; 3]; n];
        for (k, &id) in self.p.id.iter().enumerate() {
            positions[id as usize] = c(&self.p.pos[k]);
            velocities[id as usize] = c(&self.p.vel[k]);
        }
        Ok(State {
            time: self.time,
            positions,
            velocities,
        })
    }

    fn prepared(&self) -> &Prepared {
        &self.prep
    }

    fn name(&self) -> String {
        let precision = if std::mem::size_of::<T>() == 4 {
            "f32"
        } else {
            "f64"
        };
        // Below PARALLEL_MIN particles the passes run on the calling thread.
        let threads = if self.parallel {
            rayon::current_num_threads()
        } else {
            1
        };
        let plural = if threads == 1 { "" } else { "s" };
        format!("cpu {precision} ({threads} thread{plural})")
    }
}
