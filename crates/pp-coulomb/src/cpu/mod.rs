//! The CPU backend: rayon over targets, structure of arrays, double-buffered positions.

#[cfg(target_arch = "x86_64")]
mod avx512;
mod kernel;
mod pairs;

use kernel::{CpuReal, LANES};
use pairs::Sources;

use std::collections::HashMap;

use simkit_backend::{Precision, Result};

use crate::config::{Config, ForceLaw, Integrator, coincident_error};
use crate::engine::{Engine, PositionsVelocities, pad_coordinate};
use crate::particles::Particles;

/// CPU state in precision `T`. Positions are double-buffered: the force pass reads `x`, the
/// drift writes `x_next`, then the two swap, so no position is written while it is read.
pub(crate) struct CpuEngine<T: CpuReal> {
    n: usize,
    x: [Vec<T>; 3],
    x_next: [Vec<T>; 3],
    q: Vec<T>,
    v: [Vec<T>; 3],
    qm: Vec<T>,
    a: [Vec<T>; 3],
    law: ForceLaw,
    /// Use the AVX-512 rsqrt path.
    fast: bool,
    integrator: Integrator,
    dt: T,
    /// Whether `a` holds the accelerations at the current `x`.
    a_valid: bool,
}

/// Builds the engine for the configured precision.
pub(crate) fn engine(p: &Particles, c: &Config) -> Box<dyn Engine> {
    match c.precision {
        Precision::F32 => Box::new(CpuEngine::<f32>::new(p, c)),
        Precision::F64 => Box::new(CpuEngine::<f64>::new(p, c)),
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

impl<T: CpuReal> CpuEngine<T> {
    fn new(p: &Particles, c: &Config) -> Self {
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
        Self {
            n,
            x_next: x.clone(),
            x,
            q: padded(p.charge.iter().map(|&q| T::from_f64(q)), n, T::ZERO),
            v: [vel(0), vel(1), vel(2)],
            qm: (0..n)
                .map(|i| T::from_f64(p.charge[i] / p.mass[i]))
                .collect(),
            a: [vec![T::ZERO; n], vec![T::ZERO; n], vec![T::ZERO; n]],
            law: c.force,
            fast: c.rsqrt && fast_path_available(),
            integrator: c.integrator,
            dt: T::from_f64(c.dt),
            a_valid: false,
        }
    }

    /// Under the exact law, two particles at the same position are an error naming them.
    fn check_coincident(&self) -> Result<()> {
        if self.law != ForceLaw::Exact {
            return Ok(());
        }
        let mut seen: HashMap<[u64; 3], usize> = HashMap::with_capacity(self.n);
        for i in 0..self.n {
            // `+ 0.0` maps -0.0 to +0.0 so that equal coordinates have equal bits.
            let c = [0, 1, 2].map(|k| self.x[k][i].to_f64() + 0.0);
            if let Some(&j) = seen.get(&c.map(f64::to_bits)) {
                return Err(coincident_error(j, i, c));
            }
            seen.insert(c.map(f64::to_bits), i);
        }
        Ok(())
    }

    /// Accelerations at the current positions into `a`.
    fn compute_accelerations(&mut self) -> Result<()> {
        self.check_coincident()?;
        let s = Sources {
            x: &self.x[0],
            y: &self.x[1],
            z: &self.x[2],
            q: &self.q,
        };
        let [ax, ay, az] = &mut self.a;
        kernel::field(self.law, self.fast, &s, ax, ay, az);
        for i in 0..self.n {
            let qm = self.qm[i];
            ax[i] = ax[i] * qm;
            ay[i] = ay[i] * qm;
            az[i] = az[i] * qm;
        }
        self.a_valid = true;
        Ok(())
    }

    /// `v += a kick; x_next = x + v dt`, then swap the position buffers.
    fn kick_drift(&mut self, kick: T) {
        let dt = self.dt;
        for k in 0..3 {
            let (x, xn, v, a) = (&self.x[k], &mut self.x_next[k], &mut self.v[k], &self.a[k]);
            for i in 0..self.n {
                v[i] += a[i] * kick;
                xn[i] = x[i] + v[i] * dt;
            }
        }
        std::mem::swap(&mut self.x, &mut self.x_next);
        self.a_valid = false;
    }

    fn kick(&mut self, kick: T) {
        for k in 0..3 {
            for (v, a) in self.v[k].iter_mut().zip(&self.a[k]) {
                *v += *a * kick;
            }
        }
    }

    fn to_f64(a: &[Vec<T>; 3], n: usize) -> Vec<[f64; 3]> {
        (0..n)
            .map(|i| [a[0][i].to_f64(), a[1][i].to_f64(), a[2][i].to_f64()])
            .collect()
    }
}

impl<T: CpuReal> Engine for CpuEngine<T> {
    fn step(&mut self, steps: u32) -> Result<()> {
        let half = self.dt * T::from_f64(0.5);
        // The whole loop on a pool thread: no hand-over to the pool per pass.
        simkit_backend::pool::on_pool(|| {
            for _ in 0..steps {
                match self.integrator {
                    Integrator::SymplecticEuler => {
                        self.compute_accelerations()?;
                        self.kick_drift(self.dt);
                    }
                    Integrator::Leapfrog => {
                        if !self.a_valid {
                            self.compute_accelerations()?;
                        }
                        self.kick_drift(half);
                        self.compute_accelerations()?;
                        self.kick(half);
                    }
                }
            }
            Ok(())
        })
    }

    fn state(&mut self) -> Result<PositionsVelocities> {
        Ok((Self::to_f64(&self.x, self.n), Self::to_f64(&self.v, self.n)))
    }

    fn accelerations(&mut self) -> Result<Vec<[f64; 3]>> {
        if !self.a_valid {
            self.compute_accelerations()?;
        }
        Ok(Self::to_f64(&self.a, self.n))
    }

    fn set_dt(&mut self, dt: f64) -> Result<()> {
        self.dt = T::from_f64(dt);
        Ok(())
    }

    fn name(&self) -> String {
        let path = if self.fast {
            "avx512-rsqrt"
        } else {
            "portable"
        };
        format!("cpu-{} ({path})", std::any::type_name::<T>())
    }
}
