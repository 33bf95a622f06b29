//! CPU backend: particles sorted by cell at every list rebuild, a half Verlet list (each
//! pair evaluated once, Newton's third law) in fixed blocks of consecutive particles
//! ([`simkit_neighbor::BlockedHalfList`]; the wall candidates and queued reactions of each
//! block live here, in [`BlockWork`]), rayon over the blocks (on the calling thread below
//! [`PARALLEL_MIN`] particles).
//!
//! Per velocity Verlet step two passes over the blocks: the force pass (each block sums the
//! forces on its own particles and queues the reactions it owes to later blocks, per target
//! block), then [`CpuEngine::finish`], which adds the queued reactions in block order, turns
//! forces into accelerations, closes the step with the half kick and opens the next one
//! (half kick, drift, rebuild check). Periodic coordinates are wrapped at list rebuilds
//! only, and each listed pair keeps the periodic image it had then, so the force loop has
//! no minimum-image test. Block boundaries depend only on the particle count and the box,
//! so the result is bit-for-bit independent of the number of threads, with no atomics and
//! no locks.

use std::collections::HashMap;

use multiversion::multiversion;
use rayon::prelude::*;

use simkit_backend::guard::{Guarded, Halt, first_non_finite, run_guarded, verdict};
use simkit_backend::{Real, Result};

use simkit_neighbor::{BlockedHalfList, HalfListBlock, wrap_periodic};

use crate::prepared::Prepared;
use crate::spin::{contact_point_velocity, cross, open_spin, to3};
use crate::{
    Contact, ContactLaw, Integrator, State, cylinder_overlap, cylinder_surface_velocity,
    pair_index, plane_overlap, reduced_mass,
};
use simkit_backend::particles::Dynamics;

/// Below this particle count the CPU passes run on the calling thread: for small systems
/// waking the rayon pool several times per step costs more than the work (the blocks, and
/// so the results, are the same either way).
const PARALLEL_MIN: usize = 4096;

/// What the force pass keeps per block of the neighbour list besides its half list: the
/// wall candidates, the reactions `(j, F)` owed to particles of later blocks and, in a
/// rotating scene, the torques `(j, tau_j)` owed to them, and the contact history of a law
/// that keeps one ([`ContactLaw::HISTORY`] values per list entry and wall candidate).
struct BlockWork<T, const D: usize> {
    /// `(k, w)`: particle `start + k` may touch wall `w` before the next list build
    /// (ascending `k`, walls in scene order); the others are too far away to be tested.
    walls: Vec<(u32, u32)>,
    /// `ghosts[t]`: reactions owed to particles of block `t`.
    ghosts: Vec<Vec<(u32, [T; D])>>,
    /// `torques[t]`: torques owed to particles of block `t` (rotating scenes).
    torques: Vec<Vec<(u32, [T; 3])>>,
    /// History per entry of the block's partner list, of its image list and of `walls`.
    hist: Vec<T>,
    image_hist: Vec<T>,
    wall_hist: Vec<T>,
}

#[derive(Clone, Copy)]
pub(crate) struct WallT<T, C> {
    cylinder: bool,
    normal: [T; 3],
    offset: T,
    center: [T; 2],
    radius: T,
    coeff: C,
    vibrating: bool,
    /// Angular velocity of a cylinder wall (0: at rest).
    spin: T,
    /// Whether the wall depends on a periodic coordinate (then the particle position is
    /// wrapped before the wall test: positions are wrapped only at list builds).
    pub wrap: bool,
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
    /// Rotating scenes (empty otherwise): angular velocities, angular accelerations,
    /// predicted angular velocities at the force time, inverse moments of inertia.
    omega: Vec<[T; 3]>,
    alpha: Vec<[T; 3]>,
    omega_p: Vec<[T; 3]>,
    inv_inertia: Vec<T>,
}

/// The contact history of an engine keyed by scene indices: `(particle, partner)` (a wall
/// as partner `n + w`) and [`ContactLaw::HISTORY`] values per contact.
struct Histories<T> {
    keys: Vec<[u32; 2]>,
    values: Vec<T>,
}

impl<T> Default for Histories<T> {
    fn default() -> Self {
        Self {
            keys: Vec::new(),
            values: Vec::new(),
        }
    }
}

/// The dynamic state at the last check that passed (the blow-up guard's copy): the
/// per-particle arrays in sorted order, the order itself, the clock.
struct Snapshot<T, const D: usize> {
    pos: Vec<[T; D]>,
    vel: Vec<[T; D]>,
    acc: Vec<[T; D]>,
    aux: Vec<[T; D]>,
    reference: Vec<[T; D]>,
    id: Vec<u32>,
    omega: Vec<[T; 3]>,
    alpha: Vec<[T; 3]>,
    omega_p: Vec<[T; 3]>,
    history: Histories<T>,
    time: f64,
    started: bool,
    steps: u64,
}

/// What the blow-up check found first.
enum Partner {
    /// Particle–particle contact with the particle in this slot.
    Pair(usize),
    /// Particle–wall contact with this wall.
    Wall(usize),
}

pub(crate) const AXES: [&str; 3] = ["x", "y", "z"];

/// The CPU engine for dimension `D` and precision `T`.
pub(crate) struct CpuEngine<const D: usize, T: Real, L: ContactLaw> {
    prep: Prepared<L>,
    time: f64,
    started: bool,
    steps: u64,
    /// The state at the last check that passed.
    snap: Snapshot<T, D>,
    p: Particles<T, D>,
    n_species: usize,
    coeff: Vec<L::Coeff<T>>,
    walls: Vec<WallT<T, L::Coeff<T>>>,
    /// Cell sort and per-block half list (each pair with its periodic image).
    list: BlockedHalfList<T, D>,
    /// Per block of `list`: wall candidates and queued reactions.
    work: Vec<BlockWork<T, D>>,
    block: usize,
    /// Whether the passes run on the rayon pool ([`PARALLEL_MIN`] particles or more);
    /// smaller systems run on the calling thread, with the same blocks and the same bits.
    parallel: bool,
    gravity: [T; D],
    /// Rebuild when a particle moved farther than this squared distance since the build.
    rebuild_dist2: f64,
    periodic: [bool; D],
    /// Lower corner and lengths of the box: periodic coordinates are wrapped into
    /// `[lo, lo + len)` at every list build (and only then).
    lo: [T; D],
    len: [T; D],
    /// Square of twice the largest radius, in `T` (no pair `r_i + r_j` exceeds it).
    cut2: T,
    /// Gap below which a wall is listed for a particle at a list build (the skin).
    wall_margin: f64,
}

/// Read-only inputs of the force pass.
pub(crate) struct ForceInput<'a, T: Real, const D: usize, L: ContactLaw> {
    pub pos: &'a [[T; D]],
    /// The velocities the dashpots read (velocity Verlet: predicted at the force time).
    pub vel: &'a [[T; D]],
    pub radius: &'a [T],
    pub mass: &'a [T],
    pub species: &'a [u32],
    /// Predicted angular velocities at the force time (empty without rotation).
    pub omega: &'a [[T; 3]],
    /// The time step (history laws integrate over it).
    pub dt: T,
    pub n_species: usize,
    pub coeff: &'a [L::Coeff<T>],
    pub walls: &'a [WallT<T, L::Coeff<T>>],
    pub gravity: [T; D],
    /// Vertical displacement and velocity of the vibrating walls.
    pub zw: T,
    pub vw: T,
    /// The vertical axis.
    pub vert: usize,
    pub periodic: [bool; D],
    pub lo: [T; D],
    pub len: [T; D],
    /// Square of the largest contact distance (twice the largest radius).
    pub cut2: T,
    /// Particles per block of the half list (the block of a reaction's target).
    pub block: usize,
}

/// The force of wall `w` on particle `i` (if they touch) added to `f`, and with `ROT` its
/// torque to `t`; the contact's `history` is reset when they do not touch.
#[inline(always)]
pub(crate) fn wall_force<
    T: Real,
    const D: usize,
    L: ContactLaw,
    const FRICTION: bool,
    const ROT: bool,
