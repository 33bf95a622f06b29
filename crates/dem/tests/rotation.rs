//! Rotation, tangential history, Hertz–Mindlin and rolling resistance against their
//! analytic results (CPU, `f64`), and the GPU backend's rotation and contact history
//! against the CPU's.

use simkit_backend::comm::Comm;
use simkit_backend::testing::backends;
use simkit_backend::{Backend, Precision, Restart, Result, Simulation};
use simkit_dem::{
    Config, ContactLaw, Dem, Dim, DistributedDem, HertzMindlin, LinearHistory, Material, Particle,
    Scene, Solid, Wall, hertz_contact_time,
};

/// The solid of every test: `E = 1e5`, `nu = 0.3` (diameter 1, mass 1, `g = 1`: overlaps
/// of about 1 % of the radius under impacts at 1).
fn solid() -> Solid {
    Solid::new(1e5, 0.3)
}

fn law(e: f64, mu: f64) -> HertzMindlin {
    HertzMindlin::new(solid(), solid(), e, mu).expect("law")
}

/// The angular velocity of particle `k`.
fn omega(sim: &mut Dem<HertzMindlin>, k: usize) -> [f64; 3] {
    sim.state().expect("state").angular_velocities[k]
}

/// Two spheres (radius 0.5, mass 1) approaching head-on at relative speed `v`: the
/// contact time (steps with an overlap, times dt) and the restitution.
fn head_on(v: f64, e: f64) -> Result<(f64, f64)> {
    let law = law(e, 0.0);
    let tc = hertz_contact_time(0.5, 0.25, law.e_star, v);
    let dt = tc / 4000.0;
    let gap = 20.0 * v * dt;
    let mut scene = Scene::new(Dim::Three, [0.0; 3], [4.0; 3], law)?;
    scene.add_particle(
        Particle::new([1.5 - gap / 2.0, 2.0, 2.0], 0.5, 1.0).with_velocity([v / 2.0, 0.0, 0.0]),
    )?;
    scene.add_particle(
        Particle::new([2.5 + gap / 2.0, 2.0, 2.0], 0.5, 1.0).with_velocity([-v / 2.0, 0.0, 0.0]),
    )?;
    let mut sim = Dem::new(
        scene,
        &Config::default().with_dt(dt).with_check_every(0),
        Backend::Cpu,
    )?;
    let mut touching = 0u32;
    loop {
        sim.step(1)?;
        let s = sim.state()?;
        if s.positions[1][0] - s.positions[0][0] < 1.0 {
            touching += 1;
        } else if touching > 0 {
            let rebound = s.velocities[1][0] - s.velocities[0][0];
            return Ok((f64::from(touching) * dt / tc, rebound / v));
        }
        assert!(
            touching < 8000,
            "the contact at v = {v} lasts more than twice Hertz's"
        );
    }
}

#[test]
fn hertz_contact_time_and_restitution_over_three_decades_of_impact_speed() -> Result<()> {
    for v in [0.01, 0.1, 1.0, 10.0] {
        // Elastic: Hertz's contact time, which the step count resolves to 1 / 4000
        // (measured: within one step at every speed; restitution 1 to 5e-12).
        let (ratio, e) = head_on(v, 1.0)?;
        assert!(
            (ratio - 1.0).abs() <= 5e-4,
            "v = {v}: t_c / Hertz = {ratio}"
        );
        assert!((e - 1.0).abs() < 1e-9, "v = {v}: elastic restitution {e}");
        // Damped (Tsuji's damping): the restitution is the requested one at every speed
        // (measured: 0.7 + 7.2e-6 from v = 0.01 to 10).
        let (_, e) = head_on(v, 0.7)?;
        assert!(
            (e - 0.7).abs() < 1e-4,
            "v = {v}: restitution {e} for e = 0.7"
        );
    }
    Ok(())
}

