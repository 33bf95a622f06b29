//! GSD trajectories: frames read back equal to those written, files that grow past their
//! first index and name list, restarts that drop later frames, bad inputs and corrupt files
//! as errors, and writers killed at random moments that leave every completed frame.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use simkit_backend::Precision::{self, F32, F64};
use simkit_backend::rng::rng_uniform;
use simkit_output::gsd::{GsdFile, GsdFrame, GsdWriter};

/// A temporary directory, removed when dropped.
fn scratch() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

/// Frame `f` of a 3D test trajectory: `n` particles, positions and velocities from `f`,
/// three types, diameters and masses that stay, an angular velocity and an energy logged.
fn frame_3d(f: u64, n: usize) -> GsdFrame {
    let pos: Vec<f64> = (0..3 * n)
        .map(|k| ((k as f64 * 0.37 + f as f64 * 0.11).sin() + 1.0) * 2.0)
        .collect();
    let vel: Vec<f64> = (0..3 * n).map(|k| (k as f64 - f as f64) * 0.25).collect();
    let ids: Vec<u32> = (0..n as u32).map(|i| i % 3).collect();
    let d: Vec<f64> = (0..n).map(|i| 0.5 + 0.01 * i as f64).collect();
    let m: Vec<f64> = (0..n).map(|i| 1.0 + 0.1 * (i % 3) as f64).collect();
    let w: Vec<f64> = (0..3 * n).map(|k| k as f64 * 1e-3 * f as f64).collect();
    let mut frame = GsdFrame::new(10 * f, &pos, 3, &[0.0, 0.0, 0.0], &[4.0, 4.0, 4.0]).unwrap();
    frame
        .velocities(&vel, 3)
        .unwrap()
        .types(&ids, &["A", "big", "c3"])
        .unwrap()
        .diameters(&d)
        .unwrap()
        .masses(&m)
        .unwrap()
        .log("particles/angular_velocity", &w, 3)
        .unwrap()
        .log("energy/kinetic", &[f as f64 * 0.5], 1)
        .unwrap();
    frame
}

/// `frames` as a file of `precision` returns them.
fn stored(frames: &[GsdFrame], precision: Precision) -> Vec<GsdFrame> {
    frames
        .iter()
        .map(|f| f.rounded(precision).unwrap())
        .collect()
}

fn read_all(path: &Path) -> Vec<GsdFrame> {
    let file = GsdFile::open(path).unwrap();
    (0..file.frames()).map(|i| file.frame(i).unwrap()).collect()
}

#[test]
fn frames_read_back_as_written_and_attributes_are_stored_once() {
    let dir = scratch();
    let frames: Vec<GsdFrame> = (0..5).map(|f| frame_3d(f, 40)).collect();
    // f64: the same bits; f32: each float rounded once.
    let exact = dir.path().join("exact.gsd");
    let mut w = GsdWriter::create(&exact, F64).unwrap();
    for f in &frames {
        w.push(f).unwrap();
    }
    assert_eq!(read_all(&exact), frames);
    let path = dir.path().join("traj.gsd");
    let mut w = GsdWriter::create(&path, F32)
        .unwrap()
        .sync_each_frame(false);
    for f in &frames {
        w.push(f).unwrap();
    }
    assert_eq!(w.frames(), 5);
    let back = read_all(&path);
    assert_eq!(back, stored(&frames, F32));
    assert_ne!(back, frames, "f32 rounding should show in these positions");
    // Positions relative to the box centre (2, 2, 2).
    let x1 = ((0.37f64).sin() + 1.0) * 2.0 - 2.0;
    assert_eq!(frames[0].positions()[1], x1);
    assert_eq!(back[0].positions()[1], f64::from(x1 as f32));
    assert_eq!(back[0].box_(), [4.0, 4.0, 4.0, 0.0, 0.0, 0.0]);
    // Half the bytes per float (and the same log arrays).
    let (len32, len64) = (
        std::fs::metadata(&path).unwrap().len(),
        std::fs::metadata(&exact).unwrap().len(),
    );
    assert!(len32 < len64, "f32 file {len32} bytes, f64 file {len64}");
    // Types, diameters and masses are in frame 0 only; the step and logs in every frame.
    let file = GsdFile::open(&path).unwrap();
    for name in [
        "particles/types",
        "particles/diameter",
        "particles/mass",
        "configuration/box",
    ] {
        assert!(file.chunk(0, name).unwrap().is_some(), "{name} in frame 0");
        assert!(file.chunk(3, name).unwrap().is_none(), "{name} repeated");
    }
    for name in [
        "configuration/step",
        "particles/position",
        "log/energy/kinetic",
    ] {
        assert!(file.chunk(3, name).unwrap().is_some(), "{name} missing");
    }
    // 2D: Lz = 0, z = 0, two velocity components in, three stored.
    let path2 = dir.path().join("flat.gsd");
    let mut w = GsdWriter::create(&path2, F32).unwrap();
    let mut f2 = GsdFrame::new(7, &[1.0f32, 2.0, 3.0, 0.5], 2, &[0.0, 0.0], &[4.0, 3.0]).unwrap();
    f2.velocities(&[0.5f32, -0.5, 1.0, 2.0], 2).unwrap();
    w.push(&f2).unwrap();
    let back = read_all(&path2);
    assert_eq!(back, stored(&[f2], F32));
    assert_eq!(back[0].dimensions(), 2);
    assert_eq!(back[0].box_(), [4.0, 3.0, 0.0, 0.0, 0.0, 0.0]);
    assert_eq!(back[0].positions(), [-1.0, 0.5, 0.0, 1.0, -1.0, 0.0]);
    assert_eq!(back[0].velocity().unwrap(), [0.5, -0.5, 0.0, 1.0, 2.0, 0.0]);
}

