//! Which engine runs a `Dem`: the CPU engine of the dimension and precision, or the GPU
//! engine, and where each law's engines are compiled.

use std::any::Any;

use simkit_backend::particles::Dynamics;
use simkit_backend::{Backend, Error, Precision, Result};

use crate::cpu::CpuEngine;
use crate::engine::Engine;
use crate::prepared::Prepared;
use crate::{ContactLaw, Material};
#[cfg(not(test))]
use crate::{HertzMindlin, LinearHistory};

/// The engine of a prepared scene on `backend`: the built-in law's, compiled in this crate
/// (see [`ContactLaw::BUILT_IN`]), or `L`'s compiled where it is used.
///
/// Errors: those of the engines; a law that claims to be built in but is not.
pub(crate) fn engine_for<L: ContactLaw>(
    prep: Prepared<L>,
    precision: Precision,
    backend: Backend<'_>,
    saved: Option<&Dynamics>,
) -> Result<Box<dyn Engine<L>>> {
    // A constant condition: the branch not taken is not compiled for `L`.
    if const { L::BUILT_IN } {
        let engine = built_in(Box::new(prep), L::NAME, precision, backend, saved)?;
        // `L` is the built-in law whose engine `built_in` made.
        engine
            .downcast::<Box<dyn Engine<L>>>()
            .map(|e| *e)
            .map_err(|_| not_built_in(L::NAME))
    } else {
        build_engine(prep, precision, backend, saved)
    }
}

/// The engine (as `Box<dyn Engine<L>>`) of a prepared scene of a built-in law `L`
/// ([`Material`], [`HertzMindlin`] or [`LinearHistory`]), compiled here once.
#[inline(never)]
fn built_in(
    prep: Box<dyn Any>,
    name: &str,
    precision: Precision,
    backend: Backend<'_>,
    saved: Option<&Dynamics>,
) -> Result<Box<dyn Any>> {
    let prep = match prep.downcast::<Prepared<Material>>() {
        Ok(prep) => return Ok(Box::new(build_engine(*prep, precision, backend, saved)?)),
        Err(prep) => prep,
    };
    // The unit tests in this crate need the linear law's engines only (a test of the
    // Hertz–Mindlin CPU engine names its type itself); every law's engines are tested
    // through the integration tests, which link the library as users do. The unit-test
    // build compiles the whole library again, and these engines are most of it.
    #[cfg(test)]
    drop(prep);
    #[cfg(not(test))]
    {
        let prep = match prep.downcast::<Prepared<HertzMindlin>>() {
            Ok(prep) => return Ok(Box::new(build_engine(*prep, precision, backend, saved)?)),
            Err(prep) => prep,
        };
        if let Ok(prep) = prep.downcast::<Prepared<LinearHistory>>() {
            return Ok(Box::new(build_engine(*prep, precision, backend, saved)?));
        }
    }
    Err(not_built_in(name))
}

/// The error of a law that sets [`ContactLaw::BUILT_IN`] but is not simkit-dem's.
fn not_built_in(name: &str) -> Error {
    Error::invalid(
        "ContactLaw::BUILT_IN",
        format!("true for law '{name}'"),
        "is for simkit-dem's own law; leave it false for a law of your own",
    )
}

/// The engine of a prepared scene on `backend`, compiled for `L`.
fn build_engine<L: ContactLaw>(
    prep: Prepared<L>,
    precision: Precision,
    backend: Backend<'_>,
    saved: Option<&Dynamics>,
) -> Result<Box<dyn Engine<L>>> {
    Ok(match backend {
        Backend::Cpu => match (prep.axes, precision) {
            (2, Precision::F64) => Box::new(CpuEngine::<2, f64, L>::new(prep, saved)?),
            (2, Precision::F32) => Box::new(CpuEngine::<2, f32, L>::new(prep, saved)?),
            (_, Precision::F64) => Box::new(CpuEngine::<3, f64, L>::new(prep, saved)?),
            (_, Precision::F32) => Box::new(CpuEngine::<3, f32, L>::new(prep, saved)?),
        },
        #[cfg(feature = "gpu")]
        Backend::Gpu(ctx) => Box::new(crate::gpu::GpuEngine::new(ctx, prep, saved)?),
    })
}

#[cfg(test)]
mod tests {
    use serde::{Deserialize, Serialize};
    use simkit_backend::{Backend, Error, Real, Result};

    use crate::{Config, Contact, ContactForce, ContactLaw, Dem, Dim, Material, Particle, Scene};

    /// The linear law under another type that claims to be built in.
    #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
    struct Pretender(Material);

    impl ContactLaw for Pretender {
        type Coeff<T: Real> = <Material as ContactLaw>::Coeff<T>;
        type Gpu = <Material as ContactLaw>::Gpu;
        const NAME: &'static str = "pretender";
        const WGSL: &'static str = Material::WGSL;
        const BUILT_IN: bool = true;

        fn validate(&self, what: &str) -> Result<()> {
            self.0.validate(what)
        }
        fn coefficients<T: Real>(&self) -> Self::Coeff<T> {
            self.0.coefficients()
        }
        fn gpu(c: &Self::Coeff<f32>) -> Self::Gpu {
            Material::gpu(c)
        }
        fn scales(&self) -> Vec<(&'static str, f64, bool)> {
            self.0.scales()
        }
        fn has_friction(&self) -> bool {
            self.0.has_friction()
        }
        fn contact_time(&self, m_ij: f64, r_eff: f64) -> f64 {
            self.0.contact_time(m_ij, r_eff)
        }
        fn safe_dt(&self, m_ij: f64, r_eff: f64) -> f64 {
            self.0.safe_dt(m_ij, r_eff)
        }
        fn force<T: Real, const D: usize, const FRICTION: bool>(
            c: &Self::Coeff<T>,
            contact: &Contact<T, D>,
            history: &mut [T],
        ) -> ContactForce<T, D> {
            Material::force::<T, D, FRICTION>(c, contact, history)
        }
        fn elastic_energy<T: Real>(c: &Self::Coeff<T>, m_ij: T, r_eff: T, delta: T) -> T {
            Material::elastic_energy(c, m_ij, r_eff, delta)
        }
    }

    fn two_discs<L: ContactLaw>(law: L) -> Scene<L> {
        let mut scene = Scene::new(Dim::Two, [0.0; 3], [4.0, 4.0, 0.0], law).unwrap();
        scene
            .add_particle(Particle::new([1.0, 2.0, 0.0], 0.5, 1.0).with_velocity([1.0, 0.0, 0.0]))
            .unwrap();
        scene
            .add_particle(Particle::new([2.5, 2.0, 0.0], 0.5, 1.0))
            .unwrap();
        scene
    }

    #[test]
    fn a_law_that_claims_to_be_built_in_is_refused() {
        let m = Material::new(0.9, 0.05);
        match Dem::new(two_discs(Pretender(m)), &Config::default(), Backend::Cpu) {
            Err(Error::InvalidParameter { name, .. }) => {
                assert_eq!(name, "ContactLaw::BUILT_IN")
            }
            other => panic!("expected the BUILT_IN error, got {:?}", other.err()),
        }
        // The same scene under the built-in law runs.
        assert!(Dem::new(two_discs(m), &Config::default(), Backend::Cpu).is_ok());
    }
}