>(
    inp: &ForceInput<'_, T, D, L>,
    w: &WallT<T, L::Coeff<T>>,
    i: usize,
    history: &mut [T],
    f: &mut [T; D],
    t: &mut [T; 3],
) {
    let (v, m, r) = (&inp.vel[i], inp.mass[i], inp.radius[i]);
    let mut pos = inp.pos[i];
    if w.wrap {
        wrap(&mut pos, inp.periodic, inp.lo, inp.len);
    }
    let mut n = [T::ZERO; D];
    let delta;
    if w.cylinder {
        let nc;
        (delta, nc) = cylinder_overlap(w.center, w.radius, [pos[0], pos[1]], r);
        if delta <= T::ZERO {
            history.fill(T::ZERO);
            return;
        }
        n[..2].copy_from_slice(&nc);
    } else {
        n = std::array::from_fn(|d| w.normal[d]);
        let lift = if w.vibrating {
            inp.zw * n[inp.vert]
        } else {
            T::ZERO
        };
        delta = plane_overlap(&n, w.offset, lift, &pos, r);
        if delta <= T::ZERO {
            history.fill(T::ZERO);
            return;
        }
    }
    let mut wv = [T::ZERO; D];
    if w.vibrating {
        wv[inp.vert] = inp.vw;
    }
    if w.cylinder {
        let s = cylinder_surface_velocity(w.spin, w.radius, [n[0], n[1]]);
        wv[0] += s[0];
        wv[1] += s[1];
    }
    let mut vrel = [T::ZERO; D];
    let mut vn = T::ZERO;
    for d in 0..D {
        vrel[d] = v[d] - wv[d];
        vn += vrel[d] * n[d];
    }
    let w_i = if ROT { inp.omega[i] } else { [T::ZERO; 3] };
    if ROT {
        vrel = contact_point_velocity(&vrel, &n, r, &w_i, T::ZERO, &[T::ZERO; 3]);
    }
    let contact = Contact {
        m_ij: m,
        delta,
        n,
        v_rel: vrel,
        v_n: vn,
        r_eff: r,
        w_rel: w_i,
        dt: inp.dt,
    };
    let fw = L::force::<T, D, FRICTION>(&w.coeff, &contact, history);
    for (f, x) in f.iter_mut().zip(fw.force) {
        *f += x;
    }
    if ROT {
        let lever = cross(&to3(&n), &to3(&fw.force));
        for d in 0..3 {
            t[d] += fw.torque[d] - r * lever[d];
        }
    }
}

/// A pair contact's force on `i` and, in a rotating scene, the torques on `i` and `j`.
pub(crate) struct PairForce<T, const D: usize> {
    pub f: [T; D],
    pub t_i: [T; 3],
    pub t_j: [T; 3],
}

/// The force on particle `i` of its contact with particle `j` at separation
/// `sep = x_i - x_j` (the law's, with `FRICTION` its tangential part) and, with `ROT`, the
/// torques on both, or `None` when they are farther apart than their radii (then the
/// contact's `history` is reset). One statement of the pair contact for every CPU force
/// loop (the blocked half list here, the distributed run).
#[inline(always)]
pub(crate) fn contact_force<
    T: Real,
    const D: usize,
    L: ContactLaw,
    const FRICTION: bool,
    const ROT: bool,
>(
    inp: &ForceInput<'_, T, D, L>,
    i: usize,
    j: usize,
    sep: [T; D],
    history: &mut [T],
) -> Option<PairForce<T, D>> {
    let mut r2 = T::ZERO;
    for s in sep {
        r2 += s * s;
    }
    // Most list entries are not in contact: test against the largest contact distance
    // before loading the partner's radius.
    if r2 >= inp.cut2 {
        history.fill(T::ZERO);
        return None;
    }
    let (r_i, r_j) = (inp.radius[i], inp.radius[j]);
    let rsum = r_i + r_j;
    if r2 >= rsum * rsum {
        history.fill(T::ZERO);
        return None;
    }
    let dist = r2.sqrt();
    let delta = rsum - dist;
    let inv = T::ONE / dist;
    let (vi, vj) = (&inp.vel[i], &inp.vel[j]);
    let mut n = [T::ZERO; D];
    let mut vrel = [T::ZERO; D];
    let mut vn = T::ZERO;
    for d in 0..D {
        n[d] = sep[d] * inv;
        vrel[d] = vi[d] - vj[d];
        vn += vrel[d] * n[d];
    }
    let (m, mj) = (inp.mass[i], inp.mass[j]);
    let mij = reduced_mass(m, mj);
    let c = &inp.coeff[pair_index(inp.species[i], inp.species[j], inp.n_species)];
    let mut w_rel = [T::ZERO; 3];
    if ROT {
        let (w_i, w_j) = (&inp.omega[i], &inp.omega[j]);
        vrel = contact_point_velocity(&vrel, &n, r_i, w_i, r_j, w_j);
        w_rel = std::array::from_fn(|d| w_i[d] - w_j[d]);
    }
    let contact = Contact {
        m_ij: mij,
        delta,
        n,
        v_rel: vrel,
        v_n: vn,
        r_eff: r_i * r_j / rsum,
        w_rel,
        dt: inp.dt,
    };
    let out = L::force::<T, D, FRICTION>(c, &contact, history);
    let (mut t_i, mut t_j) = ([T::ZERO; 3], [T::ZERO; 3]);
    if ROT {
        // The force acts at the middle of the overlap: `-(r_i - delta / 2) n` from i's
        // centre and (as -F) at `+(r_j - delta / 2) n` from j's (as LAMMPS `pair
        // granular`).
        let lever = cross(&to3(&n), &to3(&out.force));
        let half = T::from_f64(0.5) * delta;
        let (l_i, l_j) = (r_i - half, r_j - half);
        for d in 0..3 {
            t_i[d] = out.torque[d] - l_i * lever[d];
            t_j[d] = -out.torque[d] - l_j * lever[d];
        }
    }
    Some(PairForce {
        f: out.force,
        t_i,
        t_j,
    })
}

/// Where the force pass of one block writes: its slices of the force and torque arrays
/// (the torques empty without rotation), the particle's running force and torque, and the
/// reactions and torques owed to later blocks.
struct Sums<'a, T, const D: usize> {
    start: usize,
    end: usize,
    f: &'a mut [[T; D]],
    t: &'a mut [[T; 3]],
    fi: [T; D],
    ti: [T; 3],
    ghosts: &'a mut [Vec<(u32, [T; D])>],
    torques: &'a mut [Vec<(u32, [T; 3])>],
}

/// The force of the contact of particles `i` and `j` at separation `sep = x_i - x_j`
/// ([`contact_force`]): added to `fi`, its reaction to `j` (in `f` when `j` is in the
/// block, else queued in `ghosts`); with `ROT` the torques likewise.
#[inline(always)]
fn pair_contact<T: Real, const D: usize, L: ContactLaw, const FRICTION: bool, const ROT: bool>(
    inp: &ForceInput<'_, T, D, L>,
    i: usize,
    j: usize,
    sep: [T; D],
    history: &mut [T],
    s: &mut Sums<'_, T, D>,
) {
    let Some(fp) = contact_force::<T, D, L, FRICTION, ROT>(inp, i, j, sep, history) else {
        return;
    };
    for d in 0..D {
        s.fi[d] += fp.f[d];
    }
    if ROT {
        for d in 0..3 {
            s.ti[d] += fp.t_i[d];
        }
    }
    if j < s.end {
        for (f, x) in s.f[j - s.start].iter_mut().zip(fp.f) {
            *f = *f - x;
        }
        if ROT {
            for (t, x) in s.t[j - s.start].iter_mut().zip(fp.t_j) {
                *t += x;
            }
        }
    } else {
        s.ghosts[j / inp.block].push((j as u32, fp.f));
        if ROT {
            s.torques[j / inp.block].push((j as u32, fp.t_j));
        }
    }
}

