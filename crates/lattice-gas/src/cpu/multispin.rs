//! CPU multi-spin backend: six bit-planes of `u64` (64 sites per word), collisions as
//! boolean logic, streaming as shifts; rows in parallel with rayon and the word loops
//! compiled for AVX-512 / AVX2 / baseline with runtime dispatch (`multiversion`).
//!
//! The width must be a multiple of 64. The chirality bits of a word are the two 32-bit hashes
//! of [`crate::random`] for its 64 sites, so this backend is bit-identical to the others.

use multiversion::multiversion;
use rayon::prelude::*;
use simkit_backend::{Error, Result};

use crate::engine;
use crate::field::{BlockField, CX, CY};
use crate::random::{FORCE_STREAM, chirality_word, force_hit, force_threshold, step_key};
use crate::rules::collide_bits;
use crate::{Config, Lattice, RuleSet, WALL};

/// The multi-spin CPU backend.
pub struct MultiSpinCpu {
    width: usize,
    height: usize,
    /// Words per row.
    nw: usize,
    /// `planes[(j * 6 + d) * nw + k]`: direction d of sites 64k..64k+63 of row j.
    planes: Vec<u64>,
    next: Vec<u64>,
    walls: Vec<u64>,
    config: Config,
    steps: u64,
}

impl MultiSpinCpu {
    /// A multi-spin simulation of `lattice` under `config` (validated; `config.cpu` and
    /// `config.gpu_layout` are not read); the width must be a multiple of 64.
    pub fn new(lattice: Lattice, config: &Config) -> Result<Self> {
        config.validate_for(&lattice)?;
        let (w, h) = (lattice.width(), lattice.height());
        if !w.is_multiple_of(64) {
            return Err(Error::invalid(
                "width",
                w,
                "the multi-spin backend packs 64 sites per word: use a multiple of 64, or the lookup-table backend",
            ));
        }
        let nw = w / 64;
        let mut planes = vec![0u64; 6 * h * nw];
        let mut walls = vec![0u64; h * nw];
        for (s, &c) in lattice.cells().iter().enumerate() {
            let (i, j) = (s % w, s / w);
            let (k, b) = (i / 64, i % 64);
            for d in 0..6 {
                if c & (1 << d) != 0 {
                    planes[(j * 6 + d) * nw + k] |= 1 << b;
                }
            }
            if c & WALL != 0 {
                walls[j * nw + k] |= 1 << b;
            }
        }
        Ok(Self {
            width: w,
            height: h,
            nw,
            next: vec![0; planes.len()],
            planes,
            walls,
            config: config.clone(),
            steps: 0,
        })
    }

    /// Particles per row (popcounts of the planes), cheaper than a full [`Simulation::state`](simkit_backend::Simulation::state).
    pub fn row_counts(&self) -> Vec<[u64; 6]> {
        let nw = self.nw;
        (0..self.height)
            .map(|j| {
                let mut c = [0u64; 6];
                for (d, cd) in c.iter_mut().enumerate() {
                    let p = &self.planes[(j * 6 + d) * nw..(j * 6 + d + 1) * nw];
                    *cd = p.iter().map(|x| u64::from(x.count_ones())).sum();
                }
                c
            })
            .collect()
    }

    /// Block sums of density and momentum over `block x block` sites straight from the
    /// bit-planes (popcounts of masked words): the same field as
    /// [`BlockField::from_lattice`] on [`Simulation::state`](simkit_backend::Simulation::state), without building the bytes.
    pub fn block_field(&self, block: usize) -> Result<BlockField> {
        let (w, h, nw) = (self.width, self.height, self.nw);
        let mut f = BlockField::zeros(w, h, block)?;
        let nx = f.nx;
        let mut counts = vec![[0u64; 7]; nx * f.ny];
        for j in 0..h {
            let row = &mut counts[(j / block) * nx..(j / block + 1) * nx];
            for (bx, c) in row.iter_mut().enumerate() {
                let (i0, i1) = (bx * block, ((bx + 1) * block).min(w));
                for k in i0 / 64..i1.div_ceil(64) {
                    let lo = i0.max(64 * k) - 64 * k;
                    let hi = i1.min(64 * (k + 1)) - 64 * k;
                    let mask = (u64::MAX >> (64 - (hi - lo))) << lo;
                    let fluid = mask & !self.walls[j * nw + k];
                    for (d, cd) in c[..6].iter_mut().enumerate() {
                        *cd += u64::from((self.planes[(j * 6 + d) * nw + k] & fluid).count_ones());
                    }
                    c[6] += u64::from(fluid.count_ones());
                }
            }
        }
        for (b, c) in counts.iter().enumerate() {
            f.sites[b] = c[6] as f64;
            f.particles[b] = c[..6].iter().sum::<u64>() as f64;
            f.px[b] = (0..6).map(|d| c[d] as f64 * CX[d]).sum();
            f.py[b] = (0..6).map(|d| c[d] as f64 * CY[d]).sum();
        }
        Ok(f)
    }