/// A sphere (radius 0.5, mass 1) resting on a plane tilted by `theta` about y, `g = 1`,
/// released from rest with rotation: its acceleration along the slope between times 1 and
/// `1 + t`, its speed along the slope and its spin then.
fn incline<L: ContactLaw>(
    theta: f64,
    law: L,
    t: f64,
    precision: Precision,
) -> Result<(f64, f64, f64)> {
    let (s, c) = theta.sin_cos();
    let mut scene = Scene::new(Dim::Three, [0.0; 3], [40.0, 4.0, 40.0], law)?;
    scene.set_gravity(1.0)?.set_rotation(true);
    // The plane through (30, 0, 10) with inward normal (s, 0, c): downhill is -x.
    scene.add_wall(Wall::plane([s, 0.0, c], [30.0, 0.0, 10.0], law))?;
    // Resting on it: the centre 0.5 - (static Hertz overlap, a few 1e-3) above the plane.
    let centre = [30.0 + 0.499 * s, 2.0, 10.0 + 0.499 * c];
    scene.add_particle(Particle::new(centre, 0.5, 1.0))?;
    let config = Config::default().with_precision(precision);
    let mut sim = Dem::new(scene, &config, Backend::Cpu)?;
    let steps = |t: f64, sim: &Dem<L>| (t / sim.dt()).round() as u32;
    let n1 = steps(1.0, &sim);
    sim.step(n1)?;
    let v1 = sim.state()?.velocities[0];
    let n2 = steps(t, &sim);
    sim.step(n2)?;
    let st = sim.state()?;
    let dt = f64::from(n2) * sim.dt();
    // Downhill along the plane is +x: the unit vector (cos, 0, -sin).
    let along = |v: [f64; 3]| v[0] * c - v[2] * s;
    let a = (along(st.velocities[0]) - along(v1)) / dt;
    let w = st.angular_velocities[0][1];
    Ok((a, along(st.velocities[0]), w))
}

#[test]
fn a_sphere_rolls_down_an_incline_below_the_critical_angle_and_slides_above() -> Result<()> {
    // tan(20 deg) = 0.36 < 3.5 mu = 1.75: rolling without slip, a = g sin / (1 + 2/5).
    let theta = 20f64.to_radians();
    let rolling = theta.sin() / 1.4;
    // Measured: a within 6e-9 (f64) and 8e-7 (f32) of the analytic value, the contact
    // point's speed 4e-15 v (f64) and 4e-6 v (f32).
    for (precision, tolerance) in [(Precision::F64, 1e-7), (Precision::F32, 1e-5)] {
        let (a, v, w) = incline(theta, law(0.5, 0.5), 4.0, precision)?;
        assert!(
            (a / rolling - 1.0).abs() < tolerance,
            "rolling: a = {a}, expected {rolling}"
        );
        // No slip: the contact point is at rest, v = w_y R.
        assert!(
            (v - 0.5 * w).abs() < 2e-5 * v,
            "rolling: v = {v}, w R = {}",
            0.5 * w
        );
    }
    // tan(30 deg) = 0.58 > 3.5 mu = 0.35: sliding, a = g (sin - mu cos).
    let theta = 30f64.to_radians();
    let (a, v, w) = incline(theta, law(0.5, 0.1), 4.0, Precision::F64)?;
    let sliding = theta.sin() - 0.1 * theta.cos();
    // Measured: 4e-8.
    assert!(
        (a / sliding - 1.0).abs() < 1e-6,
        "sliding: a = {a}, expected {sliding}"
    );
    assert!(
        v - 0.5 * w > 0.5,
        "sliding: the contact point must slip (v = {v}, w = {w})"
    );
    Ok(())
}

/// A sphere hitting a floor with normal speed 1 and tangential speed `vt`, without spin,
/// restitution `e`: the rebound velocity and spin.
fn oblique(vt: f64, mu: f64, e: f64) -> Result<([f64; 3], [f64; 3])> {
    let law = law(e, mu);
    let mut scene = Scene::new(Dim::Three, [0.0; 3], [40.0, 4.0, 4.0], law)?;
    scene.set_rotation(true);
    scene.add_wall(Wall::plane([0.0, 0.0, 1.0], [0.0; 3], law))?;
    scene.add_particle(Particle::new([2.0, 2.0, 0.52], 0.5, 1.0).with_velocity([vt, 0.0, -1.0]))?;
    let dt = hertz_contact_time(1.0, 0.5, law.e_star, 1.0) / 400.0;
    let mut sim = Dem::new(scene, &Config::default().with_dt(dt), Backend::Cpu)?;
    // 0.02 of flight, the contact (about 0.04), and away.
    sim.step((0.2 / dt) as u32)?;
    let s = sim.state()?;
    assert!(s.positions[0][2] > 0.6, "still in contact");
    Ok((s.velocities[0], omega(&mut sim, 0)))
}

