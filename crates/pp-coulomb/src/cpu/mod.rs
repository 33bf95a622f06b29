//! The CPU backend: rayon over targets, structure of arrays, double-buffered positions.

#[cfg(target_arch = "x86_64")]
mod avx512;
mod kernel;
mod pairs;
mod share;

use kernel::{CpuReal, LANES};
use pairs::Sources;
pub(crate) use share::{Alone, Ranks, Share};
#[cfg(test)]
mod tests;

use std::collections::HashMap;
use std::ops::Range;

use simkit_backend::guard::{Guarded, Halt, first_non_finite, run_guarded};
use simkit_backend::{Error, Precision, Result};

use crate::config::{Config, ForceLaw, Integrator, Mode, coincident_error};
use crate::engine::{Engine, pad_coordinate};
use crate::guard::{
    Checks, Energy, coincident_blow_up, energy_blow_up, energy_jump, jump_fails, non_finite_blow_up,
};
use crate::particles::Particles;
use crate::particles::PositionsVelocities;

/// CPU state in precision `T`. Positions are double-buffered: the force pass reads `x`, the
/// drift writes `x_next`, then the two swap, so no position is written while it is read.
/// `kept` is the state of the last blow-up check that passed. The mixed mode is a
/// `CpuEngine<f64>` whose force pass runs the f32 kernel on `split`.
///
/// Every pass takes a [`Share`]: the process computes accelerations for, and integrates,
/// only its own targets (`Share::own`), and gathers the positions of the others after each
/// drift. Outside the stepping loop, positions and velocities are complete on every
/// process; accelerations are complete for the process's own targets.
pub(crate) struct CpuEngine<T: CpuReal> {
    n: usize,
    x: [Vec<T>; 3],
    x_next: [Vec<T>; 3],
    q: Vec<T>,
    v: [Vec<T>; 3],
    qm: Vec<T>,
    mass: Vec<f64>,
    a: [Vec<T>; 3],
    law: ForceLaw,
    /// Use the AVX-512 rsqrt path.
    fast: bool,
    integrator: Integrator,
    dt: T,
    /// Whether `a` holds the accelerations at the current `x`.
    a_valid: bool,
    kept: Kept<T>,
    /// The mixed mode's f32 kernel inputs (`None` in f32 and f64).
    split: Option<Split32>,
}

/// The mixed mode's input to the f32 pair kernel, refreshed from the f64 positions before
/// each force evaluation: every coordinate `x` as `hi = x` rounded to f32 plus
/// `lo = x - hi` rounded to f32 (`hi + lo` is exact in f64 and within `2^-48 |x|` of `x`),
/// and the charges in f32. Padded as the state is (`hi` far away, `lo` and `q` zero).
struct Split32 {
    hi: [Vec<f32>; 3],
    lo: [Vec<f32>; 3],
    q: Vec<f32>,
}

impl Split32 {
    /// The buffers for `p` (the coordinates are split by [`Split32::update`]).
    fn new(p: &Particles) -> Self {
        let n = p.len();
        let far = || padded(std::iter::empty(), n, pad_coordinate::<f32>());
        let zeros = || padded(std::iter::empty(), n, 0.0f32);
        Self {
            hi: [far(), far(), far()],
            lo: [zeros(), zeros(), zeros()],
            q: padded(p.charge.iter().map(|&q| q as f32), n, 0.0),
        }
    }

    /// Splits the first `n` coordinates of `x` (O(N), before each force evaluation).
    fn update<T: CpuReal>(&mut self, x: &[Vec<T>; 3], n: usize) {
        for k in 0..3 {
            let (hi, lo) = (&mut self.hi[k][..n], &mut self.lo[k][..n]);
            for ((h, l), x) in hi.iter_mut().zip(lo.iter_mut()).zip(&x[k][..n]) {
                let x = x.to_f64();
                *h = x as f32;
                *l = (x - f64::from(*h)) as f32;
            }
        }
    }

    /// The coordinate the kernel sees, `hi + lo` (exact in f64).
    fn seen(&self, k: usize, i: usize) -> f64 {
        f64::from(self.hi[k][i]) + f64::from(self.lo[k][i])
    }