    fn step_once(&mut self) {
        let t = self.steps as u32;
        let ctx = Ctx {
            src: &self.planes,
            walls: &self.walls,
            nw: self.nw,
            h: self.height,
            config: &self.config,
            key: step_key(self.config.seed, t),
            force_key: step_key(self.config.seed ^ FORCE_STREAM, t),
            threshold: force_threshold(self.config.body_force),
        };
        let nw = self.nw;
        self.next
            .par_chunks_mut(6 * nw)
            .enumerate()
            .for_each_init(|| vec![0u64; 7 * nw], |tmp, (j, out)| ctx.row(j, out, tmp));
        std::mem::swap(&mut self.planes, &mut self.next);
        self.steps += 1;
    }
}

struct Ctx<'a> {
    src: &'a [u64],
    walls: &'a [u64],
    nw: usize,
    h: usize,
    config: &'a Config,
    key: u32,
    force_key: u32,
    threshold: u32,
}

/// `dst[k]` gets the bits of the site one to the left (site i takes i - 1).
fn from_left(src: &[u64], dst: &mut [u64], periodic: bool) {
    let n = src.len();
    let carry = if periodic { src[n - 1] >> 63 } else { 0 };
    dst[0] = (src[0] << 1) | carry;
    for k in 1..n {
        dst[k] = (src[k] << 1) | (src[k - 1] >> 63);
    }
}

/// `dst[k]` gets the bits of the site one to the right (site i takes i + 1).
fn from_right(src: &[u64], dst: &mut [u64], periodic: bool) {
    let n = src.len();
    for k in 0..n - 1 {
        dst[k] = (src[k] >> 1) | (src[k + 1] << 63);
    }
    let carry = if periodic { src[0] << 63 } else { 0 };
    dst[n - 1] = (src[n - 1] >> 1) | carry;
}

impl Ctx<'_> {
    fn plane(&self, j: usize, d: usize) -> &[u64] {
        &self.src[(j * 6 + d) * self.nw..(j * 6 + d + 1) * self.nw]
    }

    fn row(&self, j: usize, out: &mut [u64], tmp: &mut [u64]) {
        let nw = self.nw;
        let h = self.h;
        let px = self.config.periodic_x;
        let py = self.config.periodic_y;
        let up = if j + 1 < h {
            Some(j + 1)
        } else {
            py.then_some(0)
        };
        let down = if j > 0 {
            Some(j - 1)
        } else {
            py.then_some(h - 1)
        };
        let odd = j & 1 == 1;
        let (inc, rnd) = tmp.split_at_mut(6 * nw);
        {
            let mut planes = inc.chunks_mut(nw);
            let p: [&mut [u64]; 6] = std::array::from_fn(|_| planes.next().expect("six planes"));
            let [p0, p1, p2, p3, p4, p5] = p;
            from_left(self.plane(j, 0), p0, px);
            from_right(self.plane(j, 3), p3, px);
            match up {
                None => {
                    p1.fill(0);
                    p2.fill(0);
                }
                Some(u) if odd => {
                    p1.copy_from_slice(self.plane(u, 1));
                    from_right(self.plane(u, 2), p2, px);
                }
                Some(u) => {
                    from_left(self.plane(u, 1), p1, px);
                    p2.copy_from_slice(self.plane(u, 2));
                }
            }
            match down {
                None => {
                    p4.fill(0);
                    p5.fill(0);
                }
                Some(dn) if odd => {
                    from_right(self.plane(dn, 4), p4, px);
                    p5.copy_from_slice(self.plane(dn, 5));
                }
                Some(dn) => {
                    p4.copy_from_slice(self.plane(dn, 4));
                    from_left(self.plane(dn, 5), p5, px);
                }
            }
        }
        let first_hash = (j * nw * 2) as u32;
        random_words(rnd, first_hash, self.key);
        let walls = &self.walls[j * nw..(j + 1) * nw];
        match self.config.rules {
            RuleSet::FhpI => collide_fhp1(inc, rnd, walls, out, nw),
            RuleSet::Full => collide_full(inc, rnd, walls, out, nw),
        }
        if self.config.body_force > 0.0 {
            let first_site = (j * nw * 64) as u32;
            force_words(rnd, first_site, self.force_key, self.threshold);
            for k in 0..nw {
                let cond = rnd[k] & out[3 * nw + k] & !out[k] & !walls[k];
                out[k] |= cond;
                out[3 * nw + k] &= !cond;
            }
        }
        if self.config.inflow && walls[0] & 1 == 0 {
            for d in 0..6 {
                out[d * nw] &= !1;
            }
            out[0] |= 1;
        }
        if self.config.outflow && walls[nw - 1] >> 63 == 0 {
            for d in 0..6 {
                out[d * nw + nw - 1] &= !(1 << 63);
            }
        }
    }
}