/// Forces on the particles of block `b` into `f` (its slice of the force array) and, with
/// `ROT`, torques into `t`: gravity, walls and every pair of its half list; reactions on
/// later blocks go to `b.ghosts` (`b.torques`).
fn block_forces<T: Real, const D: usize, L: ContactLaw, const FRICTION: bool, const ROT: bool>(
    inp: &ForceInput<'_, T, D, L>,
    nb: &HalfListBlock<T, D>,
    b: &mut BlockWork<T, D>,
    f: &mut [[T; D]],
    t: &mut [[T; 3]],
) {
    let h = L::HISTORY;
    let BlockWork {
        walls,
        ghosts,
        torques,
        hist,
        image_hist,
        wall_hist,
    } = b;
    for g in ghosts.iter_mut() {
        g.clear();
    }
    for g in torques.iter_mut() {
        g.clear();
    }
    f.fill([T::ZERO; D]);
    t.fill([T::ZERO; 3]);
    let pos = inp.pos;
    let (offsets, partners) = (nb.offsets(), nb.partners());
    let (img_offsets, img_partners) = (nb.image_offsets(), nb.image_partners());
    let mut s = Sums {
        start: nb.start(),
        end: nb.end(),
        f,
        t,
        fi: [T::ZERO; D],
        ti: [T::ZERO; 3],
        ghosts,
        torques,
    };
    let mut next_wall = 0;
    for k in 0..s.f.len() {
        let i = s.start + k;
        // Reactions already received from earlier particles of this block.
        s.fi = s.f[k];
        if ROT {
            s.ti = s.t[k];
        }
        let m = inp.mass[i];
        for (c, g) in s.fi.iter_mut().zip(inp.gravity) {
            *c += g * m;
        }
        while let Some(&(wk, w)) = walls.get(next_wall) {
            if wk as usize != k {
                break;
            }
            let wh = &mut wall_hist[next_wall * h..(next_wall + 1) * h];
            let wall = &inp.walls[w as usize];
            wall_force::<T, D, L, FRICTION, ROT>(inp, wall, i, wh, &mut s.fi, &mut s.ti);
            next_wall += 1;
        }
        let xi = pos[i];
        // Same image: no periodic test per pair (positions are not wrapped between builds).
        for e in offsets[k] as usize..offsets[k + 1] as usize {
            let j = partners[e] as usize;
            let sep: [T; D] = std::array::from_fn(|d| xi[d] - pos[j][d]);
            let eh = &mut hist[e * h..(e + 1) * h];
            pair_contact::<T, D, L, FRICTION, ROT>(inp, i, j, sep, eh, &mut s);
        }
        for e in img_offsets[k] as usize..img_offsets[k + 1] as usize {
            let (j, shift) = img_partners[e];
            let j = j as usize;
            let sep: [T; D] = std::array::from_fn(|d| (xi[d] - pos[j][d]) - shift[d]);
            let eh = &mut image_hist[e * h..(e + 1) * h];
            pair_contact::<T, D, L, FRICTION, ROT>(inp, i, j, sep, eh, &mut s);
        }
        s.f[k] = s.fi;
        if ROT {
            s.t[k] = s.ti;
        }
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

/// The scene's walls in the force loop's form and precision.
pub(crate) fn walls_of<T: Real, const D: usize, L: ContactLaw>(
    prep: &Prepared<L>,
) -> Vec<WallT<T, L::Coeff<T>>> {
    let periodic = &prep.periodic;
    prep.walls
        .iter()
        .map(|w| WallT {
            cylinder: w.cylinder,
            normal: w.normal.map(T::from_f64),
            offset: T::from_f64(w.offset),
            center: w.center.map(T::from_f64),
            radius: T::from_f64(w.radius),
            coeff: w.material.coefficients(),
            vibrating: w.vibrating,
            spin: T::from_f64(w.spin),
            wrap: if w.cylinder {
                (0..D.min(2)).any(|d| periodic[d])
            } else {
                (0..D).any(|d| periodic[d] && w.normal[d] != 0.0)
            },
        })
        .collect()
}

impl<T: Real, const D: usize> Particles<T, D> {
    /// Reorders every per-particle array but `reference` into `order` (slot `k` takes the
    /// particle at `order[k]`).
    fn permute(&mut self, order: &[u32], parallel: bool) {
        permute(&mut self.pos, order, parallel);
        permute(&mut self.vel, order, parallel);
        permute(&mut self.acc, order, parallel);
        permute(&mut self.aux, order, parallel);
        permute(&mut self.radius, order, parallel);
        permute(&mut self.mass, order, parallel);
        permute(&mut self.inv_mass, order, parallel);
        permute(&mut self.species, order, parallel);
        permute(&mut self.id, order, parallel);
        permute(&mut self.omega, order, parallel);
        permute(&mut self.alpha, order, parallel);
        permute(&mut self.omega_p, order, parallel);
        permute(&mut self.inv_inertia, order, parallel);
    }
}

/// Reorders `v` so that slot `k` holds the element at `order[k]` (an empty `v`, a column
/// the scene does not use, stays empty).
fn permute<X: Copy + Send + Sync>(v: &mut Vec<X>, order: &[u32], parallel: bool) {
    if v.is_empty() {
        return;
    }
    let sorted: Vec<X> = if parallel {
        order.par_iter().map(|&o| v[o as usize]).collect()
    } else {
        order.iter().map(|&o| v[o as usize]).collect()
    };
    *v = sorted;
}

impl<const D: usize, T: Real, L: ContactLaw> CpuEngine<D, T, L> {
    /// The engine for `prep`, at its initial state or, with `saved`, at a checkpointed
    /// one.
    pub fn new(prep: Prepared<L>, saved: Option<&Dynamics>) -> Result<Self> {
        let n = prep.n;
        let cv = |a: &[f64; 3]| -> [T; D] { std::array::from_fn(|d| T::from_f64(a[d])) };
        let lo: [f64; D] = std::array::from_fn(|d| prep.lo[d]);
        let len: [f64; D] = std::array::from_fn(|d| prep.len[d]);
        let periodic: [bool; D] = std::array::from_fn(|d| prep.periodic[d]);
        let range = prep.cutoff + prep.skin;
        // Periodic lengths were checked in `Prepared::new` (shared by both backends).
        let list = BlockedHalfList::new(lo, len, periodic, range, n)?;
        let n_blocks = list.blocks().len();
        let work = (0..n_blocks)
            .map(|_| BlockWork {
                walls: Vec::new(),
                ghosts: (0..n_blocks).map(|_| Vec::new()).collect(),
                torques: (0..n_blocks).map(|_| Vec::new()).collect(),
                hist: Vec::new(),
                image_hist: Vec::new(),
                wall_hist: Vec::new(),
            })
            .collect();
        let spin = |v: Vec<[T; 3]>| if prep.rotation { v } else { Vec::new() };
        let mut gravity = [T::ZERO; D];
        gravity[prep.vertical] = T::from_f64(-prep.gravity);
        let p = Particles {
            pos: prep.positions.iter().map(cv).collect(),
            vel: prep.velocities.iter().map(cv).collect(),
            acc: vec![[T::ZERO; D]; n],
            aux: vec![[T::ZERO; D]; n],
            radius: prep.radius.iter().map(|&r| T::from_f64(r)).collect(),
            mass: prep.mass.iter().map(|&m| T::from_f64(m)).collect(),
            inv_mass: prep.mass.iter().map(|&m| T::from_f64(1.0 / m)).collect(),
            species: prep.species.clone(),
            id: (0..n as u32).collect(),
            reference: Vec::new(),
            omega: spin(prep.omega.iter().map(|w| w.map(T::from_f64)).collect()),
            alpha: spin(vec![[T::ZERO; 3]; n]),
            omega_p: spin(vec![[T::ZERO; 3]; n]),
            inv_inertia: if prep.rotation {
                prep.inertia.iter().map(|&i| T::from_f64(1.0 / i)).collect()
            } else {
                Vec::new()
            },
        };
        let r_max = p
            .radius
            .iter()
            .fold(T::ZERO, |m, &r| if r > m { r } else { m });
        let walls = walls_of::<T, D, L>(&prep);
        let mut e = Self {
            p,
            n_species: prep.n_species,
            coeff: prep.pairs.iter().map(L::coefficients).collect(),
            walls,
            block: list.block_size(),
            list,
            work,
            parallel: n >= PARALLEL_MIN,
            gravity,
            rebuild_dist2: 0.25 * prep.skin * prep.skin,
            periodic,
            lo: lo.map(T::from_f64),
            len: len.map(T::from_f64),
            cut2: (r_max + r_max) * (r_max + r_max),
            wall_margin: prep.skin,
            prep,
            time: 0.0,
            started: false,
            steps: 0,
            snap: Snapshot {
                pos: Vec::new(),
                vel: Vec::new(),
                acc: Vec::new(),
                aux: Vec::new(),
                reference: Vec::new(),
                id: Vec::new(),
                omega: Vec::new(),
                alpha: Vec::new(),
                omega_p: Vec::new(),
                history: Histories::default(),
                time: 0.0,
                started: false,
                steps: 0,
            },
        };
        match saved {
            None => e.rebuild()?,
            Some(s) => e.load(s)?,
        }
        Ok(e)
    }

    /// The contact history of the current lists keyed by scene indices (contacts whose
    /// values are all zero are left out: they restart from zero anyway).
    fn collect_history(&self) -> Histories<T> {
        let h = L::HISTORY;
        let mut out = Histories::default();
        if h == 0 {
            return out;
        }
        let id = &self.p.id;
        let n = self.prep.n as u32;
        let mut keep = |a: usize, partner: u32, v: &[T]| {
            if v.iter().any(|&x| x != T::ZERO) {
                out.keys.push([id[a], partner]);
                out.values.extend_from_slice(v);
            }
        };
        for (nb, b) in self.list.blocks().iter().zip(&self.work) {
            if nb.offsets().len() != nb.len() + 1 || b.hist.len() != nb.partners().len() * h {
                // Not built yet (the engine's first list build): no history.
                continue;
            }
            let start = nb.start();
            for k in 0..nb.len() {
                let i = start + k;
                for e in nb.offsets()[k] as usize..nb.offsets()[k + 1] as usize {
                    let j = nb.partners()[e] as usize;
                    keep(i, id[j], &b.hist[e * h..(e + 1) * h]);
                }
                for e in nb.image_offsets()[k] as usize..nb.image_offsets()[k + 1] as usize {
                    let j = nb.image_partners()[e].0 as usize;
                    keep(i, id[j], &b.image_hist[e * h..(e + 1) * h]);
                }
            }
            for (e, &(k, w)) in b.walls.iter().enumerate() {
                keep(start + k as usize, n + w, &b.wall_hist[e * h..(e + 1) * h]);
            }
        }
        out
    }

    /// Gives every entry of the current lists its history from `old` (keyed by scene
    /// indices, either orientation: a pair listed the other way round is handed over with
    /// [`ContactLaw::swap_history`]); entries not in `old` start from zero.
    fn assign_history(&mut self, old: &Histories<T>) {
        let h = L::HISTORY;
        if h == 0 {
            return;
        }
        let index: HashMap<[u32; 2], usize> = old
            .keys
            .iter()
            .enumerate()
            .map(|(k, &key)| (key, k))
            .collect();
        let id = &self.p.id;
        let n = self.prep.n as u32;
        let fetch = |a: u32, b: u32, out: &mut [T]| {
            if let Some(&k) = index.get(&[a, b]) {
                out.copy_from_slice(&old.values[k * h..(k + 1) * h]);
            } else if let Some(&k) = index.get(&[b, a]) {
                out.copy_from_slice(&old.values[k * h..(k + 1) * h]);
                L::swap_history(out);
            } else {
                out.fill(T::ZERO);
            }
        };
        for (nb, b) in self.list.blocks().iter().zip(self.work.iter_mut()) {
            let start = nb.start();
            b.hist.resize(nb.partners().len() * h, T::ZERO);
            b.image_hist.resize(nb.image_partners().len() * h, T::ZERO);
            b.wall_hist.resize(b.walls.len() * h, T::ZERO);
            for k in 0..nb.len() {
                let i = id[start + k];
                for e in nb.offsets()[k] as usize..nb.offsets()[k + 1] as usize {
                    let j = id[nb.partners()[e] as usize];
                    fetch(i, j, &mut b.hist[e * h..(e + 1) * h]);
                }
                for e in nb.image_offsets()[k] as usize..nb.image_offsets()[k + 1] as usize {
                    let j = id[nb.image_partners()[e].0 as usize];
                    fetch(i, j, &mut b.image_hist[e * h..(e + 1) * h]);
                }
            }
            for (e, &(k, w)) in b.walls.iter().enumerate() {
                fetch(
                    id[start + k as usize],
                    n + w,
                    &mut b.wall_hist[e * h..(e + 1) * h],
                );
            }
        }
    }

    /// Sets the state from a checkpoint (validated: lengths, a permutation of the
    /// particles).
    fn load(&mut self, s: &Dynamics) -> Result<()> {
        let n = self.prep.n;
        s.check(n, D, &["pos", "vel", "acc", "aux", "reference"])?;
        let arrays = |v: &[f64]| -> Vec<[T; D]> {
            v.chunks_exact(D)
                .map(|c| std::array::from_fn(|d| T::from_f64(c[d])))
                .collect()
        };
        let history = self.check_saved_extras(s)?;
        let p = &mut self.p;
        p.pos = arrays(&s.pos);
        p.vel = arrays(&s.vel);
        p.acc = arrays(&s.acc);
        p.aux = arrays(&s.aux);
        p.reference = arrays(&s.reference);
        p.id = (0..n).map(|k| s.particle(k) as u32).collect();
        if self.prep.rotation {
            let spin = |c: usize| -> Vec<[T; 3]> {
                s.spin
                    .chunks_exact(9)
                    .map(|v| std::array::from_fn(|d| T::from_f64(v[c + d])))
                    .collect()
            };
            (p.omega, p.alpha, p.omega_p) = (spin(0), spin(3), spin(6));
        }
        (self.time, self.started, self.steps) = (s.time, s.started, s.steps);
        self.relist(&history)
    }

    /// Checks the rotation and history columns of a checkpoint against the scene and
    /// returns the history in the engine's precision.
    fn check_saved_extras(&self, s: &Dynamics) -> Result<Histories<T>> {
        self.prep.check_saved_extras(s)?;
        Ok(Histories {
            keys: s.contacts.clone(),
            values: s.history.iter().map(|&x| T::from_f64(x)).collect(),
        })
    }

    /// After `p.id` changed (rollback, resume): the per-particle constants in slot order,
    /// and the neighbour list and wall candidates rebuilt from the positions of the last
    /// list build (`p.reference`, wrapped and in cell order: the stable sort keeps the
    /// order), so the list is the one the run had, with the contact history `history`.
    fn relist(&mut self, history: &Histories<T>) -> Result<()> {
        let prep = &self.prep;
        let p = &mut self.p;
        for (k, &i) in p.id.iter().enumerate() {
            let i = i as usize;
            p.radius[k] = T::from_f64(prep.radius[i]);
            p.mass[k] = T::from_f64(prep.mass[i]);
            p.inv_mass[k] = T::from_f64(1.0 / prep.mass[i]);
            p.species[k] = prep.species[i];
            if let Some(x) = p.inv_inertia.get_mut(k) {
                *x = T::from_f64(1.0 / prep.inertia[i]);
            }
        }
        let order = self.list.sort(&p.reference)?;
        if order.iter().enumerate().any(|(k, &o)| o as usize != k) {
            // Not reached for a state this engine wrote; kept consistent all the same.
            p.permute(&order, self.parallel);
            permute(&mut p.reference, &order, self.parallel);
        }
        self.list.build(&p.reference, self.parallel)?;
        std::mem::swap(&mut p.pos, &mut p.reference);
        self.find_wall_candidates();
        std::mem::swap(&mut self.p.pos, &mut self.p.reference);
        self.assign_history(history);
        Ok(())
    }

    /// The blow-up check of the current state: `(what, cause)` of the first failure, in
    /// the order non-finite position, non-finite velocity, particle outside the box by
    /// more than its radius, contact deeper than `max_overlap` of the smaller radius.
    fn first_failure(&self) -> Option<(String, String)> {
        let p = &self.p;
        for (name, v) in [("position", &p.pos), ("velocity", &p.vel)] {
            if let Some(k) = first_non_finite(v.as_flattened()) {
                let (slot, d) = (k / D, k % D);
                return Some((
                    format!(
                        "particle {}: {name} {} = {}",
                        p.id[slot], AXES[d], v[slot][d]
                    ),
                    self.prep.non_finite_cause(),
                ));
            }
        }
        if let Some(k) = first_non_finite(p.omega.as_flattened()) {
            let (slot, d) = (k / 3, k % 3);
            return Some((
                format!(
                    "particle {}: angular velocity {} = {}",
                    p.id[slot], AXES[d], p.omega[slot][d]
                ),
                self.prep.non_finite_cause(),
            ));
        }
        for d in (0..D).filter(|&d| !self.periodic[d]) {
            let lo = self.prep.lo[d];
            let hi = lo + self.prep.len[d];
            for (k, x) in p.pos.iter().enumerate() {
                let (x, r) = (x[d].to_f64(), p.radius[k].to_f64());
                if x < lo - r || x > hi + r {
                    return Some((
                        format!(
                            "particle {}: position {} = {x}, outside the box [{lo}, {hi}] by \
                             more than its radius {r}",
                            p.id[k], AXES[d]
                        ),
                        self.prep.escape_cause(),
                    ));
                }
            }
        }
        let limit = self.prep.max_overlap;
        if limit.is_finite() {
            let (ratio, i, with) = self.deepest_contact();
            if ratio > limit {
                let other = match with {
                    Partner::Pair(j) => format!("particle {}", p.id[j]),
                    Partner::Wall(w) => format!("wall {w}"),
                };
                return Some((
                    format!(
                        "particle {} overlaps {other} by {ratio} of the smaller radius \
                         (limit Config::max_overlap = {limit})",
                        p.id[i]
                    ),
                    self.prep.overlap_cause(),
                ));
            }
        }
        None
    }

    /// The deepest contact now, as overlap over the smaller radius (against a wall: the
    /// particle's radius), its slot and what it touches; `(0, 0, Pair(0))` without
    /// contacts. Walks the neighbour list and the wall candidates, like the force pass.
    fn deepest_contact(&self) -> (f64, usize, Partner) {
        let p = &self.p;
        let (zw, _) = self.prep.wall_motion(self.time);
        let vert = self.prep.vertical;
        let (per, lo, len) = (self.periodic, self.lo, self.len);
        let block = |(nb, b): (&HalfListBlock<T, D>, &BlockWork<T, D>)| {
            let mut best = (0.0f64, 0usize, Partner::Pair(0));
            let (start, offsets, partners) = (nb.start(), nb.offsets(), nb.partners());
            let (img_offsets, img_partners) = (nb.image_offsets(), nb.image_partners());
            let mut consider = |i: usize, j: usize, shift: [T; D]| {
                let mut r2 = 0.0;
                for ((xi, xj), sh) in p.pos[i].iter().zip(&p.pos[j]).zip(&shift) {
                    let s = (*xi - *xj - *sh).to_f64();
                    r2 += s * s;
                }
                let (ri, rj) = (p.radius[i].to_f64(), p.radius[j].to_f64());
                let depth = ri + rj - r2.sqrt();
                let ratio = depth / ri.min(rj);
                if ratio > best.0 {
                    best = (ratio, i, Partner::Pair(j));
                }
            };
            for k in 0..nb.len() {
                let i = start + k;
                for &j in &partners[offsets[k] as usize..offsets[k + 1] as usize] {
                    consider(i, j as usize, [T::ZERO; D]);
                }
                for &(j, shift) in
                    &img_partners[img_offsets[k] as usize..img_offsets[k + 1] as usize]
                {
                    consider(i, j as usize, shift);
                }
            }
            for &(k, w) in &b.walls {
                let i = start + k as usize;
                let mut x = p.pos[i];
                if self.walls[w as usize].wrap {
                    wrap(&mut x, per, lo, len);
                }
                let x: [f64; D] = std::array::from_fn(|d| x[d].to_f64());
                let r = p.radius[i].to_f64();
                let ratio = self.prep.walls[w as usize].overlap(&x, r, zw, vert) / r;
                if ratio > best.0 {
                    best = (ratio, i, Partner::Wall(w as usize));
                }
            }
            best
        };
        let deeper = |a: (f64, usize, Partner), b: (f64, usize, Partner)| {
            if b.0 > a.0 { b } else { a }
        };
        let blocks = self.list.blocks();
        if self.parallel {
            blocks
                .par_iter()
                .zip(self.work.par_iter())
                .map(block)
                .reduce(|| (0.0, 0, Partner::Pair(0)), deeper)
        } else {
            blocks
                .iter()
                .zip(&self.work)
                .map(block)
                .fold((0.0, 0, Partner::Pair(0)), deeper)
        }
    }

    /// Advances `steps` steps without checks (the step count is the caller's).
    fn advance_unchecked(&mut self, steps: u32) -> Result<()> {
        match self.prep.integrator {
            Integrator::VelocityVerlet => self.advance_velocity_verlet(steps),
            Integrator::PositionVerlet => {
                for _ in 0..steps {
                    self.step_position_verlet()?;
                }
                Ok(())
            }
        }
    }

    /// The dynamic state for a checkpoint.
    fn to_saved(&self) -> Dynamics {
        let history = self.collect_history();
        let flat =
            |v: &[[T; D]]| -> Vec<f64> { v.as_flattened().iter().map(|x| x.to_f64()).collect() };
        let p = &self.p;
        Dynamics {
            steps: self.steps,
            time: self.time,
            started: self.started,
            width: D as u32,
            order: p.id.clone(),
            pos: flat(&p.pos),
            vel: flat(&p.vel),
            acc: flat(&p.acc),
            aux: flat(&p.aux),
            reference: flat(&p.reference),
            spin: p
                .omega
                .iter()
                .zip(&p.alpha)
                .zip(&p.omega_p)
                .flat_map(|((w, a), wp)| w.iter().chain(a).chain(wp).map(|x| x.to_f64()))
                .collect(),
            contacts: history.keys,
            history: history.values.iter().map(|x| x.to_f64()).collect(),
        }
    }

    /// Wraps the periodic coordinates into the box, sorts the particles by cell and
    /// rebuilds the half lists (each pair with its periodic image, fixed until the next
    /// build).
    fn rebuild(&mut self) -> Result<()> {
        let history = self.collect_history();
        let (per, lo, len) = (self.periodic, self.lo, self.len);
        if self.parallel {
            self.p
                .pos
                .par_iter_mut()
                .for_each(|x| wrap(x, per, lo, len));
        } else {
            self.p.pos.iter_mut().for_each(|x| wrap(x, per, lo, len));
        }
        let order = self.list.sort(&self.p.pos)?;
        let p = &mut self.p;
        let par = self.parallel;
        p.permute(&order, par);
        p.reference.clone_from(&p.pos);
        self.list.build(&p.pos, par)?;
        self.find_wall_candidates();
        self.assign_history(&history);
        Ok(())
    }

    /// Lists for every particle the walls it may touch before the next list build: those
    /// within `skin` (twice the largest displacement allowed between builds, plus 1 % of
    /// the radius for round-off) of contact at any phase of the vibration; walls that
    /// depend on a periodic coordinate are listed for every particle.
    fn find_wall_candidates(&mut self) {
        let margin = self.wall_margin;
        let amplitude = self.prep.vibration.map_or(0.0, |v| v.amplitude.abs());
        let vert = self.prep.vertical;
        let (walls, pos, radius) = (&self.walls, &self.p.pos, &self.p.radius);
        let prepared = &self.prep.walls;
        let find = |(nb, b): (&HalfListBlock<T, D>, &mut BlockWork<T, D>)| {
            b.walls.clear();
            for i in nb.start()..nb.end() {
                let r = radius[i].to_f64();
                let x: [f64; D] = std::array::from_fn(|d| pos[i][d].to_f64());
                for (k, (w, pw)) in walls.iter().zip(prepared).enumerate() {
                    // Largest overlap the wall could have at any phase (negative: a gap).
                    let travel = if pw.vibrating && !pw.cylinder {
                        amplitude * pw.normal[vert].abs()
                    } else {
                        0.0
                    };
                    let reach = pw.overlap(&x, r, 0.0, vert) + travel;
                    if w.wrap || reach > -(margin + 0.01 * r) {
                        b.walls.push(((i - nb.start()) as u32, k as u32));
                    }
                }
            }
        };
        let blocks = self.list.blocks();
        if self.parallel {
            blocks
                .par_iter()
                .zip(self.work.par_iter_mut())
                .for_each(find);
        } else {
            blocks.iter().zip(self.work.iter_mut()).for_each(find);
        }
    }

    /// Forces at time `t` from the positions and `self.p.aux` (predicted velocities) or
    /// `self.p.vel` into `self.p.acc` (per block; reactions owed to later blocks queued);
    /// [`finish`](Self::finish) completes them.
    fn forces(&mut self, t: f64, use_aux: bool) {
        match (self.prep.friction, self.prep.rotation) {
            (true, true) => self.forces_variant::<true, true>(t, use_aux),
            (true, false) => self.forces_variant::<true, false>(t, use_aux),
            (false, true) => self.forces_variant::<false, true>(t, use_aux),
            (false, false) => self.forces_variant::<false, false>(t, use_aux),
        }
    }

    fn forces_variant<const FRICTION: bool, const ROT: bool>(&mut self, t: f64, use_aux: bool) {
        let (zw, vw) = self.prep.wall_motion(t);
        let p = &mut self.p;
        let bs = self.block;
        let inp = ForceInput {
            pos: &p.pos,
            vel: if use_aux { &p.aux } else { &p.vel },
            radius: &p.radius,
            mass: &p.mass,
            species: &p.species,
            omega: &p.omega_p,
            dt: T::from_f64(self.prep.dt),
            n_species: self.n_species,
            coeff: &self.coeff,
            walls: &self.walls,
            gravity: self.gravity,
            zw: T::from_f64(zw),
            vw: T::from_f64(vw),
            vert: self.prep.vertical,
            periodic: self.periodic,
            lo: self.lo,
            len: self.len,
            cut2: self.cut2,
            block: bs,
        };
        let run = |nb: &HalfListBlock<T, D>,
                   b: &mut BlockWork<T, D>,
                   f: &mut [[T; D]],
                   t: &mut [[T; 3]]| {
            block_forces::<T, D, L, FRICTION, ROT>(&inp, nb, b, f, t);
        };
        let blocks = self.list.blocks();
        if self.parallel {
            let tasks = blocks
                .par_iter()
                .zip(self.work.par_iter_mut())
                .zip(p.acc.par_chunks_mut(bs));
            if ROT {
                let tasks = tasks.zip(p.alpha.par_chunks_mut(bs));
                tasks.for_each(|(((nb, b), f), t)| run(nb, b, f, t));
            } else {
                // Without rotation there is no torque array: an empty slice per block.
                tasks.for_each(|((nb, b), f)| run(nb, b, f, &mut []));
            }
        } else {
            let tasks = blocks
                .iter()
                .zip(self.work.iter_mut())
                .zip(p.acc.chunks_mut(bs));
            if ROT {
                let tasks = tasks.zip(p.alpha.chunks_mut(bs));
                tasks.for_each(|(((nb, b), f), t)| run(nb, b, f, t));
            } else {
                tasks.for_each(|((nb, b), f)| run(nb, b, f, &mut []));
            }
        }
    }

    /// The rotational part of [`finish`](Self::finish): adds the torques owed by earlier
    /// blocks, turns torques into angular accelerations and, with `kick`, applies the
    /// closing half kick `w += alpha dt / 2`. No-op without rotation.
    fn finish_rotation(&mut self, kick: bool) {
        if !self.prep.rotation {
            return;
        }
        let bs = self.block;
        let h = T::from_f64(0.5 * self.prep.dt);
        let work = &self.work;
        let p = &mut self.p;
        let inv_inertia = &p.inv_inertia;
        type Spins<'a, T> = (&'a mut [[T; 3]], &'a mut [[T; 3]]);
        let body = |(t, (a, w)): (usize, Spins<'_, T>)| {
            let s = t * bs;
            for b in &work[..t] {
                for &(j, tq) in &b.torques[t] {
                    let aj = &mut a[j as usize - s];
                    for d in 0..3 {
                        aj[d] += tq[d];
                    }
                }
            }
            for (k, (a, w)) in a.iter_mut().zip(w.iter_mut()).enumerate() {
                let ii = inv_inertia[s + k];
                for d in 0..3 {
                    a[d] = a[d] * ii;
                    if kick {
                        w[d] += a[d] * h;
                    }
                }
            }
        };
        if self.parallel {
            p.alpha
                .par_chunks_mut(bs)
                .zip(p.omega.par_chunks_mut(bs))
                .enumerate()
                .for_each(body);
        } else {
            p.alpha
                .chunks_mut(bs)
                .zip(p.omega.chunks_mut(bs))
                .enumerate()
                .for_each(body);
        }
    }

    /// The opening half kick of the rotation, `w += alpha dt / 2`, and the angular velocity
    /// predicted at the force time, `w + alpha dt / 2` (the translation's scheme). No-op
    /// without rotation.
    fn open_rotation(&mut self) {
        let h = T::from_f64(0.5 * self.prep.dt);
        let p = &mut self.p;
        let open = |((w, wp), a): ((&mut [T; 3], &mut [T; 3]), &[T; 3])| open_spin(w, wp, a, h);
        if self.parallel {
            p.omega
                .par_iter_mut()
                .zip(p.omega_p.par_iter_mut())
                .zip(p.alpha.par_iter())
                .for_each(open);
        } else {
            p.omega
                .iter_mut()
                .zip(p.omega_p.iter_mut())
                .zip(p.alpha.iter())
                .for_each(open);
        }
    }

    /// Completes the force pass per block: adds the reactions owed by earlier blocks (in
    /// block order), turns forces into accelerations, and with `kick` applies the closing
    /// half kick `v += a dt / 2`. With `drift` it goes straight on with the next velocity
    /// Verlet step's opening half kick and drift (the same arithmetic as
    /// [`drift_velocity_verlet`], so the same bits) and returns the largest squared
    /// displacement since the list build; otherwise 0.
    fn finish(&mut self, kick: bool, drift: bool) -> f64 {
        let bs = self.block;
        let dt = T::from_f64(self.prep.dt);
        let h = T::from_f64(0.5 * self.prep.dt);
        let work = &self.work;
        let p = &mut self.p;
        let inv_mass = &p.inv_mass;
        let body = |(t, ((((f, v), x), vp), r)): (usize, Chunks<'_, T, D>)| -> f64 {
            let s = t * bs;
            for b in &work[..t] {
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
                max_displacement2(x, r).to_f64()
            } else {
                0.0
            }
        };
        let (acc, vel, pos, aux) = (&mut p.acc, &mut p.vel, &mut p.pos, &mut p.aux);
        max_over_blocks(bs, self.parallel, (acc, vel, pos, aux, &p.reference), body)
    }

    /// Rebuilds the lists when the largest displacement `max2` (squared) exceeds skin / 2.
    fn after_drift(&mut self, max2: f64) -> Result<()> {
        if max2 > self.rebuild_dist2 {
            self.rebuild()?;
        }
        Ok(())
    }

    /// The opening half kick and drift of a velocity Verlet step on its own (the
    /// first step of a call; later ones are fused into [`finish`](Self::finish)); returns
    /// the largest squared displacement since the list build.
    fn drift_velocity_verlet(&mut self) -> f64 {
        let dt = T::from_f64(self.prep.dt);
        let h = T::from_f64(0.5 * self.prep.dt);
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
            max_displacement2(x, r).to_f64()
        };
        let (acc, vel, pos, aux) = (&mut p.acc, &mut p.vel, &mut p.pos, &mut p.aux);
        max_over_blocks(
            bs,
            self.parallel,
            (acc, vel, pos, aux, &p.reference),
            |(_, c)| drift(c),
        )
    }

    /// The first force evaluation of a velocity Verlet run, at the initial velocities.
    fn start_velocity_verlet(&mut self) {
        self.p.aux.clone_from(&self.p.vel);
        self.p.omega_p.clone_from(&self.p.omega);
        self.forces(self.time, true);
        self.finish(false, false);
        self.finish_rotation(false);
        self.started = true;
    }

    /// `steps` velocity Verlet steps: per step one force pass and one pass that finishes
    /// the forces, closes this step and (except after the last) opens the next.
    fn advance_velocity_verlet(&mut self, steps: u32) -> Result<()> {
        if steps == 0 {
            return Ok(());
        }
        if !self.started {
            self.start_velocity_verlet();
        }
        let mut max2 = self.drift_velocity_verlet();
        self.open_rotation();
        for s in 0..steps {
            self.time += self.prep.dt;
            self.after_drift(max2)?;
            self.forces(self.time, true);
            let more = s + 1 < steps;
            max2 = self.finish(true, more);
            self.finish_rotation(true);
            if more {
                self.open_rotation();
            }
        }
        Ok(())
    }

    fn step_position_verlet(&mut self) -> Result<()> {
        self.forces(self.time, false);
        self.finish(false, false);
        let dt = T::from_f64(self.prep.dt);
        let h = T::from_f64(0.5 * self.prep.dt);
        let inv_dt = T::from_f64(1.0 / self.prep.dt);
        let first = !self.started;
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
            max_displacement2(x, r).to_f64()
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
        self.after_drift(max2)
    }
}

/// Velocity Verlet drift (flat component arrays): half kick, drift, and the predicted
/// velocity `vp` at the end of the step for the damping term.
#[multiversion(
    targets("x86_64+avx512f+avx512vl+avx2+fma", "x86_64+avx2+fma"),
    dispatcher = "direct"
)]
pub(crate) fn drift_velocity_verlet<T: Real>(
    x: &mut [T],
    v: &mut [T],
    vp: &mut [T],
    a: &[T],
    h: T,
    dt: T,
) {
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

/// The largest squared displacement of `x` from the reference positions `r` (positions
/// are not wrapped between list builds, so no minimum image is needed).
#[multiversion(
    targets("x86_64+avx512f+avx512vl+avx2+fma", "x86_64+avx2+fma"),
    dispatcher = "direct"
)]
pub(crate) fn max_displacement2<T: Real, const D: usize>(x: &[[T; D]], r: &[[T; D]]) -> T {
    let mut m2 = T::ZERO;
    for (x, r) in x.iter().zip(r) {
        let mut s2 = T::ZERO;
        for d in 0..D {
            let s = x[d] - r[d];
            s2 += s * s;
        }
        m2 = if s2 > m2 { s2 } else { m2 };
    }
    m2
}

