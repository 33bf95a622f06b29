//! Which engine runs an `Md`: the CPU engine of the dimension and precision, or the GPU
//! engine, and where each law's engines are compiled.

use std::any::Any;

use simkit_backend::particles::Dynamics;
use simkit_backend::{Backend, Error, Precision, Result};

use crate::cpu::CpuEngine;
use crate::engine::Engine;
#[cfg(not(test))]
use crate::{Buckingham, Mie, Morse, Wca, Yukawa};
use crate::{Config, Dim, LennardJones, PairLaw, System};

/// The engine of `system` on `backend`: a built-in law's, compiled in this crate (see
/// [`PairLaw::BUILT_IN`]), or `L`'s compiled where it is used.
///
/// Errors: those of the engines; a law that claims to be built in but is not.
pub(crate) fn engine_for<L: PairLaw>(
    system: &System<L>,
    config: &Config,
    dt: f64,
    backend: Backend<'_>,
    saved: Option<&Dynamics>,
) -> Result<Box<dyn Engine>> {
    // A constant condition: the branch not taken is not compiled for `L`.
    if const { L::BUILT_IN } {
        built_in(system, L::NAME, config, dt, backend, saved)
    } else {
        build_engine(system, config, dt, backend, saved)
    }
}

/// The engine of a system of a built-in law, compiled here once for each.
#[inline(never)]
fn built_in(
    system: &dyn Any,
    name: &str,
    config: &Config,
    dt: f64,
    backend: Backend<'_>,
    saved: Option<&Dynamics>,
) -> Result<Box<dyn Engine>> {
    macro_rules! try_law {
        ($($law:ty),*) => {$(
            if let Some(s) = system.downcast_ref::<System<$law>>() {
                return build_engine(s, config, dt, backend, saved);
            }
        )*};
    }
    // The unit tests in this crate need the Lennard-Jones engines only; every law's engines
    // are tested through the integration tests, which link the library as users do. The
    // unit-test build compiles the whole library again (measured on 2 cores: 167 s against
    // 146 s for the library itself, most of it these engines); it builds one law's of six.
    #[cfg(not(test))]
    try_law!(LennardJones, Morse, Yukawa, Mie, Wca, Buckingham);
    #[cfg(test)]
    try_law!(LennardJones);
    Err(Error::invalid(
        "PairLaw::BUILT_IN",
        format!("true for law '{name}'"),
        "is for simkit-md's own laws; leave it false for a law of your own",
    ))
}

/// The engine of `system` on `backend`, compiled for `L`.
fn build_engine<L: PairLaw>(
    system: &System<L>,
    config: &Config,
    dt: f64,
    backend: Backend<'_>,
    saved: Option<&Dynamics>,
) -> Result<Box<dyn Engine>> {
    Ok(match backend {
        Backend::Cpu => match (system.dim(), config.precision) {
            (Dim::Two, Precision::F64) => {
                Box::new(CpuEngine::<2, f64, L>::new(system, config, dt, saved)?)
            }
            (Dim::Two, Precision::F32) => {
                Box::new(CpuEngine::<2, f32, L>::new(system, config, dt, saved)?)
            }
            (Dim::Three, Precision::F64) => {
                Box::new(CpuEngine::<3, f64, L>::new(system, config, dt, saved)?)
            }
            (Dim::Three, Precision::F32) => {
                Box::new(CpuEngine::<3, f32, L>::new(system, config, dt, saved)?)
            }
        },
        #[cfg(feature = "gpu")]
        Backend::Gpu(ctx) => Box::new(crate::gpu::GpuEngine::new(ctx, system, config, dt, saved)?),
    })
}

#[cfg(test)]
mod tests {
    use serde::{Deserialize, Serialize};
    use simkit_backend::{Backend, Error, Real, Result};

    use crate::{Config, LennardJones, Md, PairLaw, PairTable, scenes};

    /// Lennard-Jones under another type that claims to be built in.
    #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
    struct Pretender(LennardJones);

    impl PairLaw for Pretender {
        type Coeff<T: Real> = <LennardJones as PairLaw>::Coeff<T>;
        type Gpu = <LennardJones as PairLaw>::Gpu;
        const NAME: &'static str = "pretender";
        const WGSL: &'static str = LennardJones::WGSL;
        const BUILT_IN: bool = true;

        fn validate(&self, pair: &str) -> Result<()> {
            self.0.validate(pair)
        }
        fn cutoff(&self) -> f64 {
            self.0.cutoff()
        }
        fn energy(&self, r: f64) -> f64 {
            self.0.energy(r)
        }
        fn coefficients<T: Real>(&self, shift: f64) -> Self::Coeff<T> {
            self.0.coefficients(shift)
        }
        fn gpu(c: &Self::Coeff<f32>) -> Self::Gpu {
            LennardJones::gpu(c)
        }
        fn force_energy<T: Real>(c: &Self::Coeff<T>, r2: T) -> (T, T) {
            LennardJones::force_energy(c, r2)
        }
    }

    #[test]
    fn a_law_that_claims_to_be_built_in_is_refused() {
        let table = PairTable::uniform(1, Pretender(LennardJones::new(1.0, 1.0, 2.5))).unwrap();
        let system = scenes::fcc_lattice([4; 3], 0.8, 1.0, table, &[0], 1).unwrap();
        let config = Config::default().with_dt(0.005);
        match Md::new(system, &config, Backend::Cpu) {
            Err(Error::InvalidParameter { name, .. }) => {
                assert_eq!(name, "PairLaw::BUILT_IN")
            }
            other => panic!("expected the BUILT_IN error, got {:?}", other.err()),
        }
        // The same table under the built-in law runs.
        let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5)).unwrap();
        let system = scenes::fcc_lattice([4; 3], 0.8, 1.0, table, &[0], 1).unwrap();
        assert!(Md::new(system, &config, Backend::Cpu).is_ok());
    }
}
