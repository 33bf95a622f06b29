//! Law-level checks: the WGSL contact laws (`shaders/contact.wgsl`,
//! `shaders/linear_history.wgsl`, `shaders/hertz_mindlin.wgsl` with the springs of
//! `shaders/spin.wgsl`) and wall geometry (`shaders/walls.wgsl`) that the GPU force kernel
//! calls, evaluated on the GPU for a sample of inputs, against their Rust twins
//! (`simkit_dem::{normal_force, friction_force, reduced_mass, plane_overlap,
//! cylinder_overlap, cylinder_surface_velocity, wall_motion}`, `ContactLaw::force` of
//! `Material`, `LinearHistory` and `HertzMindlin`) at `f32`.
//!
//! Tolerance of the arithmetic laws: 8 f32 ulps (`8 * 2^-23`) relative to the size of the
//! terms that are summed (not to the result, which may cancel). Both sides run the same
//! operation sequence in `f32`; WGSL allows 2.5 ulps for a division, inherits the
//! `inverseSqrt` accuracy for `sqrt`, and lets the compiler contract `a * b + c` into an
//! FMA, so a few ulps per chain of 3 to 5 operations separate conforming implementations.
//! The wall motion (`cos`, `sin`) is compared with the exact `f64` value within
//! `1e-5` of the amplitude: WGSL itself only requires an absolute error of `2^-11` for
//! `cos`/`sin` on `[-pi, pi]`; the tolerance is far tighter and still leaves room for the
//! hardware approximations GPUs use beyond that range.
#![cfg(feature = "gpu")]

use bytemuck::{Pod, Zeroable};

use simkit_backend::rng::rng_uniform;
use simkit_backend::testing::{eval_wgsl, gpu_or_skip};
use simkit_dem::{
    Contact, ContactCoefficients, ContactLaw, HertzMindlin, LAW_PRELUDE_WGSL, LinearHistory,
    Material, Solid, contact_point_velocity, cylinder_overlap, cylinder_surface_velocity,
    friction_force, normal_force, plane_overlap, reduced_mass, wall_motion,
};

const CONTACT_WGSL: &str = simkit_backend::wgsl!("contact.wgsl");
const MASS_WGSL: &str = simkit_backend::wgsl!("mass.wgsl");
const WALLS_WGSL: &str = simkit_backend::wgsl!("walls.wgsl");

/// 8 f32 ulps at 1.
const ULPS8: f64 = 8.0 * f32::EPSILON as f64;

