//! The friction law against analytic solutions of exactly the model `dem` integrates: no
//! rotation (a disc slides, it cannot roll), tangential force
//! `F_t = -min(mu_s |F_n|, mu_k m_ij |v_t|) v_t / |v_t|` (a viscous force of coefficient
//! `mu_k` per unit reduced mass, capped by Coulomb's `mu_s |F_n|`; `mu_s` is the Coulomb
//! coefficient that textbooks call the kinetic friction coefficient while sliding).

use simkit_backend::{Backend, Simulation};
use simkit_dem::{Config, ContactCoefficients, Dem, Dim, Material, Particle, Scene, Wall};

const TC: f64 = 0.01;
const PHASES: usize = 8;

/// A 2D box `[0, 40] x [0, 10]` with a frictional floor at `y = 0` and nothing else.
fn floor_scene(material: Material, gravity: f64) -> Scene {
    let mut s = Scene::new(Dim::Two, [0.0; 3], [40.0, 10.0, 0.0], material).unwrap();
    if gravity > 0.0 {
        s.set_gravity(gravity).unwrap();
    }
    s.add_wall(Wall::plane([0.0, 1.0, 0.0], [0.0; 3], material))
        .unwrap();
    s
}

/// A disc (mass 2, so `m_ij = 2` against the floor) resting on a floor under gravity `g`,
/// launched along it at `v0`. At rest on the floor `F_n = m g` (the disc starts at the
/// equilibrium overlap `g / kappa` with no normal velocity, so no normal oscillation), and
/// the tangential deceleration is `min(mu_s g, mu_k v)`:
/// - while `v > v* = mu_s g / mu_k` (Coulomb, sliding): `v = v0 - mu_s g t`, reached `v*` at
///   `t1 = (v0 - v*) / (mu_s g)` after `d1 = (v0^2 - v*^2) / (2 mu_s g)`;
/// - then (viscous): `v = v* exp(-mu_k (t - t1))`, a further `d2 = v* / mu_k` to rest.
///
/// Stopping distance `d1 + d2`; for `mu_k -> inf` the textbook `v0^2 / (2 mu g)`.
#[test]
fn sliding_disc_stops_after_the_coulomb_distance() {
    let (g, v0, mu_s, mu_k, mass) = (1.0, 1.0, 0.3, 60.0, 2.0);
    let material = Material::new(0.5, TC).with_friction(mu_s, mu_k);
    let kappa = ContactCoefficients::new(&material).kappa;
    let (x0, y0) = (2.0, 0.5 - g / kappa);
    let mut scene = floor_scene(material, g);
    scene
        .add_particle(Particle::new([x0, y0, 0.0], 0.5, mass).with_velocity([v0, 0.0, 0.0]))
        .unwrap();
    let mut sim = Dem::new(scene, &Config::default(), Backend::Cpu).unwrap();
    let dt = sim.dt();
    let v_star = mu_s * g / mu_k;
    let t1 = (v0 - v_star) / (mu_s * g);
    let d1 = (v0 * v0 - v_star * v_star) / (2.0 * mu_s * g);
    let d2 = v_star / mu_k;

    // Sliding phase: sample at 10 %, ..., 90 % of t1; v and x follow the constant
    // deceleration exactly (a constant force is integrated exactly by velocity Verlet), so
    // what is left is round-off and the normal force differing from m g by round-off.
    let mut worst_slide = 0.0f64;
    let mut done = 0u64;
    for k in 1..10 {
        let target = (0.1 * f64::from(k) * t1 / dt).round() as u64;
        sim.step((target - done) as u32).unwrap();
        done = target;
        let s = sim.state().unwrap();
        let t = s.time;
        let v = v0 - mu_s * g * t;
        let x = x0 + v0 * t - 0.5 * mu_s * g * t * t;
        let err = ((s.velocities[0][0] - v).abs() / v0).max((s.positions[0][0] - x).abs() / d1);
        worst_slide = worst_slide.max(err);
    }
    // Then to rest: 20 viscous decay times after t1 (exp(-20) of d2 left).
    let end = ((t1 + 20.0 / mu_k) / dt).round() as u64;
    sim.step((end - done) as u32).unwrap();
    let s = sim.state().unwrap();
    let travelled = s.positions[0][0] - x0;
    let expected = d1 + d2 * (1.0 - (-mu_k * (s.time - t1)).exp());
    let err_stop = (travelled - expected).abs() / expected;
    let textbook = v0 * v0 / (2.0 * mu_s * g);
    println!(
        "sliding disc (v0 {v0}, mu_s {mu_s}, mu_k {mu_k}, g {g}, dt = t_c/30): during the slide \
         |v - (v0 - mu_s g t)| / v0 and |x - x(t)| / d1 <= {worst_slide:.2e}; stopping \
         distance {travelled:.6} vs d1 + d2 = {expected:.6} (rel err {err_stop:.2e}; \
         v0^2/(2 mu_s g) = {textbook:.6}); final speed {:.2e}",
        s.velocities[0][0]
    );
    // Measured 1.0e-13 (this test, f64): round-off over 1e4 steps; bound 3x.
    assert!(worst_slide < 3e-13, "sliding phase off by {worst_slide:e}");
    // Measured 5.0e-9 (this test, f64, dt = t_c / 30): the switch from the Coulomb to the
    // viscous branch falls inside a step, and the viscous decay (mu_k dt = 0.02) carries a
    // Verlet error O((mu_k dt)^2) of d2 (d2 / d = 5e-5); bound 3x.
    assert!(err_stop < 1.5e-8, "stopping distance off by {err_stop:e}");
    // Measured 1.03e-11 = 1.0 v* exp(-mu_k (t - t1)); bound 2x the analytic value.
    let v_end = v_star * (-mu_k * (s.time - t1)).exp();
    assert!(
        s.velocities[0][0].abs() < 2.0 * v_end,
        "still sliding: {:e} (analytic {v_end:e})",
        s.velocities[0][0]
    );
}

