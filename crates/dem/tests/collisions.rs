//! Binary head-on collisions: measured restitution and contact time against the requested
//! `(e, t_c)`, for mass ratios 1, 3 and 10 (the particle mass against walls), both integrators, 2D and 3D, particle–particle,
//! particle–wall and particle–moving-wall contacts.

use simkit_backend::{Backend, Simulation};
use simkit_dem::{Config, Dem, Dim, Integrator, Material, Particle, Scene, Wall};

const TC: f64 = 0.01;
const PHASES: usize = 8;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Target {
    Particle,
    Wall,
    MovingWall,
}

/// Returns (measured restitution, measured contact time).
fn collide(
    dim: Dim,
    e: f64,
    mass_ratio: f64,
    integrator: Integrator,
    target: Target,
    phase: f64,
) -> (f64, f64) {
    let dt = TC / 50.0;
    let v = dim.vertical();
    let mut scene = Scene::new(
        dim,
        [0.0; 3],
        [8.0, 8.0, if dim == Dim::Three { 8.0 } else { 0.0 }],
        Material::new(e, TC),
    )
    .unwrap();
    let mut p0 = [4.0; 3];
    let mut p1 = [4.0; 3];
    if dim == Dim::Two {
        p0[2] = 0.0;
        p1[2] = 0.0;
    }
    let speed = 1.0;
    let mut vel0 = [0.0; 3];
    let mut vel1 = [0.0; 3];
    // Collision along the vertical axis in every case (walls are horizontal planes).
    let amplitude = 0.1;
    match target {
        Target::Particle => {
            p0[v] = 3.0;
            vel0[v] = speed * mass_ratio / (1.0 + mass_ratio);
            vel1[v] = -speed / (1.0 + mass_ratio);
            p1[v] = 4.0 + (2.0 * TC + phase * dt) * speed;
        }
        Target::Wall => {
            p0[v] = 0.5 + (2.0 * TC + phase * dt) * speed;
            vel0[v] = -speed;
            scene
                .add_wall(Wall::plane(unit(v), [0.0; 3], Material::new(e, TC)))
                .unwrap();
        }
        Target::MovingWall => {
            // Wall z_w(t) = -A cos(t): at t = pi/2 it passes 0 with velocity A and no
            // acceleration; the particle meets it there.
            let t_hit = std::f64::consts::FRAC_PI_2;
            p0[v] = 0.5 + speed * (t_hit + phase * dt);
            vel0[v] = -speed;
            scene.set_vibration(amplitude, 1.0).unwrap();
            scene
                .add_wall(Wall::plane(unit(v), [0.0; 3], Material::new(e, TC)).vibrating())
                .unwrap();
        }
    }
    // Against a wall the particle mass itself varies (m_ij = m_i): the requested e must
    // hold for any mass, which the source's m_ij-less damping term breaks.
    let m0 = if target == Target::Particle {
        1.0
    } else {
        mass_ratio
    };
    scene
        .add_particle(Particle::new(p0, 0.5, m0).with_velocity(vel0))
        .unwrap();
    if target == Target::Particle {
        scene
            .add_particle(Particle::new(p1, 0.5, mass_ratio).with_velocity(vel1))
            .unwrap();
    }
    let cfg = Config::default().with_dt(dt).with_integrator(integrator);
    let mut sim = Dem::new(scene, &cfg, Backend::Cpu).unwrap();
    let gap = |s: &simkit_dem::State, sim: &Dem| -> (f64, f64) {
        match target {
            Target::Particle => (
                s.positions[1][v] - s.positions[0][v] - 1.0,
                s.velocities[0][v] - s.velocities[1][v],
            ),
            _ => {
                let zw = sim.wall_displacement(s.time);
                let vw = amplitude
                    * (s.time).sin()
                    * if target == Target::MovingWall {
                        1.0
                    } else {
                        0.0
                    };
                let zw = if target == Target::MovingWall {
                    zw
                } else {
                    0.0
                };
                (s.positions[0][v] - 0.5 - zw, -(s.velocities[0][v] - vw))
            }
        }
    };
    if target == Target::MovingWall {
        sim.step((1.5 / dt) as u32).unwrap();
    }
    let s = sim.state().unwrap();
    let (mut g_prev, mut approach) = gap(&s, &sim);
    let mut t_prev = s.time;
    let (mut t_in, mut t_out) = (None, None);
    let mut separation_speed = 0.0;
    for _ in 0..200_000 {
        sim.step(1).unwrap();
        let s = sim.state().unwrap();
        let (g, rel) = gap(&s, &sim);
        if t_in.is_none() && g > 0.0 {
            // Approach speed just before the contact (the moving wall changes it slowly).
            approach = rel;
        }
        if t_in.is_none() && g_prev > 0.0 && g <= 0.0 {
            t_in = Some(t_prev + (s.time - t_prev) * g_prev / (g_prev - g));
        }
        if t_in.is_some() && t_out.is_none() && g_prev <= 0.0 && g > 0.0 {
            t_out = Some(t_prev + (s.time - t_prev) * (-g_prev) / (g - g_prev));
        }
        if let Some(to) = t_out
            && s.time > to + 2.0 * dt
        {
            separation_speed = -rel;
            break;
        }
        g_prev = g;
        t_prev = s.time;
    }
    let (t_in, t_out) = (
        t_in.expect("no contact"),
        t_out.expect("contact never ended"),
    );
    (separation_speed / approach, t_out - t_in)
}