/// Input records of the WGSL harness (vec4 members only: no padding rules to mirror).
const CASES_WGSL: &str = "
struct Case2 { a: vec4<f32>, b: vec4<f32> }
struct Case4 { a: vec4<f32>, b: vec4<f32>, c: vec4<f32>, d: vec4<f32> }
";

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct Case2 {
    a: [f32; 4],
    b: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct Case4 {
    a: [f32; 4],
    b: [f32; 4],
    c: [f32; 4],
    d: [f32; 4],
}

/// Coefficients of a soft frictional material and of a stiff, strongly damped one, in f32.
fn materials() -> Vec<ContactCoefficients<f32>> {
    [
        Material::new(0.9, 0.05).with_friction(0.5, 20.0),
        Material::new(0.3, 1e-3).with_friction(0.2, 2000.0),
        Material::new(0.99, 0.2).with_friction(1.0, 5.0),
    ]
    .iter()
    .map(|m| ContactCoefficients::new(m).to_real::<f32>())
    .collect()
}

fn vec4(c: &ContactCoefficients<f32>) -> [f32; 4] {
    [c.kappa, c.two_b, c.mu_s, c.mu_k]
}

/// Largest `|gpu - cpu| / scale` over the samples, asserting each is within `tol`.
fn check(what: &str, gpu: &[f32], cpu: &[f32], scale: &[f64], tol: f64) -> f64 {
    assert_eq!(gpu.len(), cpu.len());
    let mut worst = 0.0f64;
    for (k, ((&g, &c), &s)) in gpu.iter().zip(cpu).zip(scale).enumerate() {
        let err = (f64::from(g) - f64::from(c)).abs() / s.max(f64::MIN_POSITIVE);
        assert!(
            err <= tol,
            "{what} sample {k}: gpu {g:e} cpu {c:e} (error {err:e} of scale {s:e} > {tol:e})"
        );
        worst = worst.max(err);
    }
    println!(
        "{what}: {} samples, max error {worst:.3e} of scale",
        gpu.len()
    );
    worst
}

#[test]
fn normal_force_and_reduced_mass_match_their_wgsl_twins() {
    let Some(ctx) = gpu_or_skip("normal_force_and_reduced_mass_match_their_wgsl_twins") else {
        return;
    };
    // Zero, grazing (1e-7 of the radius), moderate and large overlaps; approaching,
    // resting and separating normal velocities; equal and unequal masses.
    let overlaps = [0.0f32, 5e-8, 1e-4, 0.01, 0.05, 0.3];
    let velocities = [-3.0f32, -0.2, 0.0, 1e-6, 0.2, 3.0];
    let masses = [(1.0f32, 1.0f32), (1.0, 8.0), (0.05, 2.5)];
    let mut cases = Vec::new();
    for c in materials() {
        for &delta in &overlaps {
            for &vn in &velocities {
                for &(mi, mj) in &masses {
                    cases.push(Case2 {
                        a: vec4(&c),
                        b: [mi, mj, delta, vn],
                    });
                }
            }
        }
    }
    let sources = [CASES_WGSL, MASS_WGSL, LAW_PRELUDE_WGSL, CONTACT_WGSL];
    let gpu_m: Vec<f32> = eval_wgsl(
        &ctx,
        &sources,
        "Case2",
        "f32",
        "dem_reduced_mass(x.b.x, x.b.y)",
        &cases,
    )
    .unwrap();
    let cpu_m: Vec<f32> = cases.iter().map(|k| reduced_mass(k.b[0], k.b[1])).collect();
    let scale_m: Vec<f64> = cpu_m.iter().map(|&m| f64::from(m)).collect();
    check("reduced mass", &gpu_m, &cpu_m, &scale_m, ULPS8);

    let gpu_f: Vec<f32> = eval_wgsl(
        &ctx,
        &sources,
        "Case2",
        "f32",
        "dem_normal_force(DemCoeff(x.a.x, x.a.y, x.a.z, x.a.w), dem_reduced_mass(x.b.x, x.b.y), x.b.z, x.b.w)",
        &cases,
    )
    .unwrap();
    let mut cpu_f = Vec::new();
    let mut scale_f = Vec::new();
    for k in &cases {
        let c = ContactCoefficients {
            kappa: k.a[0],
            two_b: k.a[1],
            mu_s: k.a[2],
            mu_k: k.a[3],
        };
        let m = reduced_mass(k.b[0], k.b[1]);
        cpu_f.push(normal_force(&c, m, k.b[2], k.b[3]));
        let terms = (f64::from(c.kappa) * f64::from(k.b[2])).abs()
            + (f64::from(c.two_b) * f64::from(k.b[3])).abs();
        scale_f.push(f64::from(m) * terms);
    }
    // Zero overlap at rest is exactly zero on both sides.
    for ((k, &g), &c) in cases.iter().zip(&gpu_f).zip(&cpu_f) {
        if k.b[2] == 0.0 && k.b[3] == 0.0 {
            assert_eq!((g, c), (0.0, 0.0));
        }
    }
    check("normal force", &gpu_f, &cpu_f, &scale_f, ULPS8);
}

#[test]
fn friction_force_matches_its_wgsl_twin() {
    let Some(ctx) = gpu_or_skip("friction_force_matches_its_wgsl_twin") else {
        return;
    };
    let mut cases = Vec::new();
    let mut k = 0u32;
    for c in materials() {
        for &f_n in &[0.0f32, 1e-3, 0.7, 40.0, -2.0] {
            for &slip in &[0.0f32, 1e-5, 1e-3, 0.05, 1.0, 20.0] {
                for &m_ij in &[0.5f32, 3.0] {
                    k += 1;
                    let u = |a: u32| rng_uniform(11, a, k) - 0.5;
                    // A unit normal in a pseudo-random direction (exactly axis-aligned for
                    // the first sample of each set, so that zero slip is exactly zero).
                    let n = if slip == 0.0 {
                        [0.0, 0.0, 1.0]
                    } else {
                        let d = [u(0), u(1), u(2) + 0.7];
                        let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                        [d[0] / l, d[1] / l, d[2] / l]
                    };
                    // A tangential direction: the normal crossed with a fixed axis.
                    let t = [n[1], -n[0], 0.0];
                    let tl = (t[0] * t[0] + t[1] * t[1]).sqrt().max(1e-30);
                    let v_n = 1.5 * u(3);
                    let v_rel: [f32; 3] = std::array::from_fn(|d| v_n * n[d] + slip * t[d] / tl);
                    cases.push(Case4 {
                        a: vec4(&c),
                        b: [n[0], n[1], n[2], v_n],
                        c: [v_rel[0], v_rel[1], v_rel[2], f_n],
                        d: [m_ij, 0.0, 0.0, 0.0],
                    });
                }
            }
        }
    }
    let gpu: Vec<[f32; 4]> = eval_wgsl(
        &ctx,
        &[CASES_WGSL, LAW_PRELUDE_WGSL, CONTACT_WGSL],
        "Case4",
        "vec4<f32>",
        "vec4<f32>(dem_friction_force(DemCoeff(x.a.x, x.a.y, x.a.z, x.a.w), x.b.xyz, x.b.w, x.c.xyz, x.c.w, x.d.x), 0.0)",
        &cases,
    )
    .unwrap();
    let (mut g, mut r, mut scale) = (Vec::new(), Vec::new(), Vec::new());
    let (mut capped, mut viscous, mut zero) = (0, 0, 0);
    for (k, out) in cases.iter().zip(&gpu) {
        let c = ContactCoefficients {
            kappa: k.a[0],
            two_b: k.a[1],
            mu_s: k.a[2],
            mu_k: k.a[3],
        };
        let n = [k.b[0], k.b[1], k.b[2]];
        let v_rel = [k.c[0], k.c[1], k.c[2]];
        let (v_n, f_n, m_ij) = (k.b[3], k.c[3], k.d[0]);
        let ft = friction_force(&c, &n, v_n, &v_rel, f_n, m_ij).unwrap_or([0.0; 3]);
        // Which branch of min(mu_s |F_n|, mu_k m |v_t|) applies (in f64).
        let vt: Vec<f64> = (0..3)
            .map(|d| f64::from(v_rel[d]) - f64::from(v_n) * f64::from(n[d]))
            .collect();
        let vtn = vt.iter().map(|x| x * x).sum::<f64>().sqrt();
        let coulomb = f64::from(c.mu_s) * f64::from(f_n).abs();
        let visc = f64::from(c.mu_k) * f64::from(m_ij) * vtn;
        if vtn == 0.0 || coulomb.min(visc) == 0.0 {
            zero += 1;
        } else if coulomb <= visc {
            capped += 1;
        } else {
            viscous += 1;
        }
        // Round-off of v_t = v_rel - v_n n is relative to |v_rel|: scale by |F_t| |v_rel| / |v_t|.
        let vr = v_rel
            .iter()
            .map(|&x| f64::from(x).powi(2))
            .sum::<f64>()
            .sqrt();
        let s = if vtn > 0.0 {
            coulomb.min(visc) * vr / vtn
        } else {
            0.0
        };
        for d in 0..3 {
            g.push(out[d]);
            r.push(ft[d]);
            scale.push(s);
        }
        if vtn == 0.0 {
            assert_eq!(&out[..3], &[0.0; 3], "zero slip must give zero friction");
        }
    }
    assert!(
        capped > 20 && viscous > 20 && zero > 10,
        "sample covers the Coulomb cap ({capped}), the viscous branch ({viscous}) and zero ({zero})"
    );
    check("friction force", &g, &r, &scale, ULPS8);
}

#[test]
fn wall_geometry_matches_its_wgsl_twin() {
    let Some(ctx) = gpu_or_skip("wall_geometry_matches_its_wgsl_twin") else {
        return;
    };
    // Plane walls: a floor, a tilted wall and a lid, particles touching (deep, grazing),
    // just clear and far, with the wall at rest or lifted.
    let normals = [[0.0f32, 0.0, 1.0], [0.6, 0.0, 0.8], [0.0, -1.0, 0.0]];
    let mut planes = Vec::new();
    for (w, n) in normals.iter().enumerate() {
        let offset = [0.0f32, 1.5, -8.0][w];
        for &r in &[0.5f32, 0.03] {
            for &gap in &[-0.2f32, -1e-6, 0.0, 1e-6, 0.4] {
                for &lift in &[0.0f32, 0.05, -0.05] {
                    for k in 0..3u32 {
                        // A point at height r + gap above the (lifted) plane, shifted along it.
                        let s = [1.0 + k as f32, 2.0 - 0.5 * k as f32, 0.3 * k as f32];
                        let along = s[0] * n[0] + s[1] * n[1] + s[2] * n[2];
                        let h = offset + lift + r + gap;
                        let x: [f32; 3] = std::array::from_fn(|d| s[d] + (h - along) * n[d]);
                        planes.push(Case4 {
                            a: [n[0], n[1], n[2], offset],
                            b: [x[0], x[1], x[2], r],
                            c: [lift, 0.0, 0.0, 0.0],
                            d: [0.0; 4],
                        });
                    }
                }
            }
        }
    }
    let gpu: Vec<f32> = eval_wgsl(
        &ctx,
        &[CASES_WGSL, WALLS_WGSL],
        "Case4",
        "f32",
        "dem_plane_overlap(x.a.xyz, x.a.w, x.c.x, x.b.xyz, x.b.w)",
        &planes,
    )
    .unwrap();
    let mut cpu = Vec::new();
    let mut scale = Vec::new();
    for p in &planes {
        let n = [p.a[0], p.a[1], p.a[2]];
        let x = [p.b[0], p.b[1], p.b[2]];
        cpu.push(plane_overlap(&n, p.a[3], p.c[0], &x, p.b[3]));
        let dot: f64 = (0..3).map(|d| f64::from(n[d] * x[d]).abs()).sum();
        scale.push(dot + f64::from(p.a[3].abs() + p.c[0].abs() + p.b[3]));
    }
    check("plane overlap", &gpu, &cpu, &scale, ULPS8);
    // The 2D form (the CPU's `D = 2` path) is the same law.
    for p in planes.iter().filter(|p| p.a[2] == 0.0) {
        let three = plane_overlap(
            &[p.a[0], p.a[1], 0.0],
            p.a[3],
            p.c[0],
            &[p.b[0], p.b[1], p.b[2]],
            p.b[3],
        );
        let two = plane_overlap(&[p.a[0], p.a[1]], p.a[3], p.c[0], &[p.b[0], p.b[1]], p.b[3]);
        assert_eq!(two, three);
    }

    // Cylinder walls: particles deep in the wall, grazing, just inside, near and on the axis.
    let mut cyl = Vec::new();
    for &(center, radius) in &[
        ([4.0f32, 4.0], 3.5f32),
        ([0.0, 0.0], 1.0),
        ([-2.0, 5.0], 10.0),
    ] {
        for &r in &[0.3f32, 0.01] {
            for &rho in &[
                0.0f32,
                1e-3,
                0.5 * radius,
                radius - r - 0.1,
                radius - r,
                radius - r + 1e-6,
                radius - r + 0.2,
            ] {
                for k in 0..4u32 {
                    let phi = 0.4 + 1.7 * k as f32;
                    let x = [center[0] + rho * phi.cos(), center[1] + rho * phi.sin()];
                    cyl.push(Case2 {
                        a: [center[0], center[1], radius, r],
                        b: [x[0], x[1], 0.0, 0.0],
                    });
                }
            }
        }
    }
    let gpu: Vec<[f32; 4]> = eval_wgsl(
        &ctx,
        &[CASES_WGSL, WALLS_WGSL],
        "Case2",
        "vec4<f32>",
        "vec4<f32>(dem_cylinder_overlap(x.a.xy, x.a.z, x.b.xy, x.a.w), 0.0)",
        &cyl,
    )
    .unwrap();
    let (mut gd, mut cd, mut sd, mut gn, mut cn, mut sn) =
        (vec![], vec![], vec![], vec![], vec![], vec![]);
    for (c, out) in cyl.iter().zip(&gpu) {
        let (delta, n) = cylinder_overlap([c.a[0], c.a[1]], c.a[2], [c.b[0], c.b[1]], c.a[3]);
        let rho = f64::from(c.b[0] - c.a[0]).hypot(f64::from(c.b[1] - c.a[1]));
        if rho == 0.0 {
            assert_eq!(*out, [0.0; 4], "a particle on the axis touches nothing");
            assert_eq!((delta, n), (0.0, [0.0; 2]));
            continue;
        }
        gd.push(out[2]);
        cd.push(delta);
        sd.push(f64::from(c.a[0].abs() + c.a[1].abs() + c.a[2] + c.a[3]) + rho);
        for d in 0..2 {
            gn.push(out[d]);
            cn.push(n[d]);
            // A unit vector from a difference of coordinates: round-off relative to them.
            sn.push((f64::from(c.a[0].abs().max(c.a[1].abs())) + rho) / rho);
        }
    }
    check("cylinder overlap", &gd, &cd, &sd, ULPS8);
    check("cylinder normal", &gn, &cn, &sn, ULPS8);
}

#[test]
fn cylinder_surface_velocity_matches_its_wgsl_twin() {
    let Some(ctx) = gpu_or_skip("cylinder_surface_velocity_matches_its_wgsl_twin") else {
        return;
    };
    let mut cases = Vec::new();
    for &(spin, radius) in &[(0.0f32, 10.0f32), (0.03, 15.0), (-2.5, 0.7), (1e3, 1e-2)] {
        for k in 0..8u32 {
            let phi = 0.2 + 0.8 * k as f32;
            cases.push([spin, radius, phi.cos(), phi.sin()]);
        }
    }
    let gpu: Vec<[f32; 2]> = eval_wgsl(
        &ctx,
        &[WALLS_WGSL],
        "vec4<f32>",
        "vec2<f32>",
        "dem_cylinder_surface_velocity(x.x, x.y, x.zw)",
        &cases,
    )
    .unwrap();
    let (mut g, mut c, mut s) = (vec![], vec![], vec![]);
    for (x, out) in cases.iter().zip(&gpu) {
        let v = cylinder_surface_velocity(x[0], x[1], [x[2], x[3]]);
        // The surface speed is |spin| R: the contact point goes round the axis.
        let speed = f64::from(v[0]).hypot(f64::from(v[1]));
        let expected = f64::from(x[0].abs() * x[1]);
        assert!(
            (speed - expected).abs() <= 4.0 * f64::from(f32::EPSILON) * expected,
            "surface speed {speed} for spin {} R {}",
            x[0],
            x[1]
        );
        for d in 0..2 {
            g.push(out[d]);
            c.push(v[d]);
            s.push(expected.max(f64::MIN_POSITIVE));
        }
    }
    check("cylinder surface velocity", &g, &c, &s, ULPS8);
}

#[test]
fn wall_motion_matches_its_wgsl_twin() {
    let Some(ctx) = gpu_or_skip("wall_motion_matches_its_wgsl_twin") else {
        return;
    };
    let pi = std::f32::consts::PI;
    let phases = [
        0.0f32,
        0.3,
        pi / 2.0,
        2.0,
        pi,
        -pi / 3.0,
        -pi,
        1.5 * pi,
        2.0 * pi,
        10.0,
        100.25,
    ];
    let mut cases = Vec::new();
    for &(a, omega) in &[(0.05f32, 1.0f32), (1.0, 6.0), (2e-3, 300.0)] {
        for &phase in &phases {
            cases.push([a, omega, phase, 0.0f32]);
        }
    }
    let gpu: Vec<[f32; 2]> = eval_wgsl(
        &ctx,
        &[WALLS_WGSL],
        "vec4<f32>",
        "vec2<f32>",
        "dem_wall_motion(x.x, x.y, x.z)",
        &cases,
    )
    .unwrap();
    let (mut gz, mut cz, mut sz, mut gv, mut cv, mut sv) =
        (vec![], vec![], vec![], vec![], vec![], vec![]);
    for (c, out) in cases.iter().zip(&gpu) {
        let (a, omega, phase) = (f64::from(c[0]), f64::from(c[1]), f64::from(c[2]));
        let (z, v) = wall_motion(a, omega, phase);
        gz.push(out[0]);
        cz.push(z as f32);
        sz.push(a);
        gv.push(out[1]);
        cv.push(v as f32);
        sv.push(a * omega);
    }
    check("wall displacement", &gz, &cz, &sz, 1e-5);
    check("wall velocity", &gv, &cv, &sv, 1e-5);
}

/// The whole contact force of the built-in law, `dem_contact_force` (what the GPU force
/// kernel calls for every contact), against `<Material as ContactLaw>::force` in `f32`, with
/// and without friction: within 8 ulps of the size of the normal force plus the friction
/// cap (the terms summed).
#[test]
fn the_contact_force_matches_its_wgsl_twin() {
    let Some(ctx) = gpu_or_skip("the_contact_force_matches_its_wgsl_twin") else {
        return;
    };
    let mut cases = Vec::new();
    let mut k = 0u32;
    for c in materials() {
        for &delta in &[1e-4f32, 0.01, 0.2] {
            for &m_ij in &[0.5f32, 3.0] {
                for friction in [0.0f32, 1.0] {
                    k += 1;
                    let u = |a: u32| rng_uniform(13, a, k) - 0.5;
                    let d = [u(0), u(1), u(2) + 0.7];
                    let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                    let n = [d[0] / l, d[1] / l, d[2] / l];
                    let v_rel = [2.0 * u(3), 2.0 * u(4), 2.0 * u(5)];
                    let v_n = v_rel[0] * n[0] + v_rel[1] * n[1] + v_rel[2] * n[2];
                    cases.push(Case4 {
                        a: vec4(&c),
                        b: [n[0], n[1], n[2], v_n],
                        c: [v_rel[0], v_rel[1], v_rel[2], delta],
                        d: [m_ij, friction, 0.0, 0.0],
                    });
                }
            }
        }
    }
    let gpu: Vec<[f32; 4]> = eval_wgsl(
        &ctx,
        &[
            CASES_WGSL,
            LAW_PRELUDE_WGSL,
            <Material as ContactLaw>::WGSL,
            "fn force_of(c: DemCoeff, k: DemContact, friction: bool) -> vec3<f32> {
                var h: DemHistory;
                return dem_contact_force(c, k, &h, friction).force;
            }",
        ],
        "Case4",
        "vec4<f32>",
        "vec4<f32>(force_of(DemCoeff(x.a.x, x.a.y, x.a.z, x.a.w), DemContact(x.b.xyz, x.c.w, \
         x.c.xyz, x.b.w, vec3<f32>(0.0), x.d.x, 0.5, 1e-3), x.d.y > 0.5), 0.0)",
        &cases,
    )
    .unwrap();
    let mut worst = 0.0f64;
    for (k, out) in cases.iter().zip(&gpu) {
        let c = ContactCoefficients {
            kappa: k.a[0],
            two_b: k.a[1],
            mu_s: k.a[2],
            mu_k: k.a[3],
        };
        let contact = Contact {
            m_ij: k.d[0],
            delta: k.c[3],
            n: [k.b[0], k.b[1], k.b[2]],
            v_rel: [k.c[0], k.c[1], k.c[2]],
            v_n: k.b[3],
            r_eff: 0.5,
            w_rel: [0.0; 3],
            dt: 1e-3,
        };
        let f = if k.d[1] > 0.5 {
            Material::force::<f32, 3, true>(&c, &contact, &mut []).force
        } else {
            Material::force::<f32, 3, false>(&c, &contact, &mut []).force
        };
        let fnorm = f64::from(normal_force(&c, contact.m_ij, contact.delta, contact.v_n));
        let vr: f64 = contact
            .v_rel
            .iter()
            .map(|&x| f64::from(x).powi(2))
            .sum::<f64>()
            .sqrt();
        let cap = f64::from(c.mu_s) * fnorm.abs() + f64::from(c.mu_k * contact.m_ij) * vr;
        let m_kappa = f64::from(contact.m_ij) * f64::from(c.kappa) * f64::from(contact.delta);
        let m_damp = f64::from(contact.m_ij * c.two_b) * f64::from(contact.v_n).abs();
        let scale = m_kappa + m_damp + fnorm.abs() + cap;
        for d in 0..3 {
            let e = (f64::from(out[d]) - f64::from(f[d])).abs();
            worst = worst.max(e / scale);
            assert!(e <= ULPS8 * scale, "{k:?}: {out:?} vs {f:?}");
        }
    }
    eprintln!(
        "{} cases, worst {:.2} ulps of the term size",
        cases.len(),
        worst / f64::from(f32::EPSILON)
    );
}