/// Damped contact oscillator `delta(t) = (v_in / w) e^{-b t} sin(w t)` (overlap speed at
/// impact `v_in`, `w = pi / t_c`): the largest separation speed `delta'` reached while the
/// normal force is still repulsive, at `w t* = pi - atan(2 b w / (w^2 - b^2))`, where
/// `delta'' = 0` (the force changes sign there). Returned per unit `v_in`.
fn peak_separation_speed(material: &Material) -> f64 {
    let b = -material.restitution.ln() / material.contact_time;
    let w = std::f64::consts::PI / material.contact_time;
    let wt = std::f64::consts::PI - (2.0 * b * w / (w * w - b * b)).atan();
    let t = wt / w;
    -((-b * t).exp() * (wt.cos() - b / w * wt.sin()))
}

/// An oblique impact on a frictional wall, no gravity: while the contact slides
/// (`mu_s |F_n| < mu_k m |v_t|` throughout, ensured by a large `mu_k`), the tangential
/// impulse is `mu_s` times the integral of `|F_n|`. With `e = 1` the normal force never
/// changes sign, so `Delta v_t = mu_s Delta v_n = 2 mu_s v_n`. With `e < 1` the linear
/// dashpot makes the force attractive near the end of the contact (the law takes `|F_n|`
/// for the cap), so `Delta v_t = mu_s (v_n (1 - e) + 2 v_max)` with `v_max` the peak
/// separation speed (`peak_separation_speed`): the repulsive part changes the normal speed
/// by `v_n + v_max`, the attractive part by `v_max - e v_n`.
#[test]
fn oblique_wall_impact_loses_mu_times_the_normal_impulse() {
    let (vt0, vn0, mu_s, mu_k) = (1.0, 0.5, 0.2, 1000.0);
    for e in [1.0, 0.5] {
        let material = Material::new(e, TC).with_friction(mu_s, mu_k);
        let dt = TC / 50.0;
        // The normal force jumps at the start and the end of the contact (the dashpot term
        // `2 b v_n`), inside a step: a single impact's tangential impulse depends on where
        // (up to about `mu_s 2 b v_n dt`, 1 % here for e = 0.5); the impulses are averaged
        // over PHASES impact phases spread over one step, which cancels that to first order.
        let predicted = mu_s * vn0 * (1.0 - e + 2.0 * peak_separation_speed(&material));
        let (mut dvn, mut dvt, mut spread, mut identity) = (0.0, 0.0, 0.0f64, 0.0f64);
        for k in 0..PHASES {
            let phase = k as f64 / PHASES as f64;
            let mut scene = floor_scene(material, 0.0);
            let y = 0.5 + (10.0 * TC + phase * dt) * vn0;
            scene
                .add_particle(
                    Particle::new([2.0, y, 0.0], 0.5, 2.0).with_velocity([vt0, -vn0, 0.0]),
                )
                .unwrap();
            let mut sim = Dem::new(scene, &Config::default().with_dt(dt), Backend::Cpu).unwrap();
            // 10 t_c of approach, the contact, then 10 t_c of flight.
            sim.step((21.0 * TC / dt).round() as u32).unwrap();
            let s = sim.state().unwrap();
            let (vt1, vn1) = (s.velocities[0][0], s.velocities[0][1]);
            assert!(vn1 > 0.0, "e = {e}: no rebound ({vn1})");
            let (n, t) = (vn1 + vn0, vt0 - vt1);
            dvn += n / PHASES as f64;
            dvt += t / PHASES as f64;
            spread = spread.max((t - predicted).abs() / predicted);
            identity = identity.max((t - mu_s * n).abs());
        }
        let rel = (dvt - predicted).abs() / predicted;
        println!(
            "oblique impact (v_t {vt0}, v_n {vn0}, mu_s {mu_s}, e {e}, dt = t_c/50, {PHASES} \
             phases): Delta v_n {dvn:.6}, Delta v_t {dvt:.6}, predicted {predicted:.6} \
             (rel err {rel:.2e}, worst single impact {spread:.2e}); \
             max |Delta v_t - mu_s Delta v_n| {identity:.2e}"
        );
        if e == 1.0 {
            // The force never turns attractive, so every step's friction is exactly
            // mu_s times its normal force: Delta v_t = mu_s Delta v_n to round-off (measured
            // 4.4e-16 on velocities of order 1; bound 1e-14, a few hundred steps' round-off).
            assert!(
                identity < 1e-14,
                "Delta v_t - mu_s Delta v_n = {identity:e}"
            );
        }
        // Measured 9.5e-7 (e = 1) and 8.4e-4 (e = 0.5) (this test, f64, dt = t_c / 50, mean
        // of 8 phases): the second-order remainder of the jumps of the dashpot force at the
        // contact's start and end; bound 3x each.
        let bound = if e == 1.0 { 3e-6 } else { 2.5e-3 };
        assert!(
            rel < bound,
            "e = {e}: tangential speed loss {dvt} vs {predicted} (rel err {rel:e})"
        );
    }
}
