//! Conservation, bit-identity of the three backends, the source's hand test, equilibrium and
//! bad input.

use simkit_backend::Backend;
#[cfg(feature = "gpu")]
use simkit_backend::GpuContext;
#[cfg(feature = "gpu")]
use simkit_backend::Simulation;
use simkit_backend::testing::backends;
#[cfg(feature = "gpu")]
use simkit_backend::testing::gpu_or_skip;
use simkit_lattice_gas::random::chirality;
use simkit_lattice_gas::{Engine, Lattice, Obstacle, Params, RuleSet, simulation};
#[cfg(feature = "gpu")]
use simkit_lattice_gas::{GpuLattice, GpuLayout};

fn periodic_box(w: usize, h: usize, d: f64, seed: u32) -> Lattice {
    let mut l = Lattice::new(w, h).unwrap();
    l.fill_random(d, seed).unwrap();
    l
}

fn channel(w: usize, h: usize) -> (Lattice, Params) {
    let mut l = Lattice::new(w, h).unwrap();
    l.fill_random(0.3, 11).unwrap();
    l.add_wall_rows();
    l.add_obstacle(&Obstacle::Rect {
        x0: w / 4,
        x1: w / 4 + 2,
        y0: h / 3,
        y1: 2 * h / 3,
    })
    .unwrap();
    l.add_obstacle(&Obstacle::Disc {
        cx: w as f64 * 0.6,
        cy: h as f64 * 0.4,
        radius: 5.0,
    })
    .unwrap();
    let params = Params {
        periodic_x: false,
        periodic_y: false,
        inflow: true,
        outflow: true,
        seed: 5,
        ..Params::default()
    };
    (l, params)
}

/// Both CPU engines, then the GPU (bit planes) when `backends` offers one.
fn engines(test: &str) -> Vec<Engine<'static>> {
    let mut e = vec![Engine::Lut, Engine::MultiSpin];
    for backend in backends(test) {
        if !matches!(backend, Backend::Cpu) {
            e.push(Engine::for_backend(backend, 0));
        }
    }
    e
}

/// The byte-layout GPU engine's result, when the GPU is compiled in and present.
#[cfg(feature = "gpu")]
fn gpu_bytes(test: &str, lattice: &Lattice, params: &Params, steps: u32) -> Option<Lattice> {
    simkit_backend::testing::shared_gpu(test).map(|ctx| run_gpu_bytes(ctx, lattice, params, steps))
}
#[cfg(not(feature = "gpu"))]
fn gpu_bytes(_: &str, _: &Lattice, _: &Params, _: u32) -> Option<Lattice> {
    None
}

#[cfg(feature = "gpu")]
/// The byte-layout GPU backend (the engines above get bit-planes for widths divisible by 32).
fn run_gpu_bytes(ctx: &GpuContext, lattice: &Lattice, params: &Params, steps: u32) -> Lattice {
    let mut sim =
        GpuLattice::with_layout(ctx, lattice.clone(), params.clone(), GpuLayout::Bytes).unwrap();
    sim.step(steps).unwrap();
    assert!(sim.backend_name().contains("bytes"));
    sim.state().unwrap()
}

fn run(lattice: &Lattice, params: &Params, engine: Engine<'_>, steps: u32) -> Lattice {
    let mut sim = simulation(lattice.clone(), params.clone(), engine).unwrap();
    sim.step(steps).unwrap();
    assert_eq!(sim.steps_done(), u64::from(steps));
    sim.state().unwrap()
}

#[test]
fn conservation_over_1000_steps_every_backend_both_rule_sets() {
    let test = "lattice-gas conservation";
    let lattice = periodic_box(64, 32, 0.3, 3);
    let n0 = lattice.particle_count();
    let p0 = lattice.momentum_units();
    for rules in [RuleSet::FhpI, RuleSet::Full] {
        let params = Params {
            rules,
            ..Params::default()
        };
        for engine in engines(test) {
            let mut sim = simulation(lattice.clone(), params.clone(), engine).unwrap();
            for _ in 0..10 {
                sim.step(100).unwrap();
                let l = sim.state().unwrap();
                assert_eq!(l.particle_count(), n0, "{rules:?} {}", sim.backend_name());
                assert_eq!(l.momentum_units(), p0, "{rules:?} {}", sim.backend_name());
            }
            // The lattice did change.
            assert_ne!(sim.state().unwrap(), lattice);
        }
        if let Some(l) = gpu_bytes(test, &lattice, &params, 1000) {
            assert_eq!(l.particle_count(), n0, "{rules:?} gpu bytes");
            assert_eq!(l.momentum_units(), p0, "{rules:?} gpu bytes");
        }
    }
}