fn unit(d: usize) -> [f64; 3] {
    let mut n = [0.0; 3];
    n[d] = 1.0;
    n
}

/// Per case (`e`), the measured errors of the phase-averaged restitution and contact time
/// and their bounds (3x the worst measured over targets, dimensions, integrators and mass
/// ratios; this test, f64, dt = t_c / 50; particle, wall and moving wall agree to 1e-4, once
/// step-window collisions are set apart: the wall's motion during the contact changes the
/// relative velocity by about A omega^2 t_c^2 / 2 = 5e-6, 5e-5 of the rebound speed at e = 0.1):
///
/// | e | restitution measured | bound | contact time measured | bound |
/// |---|---|---|---|---|
/// | 0.1 | 1.41e-3 | 4.3e-3 | 2.11e-3 | 6.4e-3 |
/// | 0.5 | 1.57e-3 | 4.7e-3 | 5.75e-5 | 1.8e-4 |
/// | 0.9 | 3.00e-4 | 9.0e-4 | 1.62e-4 | derived, see `check` |
/// | 1.0 | 2.32e-6 | 7.0e-6 | 1.65e-4 | derived, see `check` |
const CASES: [(f64, f64, f64); 4] = [
    (0.1, 4.3e-3, 6.4e-3),
    (0.5, 4.7e-3, 1.8e-4),
    (0.9, 9.0e-4, f64::NAN),
    (1.0, 7.0e-6, f64::NAN),
];