/// The tangential impulse over `mu` times the normal one, from the rebound velocity and
/// from the spin (`I = 2 m R^2 / 5`, `R = 0.5`, `m = 1`).
fn impulse_ratios(vt: f64, mu: f64, e: f64) -> Result<(f64, f64)> {
    let (v, w) = oblique(vt, mu, e)?;
    let normal = 1.0 + v[2];
    Ok((
        (vt - v[0]) / (mu * normal),
        w[1] * 0.1 / 0.5 / (mu * normal),
    ))
}

#[test]
fn oblique_impacts_follow_coulomb_sliding_and_reverse_the_contact_point_when_sticking() -> Result<()>
{
    let mu = 0.2;
    // Gross sliding (tangential speed above 3.5 mu (1 + e) times the normal one): the
    // tangential impulse is mu times the normal one, in the rebound and in the spin.
    for vt in [2.0, 4.0] {
        let (from_v, from_w) = impulse_ratios(vt, mu, 1.0)?;
        // Measured: 1.2e-14.
        assert!(
            (from_v - 1.0).abs() < 1e-9 && (from_w - 1.0).abs() < 1e-9,
            "vt {vt}: {from_v}, {from_w}"
        );
        // With damping the tangential dashpot sits inside the Coulomb cap (as in LAMMPS
        // `tangential mindlin`): while the contact unloads, spring and dashpot shrink
        // below the cap and the impulse falls short of mu J_n, by 0.45 % at e = 0.8
        // (measured; 0.50 % at dt / 4, so not a time-step error).
        let (from_v, from_w) = impulse_ratios(vt, mu, 0.8)?;
        assert!((0.99..=1.0).contains(&from_v), "vt {vt}, e = 0.8: {from_v}");
        assert!(
            (from_v - from_w).abs() < 1e-9,
            "rebound and spin disagree: {from_v}, {from_w}"
        );
    }
    // Small incidence (tangential speed 0.1, far below the sliding limit): the tangential
    // spring stores the contact point's motion and drives it back, so the contact point
    // moves backwards in the middle of the contact (Maw, Barber & Fawcett 1976), which no
    // memoryless friction law can do (it only brakes the sliding towards zero).
    let law = law(1.0, mu);
    let mut scene = Scene::new(Dim::Three, [0.0; 3], [40.0, 4.0, 4.0], law)?;
    scene.set_rotation(true);
    scene.add_wall(Wall::plane([0.0, 0.0, 1.0], [0.0; 3], law))?;
    scene
        .add_particle(Particle::new([2.0, 2.0, 0.52], 0.5, 1.0).with_velocity([0.1, 0.0, -1.0]))?;
    let dt = hertz_contact_time(1.0, 0.5, law.e_star, 1.0) / 400.0;
    let mut sim = Dem::new(scene, &Config::default().with_dt(dt), Backend::Cpu)?;
    let mut slowest = f64::INFINITY;
    for _ in 0..60 {
        sim.step(10)?;
        let s = sim.state()?;
        slowest = slowest.min(s.velocities[0][0] - 0.5 * s.angular_velocities[0][1]);
    }
    // Measured: -0.123.
    assert!(
        slowest < -0.1,
        "the contact point never reversed: slowest {slowest} (in 0.1)"
    );
    Ok(())
}

#[test]
fn rolling_resistance_stops_a_ball_over_the_predicted_distance() -> Result<()> {
    // A ball rolling at 1 on a floor: the saturated rolling couple mu_r R |F_n| removes
    // kinetic energy (1 + 2/5) m v^2 / 2 over d = (1 + 2/5) v^2 / (2 mu_r g).
    let mu_r = 0.1;
    let law = law(0.5, 0.5).with_rolling(mu_r, 2000.0, 20.0);
    let mut scene = Scene::new(Dim::Three, [0.0; 3], [20.0, 4.0, 4.0], law)?;
    scene.set_gravity(1.0)?.set_rotation(true);
    scene.add_wall(Wall::plane([0.0, 0.0, 1.0], [0.0; 3], law))?;
    let ball = Particle::new([2.0, 2.0, 0.4985], 0.5, 1.0)
        .with_velocity([1.0, 0.0, 0.0])
        .with_angular_velocity([0.0, 2.0, 0.0]);
    scene.add_particle(ball)?;
    let mut sim = Dem::new(scene, &Config::default(), Backend::Cpu)?;
    let expected = 1.4 / (2.0 * mu_r);
    let chunk = (0.1 / sim.dt()) as u32;
    for _ in 0..400 {
        sim.step(chunk)?;
        let s = sim.state()?;
        if s.velocities[0][0] < 1e-3 {
            let d = s.positions[0][0] - 2.0;
            // Measured: 1.8e-5 short of it.
            assert!(
                (d / expected - 1.0).abs() < 5e-4,
                "stopped after {d}, expected {expected}"
            );
            return Ok(());
        }
    }
    panic!("the ball did not stop within 40 time units");
}

