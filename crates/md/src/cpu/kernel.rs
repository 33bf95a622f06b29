//! The pair-force kernel of the CPU backend: one block of a half Verlet list
//! ([`HalfListBlock`]) at a time, in lanes.
//!
//! For particle `i`, the same-image partners are taken `W = 16` at a time (one AVX-512
//! register of `f32`, two of `f64`; on the `in.lj` liquid 16 measured about 12 % faster
//! than 8 in `f64` and 32 much slower in both): a gather fills lane arrays with the
//! separations and the coefficients of the species pair (`coeff[s_i * n_species + s_j]`,
//! no branch on the species), one loop over the lanes evaluates the law's
//! [`PairLaw::force_energy`] (the law of every CPU path, called as is and inlined: the
//! kernel is compiled for each law; the compiler turns the cutoff test into a lane mask and
//! the loop into vector instructions), and a scalar loop subtracts the reactions
//! from the partners. Lane `l` of `i`'s accumulators sums partners `l, l + W, ...`; the
//! lanes are added in order at the end, then the cross-image partners one by one. The
//! full chunks need no tail handling; the last, short chunk runs at width `W / 2` when it
//! fits (about 6 % of a step in `f64`). The energy and virial sums are a compile-time
//! option: the engine asks for them only at the steps whose energies are read (about
//! 20 % of a step in `f64`; the forces are the same bits either way). Skipping the
//! reactions of the lanes beyond the cutoff was measured slower (the branches
//! mispredict).
//!
//! The same Rust function is compiled three times: for AVX-512 (`avx512f`, `avx512vl`),
//! for AVX2 (`avx2`, `fma`) and for the baseline target; [`Kernel::detect`] picks one at run
//! time. Rust never fuses a multiply and an add on its own, so the three give the same bits
//! (the unit tests check it), and the choice of kernel never changes a result.

use simkit_backend::Real;
use simkit_neighbor::HalfListBlock;

use crate::PairLaw;

/// Partners per chunk (`W` in the module doc).
const LANES: usize = 16;

/// Which compilation of the pair kernel runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Kernel {
    /// Compiled with AVX-512 (F and VL) enabled.
    Avx512,
    /// Compiled with AVX2 and FMA enabled.
    Avx2,
    /// The baseline target (whatever SIMD it has, SSE2 on x86-64).
    Portable,
}

impl Kernel {
    /// The best kernel this CPU runs.
    pub fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::is_x86_feature_detected as has;
            if has!("avx512f") && has!("avx512vl") && has!("avx2") && has!("fma") {
                return Self::Avx512;
            }
            if has!("avx2") && has!("fma") {
                return Self::Avx2;
            }
        }
        Self::Portable
    }

    /// Every kernel this CPU runs (the best first).
    #[cfg(test)]
    pub fn available() -> Vec<Self> {
        match Self::detect() {
            Self::Avx512 => vec![Self::Avx512, Self::Avx2, Self::Portable],
            Self::Avx2 => vec![Self::Avx2, Self::Portable],
            Self::Portable => vec![Self::Portable],
        }
    }

    /// Short name for the backend description.
    pub fn name(self) -> &'static str {
        match self {
            Self::Avx512 => "avx512",
            Self::Avx2 => "avx2",
            Self::Portable => "portable",
        }
    }
}

/// What the kernel reads: positions and species in slot order, the flat species-pair
/// table.
pub(crate) struct Inputs<'a, T: Real, const D: usize, L: PairLaw> {
    /// Positions (not wrapped since the list build: the list holds each pair's image).
    pub pos: &'a [[T; D]],
    /// Species per slot.
    pub species: &'a [u32],
    /// Coefficients, entry `si * n_species + sj`.
    pub coeff: &'a [L::Coeff<T>],
    /// Number of species.
    pub n_species: usize,
    /// A separation beyond every cutoff (for the unused lanes).
    pub pad: T,
}