/// The instruction set of the multi-spin word loops on this CPU (`"avx512"`, `"avx2"` or
/// `"baseline"`), chosen at run time by the same dispatch as the loops. The AVX-512 version
/// needs the Ice Lake / Zen 4 feature set (`multiversion` skips it on CPUs with slow AVX-512).
#[multiversion(targets("x86_64+avx512f+avx512bw+avx512vl", "x86_64+avx2+fma"))]
pub fn simd_target() -> &'static str {
    multiversion::target::match_target! {
        "x86_64+avx512f" => "avx512",
        "x86_64+avx2" => "avx2",
        _ => "baseline",
    }
}

/// Chirality words: bits of hashes `first, first + 1, ...` packed two per u64.
#[multiversion(targets("x86_64+avx512f+avx512bw+avx512vl", "x86_64+avx2+fma"))]
fn random_words(dst: &mut [u64], first: u32, key: u32) {
    for (k, d) in dst.iter_mut().enumerate() {
        let lo = first.wrapping_add(2 * k as u32);
        *d = u64::from(chirality_word(key, lo))
            | u64::from(chirality_word(key, lo.wrapping_add(1))) << 32;
    }
}

/// Body-force words: bit b of word k is set when site `first + 64k + b` draws below threshold.
#[multiversion(targets("x86_64+avx512f+avx512bw+avx512vl", "x86_64+avx2+fma"))]
fn force_words(dst: &mut [u64], first: u32, key: u32, threshold: u32) {
    for (k, d) in dst.iter_mut().enumerate() {
        let base = first.wrapping_add(64 * k as u32);
        let mut word = 0u64;
        for b in 0..64u32 {
            let hit = force_hit(key, base.wrapping_add(b), threshold);
            word |= u64::from(hit) << b;
        }
        *d = word;
    }
}

macro_rules! collide_rows {
    ($name:ident, $full:expr) => {
        #[multiversion(targets("x86_64+avx512f+avx512bw+avx512vl", "x86_64+avx2+fma"))]
        fn $name(inc: &[u64], rnd: &[u64], walls: &[u64], out: &mut [u64], nw: usize) {
            let (o0, rest) = out.split_at_mut(nw);
            let (o1, rest) = rest.split_at_mut(nw);
            let (o2, rest) = rest.split_at_mut(nw);
            let (o3, rest) = rest.split_at_mut(nw);
            let (o4, o5) = rest.split_at_mut(nw);
            for k in 0..nw {
                let s = [
                    inc[k],
                    inc[nw + k],
                    inc[2 * nw + k],
                    inc[3 * nw + k],
                    inc[4 * nw + k],
                    inc[5 * nw + k],
                ];
                let o = collide_bits::<u64, $full>(s, rnd[k], walls[k]);
                o0[k] = o[0];
                o1[k] = o[1];
                o2[k] = o[2];
                o3[k] = o[3];
                o4[k] = o[4];
                o5[k] = o[5];
            }
        }
    };
}
collide_rows!(collide_fhp1, false);
collide_rows!(collide_full, true);