/// Three discs in a pyramid on a floor (2D, g = 1, rotation on): the two at the bottom
/// 0.1 apart, the third on top of both. The kinetic energy and the top disc's drop
/// after 60 time units.
fn pyramid<L: simkit_dem::ContactLaw>(law: L) -> Result<(f64, f64)> {
    let mut scene = Scene::new(Dim::Two, [0.0; 3], [8.0, 4.0, 0.0], law)?;
    scene.set_gravity(1.0)?.set_rotation(true);
    scene.add_wall(Wall::plane([0.0, 1.0, 0.0], [0.0; 3], law))?;
    let top = 0.5 + (1.0f64 - 0.55 * 0.55).sqrt();
    for x in [[3.45, 0.5], [4.55, 0.5], [4.0, top]] {
        scene.add_particle(Particle::new([x[0], x[1], 0.0], 0.5, 1.0))?;
    }
    let mut sim = Dem::new(scene, &Config::default(), Backend::Cpu)?;
    let steps = (60.0 / sim.dt()) as u32;
    sim.step(steps)?;
    let d = sim.diagnostics()?;
    let drop = top - sim.state()?.positions[2][1];
    Ok((d.kinetic + d.rotational, drop))
}

#[test]
fn static_friction_holds_a_pyramid_that_viscous_friction_lets_collapse() -> Result<()> {
    // Tangential springs (Cundall–Strack): the pile settles and stands still.
    let (ke, drop) = pyramid(law(0.5, 0.5))?;
    // Measured: kinetic energy 2e-27, the top disc 0.0017 lower (the contacts' static
    // compression).
    assert!(ke < 1e-20, "the pyramid still moves: kinetic energy {ke}");
    assert!(drop < 0.005, "the top disc sank by {drop}");
    // The linear law's friction is viscous (zero at zero sliding speed): the bottom discs
    // creep apart under the load and the top disc sinks.
    let (_, drop) = pyramid(Material::new(0.5, 0.05).with_friction(0.5, 40.0))?;
    // Measured: 0.84 (the pile collapsed).
    assert!(
        drop > 0.3,
        "the viscous pile held: the top disc sank by only {drop}"
    );
    Ok(())
}

#[test]
fn the_linear_law_with_history_rolls_without_slip_and_holds_the_pyramid() -> Result<()> {
    let theta = 20f64.to_radians();
    let law = LinearHistory::new(0.5, 0.05, 0.5);
    let (a, v, w) = incline(theta, law, 4.0, Precision::F64)?;
    let rolling = theta.sin() / 1.4;
    assert!(
        (a / rolling - 1.0).abs() < 1e-7,
        "rolling: a = {a}, expected {rolling}"
    );
    assert!(
        (v - 0.5 * w).abs() < 2e-5 * v,
        "rolling: v = {v}, w R = {}",
        0.5 * w
    );
    let (ke, drop) = pyramid(law)?;
    assert!(ke < 1e-20, "the pyramid still moves: kinetic energy {ke}");
    assert!(drop < 0.005, "the top disc sank by {drop}");
    Ok(())
}

/// 60 spheres with Hertz–Mindlin and rolling resistance poured into a box.
fn poured() -> Result<Scene<HertzMindlin>> {
    poured_with(law(0.6, 0.4).with_rolling(0.05, 2000.0, 20.0))
}

/// [`poured`] with another law.
fn poured_with(law: HertzMindlin) -> Result<Scene<HertzMindlin>> {
    let mut scene = Scene::new(Dim::Three, [0.0; 3], [4.0, 4.0, 8.0], law)?;
    scene
        .set_gravity(1.0)?
        .set_rotation(true)
        .add_box_walls(law, false)?;
    for k in 0..60 {
        let (x, y, z) = (k % 3, (k / 3) % 3, k / 9);
        let jitter = 0.02 * ((k * 7) % 5) as f64;
        let p = Particle::new(
            [
                0.9 + 1.1 * x as f64 + jitter,
                0.9 + 1.1 * y as f64,
                0.6 + 1.05 * z as f64,
            ],
            0.5,
            1.0,
        )
        .with_velocity([0.8 * jitter, -0.5 * jitter, 0.0]);
        scene.add_particle(p)?;
    }
    Ok(scene)
}