#[test]
fn the_index_and_the_name_list_grow_past_their_first_blocks() {
    let dir = scratch();
    let path = dir.path().join("traj.gsd");
    let mut w = GsdWriter::create(&path, F32)
        .unwrap()
        .sync_each_frame(false);
    let mut frames = Vec::new();
    // 9 chunks a frame: 300 frames need 2700 index entries (the first index holds 128);
    // 40 log names of 40 bytes each fill more than the first 1 KiB name list.
    for f in 0..300u64 {
        let mut frame = frame_3d(f, 3);
        if f % 7 == 0 {
            let name = format!("quantity/with/a/rather/long/name/{f:06}");
            frame.log(&name, &[f as f64], 1).unwrap();
        }
        w.push(&frame).unwrap();
        frames.push(frame);
    }
    assert_eq!(read_all(&path), stored(&frames, F32));
}

#[test]
fn a_resumed_trajectory_drops_frames_after_the_checkpoint_step() {
    let dir = scratch();
    let path = dir.path().join("traj.gsd");
    let mut w = GsdWriter::create(&path, F32).unwrap();
    for f in 0..10 {
        w.push(&frame_3d(f, 8)).unwrap();
    }
    drop(w);
    // A checkpoint at step 45: frames of steps 50..90 were written after it.
    let mut w = GsdWriter::resume(&path, 45).unwrap();
    assert_eq!(w.frames(), 5);
    for f in 5..12 {
        w.push(&frame_3d(f, 8)).unwrap();
    }
    let want: Vec<GsdFrame> = (0..12).map(|f| frame_3d(f, 8)).collect();
    assert_eq!(read_all(&path), stored(&want, F32));
    // Attributes equal to frame 0's are still left out after the resume.
    let file = GsdFile::open(&path).unwrap();
    assert!(file.chunk(11, "particles/mass").unwrap().is_none());
    // Resuming before the first frame empties the trajectory; u64::MAX keeps all.
    assert_eq!(GsdWriter::resume(&path, u64::MAX).unwrap().frames(), 12);
    let mut w = GsdWriter::resume(&path, 0).unwrap();
    assert_eq!(w.frames(), 1);
    w.push(&frame_3d(1, 2)).unwrap();
    assert_eq!(
        read_all(&path),
        stored(&[frame_3d(0, 8), frame_3d(1, 2)], F32)
    );
    // Another particle count: the types are written again (the schema takes frame 0's
    // only between frames of one count).
    let file = GsdFile::open(&path).unwrap();
    assert!(file.chunk(1, "particles/types").unwrap().is_some());
}