/// Input record of the history-law harness: coefficients (`a`, `b`), the contact (`c`:
/// normal, overlap; `d`: velocity, normal velocity; `e`: relative spin, reduced mass; `f`:
/// effective radius, time step, friction flag, index of the law) and the history before
/// (`g`, `h`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct Case8 {
    a: [f32; 4],
    b: [f32; 4],
    c: [f32; 4],
    d: [f32; 4],
    e: [f32; 4],
    f: [f32; 4],
    g: [f32; 4],
    h: [f32; 4],
}

/// Output record: force, couple, history after.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct Out4 {
    force: [f32; 4],
    torque: [f32; 4],
    h0: [f32; 4],
    h1: [f32; 4],
}

const HISTORY_HARNESS_WGSL: &str = "
struct Case8 { a: vec4<f32>, b: vec4<f32>, c: vec4<f32>, d: vec4<f32>, e: vec4<f32>, f: vec4<f32>, g: vec4<f32>, h: vec4<f32> }
struct Out4 { force: vec4<f32>, torque: vec4<f32>, h0: vec4<f32>, h1: vec4<f32> }
fn eval_case(x: Case8) -> Out4 {
    var h = DemHistory(x.g.x, x.g.y, x.g.z, x.g.w, x.h.x, x.h.y, x.h.z);
    let k = DemContact(x.c.xyz, x.c.w, x.d.xyz, x.d.w, x.e.xyz, x.e.w, x.f.x, x.f.y);
    let c = DemCoeff(x.a.x, x.a.y, x.a.z, x.a.w, x.b.x, x.b.y, x.b.z, x.b.w);
    let o = dem_contact_force(c, k, &h, x.f.z > 0.5);
    return Out4(vec4<f32>(o.force, 0.0), vec4<f32>(o.torque, 0.0), vec4<f32>(h[0], h[1], h[2], h[3]), vec4<f32>(h[4], h[5], h[6], 0.0));
}
";