/// Wraps the periodic coordinates of `x` into `[lo, lo + len)` ([`wrap_periodic`]).
#[inline(always)]
pub(crate) fn wrap<T: Real, const D: usize>(
    x: &mut [T; D],
    per: [bool; D],
    lo: [T; D],
    len: [T; D],
) {
    wrap_periodic(x, lo, std::array::from_fn(|d| lo[d] + len[d]), len, per);
}

/// The blow-up guard's view of the engine (see [`simkit_backend::guard`]).
impl<const D: usize, T: Real, L: ContactLaw> Guarded for CpuEngine<D, T, L> {
    fn steps_done(&self) -> u64 {
        self.steps
    }

    /// Copies the state into the guard's snapshot (a memcpy per array).
    fn keep(&mut self) -> Result<()> {
        let (s, p) = (&mut self.snap, &self.p);
        s.pos.clone_from(&p.pos);
        s.vel.clone_from(&p.vel);
        s.acc.clone_from(&p.acc);
        s.aux.clone_from(&p.aux);
        s.reference.clone_from(&p.reference);
        s.id.clone_from(&p.id);
        s.omega.clone_from(&p.omega);
        s.alpha.clone_from(&p.alpha);
        s.omega_p.clone_from(&p.omega_p);
        (s.time, s.started, s.steps) = (self.time, self.started, self.steps);
        self.snap.history = self.collect_history();
        Ok(())
    }

