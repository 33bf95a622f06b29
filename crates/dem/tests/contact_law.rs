//! A contact law defined outside the crate (`ContactLaw`): a purely elastic linear spring,
//! `F_n = m_ij omega^2 delta`, no damping, no friction. A head-on collision of two equal
//! discs then reverses their velocities (restitution 1) after a contact of `pi / omega`, on
//! the CPU in both precisions and on the GPU; the law's WGSL twin matches its Rust function.
//! Measured: velocities reversed to 2e-6 (f64) and 8e-6 (f32, CPU and lavapipe).

use serde::{Deserialize, Serialize};
use simkit_backend::testing::backends;
use simkit_backend::{Error, Precision, Real, Result, Simulation};
use simkit_dem::{Config, Contact, ContactForce, ContactLaw, Dem, Dim, Particle, Scene};

/// `F_n = m_ij omega^2 delta` along the normal: a frictionless elastic contact.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
struct Elastic {
    /// Natural frequency of the contact.
    omega: f64,
}

/// `omega^2`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct ElasticCoeff<T> {
    omega2: T,
}

impl ContactLaw for Elastic {
    type Coeff<T: Real> = ElasticCoeff<T>;
    type Gpu = [f32; 1];
    const NAME: &'static str = "elastic";
    const WGSL: &'static str = "
struct DemCoeff { omega2: f32 }
fn dem_contact_force(c: DemCoeff, k: DemContact, h: ptr<function, DemHistory>, friction: bool) -> DemForce {
    return DemForce((k.m_ij * (c.omega2 * k.delta)) * k.n, vec3<f32>(0.0));
}";

    fn validate(&self, what: &str) -> Result<()> {
        if self.omega.is_finite() && self.omega > 0.0 {
            Ok(())
        } else {
            Err(Error::invalid(
                format!("{what}: omega"),
                self.omega,
                "must be finite and > 0",
            ))
        }
    }

    fn coefficients<T: Real>(&self) -> ElasticCoeff<T> {
        ElasticCoeff {
            omega2: T::from_f64(self.omega * self.omega),
        }
    }

    fn gpu(c: &ElasticCoeff<f32>) -> [f32; 1] {
        [c.omega2]
    }

    fn scales(&self) -> Vec<(&'static str, f64, bool)> {
        vec![("omega^2", self.omega * self.omega, true)]
    }

    fn has_friction(&self) -> bool {
        false
    }

    fn contact_time(&self, _m_ij: f64, _r_eff: f64) -> f64 {
        std::f64::consts::PI / self.omega
    }

    fn safe_dt(&self, m_ij: f64, r_eff: f64) -> f64 {
        (self.contact_time(m_ij, r_eff) / 5.0).min(1.0 / self.omega)
    }

    fn force<T: Real, const D: usize, const FRICTION: bool>(
        c: &ElasticCoeff<T>,
        k: &Contact<T, D>,
        _history: &mut [T],
    ) -> ContactForce<T, D> {
        let f = k.m_ij * (c.omega2 * k.delta);
        ContactForce::force(k.n.map(|x| f * x))
    }

    fn elastic_energy<T: Real>(c: &ElasticCoeff<T>, m_ij: T, _r_eff: T, delta: T) -> T {
        T::from_f64(0.5) * m_ij * c.omega2 * delta * delta
    }
}

/// Two equal discs (radius 0.5, mass 1) 0.5 apart, approaching at speed 1 each.
fn head_on() -> Result<Scene<Elastic>> {
    let mut scene = Scene::new(Dim::Two, [0.0; 3], [6.0, 4.0, 0.0], Elastic { omega: 40.0 })?;
    scene.add_particle(Particle::new([2.25, 2.0, 0.0], 0.5, 1.0).with_velocity([1.0, 0.0, 0.0]))?;
    scene
        .add_particle(Particle::new([3.75, 2.0, 0.0], 0.5, 1.0).with_velocity([-1.0, 0.0, 0.0]))?;
    Ok(scene)
}