/// Evaluates a history law's WGSL twin on random contacts (sticking and sliding springs,
/// with and without a stored history and a relative spin) against its Rust function in
/// `f32`; returns the worst error of the force, couple and history, each relative to the
/// size of its terms, and the counts of sticking and sliding cases.
fn history_law_errors<L: ContactLaw<Gpu = [f32; 8]>>(
    ctx: &simkit_backend::GpuContext,
    laws: &[L],
    deltas: &[f32],
) -> ([f64; 3], [usize; 2]) {
    let mut cases = Vec::new();
    let mut key = 0u32;
    for (index, law) in laws.iter().enumerate() {
        let g = L::gpu(&law.coefficients::<f32>());
        for &delta in deltas {
            for scale in [0.0f32, 1e-5, 1e-4, 1e-3, 1e-2] {
                for friction in [0.0f32, 1.0, 1.0] {
                    key += 1;
                    let u = |a: u32| rng_uniform(29, a, key) - 0.5;
                    let d = [u(0), u(1), u(2) + 0.7];
                    let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                    let n = [d[0] / l, d[1] / l, d[2] / l];
                    let v = [u(3), u(4), u(5)];
                    let v_n = v[0] * n[0] + v[1] * n[1] + v[2] * n[2];
                    cases.push(Case8 {
                        a: [g[0], g[1], g[2], g[3]],
                        b: [g[4], g[5], g[6], g[7]],
                        c: [n[0], n[1], n[2], delta],
                        d: [v[0], v[1], v[2], v_n],
                        e: [u(6), u(7), u(8), 0.5 + u(9)],
                        f: [0.25 + 0.2 * u(10), 1e-3, friction, index as f32],
                        g: [scale * u(11), scale * u(12), scale * u(13), scale * u(14)],
                        h: [scale * u(15), scale * u(16), 0.0, 0.0],
                    });
                }
            }
        }
    }
    let gpu: Vec<Out4> = eval_wgsl(
        ctx,
        &[LAW_PRELUDE_WGSL, L::WGSL, HISTORY_HARNESS_WGSL],
        "Case8",
        "Out4",
        "eval_case(x)",
        &cases,
    )
    .unwrap();
    let norm = |v: &[f32]| v.iter().map(|&x| f64::from(x).powi(2)).sum::<f64>().sqrt();
    let mut worst = [0.0f64; 3];
    let mut counts = [0usize; 2];
    for (x, out) in cases.iter().zip(&gpu) {
        let coeff: Vec<f32> = x.a.iter().chain(&x.b).copied().collect();
        let c = laws[x.f[3] as usize].coefficients::<f32>();
        let contact = Contact {
            m_ij: x.e[3],
            delta: x.c[3],
            n: [x.c[0], x.c[1], x.c[2]],
            v_rel: [x.d[0], x.d[1], x.d[2]],
            v_n: x.d[3],
            r_eff: x.f[0],
            w_rel: [x.e[0], x.e[1], x.e[2]],
            dt: x.f[1],
        };
        let mut h = [x.g[0], x.g[1], x.g[2], x.g[3], x.h[0], x.h[1]];
        let before = h;
        let cpu = if x.f[2] > 0.5 {
            L::force::<f32, 3, true>(&c, &contact, &mut h)
        } else {
            L::force::<f32, 3, false>(&c, &contact, &mut h)
        };
        // The normal part alone sizes the force; the tangential part is at most mu |F_n|
        // plus the spring and dashpot terms before the cap.
        let f_n: f64 = (0..3)
            .map(|d| f64::from(cpu.force[d]) * f64::from(contact.n[d]))
            .sum();
        let t: Vec<f64> = (0..3)
            .map(|d| f64::from(cpu.force[d]) - f_n * f64::from(contact.n[d]))
            .collect();
        let t_abs = t.iter().map(|x| x * x).sum::<f64>().sqrt();
        if x.f[2] > 0.5 {
            let mu = f64::from(coeff[3]);
            if t_abs >= 0.999 * mu * f_n.abs() {
                counts[1] += 1;
            } else {
                counts[0] += 1;
            }
        }
        let f_scale = 2.0 * (f_n.abs() + t_abs) + norm(&cpu.force);
        let t_scale = norm(&cpu.torque) + f64::from(contact.r_eff) * f_scale;
        let h_scale = norm(&before) + norm(&h) + f64::from(contact.dt) * 2.0;
        let gpu_h = [
            out.h0[0], out.h0[1], out.h0[2], out.h0[3], out.h1[0], out.h1[1],
        ];
        for d in 0..3 {
            let e = (f64::from(out.force[d]) - f64::from(cpu.force[d])).abs() / f_scale;
            worst[0] = worst[0].max(e);
            let e = (f64::from(out.torque[d]) - f64::from(cpu.torque[d])).abs() / t_scale;
            worst[1] = worst[1].max(e);
        }
        for (g, c) in gpu_h.iter().zip(&h) {
            worst[2] = worst[2].max((f64::from(*g) - f64::from(*c)).abs() / h_scale);
        }
    }
    (worst, counts)
}