    fn sources(&self) -> Sources<'_, f32> {
        Sources {
            x: &self.hi[0],
            y: &self.hi[1],
            z: &self.hi[2],
            q: &self.q,
            lo: Some([&self.lo[0], &self.lo[1], &self.lo[2]]),
        }
    }
}

/// A copy of the state (positions, velocities, kept accelerations).
struct Kept<T> {
    x: [Vec<T>; 3],
    v: [Vec<T>; 3],
    a: [Vec<T>; 3],
    a_valid: bool,
}

/// Builds the engine for the configured precision; `accelerations` are the kept
/// accelerations of a resumed run (leapfrog), if any.
pub(crate) fn engine(
    p: &Particles,
    c: &Config,
    accelerations: Option<&[[f64; 3]]>,
) -> Box<dyn Engine> {
    match c.mode().state() {
        Precision::F32 => Box::new(CpuEngine::<f32>::new(p, c, accelerations)),
        Precision::F64 => Box::new(CpuEngine::<f64>::new(p, c, accelerations)),
    }
}

/// Why a step stopped: a coincident pair under the exact law, or a failed exchange.
enum Stop {
    Coincident(usize, usize, [f64; 3]),
    Exchange(Error),
}

impl From<Error> for Stop {
    fn from(e: Error) -> Self {
        Stop::Exchange(e)
    }
}

/// Whether the AVX-512 rsqrt path can run on this CPU.
pub(crate) fn fast_path_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    return avx512::available();
    #[cfg(not(target_arch = "x86_64"))]
    return false;
}

fn padded<T: CpuReal>(values: impl Iterator<Item = T>, n: usize, pad: T) -> Vec<T> {
    let npad = n.next_multiple_of(LANES).max(LANES);
    let mut v: Vec<T> = values.collect();
    v.resize(npad, pad);
    v
}

fn copy3<T: Copy>(to: &mut [Vec<T>; 3], from: &[Vec<T>; 3]) {
    for k in 0..3 {
        to[k].copy_from_slice(&from[k]);
    }
}

impl<T: CpuReal> CpuEngine<T> {
    /// The engine of `p` under `c`, with the kept accelerations of a resumed run, if any.
    /// `T` is the state precision of `c` (`c.mode().state()`; f64 for the mixed mode).
    pub(crate) fn new(p: &Particles, c: &Config, accelerations: Option<&[[f64; 3]]>) -> Self {
        let n = p.len();
        let coord = |k: usize| {
            padded(
                p.position.iter().map(|x| T::from_f64(x[k])),
                n,
                pad_coordinate(),
            )
        };
        let x = [coord(0), coord(1), coord(2)];
        let vel = |k: usize| p.velocity.iter().map(|v| T::from_f64(v[k])).collect();
        let v = [vel(0), vel(1), vel(2)];
        let (a, a_valid) = match accelerations {
            Some(acc) if acc.len() == n => (
                [0, 1, 2].map(|k| acc.iter().map(|a| T::from_f64(a[k])).collect()),
                true,
            ),
            _ => (
                [vec![T::ZERO; n], vec![T::ZERO; n], vec![T::ZERO; n]],
                false,
            ),
        };
        Self {
            n,
            x_next: x.clone(),
            kept: Kept {
                x: x.clone(),
                v: v.clone(),
                a: a.clone(),
                a_valid,
            },
            x,
            q: padded(p.charge.iter().map(|&q| T::from_f64(q)), n, T::ZERO),
            v,
            qm: (0..n)
                .map(|i| T::from_f64(p.charge[i] / p.mass[i]))
                .collect(),
            mass: p.mass.clone(),
            a,
            law: c.force,
            fast: c.rsqrt && fast_path_available(),
            integrator: c.integrator,
            dt: T::from_f64(c.dt),
            a_valid,
            split: (c.mode() == Mode::Mixed).then(|| Split32::new(p)),
        }
    }