#[test]
fn a_checkpoint_with_contact_history_resumes_bit_for_bit() -> Result<()> {
    for backend in backends("a_checkpoint_with_contact_history_resumes_bit_for_bit") {
        let mut sim = Dem::new(poured()?, &Config::default(), backend)?;
        sim.step(3000)?;
        let bytes = sim.checkpoint()?;
        let mut resumed = Dem::<HertzMindlin>::resume(&bytes, backend)?;
        sim.step(1500)?;
        resumed.step(1500)?;
        let (a, b) = (sim.state()?, resumed.state()?);
        assert_eq!(a, b, "{}", sim.backend_name());
        assert!(
            a.angular_velocities
                .iter()
                .any(|w| w.iter().any(|&c| c.abs() > 1e-3)),
            "nothing spins on {}",
            sim.backend_name()
        );
        // The checkpoint holds the springs (on the GPU both copies of each contact).
        let saved = sim.checkpoint()?;
        let mut again = Dem::<HertzMindlin>::resume(&saved, backend)?;
        assert_eq!(again.checkpoint()?, saved, "{}", sim.backend_name());
    }
    Ok(())
}

#[test]
fn asking_for_the_forces_before_the_first_step_does_not_change_the_run() -> Result<()> {
    let mut asked = Dem::new(poured()?, &Config::default(), Backend::Cpu)?;
    let loads = asked.forces()?;
    // Gravity on every sphere (no contacts yet): -m g along z, no torque.
    assert!(
        loads.force.iter().all(|f| *f == [0.0, 0.0, -1.0]),
        "{:?}",
        loads.force[0]
    );
    assert!(loads.torque.iter().all(|t| *t == [0.0; 3]));
    let mut plain = Dem::new(poured()?, &Config::default(), Backend::Cpu)?;
    asked.step(2000)?;
    plain.step(2000)?;
    assert_eq!(asked.state()?, plain.state()?);
    // After a step: the forces the next step starts from, with contacts now.
    let loads = asked.forces()?;
    assert!(
        loads.torque.iter().any(|t| t.iter().any(|&c| c != 0.0)),
        "no torque"
    );
    Ok(())
}

#[test]
fn contact_history_survives_neighbour_list_rebuilds() -> Result<()> {
    // A thin skin rebuilds the lists (reordering the particles) every few steps, a thick
    // one seldom: with the history carried across, the runs differ by the round-off of the
    // force sums' order only. Measured: 7e-14 after 800 steps, 3e-11 after 1600, growing
    // smoothly (stick–slip amplifies round-off: 1e-3 after 3200); one spring lost at a
    // rebuild (a force of about mu m g for a step) would show at 1e-6.
    let run = |skin: f64| -> Result<simkit_dem::State> {
        let mut sim = Dem::new(poured()?, &Config::default().with_skin(skin), Backend::Cpu)?;
        sim.step(1600)?;
        let d = sim.diagnostics()?;
        assert!(d.contacts > 30, "only {} contacts", d.contacts);
        sim.state()
    };
    let (thin, thick) = (run(0.02)?, run(1.0)?);
    let worst = thin
        .positions
        .iter()
        .zip(&thick.positions)
        .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).abs()))
        .fold(0.0, f64::max);
    assert!(worst < 1e-9, "the runs differ by {worst}");
    Ok(())
}

#[test]
fn rotation_and_history_are_refused_with_position_verlet() -> Result<()> {
    let config = Config::default().with_integrator(simkit_dem::Integrator::PositionVerlet);
    let err = Dem::new(poured()?, &config, Backend::Cpu)
        .err()
        .expect("position Verlet refused");
    assert!(err.to_string().contains("velocity Verlet"), "{err}");
    Ok(())
}

