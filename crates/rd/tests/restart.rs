//! Checkpoints: a run resumed from a checkpoint (in a new process) continues bit for bit on
//! every backend, with its step counter and simulated time; checkpoints of another model or
//! precision, truncated or corrupted ones are refused with `Error::Checkpoint`, and a
//! checkpoint whose contents are invalid is validated like `Rd::new`'s input.

/// The conformance suite every simulation crate runs (`conformance_tests!`).
#[path = "suite/mod.rs"]
mod suite;

use simkit_backend::testing::{backends, check_restart, test_path};
use simkit_backend::{Backend, Error, Restart, Result, Simulation, checkpoint};
use simkit_rd::scenes::{colony_scene, gray_scott_square};
use simkit_rd::{Colony, Config, GpuOptions, GrayScott, Rd, Real, Stepping};

fn gray_scott<T: Real>(backend: Backend<'_>) -> Result<Rd<T, GrayScott>> {
    let grid = gray_scott_square::<T>(20, 1.0, 6, 3)?;
    let model = GrayScott::new(1.0, 0.5, 0.04, 0.06)?;
    let config = Config::new(Stepping::euler(0.2))
        .with_check_every(25)
        .with_gpu(GpuOptions {
            steps_per_submit: 16,
            ..GpuOptions::default()
        });
    let mut sim = Rd::new(grid, model, &config, backend)?;
    // A change of dt part-way: the clock goes on from the time reached (restored exactly).
    sim.step(7)?;
    sim.set_stepping(Stepping::euler(0.15))?;
    Ok(sim)
}

fn colony<T: Real>(backend: Backend<'_>, stepping: Stepping) -> Result<Rd<T, Colony>> {
    let (grid, model) = colony_scene::<T>(30, 26, 5)?;
    let config = Config::new(stepping).with_check_every(40);
    let mut sim = Rd::new(grid, model, &config, backend)?;
    sim.step(3)?;
    Ok(sim)
}

/// `check_restart` (2N steps against N, checkpoint file, resume in a new process, N more:
/// byte-identical checkpoints) for Gray–Scott and the colony model (Euler with fused CPU
/// sweeps, and Heun), f32 on every backend and f64 on the CPU (and on a GPU with f64).
#[test]
fn restart_is_bit_exact() {
    let test = &test_path(module_path!(), "restart_is_bit_exact");
    for backend in backends(test) {
        check_restart(test, "gray-scott f32", backend, 60, gray_scott::<f32>);
        check_restart(test, "colony f32 euler", backend, 50, |b| {
            colony::<f32>(b, Stepping::euler(0.005))
        });
        check_restart(test, "colony f32 heun", backend, 30, |b| {
            colony::<f32>(b, Stepping::heun(0.005))
        });
        if backend.has_f64() {
            check_restart(test, "gray-scott f64", backend, 60, gray_scott::<f64>);
            check_restart(test, "colony f64 euler", backend, 50, |b| {
                colony::<f64>(b, Stepping::euler(0.005))
            });
        } else {
            eprintln!(
                "SKIPPED {test} f64 on the GPU: the adapter lacks SHADER_F64, so the f64 \
                 restarts (gray-scott, colony) ran on the CPU only"
            );
        }
    }
}

/// The step counter, the simulated time (after a change of `dt`) and the config come back
/// exactly, and the resumed run keeps time like the original.
#[test]
fn clock_and_config_are_restored() {
    for backend in backends("clock_and_config_are_restored") {
        let mut sim = gray_scott::<f32>(backend).unwrap();
        sim.step(33).unwrap();
        let bytes = sim.checkpoint().unwrap();
        let mut back = Rd::<f32, GrayScott>::resume(&bytes, backend).unwrap();
        assert_eq!(back.steps_done(), 40);
        assert_eq!(back.time().to_bits(), sim.time().to_bits());
        assert_eq!((7.0 * 0.2 + 33.0 * 0.15), sim.time());
        assert_eq!(back.config(), sim.config());
        assert_eq!(back.model(), sim.model());
        assert_eq!(back.state().unwrap(), sim.state().unwrap());
        sim.step(11).unwrap();
        back.step(11).unwrap();
        assert_eq!(back.time().to_bits(), sim.time().to_bits());
        assert_eq!(back.checkpoint().unwrap(), sim.checkpoint().unwrap());
    }
}