fn check(target: Target) {
    let dt = TC / 50.0;
    // Verlet integrates an undamped oscillator with frequency w_num, sin(w_num dt / 2) =
    // w dt / 2, i.e. w_num = w (1 + (w dt)^2 / 24 + ...): the contact is shorter by
    // (w dt)^2 / 24 = 1.64e-4 of t_c at e = 1 (w = pi / t_c); for e = 0.9 the damping adds
    // O((b dt)^2) = 1e-5 on top.
    let verlet_tc = -(std::f64::consts::PI / 50.0).powi(2) / 24.0;
    for (e, tol_e, tol_t) in CASES {
        // Step window: the linear dashpot force jumps by 2 b m_ij v_n when the contact opens
        // and when it closes, inside a step. The integrator applies it from the first to
        // the last step with overlap > 0, so one step's worth of dashpot force,
        // 2 b m_ij v dt, is kept or dropped depending on where the contact starts and ends.
        // At the start the extra kick is multiplied by e by the rest of the contact, the same
        // size as the kick at the end: they cancel, except in a window of impact phases of
        // width frac(contact steps) (the discrete contact lasts 50.1 steps at e = 0.1,
        // 50.003 at e = 0.5), where the end has one overlapping step more than the start:
        // the attractive kick -2 b v_out dt (less the spring term kappa delta of that step,
        // kappa dt / 2 b = 6.6 % of it at e = 0.1) lowers e by 2 b dt (1 - [0, kappa dt / 2b])
        // = 8.6 % to 9.2 % at e = 0.1 (measured 8.78 %). The window is narrower than 1/8 of
        // a step, so at most one of the 8 phases falls into it. Such collisions are checked
        // against that prediction and the others averaged.
        let b = -e.ln() / TC;
        let kappa = (std::f64::consts::PI / TC).powi(2) + b * b;
        let kick = 2.0 * b * dt;
        let mut worst = [0.0f64; 3];
        let mut windows = 0;
        for dim in [Dim::Two, Dim::Three] {
            for integrator in [Integrator::VelocityVerlet, Integrator::PositionVerlet] {
                for ratio in [1.0, 3.0, 10.0] {
                    let runs: Vec<(f64, f64)> = (0..PHASES)
                        .map(|k| {
                            collide(dim, e, ratio, integrator, target, k as f64 / PHASES as f64)
                        })
                        .collect();
                    let in_window = |e1: f64| e < 1.0 && e1 < e * (1.0 - kick / 2.0);
                    let regular: Vec<(f64, f64)> =
                        runs.iter().copied().filter(|r| !in_window(r.0)).collect();
                    let n = regular.len() as f64;
                    let em = regular.iter().map(|r| r.0).sum::<f64>() / n;
                    let tc = runs.iter().map(|r| r.1).sum::<f64>() / PHASES as f64;
                    let re = (em - e).abs() / e;
                    let rt = (tc - TC) / TC;
                    let label = format!("{target:?} {dim:?} {integrator:?} e={e} m2/m1={ratio}");
                    println!(
                        "{label}: e_meas={em:.5} (rel err {re:.2e}, {} of {PHASES} phases in \
                         the step window), t_c err {rt:+.3e}",
                        PHASES - regular.len()
                    );
                    assert!(
                        PHASES - regular.len() <= 1,
                        "{label}: more than one phase in the step window: {runs:?}"
                    );
                    for r in runs.iter().filter(|r| in_window(r.0)) {
                        windows += 1;
                        let drop = 1.0 - r.0 / em;
                        let lo = kick * (1.0 - kappa * dt / (2.0 * b));
                        worst[2] = worst[2].max(drop / kick);
                        assert!(
                            (lo..=kick).contains(&drop),
                            "{label}: step-window collision lowers e by {drop:.4}, \
                             predicted {lo:.4} to {kick:.4}"
                        );
                    }
                    assert!(
                        re <= tol_e,
                        "{label}: e_meas={em} (rel err {re:e} > {tol_e:e})"
                    );
                    if tol_t.is_nan() {
                        // Measured +1.62e-4 (e = 0.9) and +1.65e-4 (e = 1): the Verlet
                        // frequency shift; bound: the derived value within 10 %.
                        assert!(
                            (rt - verlet_tc).abs() <= 0.1 * verlet_tc.abs(),
                            "{label}: t_c err {rt:e}, Verlet predicts {verlet_tc:e}"
                        );
                    } else {
                        assert!(rt.abs() <= tol_t, "{label}: t_c={tc} (err {rt:e})");
                    }
                    worst[0] = worst[0].max(re);
                    worst[1] = worst[1].max(rt.abs());
                }
            }
        }
        println!(
            "{target:?} e={e}: worst relative restitution error {:.2e}, contact time {:.2e}; \
             {windows} step-window collisions, drop / (2 b dt) up to {:.3}",
            worst[0], worst[1], worst[2]
        );
    }
}

