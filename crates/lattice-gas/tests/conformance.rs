//! Conformance: the same scenes on every backend of `simkit_backend::testing::backends`, every
//! CPU method on the CPU and every layout on the GPU. The backends promise bit-identical
//! lattices, so every comparison is exact (`==` on the whole lattice) against the CPU lookup
//! table; conservation and the source's hand test are checked on each of them.

use simkit_backend::testing::backends;
use simkit_backend::{Backend, Simulation};
use simkit_lattice_gas::BlockField;
use simkit_lattice_gas::laws::chirality;
use simkit_lattice_gas::{Config, CpuMethod, GpuLayout, Lattice, LatticeGas, Obstacle, RuleSet};

/// One way to run a scene: a backend and the backend choices of [`Config`] it reads.
#[derive(Clone, Copy, Debug)]
struct Variant {
    backend: Backend<'static>,
    cpu: CpuMethod,
    gpu_layout: Option<GpuLayout>,
}

impl Variant {
    /// The CPU lookup table: the reference every other variant is compared with.
    const REFERENCE: Variant = Variant {
        backend: Backend::Cpu,
        cpu: CpuMethod::Lut,
        gpu_layout: None,
    };
}

/// Every variant that accepts a lattice `width` sites wide: on the CPU each [`CpuMethod`]
/// (multi-spin needs a multiple of 64), on the GPU (when `backends` offers one) the automatic
/// layout and each explicit one (bit-planes need a multiple of 32).
fn variants(test: &str, width: usize) -> Vec<Variant> {
    let mut list = Vec::new();
    for backend in backends(test) {
        match backend {
            Backend::Cpu => {
                for cpu in [CpuMethod::Lut, CpuMethod::MultiSpin, CpuMethod::Auto] {
                    if cpu != CpuMethod::MultiSpin || width.is_multiple_of(64) {
                        list.push(Variant {
                            backend,
                            cpu,
                            gpu_layout: None,
                        });
                    }
                }
            }
            #[cfg(feature = "gpu")]
            Backend::Gpu(_) => {
                for layout in [None, Some(GpuLayout::BitPlanes), Some(GpuLayout::Bytes)] {
                    if layout != Some(GpuLayout::BitPlanes) || width.is_multiple_of(32) {
                        list.push(Variant {
                            backend,
                            cpu: CpuMethod::Auto,
                            gpu_layout: layout,
                        });
                    }
                }
            }
        }
    }
    list
}

/// `config` with the backend choices of `variant`.
fn configured(config: &Config, variant: Variant) -> Config {
    Config {
        cpu: variant.cpu,
        gpu_layout: variant.gpu_layout,
        ..config.clone()
    }
}

fn simulation(lattice: &Lattice, config: &Config, variant: Variant) -> LatticeGas {
    LatticeGas::new(
        lattice.clone(),
        &configured(config, variant),
        variant.backend,
    )
    .unwrap()
}

/// The lattice after `steps` steps of `variant`, with the backend that ran it.
fn run(lattice: &Lattice, config: &Config, variant: Variant, steps: u32) -> (Lattice, String) {
    let mut sim = simulation(lattice, config, variant);
    sim.step(steps).unwrap();
    assert_eq!(sim.steps_done(), u64::from(steps));
    (sim.state().unwrap(), sim.backend_name())
}

fn periodic_box(w: usize, h: usize, d: f64, seed: u32) -> Lattice {
    let mut l = Lattice::new(w, h).unwrap();
    l.fill_random(d, seed).unwrap();
    l
}

fn channel(w: usize, h: usize) -> (Lattice, Config) {
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
    let config = Config {
        periodic_x: false,
        periodic_y: false,
        inflow: true,
        outflow: true,
        seed: 5,
        ..Config::default()
    };
    (l, config)
}

#[test]
fn conservation_over_1000_steps_every_backend_both_rule_sets() {
    let lattice = periodic_box(64, 32, 0.3, 3);
    let n0 = lattice.particle_count();
    let p0 = lattice.momentum_units();
    for rules in [RuleSet::FhpI, RuleSet::Full] {
        let config = Config {
            rules,
            ..Config::default()
        };
        for variant in variants("lattice-gas conservation", lattice.width()) {
            let mut sim = simulation(&lattice, &config, variant);
            for _ in 0..10 {
                sim.step(100).unwrap();
                let l = sim.state().unwrap();
                assert_eq!(l.particle_count(), n0, "{rules:?} {}", sim.backend_name());
                assert_eq!(l.momentum_units(), p0, "{rules:?} {}", sim.backend_name());
            }
            // The lattice did change.
            assert_ne!(sim.state().unwrap(), lattice);
        }
    }
}

