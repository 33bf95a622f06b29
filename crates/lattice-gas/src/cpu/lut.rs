//! CPU lookup-table backend: one byte per site, bands of rows in parallel with rayon, several
//! steps per pass over the lattice (temporal blocking).
//!
//! Each row gathers its incoming particles from three padded row copies (the row itself and
//! its two neighbours, wrapped or zero-filled at the edges), so the gather has no branches.
//! The chirality bit goes into the unused rest-particle bit 6 of the gathered state, and the
//! collision is one lookup in a 256-entry table built from the [`CollisionTable`]. On CPUs
//! with AVX-512 VBMI (detected at run time) 64 sites at a time are looked up in registers
//! (`vpermi2b`); elsewhere, and for the last `width % 64` sites of a row, a portable loop
//! (vectorisable gather pass, then one table load per site).

use rayon::prelude::*;
use simkit_backend::Result;

use crate::engine;
use crate::random::{FORCE_STREAM, chirality_word, force_hit, force_threshold, step_key};
use crate::{CollisionTable, Config, EAST, Lattice, REST, WALL, WEST};

/// The lookup-table CPU backend.
pub struct LutCpu {
    lattice: Lattice,
    next: Vec<u8>,
    rule: LutRule,
    steps: u64,
    steps_per_pass: u32,
}

impl LutCpu {
    /// A lookup-table simulation of `lattice` under `config` (validated; `config.cpu` and
    /// `config.gpu_layout` are not read).
    pub fn new(lattice: Lattice, config: &Config) -> Result<Self> {
        config.validate_for(&lattice)?;
        let next = vec![0; lattice.cells().len()];
        Ok(Self {
            rule: LutRule::new(config),
            lattice,
            next,
            steps: 0,
            steps_per_pass: Self::DEFAULT_STEPS_PER_PASS,
        })
    }

    /// Runs the portable scalar loop even where AVX-512 VBMI is present (for comparisons).
    pub fn force_scalar(mut self) -> Self {
        self.rule.vbmi = false;
        self
    }

    /// Whether the AVX-512 VBMI path runs (decided at construction from the CPU's features).
    pub fn uses_vbmi(&self) -> bool {
        self.rule.vbmi
    }

    /// Sets how many steps one pass over the lattice advances (at least 1), for the test
    /// that every setting gives the same bits.
    #[cfg(test)]
    fn with_steps_per_pass(mut self, steps: u32) -> Self {
        self.steps_per_pass = steps.max(1);
        self
    }

    /// Steps advanced per pass over the lattice (temporal blocking; the lattice after any
    /// number of steps has the same bits for every setting, only the speed differs). Four
    /// suits lattices larger than the caches, where the update is bound by memory traffic.
    pub const DEFAULT_STEPS_PER_PASS: u32 = 4;

    /// Advances `levels` steps in one pass over the lattice (temporal blocking). The rows are
    /// cut into bands, one rayon task each; a band sweeps upwards through its rows, keeping
    /// the last three rows of every intermediate step in a small ring (`3 (w + 2)` bytes per
    /// step), so the lattice is read and written once per pass instead of once per step. A
    /// band of rows `j0..j1` recomputes the intermediate rows its neighbours also compute
    /// (step `s` of `levels` over rows `j0 - (levels - s)..j1 + (levels - s)`), which costs
    /// `levels (levels - 1)` extra row updates per band.
    fn pass(&mut self, levels: usize) {
        let w = self.lattice.width();
        let h = self.lattice.height();
        let steps: Vec<RowStep<'_>> = (0..levels as u64)
            .map(|s| self.rule.at_step((self.steps + s) as u32))
            .collect();
        let ctx = PadCtx {
            src: self.lattice.cells(),
            w,
            h,
            config: &self.rule.config,
        };
        let band = band_rows(h, levels, rayon::current_num_threads());
        self.next
            .par_chunks_mut(band * w)
            .enumerate()
            .for_each_init(
                || vec![0u8; levels * 3 * (w + 2)],
                |ring, (b, out)| ctx.band(&steps, b * band, out, ring),
            );
        let cells = std::mem::take(&mut self.next);
        self.next =
            std::mem::replace(&mut self.lattice, Lattice::from_raw(w, h, cells)).into_cells();
        self.steps += levels as u64;
    }
}