#[test]
fn bad_frames_are_errors_that_name_the_value() {
    let box3 = ([0.0; 3], [1.0; 3]);
    let err = |r: simkit_backend::Result<GsdFrame>| r.unwrap_err().to_string();
    let e = err(GsdFrame::new(0, &[0.5, f64::NAN, 0.5], 3, &box3.0, &box3.1));
    assert!(e.contains("position[0].y"), "{e}");
    // A value beyond f32: refused by an f32 trajectory (which goes on), kept in f64.
    let huge = GsdFrame::new(0, &[0.5, 1e39, 0.5], 3, &box3.0, &box3.1).unwrap();
    let dir = scratch();
    let mut w = GsdWriter::create(dir.path().join("f32.gsd"), F32).unwrap();
    let e = w.push(&huge).unwrap_err().to_string();
    assert!(
        e.contains("particles/position[1]") && e.contains("f64"),
        "{e}"
    );
    let fine = GsdFrame::new(1, &[0.5; 3], 3, &box3.0, &box3.1).unwrap();
    w.push(&fine).unwrap();
    assert_eq!(read_all(&dir.path().join("f32.gsd")), [fine]);
    let mut w = GsdWriter::create(dir.path().join("f64.gsd"), F64).unwrap();
    w.push(&huge).unwrap();
    assert_eq!(read_all(&dir.path().join("f64.gsd")), [huge]);
    let e = err(GsdFrame::new(
        0,
        &[0.5; 3],
        3,
        &box3.0,
        &[1.0, f64::INFINITY, 1.0],
    ));
    assert!(e.contains("hi[1] - lo[1]"), "{e}");
    let e = err(GsdFrame::new(0, &[0.5; 4], 4, &[0.0; 4], &[1.0; 4]));
    assert!(e.contains("dim"), "{e}");
    let e = err(GsdFrame::new(0, &[0.5; 3], 3, &[0.0; 3], &[1.0, 0.0, 1.0]));
    assert!(e.contains("hi[1] - lo[1]"), "{e}");
    let e = err(GsdFrame::new(0, &[0.5; 3], 3, &[0.0; 2], &[1.0; 3]));
    assert!(e.contains("lo.len()"), "{e}");
    let mut f = GsdFrame::new(0, &[0.5; 6], 3, &box3.0, &box3.1).unwrap();
    let e = f.velocities(&[0.0; 4], 2).unwrap_err().to_string();
    assert!(e.contains("velocities"), "{e}");
    let e = f.types(&[0u32, 2], &["a", "b"]).unwrap_err().to_string();
    assert!(e.contains("ids[1]"), "{e}");
    let e = f.types(&[0u32, 1], &["a", "a"]).unwrap_err().to_string();
    assert!(e.contains("distinct"), "{e}");
    let e = f.diameters(&[1.0, -1.0]).unwrap_err().to_string();
    assert!(e.contains("diameter[1]"), "{e}");
    let e = f.masses(&[1.0]).unwrap_err().to_string();
    assert!(e.contains("mass.len()"), "{e}");
    let e = f.log("x", &[1.0, 2.0, 3.0], 2).unwrap_err().to_string();
    assert!(e.contains("columns"), "{e}");
    f.log("x", &[1.0], 1).unwrap();
    assert!(f.log("x", &[1.0], 1).is_err(), "a name logged twice");
}