#[test]
fn the_history_laws_match_their_wgsl_twins() {
    let Some(ctx) = gpu_or_skip("the_history_laws_match_their_wgsl_twins") else {
        return;
    };
    let linear = [
        LinearHistory::new(0.9, 0.05, 0.5).with_rolling_friction(0.1),
        LinearHistory::new(0.3, 1e-3, 0.2),
        LinearHistory::new(0.99, 0.2, 1.0).with_stiffness_ratio(0.5),
    ];
    let glass = Solid::new(1e5, 0.3);
    let hertz = [
        HertzMindlin::new(glass, glass, 0.6, 0.4)
            .unwrap()
            .with_rolling(0.05, 2000.0, 20.0),
        HertzMindlin::new(glass, Solid::new(3e6, 0.2), 0.9, 0.8).unwrap(),
    ];
    let deltas = [1e-4f32, 3e-3, 0.02];
    for (name, (worst, counts)) in [
        ("linear-history", history_law_errors(&ctx, &linear, &deltas)),
        ("hertz-mindlin", history_law_errors(&ctx, &hertz, &deltas)),
    ] {
        let ulps = worst.map(|w| w / f64::from(f32::EPSILON));
        println!(
            "{name}: {} sticking, {} sliding; worst force {:.2} ulps, couple {:.2}, \
             history {:.2} (of the term sizes)",
            counts[0], counts[1], ulps[0], ulps[1], ulps[2]
        );
        assert!(counts[0] >= 10 && counts[1] >= 10, "{name}: {counts:?}");
        // Measured 0 ulps on lavapipe (the same operations in the same order). The chains
        // are longer than the memoryless law's (a projection, a square root and a division
        // in the spring's turn, another at the cap): 32 ulps of the term sizes leave room
        // for the FMA contraction and the division and square root accuracy WGSL allows.
        for (what, u) in ["force", "couple", "history"].iter().zip(ulps) {
            assert!(u <= 32.0, "{name}: {what} off by {u} ulps");
        }
    }
}