/// Rows per band of a temporally blocked pass over `h` rows advancing `levels` steps: about
/// four bands per thread, and at least `16 levels` rows so that the recomputed rows at the
/// band's edges (`levels (levels - 1)`) stay a small fraction.
fn band_rows(h: usize, levels: usize, threads: usize) -> usize {
    h.div_ceil(4 * threads.max(1)).max(16 * levels).min(h)
}

/// The edges of a whole lattice: the padded copies of a row and of its neighbours.
struct PadCtx<'a> {
    src: &'a [u8],
    w: usize,
    h: usize,
    config: &'a Config,
}

impl PadCtx<'_> {
    /// Copies row `jj` (wrapped or absent) into `dst` (length w + 2) with one padding site
    /// on each side.
    fn pad_row(&self, jj: Option<usize>, dst: &mut [u8]) {
        let w = self.w;
        match jj {
            None => dst.fill(0),
            Some(jj) => {
                dst[1..=w].copy_from_slice(&self.src[jj * w..(jj + 1) * w]);
                self.pad_edges(dst);
            }
        }
    }

    /// Fills the two padding sites of a padded row whose sites `1..=w` are set: the wrapped
    /// sites where x is periodic, else empty.
    fn pad_edges(&self, dst: &mut [u8]) {
        let w = self.w;
        if self.config.periodic_x {
            dst[0] = dst[w];
            dst[w + 1] = dst[1];
        } else {
            dst[0] = 0;
            dst[w + 1] = 0;
        }
    }

    /// The lattice row at band coordinate `x` (any integer): wrapped where y is periodic,
    /// `None` outside the lattice where it is not.
    fn row_at(&self, x: isize) -> Option<usize> {
        let h = self.h as isize;
        if self.config.periodic_y {
            Some(x.rem_euclid(h) as usize)
        } else {
            (0..h).contains(&x).then_some(x as usize)
        }
    }

    /// Advances the rows `j0..j0 + out.len() / w` by `steps.len()` steps into `out`, reading
    /// the old lattice; `ring` holds `3 (w + 2)` bytes per step.
    fn band(&self, steps: &[RowStep<'_>], j0: usize, out: &mut [u8], ring: &mut [u8]) {
        let w = self.w;
        let levels = steps.len() as isize;
        let pw = w + 2;
        let (j0, j1) = (j0 as isize, (j0 + out.len() / w) as isize);
        // At sweep position r: load row r of the old lattice, then compute row r - s of
        // step s, for s = 1..=levels, each from rows r - s - 1..=r - s + 1 of step s - 1
        // (the last of them made just before). Ring slot x mod 3 of level s holds row x.
        let slot = |x: isize| x.rem_euclid(3) as usize * pw;
        for r in j0 - levels..j1 + levels {
            self.pad_row(self.row_at(r), &mut ring[slot(r)..slot(r) + pw]);
            for s in 1..=levels {
                let x = r - s;
                let reach = levels - s;
                if x < j0 - reach || x >= j1 + reach {
                    continue;
                }
                let (before, after) = ring.split_at_mut(s as usize * 3 * pw);
                let src = &before[(s as usize - 1) * 3 * pw..];
                let rows = [
                    &src[slot(x)..slot(x) + pw],
                    &src[slot(x + 1)..slot(x + 1) + pw],
                    &src[slot(x - 1)..slot(x - 1) + pw],
                ];
                let Some(jj) = self.row_at(x) else {
                    if s < levels {
                        after[slot(x)..slot(x) + pw].fill(0);
                    }
                    continue;
                };
                let step = &steps[s as usize - 1];
                if s == levels {
                    let q = (x - j0) as usize;
                    let dst = &mut out[q * w..(q + 1) * w];
                    step.row(jj, (jj * w) as u32, dst, rows, [true, true]);
                } else {
                    let dst = &mut after[slot(x)..slot(x) + pw];
                    step.row(jj, (jj * w) as u32, &mut dst[1..=w], rows, [true, true]);
                    self.pad_edges(dst);
                }
            }
        }
    }
}