#[test]
fn backends_bit_identical_channel_and_periodic_box() {
    let test = "lattice-gas bit identity";
    let (chan, chan_params) = channel(128, 64);
    let boxed = periodic_box(128, 64, 0.25, 9);
    for rules in [RuleSet::FhpI, RuleSet::Full] {
        for (lattice, base) in [(&chan, chan_params.clone()), (&boxed, Params::default())] {
            let params = Params { rules, ..base };
            let reference = run(lattice, &params, Engine::Lut, 500);
            for engine in engines(test).into_iter().skip(1) {
                let got = run(lattice, &params, engine, 500);
                assert!(
                    got == reference,
                    "{rules:?} {engine:?} differs from the LUT backend"
                );
            }
            if let Some(got) = gpu_bytes(test, lattice, &params, 500) {
                assert!(got == reference, "{rules:?} GPU bytes differs from LUT");
            }
        }
    }
    // The channel flows: the inflow injects east-movers, the walls and outflow keep their state.
    let out = run(&chan, &chan_params, Engine::Lut, 500);
    assert!(out.momentum_units().0 > 0);
}

#[test]
fn body_force_bit_identical_and_drives_flow() {
    let test = "lattice-gas body force";
    let mut l = Lattice::new(64, 34).unwrap();
    l.add_wall_rows();
    l.fill_random(0.2, 4).unwrap();
    let params = Params {
        periodic_y: false,
        body_force: 0.01,
        ..Params::default()
    };
    let reference = run(&l, &params, Engine::Lut, 300);
    for engine in engines(test).into_iter().skip(1) {
        assert!(run(&l, &params, engine, 300) == reference, "{engine:?}");
    }
    if let Some(got) = gpu_bytes(test, &l, &params, 300) {
        assert!(got == reference, "GPU bytes");
    }
    assert!(reference.momentum_units().0 > l.momentum_units().0 + 200);
    assert_eq!(reference.particle_count(), l.particle_count());
}

#[test]
fn hand_test_head_on_pair_gives_18_or_36() {
    let test = "lattice-gas hand test";
    let (w, h, j) = (64usize, 8usize, 2usize);
    let mut seen = [false, false];
    for seed in 0..16u32 {
        let mut l = Lattice::new(w, h).unwrap();
        l.set(4, j, 1).unwrap(); // east-mover
        l.set(6, j, 8).unwrap(); // west-mover
        let params = Params {
            seed,
            ..Params::default()
        };
        let bit = chirality(seed, 0, (j * w + 5) as u32);
        let want = if bit == 1 { 18 } else { 36 };
        seen[bit as usize] = true;
        for engine in engines(test) {
            let out = run(&l, &params, engine, 1);
            assert_eq!(out.get(5, j), Some(want), "seed {seed} {engine:?}");
            assert_eq!(out.particle_count(), 2);
        }
    }
    assert!(seen[0] && seen[1], "both random outcomes occur");
}

#[test]
fn equilibrium_occupations_are_equal() {
    let lattice = periodic_box(256, 128, 0.3, 21);
    let mut sim = simulation(lattice, Params::default(), Engine::MultiSpin).unwrap();
    sim.step(100).unwrap();
    let mut sums = [0f64; 6];
    let samples = 40;
    for _ in 0..samples {
        sim.step(25).unwrap();
        let l = sim.state().unwrap();
        for c in l.cells() {
            for (k, s) in sums.iter_mut().enumerate() {
                *s += f64::from((c >> k) & 1);
            }
        }
    }
    let n = (256 * 128 * samples) as f64;
    let means: Vec<f64> = sums.iter().map(|s| s / n).collect();
    let avg = means.iter().sum::<f64>() / 6.0;
    // Standard error of one mean if the samples were independent: sqrt(d(1-d)/n) ~ 4e-4.
    let sigma = (avg * (1.0 - avg) / n).sqrt();
    for m in &means {
        assert!((m - avg).abs() < 5.0 * sigma + 1e-4, "means {means:?}");
    }
    assert!((avg - 0.3).abs() < 0.01);
}