#[test]
fn the_contact_point_velocity_matches_its_wgsl_twin() {
    let Some(ctx) = gpu_or_skip("the_contact_point_velocity_matches_its_wgsl_twin") else {
        return;
    };
    let cases: Vec<Case4> = (0..64u32)
        .map(|k| {
            let u = |a: u32| 4.0 * (rng_uniform(31, a, k) - 0.5);
            let d = [u(0), u(1), u(2)];
            let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            Case4 {
                a: [u(3), u(4), u(5), 0.5 + u(6).abs()],
                b: [
                    d[0] / l,
                    d[1] / l,
                    d[2] / l,
                    if k % 4 == 0 { 0.0 } else { u(7).abs() },
                ],
                c: [u(8), u(9), u(10), 0.0],
                d: [u(11), u(12), u(13), 0.0],
            }
        })
        .collect();
    let gpu: Vec<[f32; 4]> = eval_wgsl(
        &ctx,
        &[CASES_WGSL, LAW_PRELUDE_WGSL],
        "Case4",
        "vec4<f32>",
        "vec4<f32>(dem_contact_point_velocity(x.a.xyz, x.b.xyz, x.a.w, x.c.xyz, x.b.w, x.d.xyz), 0.0)",
        &cases,
    )
    .unwrap();
    let mut worst = 0.0f64;
    for (x, g) in cases.iter().zip(&gpu) {
        let v = [x.a[0], x.a[1], x.a[2]];
        let n = [x.b[0], x.b[1], x.b[2]];
        let (w_i, w_j) = ([x.c[0], x.c[1], x.c[2]], [x.d[0], x.d[1], x.d[2]]);
        let cpu = contact_point_velocity(&v, &n, x.a[3], &w_i, x.b[3], &w_j);
        // The terms: |v| and the lever arms' speeds.
        let norm = |a: &[f32; 3]| a.iter().map(|&c| f64::from(c).powi(2)).sum::<f64>().sqrt();
        let scale = norm(&v) + f64::from(x.a[3]) * norm(&w_i) + f64::from(x.b[3]) * norm(&w_j);
        for d in 0..3 {
            let e = (f64::from(g[d]) - f64::from(cpu[d])).abs() / scale;
            worst = worst.max(e);
            assert!(e <= ULPS8, "{x:?}: {g:?} vs {cpu:?}");
        }
    }
    println!(
        "64 cases, worst {:.2} ulps of the term size",
        worst / f64::from(f32::EPSILON)
    );
}
