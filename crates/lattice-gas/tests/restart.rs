//! Checkpoint and restart: a run of 2N steps equals N steps, checkpoint, resume in a new
//! process and N more steps, bit for bit, on every CPU method and GPU layout; a checkpoint
//! resumes exactly on another backend; bad files give clear errors.

/// The conformance suite every simulation crate runs (`conformance_tests!`).
#[path = "suite/mod.rs"]
mod suite;

use simkit_backend::testing::{backends, check_restart, test_path};
use simkit_backend::{Backend, Error, Restart, Simulation, checkpoint};
use simkit_lattice_gas::{Config, CpuMethod, GpuLayout, Lattice, LatticeGas, Obstacle, RuleSet};

/// A channel with walls, a disc, inflow/outflow and a body force: every source of random
/// bits and every boundary kind that depends on the step counter.
fn scene(config: &Config, backend: Backend<'_>) -> simkit_backend::Result<LatticeGas> {
    let mut lattice = Lattice::new(128, 48)?;
    lattice.fill_random(0.25, 11)?;
    lattice.add_wall_rows();
    lattice.add_obstacle(&Obstacle::Disc {
        cx: 40.0,
        cy: 20.0,
        radius: 6.0,
    })?;
    LatticeGas::new(lattice, config, backend)
}

fn configs() -> Vec<(&'static str, Config)> {
    let channel = Config {
        rules: RuleSet::Full,
        seed: 77,
        periodic_x: false,
        inflow: true,
        outflow: true,
        body_force: 0.02,
        ..Config::default()
    };
    vec![
        (
            "lut",
            Config {
                cpu: CpuMethod::Lut,
                gpu_layout: Some(GpuLayout::Bytes),
                ..channel.clone()
            },
        ),
        (
            "multispin",
            Config {
                cpu: CpuMethod::MultiSpin,
                gpu_layout: Some(GpuLayout::BitPlanes),
                ..channel.clone()
            },
        ),
        (
            "periodic",
            Config {
                body_force: 0.05,
                ..Config::default()
            },
        ),
    ]
}

#[test]
fn restart_is_bit_exact() {
    for backend in backends("restart_is_bit_exact") {
        for (label, config) in configs() {
            check_restart(
                &test_path(module_path!(), "restart_is_bit_exact"),
                label,
                backend,
                37,
                |b| scene(&config, b),
            );
        }
    }
}

#[test]
fn a_checkpoint_resumes_exactly_on_another_backend() {
    let list = backends("a_checkpoint_resumes_exactly_on_another_backend");
    let (_, config) = configs().remove(1);
    let mut whole = scene(&config, Backend::Cpu).unwrap();
    whole.step(60).unwrap();
    let want = whole.state().unwrap();
    for from in &list {
        for to in &list {
            let mut half = scene(&config, *from).unwrap();
            half.step(30).unwrap();
            let bytes = half.checkpoint().unwrap();
            let mut resumed = LatticeGas::resume(&bytes, *to).unwrap();
            assert_eq!(resumed.steps_done(), 30);
            resumed.step(30).unwrap();
            assert!(
                resumed.state().unwrap() == want,
                "{} -> {}: the resumed lattice differs",
                from.name(),
                to.name()
            );
        }
    }
}

#[test]
fn bad_checkpoints_are_clear_errors() {
    let (_, config) = configs().remove(0);
    let mut sim = scene(&config, Backend::Cpu).unwrap();
    sim.step(3).unwrap();
    let bytes = sim.checkpoint().unwrap();
    let reason = |b: &[u8]| match LatticeGas::resume(b, Backend::Cpu) {
        Err(Error::Checkpoint { reason, .. }) => reason,
        Err(other) => panic!("expected a checkpoint error, got {other}"),
        Ok(_) => panic!("a bad checkpoint was accepted"),
    };
    assert!(reason(&bytes[..bytes.len() / 2]).contains("truncated"));
    let mut flipped = bytes.clone();
    let mid = bytes.len() / 2;
    flipped[mid] ^= 0x10;
    assert!(reason(&flipped).contains("checksum"));
    let other = checkpoint::encode("simkit-rd", "0.1.0", "Rd<f64, GrayScott>", &1u32).unwrap();
    assert!(reason(&other).contains("simkit-rd"));
    let other_model = checkpoint::encode(
        "simkit-lattice-gas",
        env!("CARGO_PKG_VERSION"),
        "Something",
        &1u32,
    )
    .unwrap();
    assert!(reason(&other_model).contains("Something"));
    // A file that is not there names the path.
    let e = LatticeGas::resume_file("/nonexistent/run.ckpt", Backend::Cpu).unwrap_err();
    assert!(e.to_string().contains("/nonexistent/run.ckpt"), "{e}");
    // Files round-trip.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.ckpt");
    sim.write_checkpoint(&path).unwrap();
    let resumed = LatticeGas::resume_file(&path, Backend::Cpu).unwrap();
    assert_eq!(resumed.steps_done(), 3);
    // A well-formed checkpoint of an invalid lattice (bit 6 set, a wrong cell count, an odd
    // height with a periodic y axis) is refused as the constructor refuses it. The payload
    // is (config, width, height, cells, steps).
    let encode = |w: u64, h: u64, cells: Vec<u8>| {
        checkpoint::encode(
            "simkit-lattice-gas",
            env!("CARGO_PKG_VERSION"),
            "LatticeGas",
            &(Config::default(), w, h, cells, 0u64),
        )
        .unwrap()
    };
    let invalid = |b: Vec<u8>| {
        LatticeGas::resume(&b, Backend::Cpu)
            .unwrap_err()
            .to_string()
    };
    assert!(invalid(encode(4, 4, vec![0x40; 16])).contains("bit 6"));
    assert!(invalid(encode(4, 4, vec![0; 15])).contains("cells.len()"));
    assert!(invalid(encode(4, 3, vec![0; 12])).contains("even number of rows"));
    assert!(LatticeGas::resume(&encode(4, 4, vec![1; 16]), Backend::Cpu).is_ok());
}