impl engine::Engine for MultiSpinCpu {
    fn step(&mut self, steps: u32) -> Result<()> {
        // The whole loop on a pool thread: no hand-over to the pool per row pass.
        simkit_backend::pool::on_pool(|| {
            for _ in 0..steps {
                self.step_once();
            }
        });
        Ok(())
    }

    fn set_steps(&mut self, steps: u64) -> Result<()> {
        self.steps = steps;
        Ok(())
    }

    fn state(&mut self) -> Result<Lattice> {
        let (w, h, nw) = (self.width, self.height, self.nw);
        let mut cells = vec![0u8; w * h];
        for (s, c) in cells.iter_mut().enumerate() {
            let (i, j) = (s % w, s / w);
            let (k, b) = (i / 64, i % 64);
            let mut v = (((self.walls[j * nw + k] >> b) & 1) as u8) << 7;
            for d in 0..6 {
                v |= (((self.planes[(j * 6 + d) * nw + k] >> b) & 1) as u8) << d;
            }
            *c = v;
        }
        Ok(Lattice::from_raw(w, h, cells))
    }

    fn name(&self) -> String {
        format!("cpu-multispin ({})", simd_target())
    }

    fn block_field(&mut self, block: usize) -> Result<BlockField> {
        MultiSpinCpu::block_field(self, block)
    }
}

engine::simulation_via_engine!(MultiSpinCpu);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::CollisionTable;
    use simkit_backend::Simulation;

    #[test]
    fn block_field_from_planes_equals_the_byte_version() {
        let mut l = Lattice::new(192, 40).unwrap();
        l.add_wall_rows();
        l.add_obstacle(&crate::Obstacle::Disc {
            cx: 70.0,
            cy: 17.0,
            radius: 9.0,
        })
        .unwrap();
        l.fill_random(0.3, 8).unwrap();
        let config = Config {
            periodic_y: false,
            ..Config::default()
        };
        let mut sim = MultiSpinCpu::new(l, &config).unwrap();
        sim.step(20).unwrap();
        let state = sim.state().unwrap();
        for block in [1, 5, 16, 64, 100] {
            let a = sim.block_field(block).unwrap();
            let b = BlockField::from_lattice(&state, block).unwrap();
            assert_eq!(
                (a.nx, a.ny, &a.sites, &a.particles),
                (b.nx, b.ny, &b.sites, &b.particles)
            );
            for (x, y) in a.px.iter().zip(&b.px).chain(a.py.iter().zip(&b.py)) {
                assert!((x - y).abs() < 1e-9, "block {block}: {x} vs {y}");
            }
        }
        assert!(sim.block_field(0).is_err());
    }

    #[test]
    #[cfg(target_arch = "x86_64")]
    fn dispatch_follows_the_cpu_features() {
        let t = simd_target();
        println!("multi-spin word loops: {t}");
        let avx2 = is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma");
        assert_eq!(t != "baseline", avx2, "{t}");
        if t == "avx512" {
            assert!(is_x86_feature_detected!("avx512f") && is_x86_feature_detected!("avx512bw"));
        }
        // The conformance tests compare this dispatch with the lookup table bit for bit.
        let test = "dispatch_follows_the_cpu_features";
        simkit_backend::testing::simd_exercised(test, "avx512f", t == "avx512");
        simkit_backend::testing::simd_exercised(test, "avx2", t != "baseline");
    }

    #[test]
    fn boolean_logic_equals_the_tables() {
        for rules in [RuleSet::FhpI, RuleSet::Full] {
            let t = CollisionTable::new(rules);
            for st in 0..64u8 {
                for wall in [0u8, WALL] {
                    for r in 0..2u32 {
                        let s: [u64; 6] = std::array::from_fn(|d| u64::from((st >> d) & 1));
                        let o = match rules {
                            RuleSet::FhpI => {
                                collide_bits::<u64, false>(s, r.into(), u64::from(wall >> 7))
                            }
                            RuleSet::Full => {
                                collide_bits::<u64, true>(s, r.into(), u64::from(wall >> 7))
                            }
                        };
                        let got = (0..6).fold(wall, |acc, d| acc | (((o[d] & 1) as u8) << d));
                        assert_eq!(
                            got,
                            t.apply(st | wall, r),
                            "{rules:?} state {st} wall {wall} r {r}"
                        );
                    }
                }
            }
        }
    }
}