/// The lookup-table update rule: the settings, the collision table and whether the VBMI path
/// runs. [`LutCpu`] and the blocks of [`crate::DistributedLatticeGas`] both step through it,
/// so streaming, collision, forcing and the open columns are written once.
#[derive(Clone, Debug)]
pub(crate) struct LutRule {
    config: Config,
    /// The collision table indexed by `state | chirality << 6`.
    table: [u8; 256],
    /// Whether the AVX-512 VBMI path runs.
    vbmi: bool,
}

impl LutRule {
    /// The rule of `config` (validated by the caller), with the VBMI path where the CPU has
    /// it.
    pub(crate) fn new(config: &Config) -> Self {
        Self {
            table: table256(&CollisionTable::new(config.rules)),
            vbmi: has_vbmi(),
            config: config.clone(),
        }
    }

    /// The row update of step `step` (the number of steps completed before it, which keys
    /// the random bits).
    pub(crate) fn at_step(&self, step: u32) -> RowStep<'_> {
        RowStep {
            config: &self.config,
            table: &self.table,
            vbmi: self.vbmi,
            key: step_key(self.config.seed, step),
            force_key: step_key(self.config.seed ^ FORCE_STREAM, step),
            threshold: force_threshold(self.config.body_force),
        }
    }
}

/// One step of the rule, applied to any run of consecutive sites of a row
/// ([`RowStep::row`]).
pub(crate) struct RowStep<'a> {
    config: &'a Config,
    table: &'a [u8; 256],
    vbmi: bool,
    key: u32,
    force_key: u32,
    threshold: u32,
}