#[test]
fn distributed_runs_pour_the_same_heap() -> Result<()> {
    // The poured box (walls on every side, rolling resistance) on DistributedDem in one
    // process against Dem: the two sum contacts in other orders, so they agree to rounding
    // over a stretch (the statistics of long runs: tests/distributed.rs).
    let mut dem = Dem::new(poured()?, &Config::default(), Backend::Cpu)?;
    let mut dist = DistributedDem::new(poured()?, &Config::default(), Comm::serial())?;
    dem.step(2000)?;
    dist.step(2000)?;
    let contacts = dem.diagnostics()?.contacts;
    let (a, b) = (dem.state()?, dist.state()?);
    let worst = |x: &[[f64; 3]], y: &[[f64; 3]]| {
        x.iter()
            .flatten()
            .zip(y.iter().flatten())
            .map(|(p, q)| (p - q).abs())
            .fold(0.0, f64::max)
    };
    let (dx, dw) = (
        worst(&a.positions, &b.positions),
        worst(&a.angular_velocities, &b.angular_velocities),
    );
    println!(
        "poured box, 2000 steps ({contacts} contacts): positions differ by {dx:.2e}, angular \
         velocities by {dw:.2e}"
    );
    assert!(contacts > 30, "{contacts} contacts");
    // Measured: 6.0e-11 and 1.1e-9 (rounding, grown by the 33 contacts).
    assert!(dx < 1e-9 && dw < 1e-8, "{dx:e} {dw:e}");
    assert!(
        b.angular_velocities
            .iter()
            .flatten()
            .any(|w| w.abs() > 1e-3)
    );
    let d = dist.diagnostics()?;
    assert!(d.rotational > 0.0, "{d:?}");
    Ok(())
}

/// A sphere (3D) or disc (2D) of radius 0.5 and mass 1 hitting a floor with normal speed 1
/// and tangential speed `vt`, without spin, under the elastic linear law with history
/// (`e = 1`, `t_c = 0.01`, `mu`, `k_t / k_n = ratio`): the tangential velocity of the
/// contact point, the centre's tangential velocity and the spin after the impact.
fn linear_oblique(dim: Dim, ratio: f64, mu: f64, vt: f64) -> Result<(f64, f64, f64)> {
    let law = LinearHistory::new(1.0, 0.01, mu).with_stiffness_ratio(ratio);
    let up = dim.vertical();
    let mut hi = [40.0, 4.0, 4.0];
    let mut x = [2.0, 2.0, 2.0];
    let mut v = [vt, 0.0, 0.0];
    let mut normal = [0.0; 3];
    if dim == Dim::Two {
        hi[2] = 0.0;
        x[2] = 0.0;
    }
    x[up] = 0.501;
    v[up] = -1.0;
    normal[up] = 1.0;
    let mut scene = Scene::new(dim, [0.0; 3], hi, law)?;
    scene.set_rotation(true);
    scene.add_wall(Wall::plane(normal, [0.0; 3], law))?;
    scene.add_particle(Particle::new(x, 0.5, 1.0).with_velocity(v))?;
    let dt = 0.01 / 2000.0;
    let mut sim = Dem::new(
        scene,
        &Config::default().with_dt(dt).with_check_every(0),
        Backend::Cpu,
    )?;
    // 0.001 of flight, the contact (0.01), and 0.002 away.
    sim.step(2600)?;
    let s = sim.state()?;
    assert!(s.positions[0][up] > 0.501, "still in contact");
    // The spin about the axis normal to the floor and the motion: y in 3D, z in 2D (whose
    // sign is opposite: a disc rolling along +x on a floor turns clockwise).
    let w = match dim {
        Dim::Three => s.angular_velocities[0][1],
        Dim::Two => -s.angular_velocities[0][2],
    };
    Ok((s.velocities[0][0] - 0.5 * w, s.velocities[0][0], w))
}