    /// Under the exact law, the first two particles at the same position, if any: the
    /// same position as the kernel sees it (mixed mode: `hi + lo` of the split
    /// coordinates, refreshed by the caller, reported as the first one's f64 position).
    fn coincident(&self) -> Option<(usize, usize, [f64; 3])> {
        if self.law != ForceLaw::Exact {
            return None;
        }
        let mut seen: HashMap<[u64; 3], usize> = HashMap::with_capacity(self.n);
        for i in 0..self.n {
            // `+ 0.0` maps -0.0 to +0.0 so that equal coordinates have equal bits.
            let c = [0, 1, 2].map(|k| match &self.split {
                Some(split) => split.seen(k, i) + 0.0,
                None => self.x[k][i].to_f64() + 0.0,
            });
            if let Some(&j) = seen.get(&c.map(f64::to_bits)) {
                let at = match self.split {
                    Some(_) => [0, 1, 2].map(|k| self.x[k][j].to_f64()),
                    None => c,
                };
                return Some((j, i, at));
            }
            seen.insert(c.map(f64::to_bits), i);
        }
        None
    }

    /// Accelerations at the current positions into `a[own]`; under the exact law, the
    /// first coincident pair instead (and `a` untouched). Every process looks for the pair
    /// among all particles, so all find the same one.
    fn compute_accelerations(
        &mut self,
        own: Range<usize>,
    ) -> std::result::Result<(), (usize, usize, [f64; 3])> {
        if let Some(split) = &mut self.split {
            split.update(&self.x, self.n);
        }
        if let Some(pair) = self.coincident() {
            return Err(pair);
        }
        let [ax, ay, az] = &mut self.a;
        let first = own.start;
        let (ax, ay, az) = (&mut ax[own.clone()], &mut ay[own.clone()], &mut az[own]);
        match &self.split {
            // Mixed: the f32 kernel on the split coordinates, its f64 sums kept in `T`.
            Some(split) => kernel::field(self.law, self.fast, &split.sources(), first, ax, ay, az),
            None => {
                let s = Sources {
                    x: &self.x[0],
                    y: &self.x[1],
                    z: &self.x[2],
                    q: &self.q,
                    lo: None,
                };
                kernel::field(self.law, self.fast, &s, first, ax, ay, az);
            }
        }
        for (t, qm) in self.qm[first..first + ax.len()].iter().enumerate() {
            ax[t] = ax[t] * *qm;
            ay[t] = ay[t] * *qm;
            az[t] = az[t] * *qm;
        }
        self.a_valid = true;
        Ok(())
    }

    /// `v += a kick; x_next = x + v dt` for the targets `own`, then swap the position
    /// buffers and gather the other processes' new positions.
    fn kick_drift(&mut self, kick: T, own: Range<usize>, share: &impl Share) -> Result<()> {
        let dt = self.dt;
        for k in 0..3 {
            let (x, xn, v, a) = (&self.x[k], &mut self.x_next[k], &mut self.v[k], &self.a[k]);
            for i in own.clone() {
                v[i] += a[i] * kick;
                xn[i] = x[i] + v[i] * dt;
            }
        }
        std::mem::swap(&mut self.x, &mut self.x_next);
        self.a_valid = false;
        let [x, y, z] = &mut self.x;
        share.gather(&mut [x, y, z], self.n)
    }

    /// `v += a kick` for the targets `own`.
    fn kick(&mut self, kick: T, own: Range<usize>) {
        for k in 0..3 {
            for (v, a) in self.v[k][own.clone()]
                .iter_mut()
                .zip(&self.a[k][own.clone()])
            {
                *v += *a * kick;
            }
        }
    }

    /// One step of this process's targets, positions gathered after each drift.
    fn one_step(&mut self, share: &impl Share) -> std::result::Result<(), Stop> {
        let own = share.own(self.n);
        let coincident = |(i, j, x)| Stop::Coincident(i, j, x);
        match self.integrator {
            Integrator::SymplecticEuler => {
                self.compute_accelerations(own.clone())
                    .map_err(coincident)?;
                self.kick_drift(self.dt, own, share)?;
            }
            Integrator::Leapfrog => {
                let half = self.dt * T::from_f64(0.5);
                if !self.a_valid {
                    self.compute_accelerations(own.clone())
                        .map_err(coincident)?;
                }
                self.kick_drift(half, own.clone(), share)?;
                self.compute_accelerations(own.clone())
                    .map_err(coincident)?;
                self.kick(half, own);
            }
        }
        Ok(())
    }