#[test]
fn backends_bit_identical_channel_and_periodic_box() {
    let (chan, chan_config) = channel(128, 64);
    let boxed = periodic_box(128, 64, 0.25, 9);
    for rules in [RuleSet::FhpI, RuleSet::Full] {
        for (lattice, base) in [(&chan, chan_config.clone()), (&boxed, Config::default())] {
            let config = Config { rules, ..base };
            let (reference, _) = run(lattice, &config, Variant::REFERENCE, 500);
            for variant in variants("lattice-gas bit identity", lattice.width()) {
                let (got, name) = run(lattice, &config, variant, 500);
                assert!(
                    got == reference,
                    "{rules:?} {variant:?} ({name}) differs from the LUT backend"
                );
            }
        }
    }
    // The channel flows: the inflow injects east-movers, the walls and outflow keep their state.
    let (out, _) = run(&chan, &chan_config, Variant::REFERENCE, 500);
    assert!(out.momentum_units().0 > 0);
}

#[test]
fn body_force_bit_identical_and_drives_flow() {
    let mut l = Lattice::new(64, 34).unwrap();
    l.add_wall_rows();
    l.fill_random(0.2, 4).unwrap();
    let config = Config {
        periodic_y: false,
        body_force: 0.01,
        ..Config::default()
    };
    let (reference, _) = run(&l, &config, Variant::REFERENCE, 300);
    for variant in variants("lattice-gas body force", l.width()) {
        let (got, name) = run(&l, &config, variant, 300);
        assert!(got == reference, "{variant:?} ({name})");
    }
    assert!(reference.momentum_units().0 > l.momentum_units().0 + 200);
    assert_eq!(reference.particle_count(), l.particle_count());
}

#[test]
fn backends_match_lut_on_odd_sizes() {
    // Widths that are not multiples of 4 (the GPU byte layout packs four sites per word), 32
    // or 64: the CPU runs the lookup table, the GPU the byte layout.
    let (chan, chan_config) = channel(50, 31);
    let boxed = periodic_box(37, 18, 0.3, 4);
    let forced = Config {
        body_force: 0.05,
        periodic_y: false,
        rules: RuleSet::Full,
        ..Config::default()
    };
    for (lattice, config) in [
        (&chan, chan_config),
        (&boxed, Config::default()),
        (&boxed, forced),
    ] {
        let (reference, _) = run(lattice, &config, Variant::REFERENCE, 200);
        assert_ne!(&reference, lattice);
        for variant in variants("lattice-gas odd sizes", lattice.width()) {
            let (got, name) = run(lattice, &config, variant, 200);
            assert!(got == reference, "{config:?} {variant:?} ({name})");
        }
    }
}

#[test]
fn hand_test_head_on_pair_gives_18_or_36() {
    let (w, h, j) = (64usize, 8usize, 2usize);
    let mut seen = [false, false];
    for seed in 0..16u32 {
        let mut l = Lattice::new(w, h).unwrap();
        l.set(4, j, 1).unwrap(); // east-mover
        l.set(6, j, 8).unwrap(); // west-mover
        let config = Config {
            seed,
            ..Config::default()
        };
        let bit = chirality(seed, 0, (j * w + 5) as u32);
        let want = if bit == 1 { 18 } else { 36 };
        seen[bit as usize] = true;
        for variant in variants("lattice-gas hand test", w) {
            let (out, name) = run(&l, &config, variant, 1);
            assert_eq!(out.get(5, j), Some(want), "seed {seed} {name}");
            assert_eq!(out.particle_count(), 2);
        }
    }
    assert!(seen[0] && seen[1], "both random outcomes occur");
}

#[test]
fn block_field_equals_the_byte_block_sums_on_every_backend() {
    let (lattice, config) = channel(128, 40);
    for variant in variants("lattice-gas block field", lattice.width()) {
        let mut sim = simulation(&lattice, &config, variant);
        sim.step(20).unwrap();
        let bytes = BlockField::from_lattice(&sim.state().unwrap(), 16).unwrap();
        let got = sim.block_field(16).unwrap();
        let name = sim.backend_name();
        // Counts are integers, exact; the momenta are sums of the same lattice vectors in
        // another order (per direction, then per block), equal to rounding: 1e-9 on sums of
        // at most 6 * 256 unit vectors (measured: 2.1e-14 on multi-spin, 0 elsewhere).
        assert_eq!(
            (got.blocks(), got.sites(), got.particles()),
            (bytes.blocks(), bytes.sites(), bytes.particles()),
            "{name}"
        );
        let ((gx, gy), (bx, by)) = (got.momentum(), bytes.momentum());
        for (x, y) in gx.iter().zip(bx).chain(gy.iter().zip(by)) {
            assert!((x - y).abs() < 1e-9, "{name}: {x} vs {y}");
        }
        assert!(sim.block_field(0).is_err(), "{name}");
    }
}