#[test]
fn oblique_impacts_of_the_linear_law_follow_its_exact_curve_over_all_incidences() -> Result<()> {
    // With k_t / k_n = 1 / (1 + m R^2 / I) (2/7 for spheres, 1/3 for discs) the tangential
    // spring of the contact point (effective mass m / (1 + m R^2 / I)) oscillates with the
    // normal one, and the elastic impact has a closed form in the normalised incidence
    // psi = (k_t / k_n) w / (mu v_n) (w the contact point's tangential speed): for
    // psi <= 1 the contact sticks throughout and the contact point leaves reversed,
    // psi' = -psi; for psi > 1 the spring sits on the Coulomb cap mu |F_n| for the whole
    // contact and psi' = psi - 2 (the gross-sliding line, tangential impulse mu J_n).
    // This is the linear model's counterpart of the curves of Maw, Barber & Fawcett (1976)
    // and Thornton, Cummins & Cleary (2011), derived in docs/dem.md.
    let mu = 0.3;
    for (dim, ratio, inertia) in [(Dim::Three, 2.0 / 7.0, 0.4), (Dim::Two, 1.0 / 3.0, 0.5)] {
        // The largest error on each branch: in psi', and in the rebound velocity and spin
        // relative to the incident tangential speed.
        let (mut sticking, mut sliding) = (0.0f64, 0.0f64);
        for psi in [0.1, 0.4, 0.8, 0.95, 1.05, 1.3, 1.7, 2.0, 3.0, 6.0] {
            let vt = psi * mu / ratio;
            let (w, v, spin) = linear_oblique(dim, ratio, mu, vt)?;
            let exact = if psi <= 1.0 { -psi } else { psi - 2.0 };
            // The rebound velocity and spin that the contact point's speed implies: the
            // tangential impulse m (v' - vt) turns the particle by (vt - v') m R / I
            // (m = 1, R = 0.5, I = inertia m R^2).
            let v_exact = (exact * mu / ratio + vt / inertia) / (1.0 + 1.0 / inertia);
            let spin_exact = (vt - v_exact) / (inertia * 0.5);
            let err = (ratio * w / mu - exact)
                .abs()
                .max((v - v_exact).abs() / vt)
                .max((spin - spin_exact).abs() / vt);
            if psi <= 1.0 {
                sticking = sticking.max(err);
            } else {
                sliding = sliding.max(err);
            }
        }
        // Measured (dt = t_c / 2000): sticking 1.8e-3 in 3D, 1.6e-3 in 2D, first order in
        // dt (half at t_c / 4000: the spring is advanced with the velocity of the step
        // before); sliding: 3.5e-10 in both.
        assert!(
            sticking < 2.5e-3,
            "{dim:?}: sticking branch off by {sticking}"
        );
        assert!(sliding < 1e-9, "{dim:?}: sliding branch off by {sliding}");
        println!("{dim:?}: sticking {sticking:.2e}, sliding {sliding:.2e}");
    }
    Ok(())
}

/// The GPU backend's rotation and contact history against the CPU's.
#[cfg(feature = "gpu")]
mod gpu {
    use super::*;

    /// The largest difference between two runs' positions and angular velocities.
    fn worst_differences(a: &simkit_dem::State, b: &simkit_dem::State) -> (f64, f64) {
        let worst = |x: &[[f64; 3]], y: &[[f64; 3]]| {
            assert_eq!(x.len(), y.len());
            x.iter()
                .zip(y)
                .flat_map(|(p, q)| p.iter().zip(q).map(|(u, v)| (u - v).abs()))
                .fold(0.0, f64::max)
        };
        (
            worst(&a.positions, &b.positions),
            worst(&a.angular_velocities, &b.angular_velocities),
        )
    }

    /// How far the GPU runs of `scene` part from the CPU's `f64` run after `steps`, against how
    /// far the CPU's `f32` run does (the round-off yardstick) and how far the `f64` run of
    /// `control` (the same scene without its rolling resistance) does (what the test must see):
    /// `(positions, angular velocities)` each.
    struct Parting {
        single: (f64, f64),
        control: (f64, f64),
        gpus: Vec<(String, (f64, f64))>,
    }

    fn parting<L: ContactLaw>(
        test: &str,
        scene: &Scene<L>,
        control: &Scene<L>,
        steps: u32,
    ) -> Result<Parting> {
        let run = |scene: &Scene<L>, backend, precision| -> Result<(String, simkit_dem::State)> {
            let cfg = Config::default().with_precision(precision);
            let mut sim = Dem::new(scene.clone(), &cfg, backend)?;
            sim.step(steps)?;
            Ok((sim.backend_name(), sim.state()?))
        };
        let (_, exact) = run(scene, Backend::Cpu, Precision::F64)?;
        let (_, single) = run(scene, Backend::Cpu, Precision::F32)?;
        let (_, other) = run(control, Backend::Cpu, Precision::F64)?;
        let mut gpus = Vec::new();
        for backend in backends(test) {
            if matches!(backend, Backend::Gpu(_)) {
                let (name, state) = run(scene, backend, Precision::F32)?;
                gpus.push((name, worst_differences(&exact, &state)));
            }
        }
        Ok(Parting {
            single: worst_differences(&exact, &single),
            control: worst_differences(&exact, &other),
            gpus,
        })
    }