    /// Advances `steps` steps with the blow-up checks of `c` (see [`Engine::step`]); the
    /// loop of both the single-process engine ([`Alone`]) and a distributed run. With
    /// replicated data every process reaches every decision from the same values, so all
    /// stop at the same step with the same error.
    pub(crate) fn run(&mut self, steps: u32, c: &mut Checks<'_>, share: &impl Share) -> Result<()> {
        let (at, every) = (c.done, c.every);
        let mut checked = Checked {
            engine: self,
            checks: c,
            share,
            at,
            kept: at,
        };
        run_guarded(&mut checked, steps, every)
    }
    /// Keeps a copy of the current state (the last state that passed a check).
    fn keep(&mut self) {
        copy3(&mut self.kept.x, &self.x);
        copy3(&mut self.kept.v, &self.v);
        copy3(&mut self.kept.a, &self.a);
        self.kept.a_valid = self.a_valid;
    }

    /// Puts the state back to the kept copy.
    fn restore(&mut self) {
        copy3(&mut self.x, &self.kept.x);
        copy3(&mut self.v, &self.kept.v);
        copy3(&mut self.a, &self.kept.a);
        self.a_valid = self.kept.a_valid;
    }

    /// The first particle with a non-finite position or velocity, as a message.
    fn first_non_finite(&self) -> Option<String> {
        let arrays = [
            ("position x", &self.x[0][..self.n]),
            ("position y", &self.x[1][..self.n]),
            ("position z", &self.x[2][..self.n]),
            ("velocity x", &self.v[0][..]),
            ("velocity y", &self.v[1][..]),
            ("velocity z", &self.v[2][..]),
        ];
        arrays
            .iter()
            .filter_map(|(name, a)| first_non_finite(a).map(|i| (i, *name, a[i])))
            .min_by_key(|(i, _, _)| *i)
            .map(|(i, name, value)| format!("particle {i}: {name} = {}", value.to_f64()))
    }

    fn to_f64(a: &[Vec<T>; 3], n: usize) -> Vec<[f64; 3]> {
        (0..n)
            .map(|i| [a[0][i].to_f64(), a[1][i].to_f64(), a[2][i].to_f64()])
            .collect()
    }

    /// Checks after reaching step `at` (last good state: step `kept`): finite state, and at
    /// interval checks the energy jump; on failure, restores the kept state. Gathers the
    /// velocities first, so the checks see the whole state.
    fn check(&mut self, at: u64, kept: u64, c: &mut Checks<'_>, share: &impl Share) -> Result<()> {
        let [vx, vy, vz] = &mut self.v;
        share.gather(&mut [vx, vy, vz], self.n)?;
        if let Some(what) = self.first_non_finite() {
            self.restore();
            return Err(non_finite_blow_up(at, kept, what));
        }
        if let (true, Some(tol)) = (c.is_interval(at), c.energy_tolerance) {
            let now = self.energy_now(share)?;
            if let Some(reference) = *c.energy_ref {
                let jump = energy_jump(reference, now);
                if jump_fails(jump, tol) {
                    let bad = (Self::to_f64(&self.x, self.n), Self::to_f64(&self.v, self.n));
                    self.restore();
                    let good = (Self::to_f64(&self.x, self.n), Self::to_f64(&self.v, self.n));
                    return Err(energy_blow_up(at, kept, c, jump, &good, &bad));
                }
            }
            *c.energy_ref = Some(now);
        }
        Ok(())
    }

    /// Kinetic and potential energy (exact law) of the current state, in f64; the
    /// potentials of the targets are computed by their processes and gathered, then summed
    /// in particle order (the bits of one process).
    pub(crate) fn energy_now(&self, share: &impl Share) -> Result<Energy> {
        let kinetic = (0..self.n)
            .map(|i| {
                let v2: f64 = (0..3).map(|k| self.v[k][i].to_f64().powi(2)).sum();
                0.5 * self.mass[i] * v2
            })
            .sum();
        let s = Sources {
            x: &self.x[0],
            y: &self.x[1],
            z: &self.x[2],
            q: &self.q,
            lo: None,
        };
        let mut phi = vec![0.0; self.n];
        kernel::exact_potentials(&s, share.own(self.n), &mut phi);
        share.gather(&mut [&mut phi], self.n)?;
        let potential = 0.5
            * phi
                .iter()
                .zip(&self.q)
                .map(|(p, q)| p * q.to_f64())
                .sum::<f64>();
        Ok(Energy { kinetic, potential })
    }