#[test]
fn bad_input_is_refused() {
    assert!(Lattice::new(0, 4).is_err());
    assert!(Lattice::new(4, 0).is_err());
    let odd = Lattice::new(64, 5).unwrap();
    let e = simulation(odd.clone(), Params::default(), Engine::Lut)
        .err()
        .unwrap();
    assert!(e.to_string().contains("even"), "{e}");
    assert!(simulation(odd.clone(), Params::default(), Engine::MultiSpin).is_err());
    let ok = Params {
        periodic_y: false,
        ..Params::default()
    };
    assert!(simulation(odd, ok, Engine::Lut).is_ok());
    let mut l = Lattice::new(64, 4).unwrap();
    let mask = Obstacle::Mask {
        width: 10,
        height: 4,
        data: vec![false; 40],
    };
    assert!(l.add_obstacle(&mask).is_err());
    for p in [-0.1, 1.5, f64::NAN] {
        let params = Params {
            body_force: p,
            ..Params::default()
        };
        assert!(simulation(l.clone(), params, Engine::Lut).is_err());
    }
    assert!(l.fill_random(1.2, 1).is_err());
    assert!(Lattice::from_cells(2, 2, vec![64, 0, 0, 0]).is_err());
    assert!(Lattice::from_cells(2, 2, vec![0, 0, 0]).is_err());
    assert!(l.set(64, 0, 1).is_err());
    // Multi-spin needs a width that is a multiple of 64.
    let narrow = Lattice::new(48, 4).unwrap();
    assert!(simulation(narrow.clone(), Params::default(), Engine::MultiSpin).is_err());
    assert!(simulation(narrow.clone(), Params::default(), Engine::Lut).is_ok());
    // The GPU bit-plane layout needs a multiple of 32.
    #[cfg(feature = "gpu")]
    if let Some(ctx) = gpu_or_skip("lattice-gas bad layout") {
        let e = GpuLattice::with_layout(
            &ctx,
            Lattice::new(40, 4).unwrap(),
            Params::default(),
            GpuLayout::BitPlanes,
        );
        assert!(e.is_err());
        assert!(GpuLattice::with_layout(&ctx, narrow, Params::default(), GpuLayout::Bytes).is_ok());
        let w96 = Lattice::new(96, 4).unwrap();
        assert!(
            GpuLattice::with_layout(&ctx, w96, Params::default(), GpuLayout::BitPlanes).is_ok()
        );
    }
    let inflow_periodic = Params {
        inflow: true,
        ..Params::default()
    };
    assert!(simulation(Lattice::new(64, 4).unwrap(), inflow_periodic, Engine::Lut).is_err());
}

#[cfg(feature = "gpu")]
#[test]
fn gpu_matches_lut_on_odd_sizes() {
    // Widths that are not multiples of 4 (the GPU packs four sites per word) or 64.
    let Some(ctx) = gpu_or_skip("lattice-gas odd sizes") else {
        return;
    };
    let (chan, chan_params) = channel(50, 31);
    let boxed = periodic_box(37, 18, 0.3, 4);
    let forced = Params {
        body_force: 0.05,
        periodic_y: false,
        rules: RuleSet::Full,
        ..Params::default()
    };
    for (lattice, params) in [
        (&chan, chan_params),
        (&boxed, Params::default()),
        (&boxed, forced),
    ] {
        let reference = run(lattice, &params, Engine::Lut, 200);
        assert_ne!(&reference, lattice);
        assert!(
            run(lattice, &params, Engine::Gpu(&ctx), 200) == reference,
            "{params:?}"
        );
    }
}

#[test]
fn obstacle_from_data_mask() {
    // 8 x 6 mask, a 2 x 2 wall square at columns 2..4 of the two top rows. Mask rows are
    // lattice rows: data[j * 8 + i] is site (i, j), row 0 the bottom.
    let (w, h) = (8usize, 6usize);
    let mut data = vec![false; w * h];
    for (i, j) in [(2, 4), (3, 4), (2, 5), (3, 5)] {
        data[j * w + i] = true;
    }
    let obstacle = Obstacle::Mask {
        width: w,
        height: h,
        data,
    };
    let mut l = Lattice::new(w, h).unwrap();
    l.add_obstacle(&obstacle).unwrap();
    let walls: Vec<(usize, usize)> = (0..h)
        .flat_map(|j| (0..w).map(move |i| (i, j)))
        .filter(|&(i, j)| l.get(i, j).unwrap() & simkit_lattice_gas::WALL != 0)
        .collect();
    // The last mask row is the top row of the lattice (j = 5).
    assert_eq!(walls, vec![(2, 4), (3, 4), (2, 5), (3, 5)]);
    // A mask of another size is refused, and so is one whose data does not fill it.
    assert!(Lattice::new(8, 8).unwrap().add_obstacle(&obstacle).is_err());
    let short = Obstacle::Mask {
        width: w,
        height: h,
        data: vec![true; w * h - 1],
    };
    assert!(Lattice::new(w, h).unwrap().add_obstacle(&short).is_err());
}