    #[test]
    fn the_gpu_runs_rotation_and_contact_history_as_the_cpu_does() -> Result<()> {
        let test = "the_gpu_runs_rotation_and_contact_history_as_the_cpu_does";
        // 3D: Hertz–Mindlin with rolling resistance, 60 spheres poured into a box (walls with
        // history too), onto the floor and into each other.
        let hertz = law(0.6, 0.4);
        let rolling = poured_with(hertz.with_rolling(0.05, 2000.0, 20.0))?;
        let plain = poured_with(hertz)?;
        // 2D: the linear law with history and rolling friction in a drum turning fast enough
        // that the shell drags the discs within the run.
        let linear = LinearHistory::new(0.5, 0.03, 0.5);
        let p = simkit_dem::scenes::DrumParams {
            n: 200,
            froude: 1.5,
            ..Default::default()
        };
        let drum = simkit_dem::scenes::rotating_drum(linear.with_rolling_friction(0.1), None, &p)?;
        let free = simkit_dem::scenes::rotating_drum(linear, None, &p)?;
        // Steps where the runs have met but round-off has not yet grown to the size of the
        // grains' motion (by 2100 steps the f32 runs part from f64 by 0.03 to 0.6).
        for (name, r) in [
            ("poured, 700 steps", parting(test, &rolling, &plain, 700)?),
            ("drum, 1400 steps", parting(test, &drum, &free, 1400)?),
        ] {
            println!(
                "{name}: CPU f32 parts from f64 by {:.2e} (positions) / {:.2e} (angular \
                 velocities), the run without rolling resistance by {:.2e} / {:.2e}",
                r.single.0, r.single.1, r.control.0, r.control.1
            );
            for (gpu, (x, w)) in r.gpus {
                println!("{name}: {gpu} parts by {x:.2e} / {w:.2e}");
                // Measured on lavapipe: poured 7.2e-4 / 9.0e-3 against the CPU's f32
                // 7.2e-4 / 5.1e-3 (1.0x / 1.8x), the drum 3.0e-4 / 1.5e-2, equal to the
                // CPU's f32; the runs without rolling resistance part by 135x and 184x more.
                // Bound: 3x the CPU's f32, and 30x below the control.
                assert!(
                    x <= 3.0 * r.single.0 && w <= 3.0 * r.single.1,
                    "{name}: {gpu} parts from f64 by {x:.2e} / {w:.2e}, f32 on the CPU by \
                     {:.2e} / {:.2e}",
                    r.single.0,
                    r.single.1
                );
                assert!(
                    30.0 * x <= r.control.0,
                    "{name}: the test cannot see the rolling resistance: {x:.2e} vs {:.2e}",
                    r.control.0
                );
            }
        }
        Ok(())
    }

    #[test]
    fn a_grain_with_more_contacts_than_the_gpu_keeps_is_a_clear_error() -> Result<()> {
        let Some(ctx) = simkit_backend::testing::gpu_or_skip(
            "a_grain_with_more_contacts_than_the_gpu_keeps_is_a_clear_error",
        ) else {
            return Ok(());
        };
        // A disc of radius 1 touched by 16 discs of radius 0.2 (the GPU keeps 12 per disc).
        let law = LinearHistory::new(0.5, 0.05, 0.5);
        let mut scene = Scene::new(Dim::Two, [0.0; 3], [6.0, 6.0, 0.0], law)?;
        scene.add_particle(Particle::new([3.0, 3.0, 0.0], 1.0, 1.0))?;
        for k in 0..16 {
            let a = std::f64::consts::TAU * k as f64 / 16.0;
            let at = [3.0 + 1.199 * a.cos(), 3.0 + 1.199 * a.sin(), 0.0];
            scene.add_particle(Particle::new(at, 0.2, 0.04))?;
        }
        let mut cpu = Dem::new(scene.clone(), &Config::default(), Backend::Cpu)?;
        cpu.step(10)?;
        let mut gpu = Dem::new(scene, &Config::default(), Backend::Gpu(&ctx))?;
        let err = gpu.step(10).expect_err("16 contacts on one disc");
        let text = err.to_string();
        assert!(
            matches!(err, simkit_backend::Error::BlowUp { .. })
                && text.contains("particle 0 has more than 12"),
            "{text}"
        );
        Ok(())
    }
}
