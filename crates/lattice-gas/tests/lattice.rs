//! The lattice and its settings: relaxation to equilibrium, obstacle masks and bad input.

use simkit_backend::{Backend, Simulation};
use simkit_lattice_gas::{Config, CpuMethod, Lattice, LatticeGas, Obstacle, RuleSet};

/// A CPU simulation with the given method.
fn cpu(lattice: Lattice, config: Config, method: CpuMethod) -> simkit_backend::Result<LatticeGas> {
    let config = Config {
        cpu: method,
        ..config
    };
    LatticeGas::new(lattice, &config, Backend::Cpu)
}

/// Relaxation to equilibrium from far away: at the start only east- and west-movers (each
/// with probability 1/2; the other four directions empty, zero momentum). Streaming alone
/// would keep the occupations at (1/2, 0, 0, 1/2, 0, 0) for ever; the collisions must spread
/// the particles over all six directions, to the equilibrium 1/6 each (equal occupations at
/// zero velocity). Checked for both rule sets and both CPU methods: after 100 steps the six
/// mean occupations over 40 samples agree within 5 standard errors (the samples are 25
/// steps apart, close to independent).
#[test]
fn relaxation_to_equal_occupations_from_far_away() {
    for (rules, method) in [
        (RuleSet::FhpI, CpuMethod::MultiSpin),
        (RuleSet::Full, CpuMethod::Lut),
    ] {
        let mut lattice = Lattice::new(256, 128).unwrap();
        lattice
            .fill_with(21, |_, _, k| if k == 0 || k == 3 { 0.5 } else { 0.0 })
            .unwrap();
        let occupations = |l: &Lattice| {
            let mut sums = [0f64; 6];
            for c in l.cells() {
                for (k, s) in sums.iter_mut().enumerate() {
                    *s += f64::from((c >> k) & 1);
                }
            }
            sums.map(|s| s / l.cells().len() as f64)
        };
        let start = occupations(&lattice);
        assert!(start[1] == 0.0 && start[2] == 0.0 && start[4] == 0.0 && start[5] == 0.0);
        let config = Config {
            rules,
            ..Config::default()
        };
        let mut sim = cpu(lattice, config, method).unwrap();
        sim.step(100).unwrap();
        let mut means = [0f64; 6];
        let samples = 40;
        for _ in 0..samples {
            sim.step(25).unwrap();
            let o = occupations(&sim.state().unwrap());
            for k in 0..6 {
                means[k] += o[k] / f64::from(samples);
            }
        }
        let n = (256 * 128 * samples) as f64;
        let sigma = ((1.0 / 6.0) * (5.0 / 6.0) / n).sqrt();
        println!("{rules:?}: start {start:?}, relaxed {means:?}, sigma {sigma:.1e}");
        // Particles are conserved: equilibrium is the starting total over six directions.
        let equilibrium = start.iter().sum::<f64>() / 6.0;
        for m in &means {
            assert!(
                (m - equilibrium).abs() < 5.0 * sigma,
                "{rules:?}: means {means:?}, equilibrium {equilibrium}"
            );
        }
    }
}

#[test]
fn bad_input_is_refused() {
    assert!(Lattice::new(0, 4).is_err());
    assert!(Lattice::new(4, 0).is_err());
    let odd = Lattice::new(64, 5).unwrap();
    let e = cpu(odd.clone(), Config::default(), CpuMethod::Lut)
        .err()
        .unwrap();
    assert!(e.to_string().contains("even"), "{e}");
    assert!(cpu(odd.clone(), Config::default(), CpuMethod::MultiSpin).is_err());
    let ok = Config {
        periodic_y: false,
        ..Config::default()
    };
    assert!(cpu(odd, ok, CpuMethod::Lut).is_ok());
    let mut l = Lattice::new(64, 4).unwrap();
    let mask = Obstacle::Mask {
        width: 10,
        height: 4,
        data: vec![false; 40],
    };
    assert!(l.add_obstacle(&mask).is_err());
    for p in [-0.1, 1.5, f64::NAN] {
        let config = Config {
            body_force: p,
            ..Config::default()
        };
        assert!(config.validate().is_err());
        assert!(cpu(l.clone(), config, CpuMethod::Lut).is_err());
    }
    assert!(l.fill_random(1.2, 1).is_err());
    assert!(Lattice::from_cells(2, 2, vec![64, 0, 0, 0]).is_err());
    assert!(Lattice::from_cells(2, 2, vec![0, 0, 0]).is_err());
    assert!(l.set(64, 0, 1).is_err());
    // Multi-spin needs a width that is a multiple of 64; the automatic choice falls back to
    // the lookup table.
    let narrow = Lattice::new(48, 4).unwrap();
    assert!(cpu(narrow.clone(), Config::default(), CpuMethod::MultiSpin).is_err());
    assert!(cpu(narrow.clone(), Config::default(), CpuMethod::Lut).is_ok());
    assert!(cpu(narrow.clone(), Config::default(), CpuMethod::Auto).is_ok());
    // The GPU bit-plane layout needs a multiple of 32.
    #[cfg(feature = "gpu")]
    if let Some(ctx) = simkit_backend::testing::gpu_or_skip("lattice-gas bad layout") {
        use simkit_lattice_gas::GpuLayout;
        let gpu = |lattice: Lattice, layout| {
            let config = Config {
                gpu_layout: Some(layout),
                ..Config::default()
            };
            LatticeGas::new(lattice, &config, Backend::Gpu(&ctx))
        };
        assert!(gpu(Lattice::new(40, 4).unwrap(), GpuLayout::BitPlanes).is_err());
        assert!(gpu(narrow, GpuLayout::Bytes).is_ok());
        assert!(gpu(Lattice::new(96, 4).unwrap(), GpuLayout::BitPlanes).is_ok());
    }
    let inflow_periodic = Config {
        inflow: true,
        ..Config::default()
    };
    assert!(inflow_periodic.validate().is_err());
    assert!(
        cpu(
            Lattice::new(64, 4).unwrap(),
            inflow_periodic,
            CpuMethod::Lut
        )
        .is_err()
    );
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

#[test]
fn overflowing_lattice_sizes_are_refused() {
    // 2^32 x 2^32 = 2^64 used to wrap to 0 in the size check: accepted with no storage.
    let big = 1usize << 32;
    for (w, h) in [(big, big), (usize::MAX, 2), (big, 1), (65_536, 65_537)] {
        let e = Lattice::new(w, h).unwrap_err().to_string();
        assert!(e.contains(&format!("lattice size: {w} x {h}")), "{e}");
        assert!(e.contains("more than 2^32 - 1 sites"), "{e}");
        let e = Lattice::from_cells(w, h, Vec::new())
            .unwrap_err()
            .to_string();
        assert!(e.contains(&format!("lattice size: {w} x {h}")), "{e}");
    }
}