#[test]
fn corrupt_files_are_errors_not_panics() {
    let dir = scratch();
    let path = dir.path().join("traj.gsd");
    let mut w = GsdWriter::create(&path, F32)
        .unwrap()
        .sync_each_frame(false);
    for f in 0..3 {
        w.push(&frame_3d(f, 5)).unwrap();
    }
    let good = std::fs::read(&path).unwrap();
    let bad = dir.path().join("bad.gsd");
    let open = |bytes: &[u8]| {
        std::fs::write(&bad, bytes).unwrap();
        GsdFile::open(&bad).and_then(|f| {
            (0..f.frames()).try_for_each(|i| f.frame(i).map(drop))?;
            Ok(f.frames())
        })
    };
    assert_eq!(open(&good).unwrap(), 3);
    let e = open(&good[..100]).unwrap_err().to_string();
    assert!(e.contains("shorter than the header"), "{e}");
    let e = open(&good[..2000]).unwrap_err().to_string();
    assert!(e.contains("does not fit"), "{e}");
    let e = open(
        b"not a trajectory at all, but long enough to hold a header? no"
            .repeat(9)
            .as_slice(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("magic"), "{e}");
    // Random bytes changed anywhere: an error or frames, never a panic or a huge allocation
    // (every size is checked against the file's before reading).
    let mut errors = 0;
    for case in 0..2000u32 {
        let mut bytes = good.clone();
        for k in 0..1 + case % 4 {
            let at = (rng_uniform(0x65d, case, 2 * k) * bytes.len() as f32) as usize;
            let value = (rng_uniform(0x65d, case, 2 * k + 1) * 256.0) as u8;
            let last = bytes.len() - 1;
            bytes[at.min(last)] = value;
        }
        errors += usize::from(open(&bytes).is_err());
    }
    assert!(errors > 0, "no corruption was noticed in 2000 cases");
}

/// A frame of [`every_write_boundary_leaves_the_completed_frames`]: every fifth frame logs
/// a new name, so the name list fills too.
fn marked_frame(f: u64, n: usize) -> GsdFrame {
    let mut frame = frame_3d(f, n);
    if f.is_multiple_of(5) {
        let name = format!("marker/{f:08}/{}", "x".repeat(40));
        frame.log(&name, &[f as f64], 1).unwrap();
    }
    frame
}

/// A writer stopped after each of its writes in turn (data, names, index, header; the index
/// and the name list both outgrow their first blocks), as a crash there would stop it:
/// the file opens and holds exactly the frames whose `push` returned, and a resumed writer
/// completes the trajectory.
#[test]
fn every_write_boundary_leaves_the_completed_frames() {
    let dir = scratch();
    let path = dir.path().join("traj.gsd");
    const FRAMES: u64 = 40;
    let want: Vec<GsdFrame> = (0..FRAMES).map(|f| marked_frame(f, 4)).collect();
    let mut writes = 0;
    loop {
        let mut w = GsdWriter::create(&path, F64)
            .unwrap()
            .sync_each_frame(false)
            .fail_after_writes(writes);
        let done = want.iter().take_while(|f| w.push(f).is_ok()).count();
        if done == want.len() {
            break;
        }
        assert!(w.push(&want[done]).is_err(), "a failed writer went on");
        let got = read_all(&path);
        assert_eq!(got, want[..done], "stopped after {writes} writes");
        let mut w = GsdWriter::resume(&path, u64::MAX).unwrap();
        for f in &want[done..] {
            w.push(f).unwrap();
        }
        assert_eq!(read_all(&path), want, "resumed after {writes} writes");
        writes += 1;
    }
    // Data, then index entries, per frame; names, index copies and headers besides.
    assert!(writes > 2 * FRAMES, "only {writes} writes");
    eprintln!("{writes} write boundaries checked");
}

const CHILD: &str = "SIMKIT_GSD_WRITER";

/// Kills a process that appends frames (the index and name list growing, every frame synced)
/// at random moments; after each kill the file opens and holds frames 0, 1, ... each equal
/// to the one written, and the next writer resumes it.
#[test]
fn killed_writers_leave_every_completed_frame() {
    let test = simkit_backend::testing::test_path(
        module_path!(),
        "killed_writers_leave_every_completed_frame",
    );
    if let Ok(path) = std::env::var(CHILD) {
        let path = PathBuf::from(path);
        let mut w = if path.exists() {
            GsdWriter::resume(&path, u64::MAX).unwrap()
        } else {
            GsdWriter::create(&path, F32).unwrap()
        };
        std::fs::write(path.with_extension("alive"), b"").unwrap();
        let start = Instant::now();
        while start.elapsed() < Duration::from_secs(60) {
            w.push(&marked_frame(w.frames(), 50)).unwrap();
        }
        return;
    }
    let dir = scratch();
    let path = dir.path().join("traj.gsd");
    let exe = std::env::current_exe().unwrap();
    let mut growth = Vec::new();
    for k in 0..20u32 {
        let alive = path.with_extension("alive");
        let _ = std::fs::remove_file(&alive);
        let mut child = Command::new(&exe)
            .args([test.as_str(), "--exact", "--test-threads=1"])
            .env(CHILD, &path)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let start = Instant::now();
        while !alive.exists() {
            assert!(
                child.try_wait().unwrap().is_none(),
                "writer {k} ended early"
            );
            assert!(
                start.elapsed() < Duration::from_secs(60),
                "writer {k} never started"
            );
            std::thread::sleep(Duration::from_millis(1));
        }
        let wait = 30.0 * f64::from(rng_uniform(0x6b1d, k, 0));
        std::thread::sleep(Duration::from_secs_f64(wait * 1e-3));
        child.kill().unwrap();
        child.wait().unwrap();
        let frames = read_all(&path);
        for (f, got) in frames.iter().enumerate() {
            assert_eq!(
                *got,
                marked_frame(f as u64, 50).rounded(F32).unwrap(),
                "kill {k}: frame {f} differs"
            );
        }
        growth.push(frames.len());
    }
    assert!(
        growth.windows(2).all(|w| w[0] <= w[1]) && growth.last() > growth.first(),
        "the writers made no progress across kills: {growth:?}"
    );
    eprintln!("frames after each kill: {growth:?}");
}