fn checkpoint_error<T: Real, M: simkit_rd::Model>(bytes: &[u8], what: &str) -> String {
    match Rd::<T, M>::resume(bytes, Backend::Cpu) {
        Err(Error::Checkpoint { reason, .. }) => reason,
        Err(e) => panic!("{what}: expected Error::Checkpoint, got {e}"),
        Ok(_) => panic!("{what}: resumed"),
    }
}

/// Another precision or model, a truncated file, a flipped bit, a payload that does not
/// decode: `Error::Checkpoint` saying which.
#[test]
fn foreign_truncated_and_corrupt_checkpoints_are_refused() {
    let bytes = gray_scott::<f32>(Backend::Cpu)
        .unwrap()
        .checkpoint()
        .unwrap();
    let r = checkpoint_error::<f64, GrayScott>(&bytes, "f32 as f64");
    assert!(r.contains("Rd<f32") && r.contains("not Rd<f64"), "{r}");
    let r = checkpoint_error::<f32, Colony>(&bytes, "gray-scott as colony");
    assert!(r.contains("GrayScott") && r.contains("Colony"), "{r}");
    for cut in [0, 5, 20, bytes.len() / 2, bytes.len() - 1] {
        let r = checkpoint_error::<f32, GrayScott>(&bytes[..cut], "truncated");
        assert!(
            r.contains("truncated") || r.contains("not a simkit checkpoint"),
            "{r}"
        );
    }
    for at in [9, 40, bytes.len() / 2, bytes.len() - 2] {
        let mut bad = bytes.clone();
        bad[at] ^= 0x10;
        checkpoint_error::<f32, GrayScott>(&bad, "flipped bit");
    }
    let mut long = bytes.clone();
    long.push(0);
    checkpoint_error::<f32, GrayScott>(&long, "trailing byte");
    // A well-formed file of the right model whose payload is something else.
    let h = checkpoint::header(&bytes).unwrap();
    let other = checkpoint::encode(&h.package, &h.version, &h.model, &(1u8, [2.5f64; 3])).unwrap();
    let r = checkpoint_error::<f32, GrayScott>(&other, "foreign payload");
    assert!(r.contains("does not decode"), "{r}");
}

/// A checkpoint with a valid checksum but a NaN field value is refused as `Rd::new` refuses
/// that grid (the payload is validated again, not trusted).
#[test]
fn checkpoint_contents_are_validated_again() {
    let (mut grid, model) = colony_scene::<f32>(8, 6, 1).unwrap();
    let marker = 0.123_456_79_f32;
    grid.field_mut(1)[9] = marker;
    let mut sim = Rd::new(
        grid,
        model,
        &Config::new(Stepping::euler(0.005)),
        Backend::Cpu,
    )
    .unwrap();
    let mut bytes = sim.checkpoint().unwrap();
    let at = bytes
        .windows(4)
        .position(|w| w == marker.to_le_bytes())
        .expect("the marker value is in the payload");
    bytes[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    let body = bytes.len() - 4;
    let crc = crc32fast::hash(&bytes[..body]);
    bytes[body..].copy_from_slice(&crc.to_le_bytes());
    let e = Rd::<f32, Colony>::resume(&bytes, Backend::Cpu).unwrap_err();
    let s = e.to_string();
    assert!(
        matches!(e, Error::InvalidParameter { .. }) && s.contains("field 1 at cell (1, 1)"),
        "{s}"
    );
}