impl RowStep<'_> {
    /// The new states of `out.len()` consecutive sites of global row `j` (its parity picks
    /// the neighbour offsets), the first of them global site index `first` (which keys the
    /// random bits). `rows` are the padded old states of the same columns in row `j`, in
    /// the row above (`j + 1`) and in the row below: `out.len() + 2` sites each, padded
    /// index `q + 1` over `out[q]`, already wrapped or zero-filled at the lattice's edges.
    /// `edges` says whether `out[0]` is in the lattice's first column and `out[last]` in its
    /// last (where the inflow and outflow columns act).
    #[inline(always)]
    pub(crate) fn row(
        &self,
        j: usize,
        first: u32,
        out: &mut [u8],
        rows: [&[u8]; 3],
        edges: [bool; 2],
    ) {
        if self.config.body_force > 0.0 {
            self.collide::<true>(j, first, out, rows);
        } else {
            self.collide::<false>(j, first, out, rows);
        }
        let n = out.len();
        if edges[0] && self.config.inflow && out[0] & WALL == 0 {
            out[0] = EAST;
        }
        if edges[1] && self.config.outflow && out[n - 1] & WALL == 0 {
            out[n - 1] = 0;
        }
    }

    /// Streaming, collision and body force of the run (the VBMI path first, the portable
    /// loop for what it leaves).
    #[inline(always)]
    fn collide<const FORCE: bool>(&self, j: usize, first: u32, out: &mut [u8], rows: [&[u8]; 3]) {
        let odd = j & 1 == 1;
        let done = self.sites_fast::<FORCE>(first, odd, out, rows);
        let [mid, up, down] = rows;
        if odd {
            self.sites::<FORCE, true>(first, done, out, mid, up, down);
        } else {
            self.sites::<FORCE, false>(first, done, out, mid, up, down);
        }
    }

    /// The VBMI path for the first `64 * (out.len() / 64)` sites (body force applied
    /// afterwards); returns the number of sites done (0 without VBMI).
    #[cfg(target_arch = "x86_64")]
    fn sites_fast<const FORCE: bool>(
        &self,
        first: u32,
        odd: bool,
        out: &mut [u8],
        rows: [&[u8]; 3],
    ) -> usize {
        if !self.vbmi {
            return 0;
        }
        let table = self.table;
        // SAFETY: `vbmi` is only set when `lut_vbmi::available()` returned true.
        let done = unsafe {
            if odd {
                super::lut_vbmi::sites::<true>(table, out, rows, first, self.key)
            } else {
                super::lut_vbmi::sites::<false>(table, out, rows, first, self.key)
            }
        };
        if FORCE {
            for (q, o) in out[..done].iter_mut().enumerate() {
                if *o & (WALL | EAST | WEST) == WEST
                    && force_hit(self.force_key, first + q as u32, self.threshold)
                {
                    *o ^= EAST | WEST;
                }
            }
        }
        done
    }

    #[cfg(not(target_arch = "x86_64"))]
    fn sites_fast<const FORCE: bool>(&self, _: u32, _: bool, _: &mut [u8], _: [&[u8]; 3]) -> usize {
        0
    }

    /// Gather + collide for the sites `start..` of the run in two passes: the gather of the
    /// incoming bits into `out` (branch-free byte operations the compiler vectorises), then
    /// the lookup in place, in runs of sites that share one chirality hash (32 consecutive
    /// site indices).
    #[inline(always)]
    fn sites<const FORCE: bool, const ODD: bool>(
        &self,
        first: u32,
        start: usize,
        out: &mut [u8],
        mid: &[u8],
        up: &[u8],
        down: &[u8],
    ) {
        let w = out.len();
        let len = w - start;
        // Padded index i + 1 is site i; its sources at i - 1 / i / i + 1 are padded i / i + 1
        // / i + 2: slices shifted by 0, 1 and 2.
        fn shifted(row: &[u8], from: usize, len: usize) -> [&[u8]; 3] {
            [0, 1, 2].map(|o| &row[from + o..from + o + len])
        }
        let [m0, m1, m2] = shifted(mid, start, len);
        let [u0, u1, u2] = shifted(up, start, len);
        let [d0, d1, d2] = shifted(down, start, len);
        let dst = &mut out[start..];
        for q in 0..len {
            let n = (m0[q] & 1) | (m2[q] & 8) | (m1[q] & WALL);
            dst[q] = if ODD {
                n | (u1[q] & 2) | (u2[q] & 4) | (d2[q] & 16) | (d1[q] & 32)
            } else {
                n | (u0[q] & 2) | (u1[q] & 4) | (d1[q] & 16) | (d0[q] & 32)
            };
        }
        let mut i = start;
        while i < w {
            let s0 = first + i as u32;
            let run = (32 - (s0 & 31) as usize).min(w - i);
            let word = chirality_word(self.key, s0 >> 5) >> (s0 & 31);
            for (q, o) in out[i..i + run].iter_mut().enumerate() {
                let r = ((word >> q) & 1) as u8;
                let mut v = self.table[usize::from(*o | (r << 6))];
                if FORCE
                    && v & (WALL | EAST | WEST) == WEST
                    && force_hit(self.force_key, s0 + q as u32, self.threshold)
                {
                    v ^= EAST | WEST;
                }
                *o = v;
            }
            i += run;
        }
    }
}

/// The collision table indexed by `state | chirality << 6` (the state with its wall bit; the
/// rest-particle bit 6 is never set, so it carries the chirality).
fn table256(table: &CollisionTable) -> [u8; 256] {
    std::array::from_fn(|idx| {
        let state = idx as u8 & !REST;
        table.apply(state, (idx as u32 >> 6) & 1)
    })
}

/// Whether this CPU has AVX-512 VBMI, so that [`LutCpu`] runs its 64-site register lookup
/// (checked at run time).
#[cfg(target_arch = "x86_64")]
pub fn has_vbmi() -> bool {
    super::lut_vbmi::available()
}

/// Whether this CPU has AVX-512 VBMI (never, off x86-64).
#[cfg(not(target_arch = "x86_64"))]
pub fn has_vbmi() -> bool {
    false
}

impl engine::Engine for LutCpu {
    fn step(&mut self, steps: u32) -> Result<()> {
        // The whole loop on a pool thread: no hand-over to the pool per row pass.
        simkit_backend::pool::on_pool(|| {
            let mut left = steps;
            while left > 0 {
                let levels = left.min(self.steps_per_pass);
                self.pass(levels as usize);
                left -= levels;
            }
        });
        Ok(())
    }

    fn set_steps(&mut self, steps: u64) -> Result<()> {
        self.steps = steps;
        Ok(())
    }