#[test]
fn a_user_contact_law_bounces_elastically_on_every_backend() -> Result<()> {
    let scene = head_on()?;
    for backend in backends("a_user_contact_law_bounces_elastically_on_every_backend") {
        let precisions = if backend.is_gpu() {
            vec![Precision::F32]
        } else {
            vec![Precision::F64, Precision::F32]
        };
        for precision in precisions {
            let config = Config {
                precision,
                ..Config::default()
            };
            let mut dem = Dem::new(scene.clone(), &config, backend)?;
            // dt = t_c / 30; the gap of 0.5 closes at t = 0.25, the contact lasts pi / 40.
            let dt = dem.dt();
            assert!((dt - std::f64::consts::PI / 40.0 / 30.0).abs() < 1e-15);
            let mut touched = None;
            let mut released = None;
            let mut t = 0.0;
            while t < 0.6 {
                dem.step(1)?;
                t += dt;
                let v = dem.state()?.velocities;
                if touched.is_none() && v[0][0] < 1.0 {
                    touched = Some(t);
                }
                if touched.is_some() && released.is_none() && v[0][0] <= -1.0 + 1e-3 {
                    released = Some(t);
                }
            }
            let v = dem.state()?.velocities;
            let duration = released.unwrap() - touched.unwrap();
            eprintln!(
                "{} {precision:?}: v = {:.6} / {:.6} after the contact, which lasted {duration:.4} \
                 (pi / omega = {:.4})",
                dem.backend_name(),
                v[0][0],
                v[1][0],
                std::f64::consts::PI / 40.0
            );
            // Restitution 1 to the integrator's error; the bodies swap velocities.
            assert!(
                (v[0][0] + 1.0).abs() < 2e-3 && (v[1][0] - 1.0).abs() < 2e-3,
                "{v:?}"
            );
            assert!((duration - std::f64::consts::PI / 40.0).abs() < 3.0 * dt);
            // The energy is all kinetic again.
            let d = dem.diagnostics()?;
            assert!((d.kinetic - 1.0).abs() < 4e-3 && d.elastic == 0.0, "{d:?}");
        }
    }
    Ok(())
}

#[cfg(feature = "gpu")]
#[test]
fn the_user_law_wgsl_matches_its_rust_function() {
    use simkit_backend::testing::{eval_wgsl, gpu_or_skip};
    let Some(ctx) = gpu_or_skip("the_user_law_wgsl_matches_its_rust_function") else {
        return;
    };
    let law = Elastic { omega: 40.0 };
    let c = law.coefficients::<f32>();
    let cases: Vec<[f32; 8]> = (1..=50)
        .map(|k| {
            let delta = 1e-3 * k as f32;
            let m = 0.1 * k as f32;
            let a = 0.13 * k as f32;
            [delta, m, a.cos(), a.sin(), 0.0, 0.0, 0.0, 0.0]
        })
        .collect();
    let gpu: Vec<[f32; 4]> = eval_wgsl(
        &ctx,
        &[
            "struct Case { a: vec4<f32>, b: vec4<f32> }",
            simkit_dem::LAW_PRELUDE_WGSL,
            Elastic::WGSL,
            // The law's force without a history (a pointer argument needs a variable).
            "fn force_of(c: DemCoeff, k: DemContact) -> vec3<f32> {
                var h: DemHistory;
                return dem_contact_force(c, k, &h, false).force;
            }",
        ],
        "Case",
        "vec4<f32>",
        &format!(
            "vec4<f32>(force_of(DemCoeff({:?}), DemContact(vec3<f32>(x.a.z, x.a.w, 0.0), \
             x.a.x, vec3<f32>(0.0), 0.0, vec3<f32>(0.0), x.a.y, 0.25, 1e-3)), 0.0)",
            c.omega2
        ),
        &cases,
    )
    .unwrap();
    for (x, g) in cases.iter().zip(&gpu) {
        let contact = Contact {
            m_ij: x[1],
            delta: x[0],
            n: [x[2], x[3], 0.0],
            v_rel: [0.0; 3],
            v_n: 0.0,
            r_eff: 0.25,
            w_rel: [0.0; 3],
            dt: 1e-3,
        };
        let f = Elastic::force::<f32, 3, false>(&c, &contact, &mut []).force;
        for d in 0..3 {
            let scale = (x[1] * c.omega2 * x[0]).abs();
            assert!(
                (g[d] - f[d]).abs() <= 4.0 * f32::EPSILON * scale,
                "{x:?}: {g:?} vs {f:?}"
            );
        }
    }
}