    fn advance(&mut self, n: u32) -> std::result::Result<(), Halt> {
        self.advance_unchecked(n)?;
        self.steps += u64::from(n);
        Ok(())
    }

    fn check(&mut self) -> std::result::Result<(), Halt> {
        verdict(self.steps, self.first_failure())
    }

    fn restore(&mut self) -> Result<()> {
        let (s, p) = (&self.snap, &mut self.p);
        p.pos.clone_from(&s.pos);
        p.vel.clone_from(&s.vel);
        p.acc.clone_from(&s.acc);
        p.aux.clone_from(&s.aux);
        p.reference.clone_from(&s.reference);
        p.id.clone_from(&s.id);
        p.omega.clone_from(&s.omega);
        p.alpha.clone_from(&s.alpha);
        p.omega_p.clone_from(&s.omega_p);
        (self.time, self.started, self.steps) = (s.time, s.started, s.steps);
        let history = std::mem::take(&mut self.snap.history);
        let out = self.relist(&history);
        self.snap.history = history;
        out
    }
}

impl<const D: usize, T: Real, L: ContactLaw> crate::engine::Engine<L> for CpuEngine<D, T, L> {
    fn step(&mut self, steps: u32) -> Result<()> {
        let every = self.prep.check_every;
        let run = |e: &mut Self| run_guarded(e, steps, every);
        if self.parallel {
            // The whole loop on a pool thread: no hand-over to the pool per pass.
            simkit_backend::pool::on_pool(|| run(self))
        } else {
            run(self)
        }
    }