/// Forces of block `nb`: `near[k]` gets the force on slot `nb.start() + k` from every
/// pair the block lists (partners' reactions included: `near` spans the block and its
/// same-image partners, [`HalfListBlock::near_reach`]), except the reactions on
/// cross-image partners beyond that span, which go to `far` one per pair in visiting order
/// (see [`BlockForces`](super::buffers::BlockForces)); `ew[k]` the sums of `phi` and
/// `r . F` over the particle's listed pairs (each pair counted once, at its first
/// particle) when `energy` is set (`ew` is left as it is otherwise; the forces are the
/// same bits either way).
///
/// # Safety
/// Every partner `j` of `nb` must satisfy `nb.start() <= j`, `j < pos.len()` and
/// `j < inp.species.len()`, every same-image partner `j < nb.start() + near.len()`
/// (`near.len() >= nb.near_reach() - nb.start()`), and `nb.end() <= pos.len()`: the kernel
/// reads `pos[j]` and `species[j]` and writes `near[j - nb.start()]` unchecked. A half list
/// built over these positions (one species per position) satisfies all of them. `far`
/// must hold one entry per cross-image pair beyond `near` (checked: the kernel panics
/// otherwise).
pub(crate) unsafe fn block_forces<T: Real, const D: usize, L: PairLaw>(
    kernel: Kernel,
    inp: &Inputs<'_, T, D, L>,
    nb: &HalfListBlock<T, D>,
    near: &mut [[T; D]],
    far: &mut [[T; D]],
    ew: &mut [[T; 2]],
    energy: bool,
) {
    // SAFETY: passed on from the caller.
    unsafe { dispatch::<T, D, L, LANES, { LANES / 2 }>(kernel, inp, nb, near, far, ew, energy) }
}

/// # Safety
/// As [`block_forces`].
#[inline(always)]
unsafe fn dispatch<T: Real, const D: usize, L: PairLaw, const W: usize, const H: usize>(
    kernel: Kernel,
    inp: &Inputs<'_, T, D, L>,
    nb: &HalfListBlock<T, D>,
    near: &mut [[T; D]],
    far: &mut [[T; D]],
    ew: &mut [[T; 2]],
    energy: bool,
) {
    match kernel {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `Kernel::detect` only returns Avx512 when the CPU has these features.
        Kernel::Avx512 => unsafe { lanes_avx512::<T, D, L, W, H>(inp, nb, near, far, ew, energy) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `Kernel::detect` only returns Avx2 (or better) when the CPU has AVX2, FMA.
        Kernel::Avx2 => unsafe { lanes_avx2::<T, D, L, W, H>(inp, nb, near, far, ew, energy) },
        // SAFETY: as [`block_forces`].
        _ => unsafe { lanes::<T, D, L, W, H>(inp, nb, near, far, ew, energy) },
    }
}

/// [`lanes`] compiled for AVX-512.
///
/// # Safety
/// The CPU must have AVX-512F, AVX-512VL, AVX2 and FMA; and as [`block_forces`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
unsafe fn lanes_avx512<T: Real, const D: usize, L: PairLaw, const W: usize, const H: usize>(
    inp: &Inputs<'_, T, D, L>,
    nb: &HalfListBlock<T, D>,
    near: &mut [[T; D]],
    far: &mut [[T; D]],
    ew: &mut [[T; 2]],
    energy: bool,
) {
    // SAFETY: passed on from the caller.
    unsafe { lanes::<T, D, L, W, H>(inp, nb, near, far, ew, energy) };
}

/// [`lanes`] compiled for AVX2.
///
/// # Safety
/// The CPU must have AVX2 and FMA; and as [`block_forces`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn lanes_avx2<T: Real, const D: usize, L: PairLaw, const W: usize, const H: usize>(
    inp: &Inputs<'_, T, D, L>,
    nb: &HalfListBlock<T, D>,
    near: &mut [[T; D]],
    far: &mut [[T; D]],
    ew: &mut [[T; 2]],
    energy: bool,
) {
    // SAFETY: passed on from the caller.
    unsafe { lanes::<T, D, L, W, H>(inp, nb, near, far, ew, energy) };
}

/// The kernel body (see the module doc), `W` lanes; the coefficient gather is left out
/// for a single species, the energy and virial sums when `energy` is not set.
///
/// # Safety
/// As [`block_forces`].
#[inline(always)]
unsafe fn lanes<T: Real, const D: usize, L: PairLaw, const W: usize, const H: usize>(
    inp: &Inputs<'_, T, D, L>,
    nb: &HalfListBlock<T, D>,
    near: &mut [[T; D]],
    far: &mut [[T; D]],
    ew: &mut [[T; 2]],
    energy: bool,
) {
    // SAFETY: passed on from the caller.
    unsafe {
        match (inp.n_species == 1, energy) {
            (true, true) => body::<T, D, L, W, H, true, true>(inp, nb, near, far, ew),
            (true, false) => body::<T, D, L, W, H, true, false>(inp, nb, near, far, ew),
            (false, true) => body::<T, D, L, W, H, false, true>(inp, nb, near, far, ew),
            (false, false) => body::<T, D, L, W, H, false, false>(inp, nb, near, far, ew),
        }
    }
}