    fn state(&mut self) -> Result<Lattice> {
        Ok(self.lattice.clone())
    }

    fn name(&self) -> String {
        if self.uses_vbmi() {
            "cpu-lut (avx512-vbmi)".into()
        } else {
            "cpu-lut (scalar)".into()
        }
    }
}

engine::simulation_via_engine!(LutCpu);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Obstacle, RuleSet};
    use simkit_backend::Simulation;

    /// Temporal blocking changes nothing but speed: every number of steps per pass gives the
    /// lattice of one step per pass, with lattices shorter than a band and longer, periodic
    /// and closed in y, a step count that is not a multiple of the pass, and a thread count
    /// that makes several bands.
    #[test]
    fn steps_per_pass_keep_the_bits() {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .unwrap();
        for (w, h) in [(70, 4), (64, 40), (33, 130), (128, 290)] {
            let mut chan = Lattice::new(w, h).unwrap();
            chan.fill_random(0.35, h as u32).unwrap();
            chan.add_wall_rows();
            let channel = Config {
                periodic_x: false,
                periodic_y: false,
                inflow: true,
                outflow: true,
                body_force: 0.05,
                seed: 7,
                ..Config::default()
            };
            let mut boxed = Lattice::new(w, h).unwrap();
            boxed.fill_random(0.4, 5).unwrap();
            let periodic = Config {
                periodic_x: false,
                ..Config::default()
            };
            for (l, p) in [(chan, channel), (boxed, periodic)] {
                let run = |per_pass: u32| {
                    let mut sim = LutCpu::new(l.clone(), &p)
                        .unwrap()
                        .with_steps_per_pass(per_pass);
                    pool.install(|| sim.step(23)).unwrap();
                    sim.state().unwrap()
                };
                let one = run(1);
                assert!(one != l, "{w} x {h}: lattice unchanged");
                for per_pass in [2, 3, 4, 7, 30] {
                    assert!(run(per_pass) == one, "{w} x {h} {p:?}, {per_pass} per pass");
                }
            }
        }
    }

    /// The VBMI path (where the CPU has it) and the scalar loop give the same lattice, for
    /// widths with and without a scalar tail, periodic and channel scenes, force and both
    /// rule sets.
    #[test]
    fn vbmi_path_equals_scalar_loop() {
        let vbmi = LutCpu::new(Lattice::new(64, 2).unwrap(), &Config::default())
            .unwrap()
            .uses_vbmi();
        simkit_backend::testing::simd_exercised("vbmi_path_equals_scalar_loop", "avx512vbmi", vbmi);
        for (w, h) in [(64, 8), (200, 30), (37, 10), (320, 64)] {
            for rules in [RuleSet::FhpI, RuleSet::Full] {
                let mut chan = Lattice::new(w, h).unwrap();
                chan.fill_random(0.3, w as u32).unwrap();
                chan.add_wall_rows();
                chan.add_obstacle(&Obstacle::Disc {
                    cx: w as f64 / 2.0,
                    cy: h as f64 * 0.4,
                    radius: 3.0,
                })
                .unwrap();
                let channel = Config {
                    rules,
                    periodic_x: false,
                    periodic_y: false,
                    inflow: true,
                    outflow: true,
                    body_force: 0.05,
                    seed: 3,
                    ..Config::default()
                };
                let mut boxed = Lattice::new(w, h).unwrap();
                boxed.fill_random(0.4, 2).unwrap();
                let periodic = Config {
                    rules,
                    ..Config::default()
                };
                for (l, p) in [(chan, channel), (boxed, periodic)] {
                    let mut fast = LutCpu::new(l.clone(), &p).unwrap();
                    let mut slow = LutCpu::new(l.clone(), &p).unwrap().force_scalar();
                    assert!(!slow.uses_vbmi());
                    fast.step(50).unwrap();
                    slow.step(50).unwrap();
                    let got = fast.state().unwrap();
                    assert!(got != l, "{w} x {h} {p:?}: lattice unchanged");
                    assert!(got == slow.state().unwrap(), "{w} x {h} {p:?}");
                }
            }
        }
    }
}