/// Velocity and position Verlet compute the same positions in exact arithmetic (the
/// position Verlet displacement `x(t) - x(t - dt)` is `dt` times velocity Verlet's half-step
/// velocity, and both give the damping the velocity `v(t - dt/2) + a(t - dt) dt / 2 + ...`
/// of the same formula); in floating point they round differently. Checked on a vibrated
/// bed with friction, walls and many contacts after 2000 steps.
#[test]
fn velocity_and_position_verlet_give_the_same_trajectory() {
    let m = Material::new(0.7, TC).with_friction(0.4, 30.0);
    let mut scene = Scene::new(Dim::Two, [0.0; 3], [8.0, 8.0, 0.0], m).unwrap();
    scene
        .set_gravity(1.0)
        .unwrap()
        .set_vibration(0.1, 10.0)
        .unwrap();
    scene.add_box_walls(m, true).unwrap();
    for k in 0..40u32 {
        let h = |a: u32| simkit_backend::rng::rng_uniform(11, a, k) as f64 - 0.5;
        let p = [
            0.7 + 1.1 * f64::from(k % 6),
            0.7 + 1.1 * f64::from(k / 6),
            0.0,
        ];
        scene
            .add_particle(
                Particle::new(p, 0.5, 1.0 + f64::from(k % 3)).with_velocity([h(0), h(1), 0.0]),
            )
            .unwrap();
    }
    let run = |integrator| {
        let cfg = Config::default()
            .with_dt(TC / 30.0)
            .with_integrator(integrator);
        let mut sim = Dem::new(scene.clone(), &cfg, Backend::Cpu).unwrap();
        let mut worst = 0.0f64;
        let mut states = Vec::new();
        for _ in 0..20 {
            sim.step(100).unwrap();
            worst = worst.max(sim.diagnostics().unwrap().max_overlap_ratio);
            states.push(sim.state().unwrap());
        }
        (states, worst)
    };
    let (vv, overlap) = run(Integrator::VelocityVerlet);
    let (pv, _) = run(Integrator::PositionVerlet);
    let mut diffs = Vec::new();
    for (a, b) in vv.iter().zip(&pv) {
        let d = a
            .positions
            .iter()
            .zip(&b.positions)
            .flat_map(|(x, y)| (0..2).map(move |c| (x[c] - y[c]).abs()))
            .fold(0.0, f64::max);
        diffs.push(d);
    }
    let identical = vv.iter().zip(&pv).all(|(a, b)| a.positions == b.positions);
    println!(
        "velocity vs position Verlet (40 discs, vibrated box, friction), largest position \
         difference every 100 steps: {:?}; bit-identical: {identical}; deepest overlap {overlap:.2e} R",
        diffs.iter().map(|d| format!("{d:.1e}")).collect::<Vec<_>>()
    );
    assert!(overlap > 1e-3, "the bed should have contacts");
    // Equal to rounding, not bit for bit: the first 100 steps differ by 2.2e-16 (one
    // rounding of positions of order 1), the contacts of the bed then amplify that to 4.7e-13
    // after 2000 steps (measured, this test, f64); bound 3x. A lagged damping velocity in
    // either scheme (v(t - dt/2) without the a dt / 2 correction) fails it.
    let last = *diffs.last().unwrap();
    assert!(last < 1.5e-12, "VV and PV trajectories differ by {last:e}");
}

#[test]
fn particle_particle_restitution_and_contact_time() {
    check(Target::Particle);
}

#[test]
fn particle_wall_restitution_and_contact_time() {
    check(Target::Wall);
}

#[test]
fn moving_wall_restitution_in_wall_frame() {
    check(Target::MovingWall);
}