/// # Safety
/// As [`block_forces`].
#[inline(always)]
unsafe fn body<
    T: Real,
    const D: usize,
    L: PairLaw,
    const W: usize,
    const H: usize,
    const SINGLE: bool,
    const ENERGY: bool,
>(
    inp: &Inputs<'_, T, D, L>,
    nb: &HalfListBlock<T, D>,
    near: &mut [[T; D]],
    far: &mut [[T; D]],
    ew: &mut [[T; 2]],
) {
    near.fill([T::ZERO; D]);
    let near_end = nb.start() + near.len();
    let mut queued = 0;
    let (pos, species, coeff, ns) = (inp.pos, inp.species, inp.coeff, inp.n_species);
    let start = nb.start();
    let (offsets, partners) = (nb.offsets(), nb.partners());
    let (img_offsets, img_partners) = (nb.image_offsets(), nb.image_partners());
    for (k, ew) in ew.iter_mut().enumerate().take(nb.len()) {
        let i = start + k;
        let xi = pos[i];
        let row = &coeff[species[i] as usize * ns..][..ns];
        let mut acc = Acc {
            f: [[T::ZERO; W]; D],
            e: [T::ZERO; W],
            w: [T::ZERO; W],
        };
        let list = &partners[offsets[k] as usize..offsets[k + 1] as usize];
        let mut full = list.chunks_exact(W);
        for chunk in &mut full {
            let idx: &[u32; W] = chunk.try_into().unwrap_or_else(|_| unreachable!());
            // SAFETY: passed on from the caller.
            unsafe {
                chunk_forces::<T, D, L, W, W, SINGLE, ENERGY>(
                    inp, row, xi, idx, W, start, near, &mut acc,
                )
            };
        }
        let rest = full.remainder();
        // The last chunk at half width when it fits (the unused lanes read particle `i`
        // itself: a zero separation, whose squared distance is replaced by `pad^2`).
        let cnt = rest.len();
        if cnt > H {
            let idx: [u32; W] = std::array::from_fn(|l| rest.get(l).copied().unwrap_or(i as u32));
            // SAFETY: passed on from the caller.
            unsafe {
                chunk_forces::<T, D, L, W, W, SINGLE, ENERGY>(
                    inp, row, xi, &idx, cnt, start, near, &mut acc,
                )
            };
        } else if cnt > 0 {
            let idx: [u32; H] = std::array::from_fn(|l| rest.get(l).copied().unwrap_or(i as u32));
            // SAFETY: passed on from the caller.
            unsafe {
                chunk_forces::<T, D, L, H, W, SINGLE, ENERGY>(
                    inp, row, xi, &idx, cnt, start, near, &mut acc,
                )
            };
        }
        let mut fi = [T::ZERO; D];
        let (mut e, mut w) = (T::ZERO, T::ZERO);
        for l in 0..W {
            for (f, a) in fi.iter_mut().zip(&acc.f) {
                *f += a[l];
            }
            e += acc.e[l];
            w += acc.w[l];
        }
        for &(j, shift) in &img_partners[img_offsets[k] as usize..img_offsets[k + 1] as usize] {
            let j = j as usize;
            let s: [T; D] = std::array::from_fn(|d| (xi[d] - pos[j][d]) - shift[d]);
            let mut r2 = T::ZERO;
            for x in s {
                r2 += x * x;
            }
            let (fr, pe) = L::force_energy(&row[species[j] as usize], r2);
            let f: [T; D] = std::array::from_fn(|d| fr * s[d]);
            for d in 0..D {
                fi[d] += f[d];
            }
            if j < near_end {
                let fj = &mut near[j - start];
                for d in 0..D {
                    fj[d] = fj[d] - f[d];
                }
            } else {
                far[queued] = f.map(|x| T::ZERO - x);
                queued += 1;
            }
            if ENERGY {
                e += pe;
                w += fr * r2;
            }
        }
        let own = &mut near[k];
        for d in 0..D {
            own[d] += fi[d];
        }
        if ENERGY {
            *ew = [e, w];
        }
    }
}

/// Particle `i`'s lane accumulators: force, `phi` and `r . F` (lane `l` sums partners
/// `l, l + W, ...`).
struct Acc<T, const D: usize, const W: usize> {
    f: [[T; W]; D],
    e: [T; W],
    w: [T; W],
}