    fn state(&mut self) -> Result<State> {
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
        let mut angular_velocities = vec![[0.0; 3]; self.p.omega.len()];
        let (per, lo, len) = (self.periodic, self.lo, self.len);
        for (k, &id) in self.p.id.iter().enumerate() {
            // Positions drift out of a periodic box by up to skin / 2 between list builds.
            let mut x = self.p.pos[k];
            wrap(&mut x, per, lo, len);
            positions[id as usize] = c(&x);
            velocities[id as usize] = c(&self.p.vel[k]);
            if let Some(w) = self.p.omega.get(k) {
                angular_velocities[id as usize] = w.map(|x| x.to_f64());
            }
        }
        Ok(State {
            time: self.time,
            positions,
            velocities,
            angular_velocities,
            species: self.prep.species.clone(),
        })
    }

    fn prepared(&self) -> &Prepared<L> {
        &self.prep
    }

    fn steps_done(&self) -> u64 {
        self.steps
    }

    fn model(&self) -> String {
        crate::engine::model_name::<L>(false, T::PRECISION, D)
    }

    fn save(&mut self) -> Result<Dynamics> {
        Ok(self.to_saved())
    }

    fn forces(&mut self) -> Result<crate::Forces> {
        if !self.started {
            match self.prep.integrator {
                Integrator::VelocityVerlet => self.start_velocity_verlet(),
                Integrator::PositionVerlet => {
                    return Err(simkit_backend::Error::Unsupported(
                        "Dem::forces before the first step of a position Verlet run (its \
                         forces are evaluated inside the step); step once first"
                            .into(),
                    ));
                }
            }
        }
        let n = self.p.pos.len();
        let (mut f, mut t) = (vec![[0.0; 3]; n], vec![[0.0; 3]; n]);
        let prep = &self.prep;
        for (k, &id) in self.p.id.iter().enumerate() {
            let i = id as usize;
            for (f, a) in f[i].iter_mut().zip(&self.p.acc[k]) {
                *f = a.to_f64() * prep.mass[i];
            }
            if let Some(a) = self.p.alpha.get(k) {
                t[i] = a.map(|x| x.to_f64() * prep.inertia[i]);
            }
        }
        Ok(crate::Forces {
            force: f,
            torque: t,
        })
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::Engine;
    use crate::scenes::{BedParams, vibrating_bed};
    use crate::{Config, Dim, Material, Particle, Scene, Wall};

    /// Final states after `steps` steps with the wall candidates of the list builds, and
    /// with every wall tested against every particle.
    fn listed_and_all<const D: usize>(scene: &Scene, steps: u32) -> (State, State) {
        let run = |all: bool| {
            let prep = Prepared::new(scene, &Config::default(), false).expect("prepared");
            let mut e = CpuEngine::<D, f64, Material>::new(prep, None).expect("engine");
            if all {
                e.wall_margin = f64::INFINITY;
                e.rebuild().expect("rebuild");
            }
            e.step(steps).expect("step");
            e.state().expect("state")
        };
        (run(false), run(true))
    }

    fn assert_same(a: &State, b: &State) {
        assert_eq!(a.positions, b.positions, "positions differ");
        assert_eq!(a.velocities, b.velocities, "velocities differ");
    }

    /// The history of every contact, keyed `(min id, max id)` in the orientation of the
    /// smaller index first.
    fn history_map(e: &CpuEngine<3, f64, crate::HertzMindlin>) -> Vec<([u32; 2], Vec<f64>)> {
        let h = e.collect_history();
        let mut out: Vec<([u32; 2], Vec<f64>)> = h
            .keys
            .iter()
            .zip(h.values.chunks_exact(6))
            .map(|(&[a, b], v)| {
                let mut v = v.to_vec();
                if a > b {
                    <crate::HertzMindlin as ContactLaw>::swap_history(&mut v);
                }
                ([a.min(b), a.max(b)], v)
            })
            .collect();
        out.sort_by_key(|x| x.0);
        out
    }

    #[test]
    fn a_list_rebuild_keeps_every_contact_history() {
        use crate::{HertzMindlin, Solid};
        let s = Solid::new(1e5, 0.3);
        let law = HertzMindlin::new(s, s, 0.6, 0.4)
            .expect("law")
            .with_rolling(0.05, 2000.0, 20.0);
        let mut scene = Scene::new(Dim::Three, [0.0; 3], [8.0; 3], law).expect("scene");
        scene.set_rotation(true);
        scene.add_box_walls(law, false).expect("walls");
        thrown_grains(&mut scene, [1.5, 1.0]);
        let prep = Prepared::new(&scene, &Config::default(), false).expect("prepared");
        let mut e = CpuEngine::<3, f64, HertzMindlin>::new(prep, None).expect("engine");
        let mut checked = 0;
        for _ in 0..20 {
            e.step(200).expect("step");
            let before = history_map(&e);
            e.rebuild().expect("rebuild");
            assert_eq!(history_map(&e), before);
            checked += before.len();
        }
        assert!(checked > 100, "only {checked} contact histories checked");
    }

    #[test]
    fn wall_candidates_miss_no_contact_of_a_vibrated_bed() {
        let p = BedParams {
            n: 256,
            width: 16,
            ..BedParams::default()
        };
        let (scene, _) = vibrating_bed(&p).expect("bed");
        let (a, b) = listed_and_all::<2>(&scene, 4000);
        assert_same(&a, &b);
    }

    #[test]
    fn wall_candidates_cover_the_travel_of_a_vibrating_wall() {
        // No gravity: grains at rest a little above the floor never move (no rebuild) until
        // the rising floor reaches them, so only the travel margin can list them.
        let m = Material::new(0.8, 0.05);
        let mut scene = Scene::new(Dim::Two, [0.0; 3], [10.0, 10.0, 0.0], m).expect("scene");
        scene.set_vibration(0.5, 1.0).expect("vibration");
        scene.add_box_walls(m, true).expect("walls");
        for k in 0..8 {
            let pos = [0.5 + 1.2 * k as f64, 0.3 + 0.03 * k as f64, 0.0];
            scene
                .add_particle(Particle::new(pos, 0.25, 1.0))
                .expect("particle");
        }
        let (a, b) = listed_and_all::<2>(&scene, 4000);
        assert_same(&a, &b);
        assert!(
            a.velocities.iter().all(|v| v[1] > 0.0),
            "the floor did not hit every grain"
        );
    }

    #[test]
    fn periodic_box_shorter_than_twice_the_list_range_is_refused() {
        let m = Material::new(0.9, 0.05);
        let mut scene = Scene::new(Dim::Two, [0.0; 3], [1.5, 6.0, 0.0], m).expect("scene");
        scene.set_periodic([true, false, false]);
        scene
            .add_particle(Particle::new([0.5, 3.0, 0.0], 0.5, 1.0))
            .expect("particle");
        // Refused in the shared preparation, so by both backends alike.
        let Err(e) = Prepared::new(&scene, &Config::default(), false) else {
            panic!("a 1.5-long periodic axis with list range 1.1 was accepted");
        };
        let msg = e.to_string();
        assert!(msg.contains("along x") && msg.contains("1.5"), "{msg}");
    }

    /// 150 grains of radius 0.3 on a 5 x 5 x 6 lattice in an 8^3 box, thrown along
    /// `direction` (with some spread), under gravity.
    fn thrown_grains<L: ContactLaw>(scene: &mut Scene<L>, direction: [f64; 2]) {
        scene.set_gravity(1.0).expect("gravity");
        for k in 0..150 {
            let (x, y, z) = (k % 5, (k / 5) % 5, k / 25);
            let pos = [
                2.6 + 0.7 * x as f64,
                2.6 + 0.7 * y as f64,
                2.5 + 0.7 * z as f64,
            ];
            let spread = 0.1 * (k % 7) as f64 - 0.3;
            let vel = [direction[0] + spread, direction[1] - spread, 0.0];
            scene
                .add_particle(Particle::new(pos, 0.3, 1.0).with_velocity(vel))
                .expect("particle");
        }
    }

    #[test]
    fn wall_candidates_miss_no_contact_in_a_cylinder() {
        let m = Material::new(0.7, 0.05).with_friction(0.3, 40.0);
        let mut scene = Scene::new(Dim::Three, [0.0; 3], [8.0; 3], m).expect("scene");
        scene
            .add_wall(Wall::cylinder([4.0, 4.0], 3.5, m))
            .expect("cylinder")
            .add_wall(Wall::plane([0.0, 0.0, 1.0], [0.0, 0.0, 0.0], m))
            .expect("floor");
        thrown_grains(&mut scene, [1.5, 1.0]);
        let (a, b) = listed_and_all::<3>(&scene, 6000);
        assert_same(&a, &b);
        // Grains do end up against the cylinder.
        let touching = a
            .positions
            .iter()
            .filter(|x| (x[0] - 4.0).hypot(x[1] - 4.0) + 0.3 > 3.5);
        assert!(touching.count() > 0, "no grain touches the cylinder");
    }

    #[test]
    fn wall_candidates_miss_no_contact_with_a_wall_across_a_periodic_axis() {
        // y is periodic and the floor tilts slightly along y, so it depends on a periodic
        // coordinate: listed for every particle, tested at the wrapped position.
        let m = Material::new(0.7, 0.05);
        let mut scene = Scene::new(Dim::Three, [0.0; 3], [8.0; 3], m).expect("scene");
        scene.set_periodic([false, true, false]);
        scene
            .add_wall(Wall::plane([0.0, 0.01, 1.0], [0.0, 0.0, 0.0], m))
            .expect("floor")
            .add_wall(Wall::plane([1.0, 0.0, 0.0], [0.0, 0.0, 0.0], m))
            .expect("left")
            .add_wall(Wall::plane([-1.0, 0.0, 0.0], [8.0, 0.0, 0.0], m))
            .expect("right");
        thrown_grains(&mut scene, [0.0, 1.5]);
        let (a, b) = listed_and_all::<3>(&scene, 6000);
        assert_same(&a, &b);
        // Grains started at y >= 2.6 moving +y: some went round the periodic boundary.
        assert!(
            a.positions.iter().any(|x| x[1] < 2.0),
            "no grain crossed the periodic boundary"
        );
    }
}