    /// The accelerations kept for the next step, if any, gathered from every process.
    pub(crate) fn kept_accelerations_with(
        &mut self,
        share: &impl Share,
    ) -> Result<Option<Vec<[f64; 3]>>> {
        if !self.a_valid {
            return Ok(None);
        }
        let [ax, ay, az] = &mut self.a;
        share.gather(&mut [ax, ay, az], self.n)?;
        Ok(Some(Self::to_f64(&self.a, self.n)))
    }

    /// Accelerations at the current positions (computed for the own targets if not kept),
    /// gathered from every process.
    pub(crate) fn accelerations_with(&mut self, share: &impl Share) -> Result<Vec<[f64; 3]>> {
        if !self.a_valid
            && let Err((i, j, at)) = self.compute_accelerations(share.own(self.n))
        {
            return Err(coincident_error(i, j, at));
        }
        let [ax, ay, az] = &mut self.a;
        share.gather(&mut [ax, ay, az], self.n)?;
        Ok(Self::to_f64(&self.a, self.n))
    }

    /// Current positions and velocities (f64; complete outside the stepping loop).
    pub(crate) fn state_now(&self) -> PositionsVelocities {
        (Self::to_f64(&self.x, self.n), Self::to_f64(&self.v, self.n))
    }

    /// Changes the time step for the following steps.
    pub(crate) fn set_time_step(&mut self, dt: f64) {
        self.dt = T::from_f64(dt);
    }
}

impl<T: CpuReal> Engine for CpuEngine<T> {
    fn step(&mut self, steps: u32, c: &mut Checks<'_>) -> Result<()> {
        // The whole loop on a pool thread: no hand-over to the pool per pass.
        simkit_backend::pool::on_pool(|| self.run(steps, c, &Alone))
    }

    fn energy(&mut self) -> Result<Energy> {
        simkit_backend::pool::on_pool(|| self.energy_now(&Alone))
    }

    fn kept_accelerations(&mut self) -> Result<Option<Vec<[f64; 3]>>> {
        self.kept_accelerations_with(&Alone)
    }

    fn state(&mut self) -> Result<PositionsVelocities> {
        Ok(self.state_now())
    }

    fn accelerations(&mut self) -> Result<Vec<[f64; 3]>> {
        self.accelerations_with(&Alone)
    }

    fn set_dt(&mut self, dt: f64) -> Result<()> {
        self.set_time_step(dt);
        Ok(())
    }

    fn name(&self) -> String {
        let path = if self.fast {
            "avx512-rsqrt"
        } else {
            "portable"
        };
        let precision = match self.split {
            Some(_) => "mixed f32/f64",
            None => std::any::type_name::<T>(),
        };
        format!("cpu-{precision} ({path})")
    }
}

/// The blow-up guard's view of a run (see [`simkit_backend::guard`]): the engine, the
/// checks of the call and the step counts of the current and of the kept state.
struct Checked<'a, 'c, T: CpuReal, S: Share> {
    engine: &'a mut CpuEngine<T>,
    checks: &'a mut Checks<'c>,
    share: &'a S,
    at: u64,
    kept: u64,
}

impl<T: CpuReal, S: Share> Guarded for Checked<'_, '_, T, S> {
    fn steps_done(&self) -> u64 {
        self.at
    }

    fn keep(&mut self) -> Result<()> {
        self.engine.keep();
        self.kept = self.at;
        Ok(())
    }

    fn advance(&mut self, n: u32) -> std::result::Result<(), Halt> {
        for s in 0..u64::from(n) {
            match self.engine.one_step(self.share) {
                Ok(()) => {}
                Err(Stop::Coincident(i, j, x)) => {
                    return Err(Halt::Error(coincident_blow_up(
                        self.at + s + 1,
                        self.kept,
                        i,
                        j,
                        x,
                    )));
                }
                Err(Stop::Exchange(e)) => return Err(Halt::Error(e)),
            }
        }
        self.at += u64::from(n);
        Ok(())
    }

    fn check(&mut self) -> std::result::Result<(), Halt> {
        let (at, kept) = (self.at, self.kept);
        Ok(self.engine.check(at, kept, self.checks, self.share)?)
    }

    fn restore(&mut self) -> Result<()> {
        self.engine.restore();
        self.at = self.kept;
        Ok(())
    }
}