/// One chunk of `C <= W` of `i`'s partners, into lanes `0..C` of `acc`: `idx[..cnt]` are
/// partners, the other lanes `i` itself (given the squared distance `pad^2`, beyond every
/// cutoff: the law gives (0, 0) there, and adding +0 leaves a sum unchanged, a sum started
/// at +0 being never -0; so a short last chunk gives the same bits at `C = W` or `W / 2`).
///
/// # Safety
/// As [`block_forces`], `idx` holding `i` or partners of `i`, `cnt <= C <= W`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
unsafe fn chunk_forces<
    T: Real,
    const D: usize,
    L: PairLaw,
    const C: usize,
    const W: usize,
    const SINGLE: bool,
    const ENERGY: bool,
>(
    inp: &Inputs<'_, T, D, L>,
    row: &[L::Coeff<T>],
    xi: [T; D],
    idx: &[u32; C],
    cnt: usize,
    start: usize,
    near: &mut [[T; D]],
    acc: &mut Acc<T, D, W>,
) {
    let (pos, species) = (inp.pos, inp.species);
    // Gather.
    let mut sep = [[T::ZERO; C]; D];
    for l in 0..C {
        // SAFETY: `idx[l]` is `i` or a partner of `i`, both below `pos.len()` (the caller's
        // guarantee).
        let xj = unsafe { pos.get_unchecked(idx[l] as usize) };
        for d in 0..D {
            sep[d][l] = xi[d] - xj[d];
        }
    }
    let c0 = row[0];
    let mut cs = [c0; C];
    if !SINGLE {
        for (l, &j) in idx[..cnt].iter().enumerate() {
            // SAFETY: `j < species.len()` (the caller's guarantee).
            cs[l] = row[unsafe { *species.get_unchecked(j as usize) } as usize];
        }
    }
    let pad2 = inp.pad * inp.pad;
    // The law, lane by lane (vectorised).
    let mut fp = [[T::ZERO; C]; D];
    for l in 0..C {
        let mut r2 = T::ZERO;
        for s in &sep {
            r2 += s[l] * s[l];
        }
        let r2 = if cnt == C || l < cnt { r2 } else { pad2 };
        let c = if SINGLE { &c0 } else { &cs[l] };
        let (fr, e) = L::force_energy(c, r2);
        for d in 0..D {
            fp[d][l] = fr * sep[d][l];
            acc.f[d][l] += fp[d][l];
        }
        if ENERGY {
            acc.e[l] += e;
            acc.w[l] += fr * r2;
        }
    }
    // Reactions.
    for (l, &j) in idx[..cnt].iter().enumerate() {
        // SAFETY: `start < j < start + near.len()` (the caller's guarantee).
        let fj = unsafe { near.get_unchecked_mut(j as usize - start) };
        for d in 0..D {
            fj[d] = fj[d] - fp[d][l];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpu::buffers::BlockForces;
    use crate::{LennardJones, LjCoeff, PairTable};
    use simkit_neighbor::BlockedHalfList;

    /// A dense random 3-species liquid, sorted and listed; returns the sorted positions,
    /// species and the list.
    fn liquid<T: Real>(n: usize, l: f64) -> (Vec<[T; 3]>, Vec<u32>, BlockedHalfList<T, 3>) {
        let mut s = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let pos: Vec<[T; 3]> = (0..n)
            .map(|_| std::array::from_fn(|_| T::from_f64(l * next())))
            .collect();
        let species: Vec<u32> = (0..n).map(|k| (k % 3) as u32).collect();
        let mut list = BlockedHalfList::new([0.0; 3], [l; 3], [true; 3], 2.8, n).unwrap();
        let order = list.sort(&pos).unwrap();
        let pos: Vec<[T; 3]> = order.iter().map(|&k| pos[k as usize]).collect();
        let species = order.iter().map(|&k| species[k as usize]).collect();
        list.build(&pos, false).unwrap();
        (pos, species, list)
    }

    fn table() -> PairTable {
        let mut t = PairTable::uniform(3, LennardJones::new(1.0, 1.0, 2.5)).unwrap();
        t.set(0, 1, LennardJones::weighted(0.7, 0.9, 1.2, 0.8, 2.2))
            .unwrap();
        t.set(1, 2, LennardJones::repulsive(1.5, 0.8, 1.3)).unwrap();
        t.set(2, 2, LennardJones::new(0.5, 1.1, 2.7)).unwrap();
        t
    }

    /// Forces (total per slot, local buffers reduced), energies and virials of every block
    /// with `kernel`.
    #[allow(clippy::type_complexity)]
    fn run<T: Real>(
        kernel: Kernel,
        pos: &[[T; 3]],
        species: &[u32],
        list: &BlockedHalfList<T, 3>,
        coeff: &[LjCoeff<T>],
        energy: bool,
    ) -> (Vec<[T; 3]>, Vec<[T; 2]>) {
        let inp = Inputs::<T, 3, LennardJones> {
            pos,
            species,
            coeff,
            n_species: 3,
            pad: T::from_f64(5.4),
        };
        let mut f = vec![[T::ZERO; 3]; pos.len()];
        let mut ew = vec![[T::ZERO; 2]; pos.len()];
        for nb in list.blocks() {
            let mut buf = BlockForces::default();
            buf.fit(nb, pos.len()).unwrap();
            // SAFETY: `buf` was fitted to `nb`, the list was built for `pos`.
            unsafe {
                block_forces(
                    kernel,
                    &inp,
                    nb,
                    &mut buf.near,
                    &mut buf.far,
                    &mut ew[nb.start()..nb.end()],
                    energy,
                )
            };
            buf.add_dense(nb.start(), nb.start(), &mut f[nb.start()..]);
            buf.add_far(0, &mut f);
        }
        (f, ew)
    }

    fn bits<T: Real>(v: &[[T; 3]]) -> Vec<u64> {
        v.iter().flatten().map(|x| x.to_f64().to_bits()).collect()
    }

    fn every_kernel_gives_the_same_bits_in<T: Real>(name: &str) {
        let (pos, species, list) = liquid::<T>(3000, 15.0);
        assert!(list.blocks().len() > 2 && list.pair_count() > 50_000);
        // Some blocks queue cross-image reactions beyond their dense span.
        assert!(list.blocks().iter().any(|nb| nb.reach() > nb.near_reach()));
        let coeff = table().coefficients::<T>(true);
        let (f0, e0) = run(Kernel::Portable, &pos, &species, &list, &coeff, true);
        // Against a plain loop over every pair with the minimum image, in f64.
        let c64 = table().coefficients::<f64>(true);
        let l = 15.0;
        let mut worst = 0.0f64;
        for (i, xi) in pos.iter().enumerate().step_by(37) {
            let mut f = [0.0f64; 3];
            for (j, xj) in pos.iter().enumerate() {
                if j == i {
                    continue;
                }
                let s: [f64; 3] = std::array::from_fn(|d| {
                    let x = xi[d].to_f64() - xj[d].to_f64();
                    x - l * (x / l).round()
                });
                let r2 = s.iter().map(|x| x * x).sum();
                let (fr, _) = LennardJones::force_energy(
                    &c64[species[i] as usize * 3 + species[j] as usize],
                    r2,
                );
                for d in 0..3 {
                    f[d] += fr * s[d];
                }
            }
            let scale = f.iter().fold(1.0f64, |m, x| m.max(x.abs()));
            for d in 0..3 {
                worst = worst.max((f[d] - f0[i][d].to_f64()).abs() / scale);
            }
        }
        let tol = if T::PRECISION == simkit_backend::Precision::F64 {
            1e-9
        } else {
            1e-2
        };
        assert!(worst < tol, "{name}: {worst:e}");
        for kernel in Kernel::available() {
            let (f, e) = run(kernel, &pos, &species, &list, &coeff, true);
            assert_eq!(bits(&f), bits(&f0), "{name} {kernel:?}");
            // Without the energies: the same forces, `ew` untouched.
            let (f, e_off) = run(kernel, &pos, &species, &list, &coeff, false);
            assert_eq!(bits(&f), bits(&f0), "{name} {kernel:?} without energies");
            assert!(e_off.iter().flatten().all(|x| x.to_f64().to_bits() == 0));
            let eb = |v: &[[T; 2]]| -> Vec<u64> {
                v.iter().flatten().map(|x| x.to_f64().to_bits()).collect()
            };
            assert_eq!(eb(&e), eb(&e0), "{name} {kernel:?}");
        }
        let test = format!("md kernel {name}");
        let have = Kernel::available();
        simkit_backend::testing::simd_exercised(&test, "avx512f", have.contains(&Kernel::Avx512));
        simkit_backend::testing::simd_exercised(&test, "avx2", have.contains(&Kernel::Avx2));
    }

    #[test]
    fn every_kernel_gives_the_same_bits_f64() {
        every_kernel_gives_the_same_bits_in::<f64>("f64");
    }

    #[test]
    fn every_kernel_gives_the_same_bits_f32() {
        every_kernel_gives_the_same_bits_in::<f32>("f32");
    }
}
