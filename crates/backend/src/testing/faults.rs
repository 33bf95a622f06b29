//! Fault injection for checkpoint writes: a writer killed at random moments, and a writer
//! that runs out of space. Each runs the calling test's own binary as the faulty child
//! process (as [`super::check_restart`] does).

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::{Backend, Restart};

/// Environment variable through which the helpers tell their child what to do.
const FAULT_CHILD_ENV: &str = "SIMKIT_FAULT_CHILD";

/// The checkpoint file of the helpers, in their directory.
const FILE: &str = "run.ckpt";

/// The file a writer of [`check_killed_writers`] makes once it starts writing.
const ALIVE: &str = "alive";

/// What [`check_killed_writers`] saw.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Kills {
    /// Writers killed.
    pub kills: u32,
    /// Kills after which a checkpoint was there (each resumed to the bits of the
    /// uninterrupted run).
    pub with_checkpoint: u32,
    /// Kills that left a temporary file: the writer died in the middle of a write (the
    /// next checkpoint write removes it).
    pub mid_write: u32,
}

/// A scratch directory for the test `test`, emptied.
fn scratch(test: &str, what: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "simkit-{what}-{}-{}",
        std::process::id(),
        test.replace(|c: char| !c.is_ascii_alphanumeric(), "_")
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("creating the scratch directory");
    dir
}

/// Temporary files of the atomic writer left in `dir`.
fn temporaries(dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(dir)
        .map(|d| {
            d.filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| {
                    p.file_name()
                        .is_some_and(|n| n.to_string_lossy().contains(".tmp-"))
                })
                .collect()
        })
        .unwrap_or_default()
}

/// The child's side of the helpers: `Some(job)` when this process is one.
fn child_job() -> Option<(String, PathBuf)> {
    let job = std::env::var(FAULT_CHILD_ENV).ok()?;
    let (what, dir) = job.split_once('|')?;
    Some((what.to_string(), PathBuf::from(dir)))
}

/// Kills (SIGKILL) a process that writes checkpoints of a run `kills` times, each at a
/// pseudo-random moment (fixed seed), and checks after each kill that the checkpoint file
/// is absent (nothing written yet) or whole: it resumes, and its bytes are those of an
/// uninterrupted run at its step; at the end, a write removes the temporary files the
/// killed writers left. Each writer resumes from the file the last one left and
/// writes a checkpoint after every `every` steps, so the run moves on across the kills.
///
/// Call it from the `#[test]` function whose full name in the test binary is `test`: the
/// writer is that test binary, run with `--exact test` and an environment variable that
/// makes this call write instead. `make` builds the run on the CPU.
///
/// # Panics
/// When a checkpoint left by a killed writer does not resume or differs from the
/// uninterrupted run, or a writer fails.
pub fn check_killed_writers<S: Restart>(
    test: &str,
    kills: u32,
    every: u32,
    make: impl Fn() -> crate::Result<S>,
) -> Kills {
    if let Some((what, dir)) = child_job() {
        if what == "write" {
            let path = dir.join(FILE);
            let mut run = if path.exists() {
                S::resume_file(&path, Backend::Cpu).expect("resuming the last checkpoint")
            } else {
                make().expect("building the run")
            };
            // Tells the parent that the writing starts now.
            std::fs::write(dir.join(ALIVE), b"").expect("the start marker");
            // Until killed (a minute at most, should the parent be gone).
            let start = Instant::now();
            while start.elapsed() < Duration::from_secs(60) {
                run.step(every).expect("stepping");
                run.write_checkpoint(&path).expect("writing the checkpoint");
            }
        }
        return Kills::default();
    }
    let dir = scratch(test, "kills");
    let path = dir.join(FILE);
    let mut reference = make().expect("building the reference run");
    let exe = std::env::current_exe().expect("the test binary's path");
    let mut seen = Kills::default();
    for k in 0..kills {
        let _ = std::fs::remove_file(dir.join(ALIVE));
        let mut child = Command::new(&exe)
            .args([test, "--exact", "--nocapture", "--test-threads=1"])
            .env(FAULT_CHILD_ENV, format!("write|{}", dir.display()))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("starting the writer");
        // Once it writes (however slow its start on a loaded machine), 0 to 20 ms later: a
        // few steps and writes in, at a random point of one of them.
        let start = Instant::now();
        while !dir.join(ALIVE).exists() {
            if let Some(status) = child.try_wait().expect("polling the writer") {
                panic!("writer {k} ended before it started writing: {status}");
            }
            assert!(
                start.elapsed() < Duration::from_secs(60),
                "writer {k} did not start writing within a minute"
            );
            std::thread::sleep(Duration::from_millis(1));
        }
        let wait = 20.0 * f64::from(crate::rng::rng_uniform(0x6b11, k, 0));
        std::thread::sleep(Duration::from_secs_f64(wait * 1e-3));
        if let Some(status) = child.try_wait().expect("polling the writer") {
            panic!("writer {k} ended by itself before the kill: {status}");
        }
        child.kill().expect("killing the writer");
        child.wait().expect("reaping the writer");
        seen.kills += 1;
        if !temporaries(&dir).is_empty() {
            seen.mid_write += 1;
        }
        let Ok(bytes) = std::fs::read(&path) else {
            continue;
        };
        seen.with_checkpoint += 1;
        let resumed = S::resume(&bytes, Backend::Cpu)
            .unwrap_or_else(|e| panic!("kill {k}: the checkpoint left does not resume: {e}"));
        let at = resumed.steps_done();
        let behind = at
            .checked_sub(reference.steps_done())
            .expect("a later checkpoint holds an earlier step");
        let behind = u32::try_from(behind).expect("a stretch of steps");
        reference.step(behind).expect("stepping the reference run");
        let want = reference.checkpoint().expect("the reference checkpoint");
        assert!(
            want == bytes,
            "kill {k}: the checkpoint at step {at} differs from the uninterrupted run's"
        );
    }
    // The next write clears what the killed writers left.
    reference
        .write_checkpoint(&path)
        .expect("a write after the kills");
    let left = temporaries(&dir);
    assert!(
        left.is_empty(),
        "temporary files of dead writers left: {left:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
    seen
}

/// Writes a checkpoint of the run `make` builds, then lets a child process with a
/// file-size limit below the checkpoint's size (`ulimit -f`, `SIGXFSZ` ignored: writes
/// fail with `EFBIG`, as on a full disk) step the same run and write its checkpoint over
/// the first: the write must return `Err`, the first checkpoint stay as it was, and no
/// temporary file remain. Returns the child's error message. Call it as
/// [`check_killed_writers`]; needs `sh` (Unix).
///
/// # Panics
/// When the write succeeds, the old file changed, a temporary file is left, or the child
/// fails otherwise.
pub fn check_full_disk<S: Restart>(test: &str, make: impl Fn() -> crate::Result<S>) -> String {
    if let Some((what, dir)) = child_job() {
        if what == "full" {
            let mut run = make().expect("building the run");
            run.step(3).expect("stepping");
            match run.write_checkpoint(dir.join(FILE)) {
                Ok(()) => panic!("the write past the file-size limit succeeded"),
                Err(e) => std::fs::write(dir.join("error.txt"), e.to_string())
                    .expect("the error for the parent (a small file)"),
            }
        }
        return String::new();
    }
    let dir = scratch(test, "full");
    let path = dir.join(FILE);
    let mut run = make().expect("building the run");
    run.write_checkpoint(&path).expect("the first checkpoint");
    let old = std::fs::read(&path).expect("reading it back");
    // In blocks of 512 or 1024 bytes depending on the shell: below a quarter of the file.
    let blocks = (old.len() / 4096).max(1);
    assert!(
        blocks * 1024 < old.len(),
        "the checkpoint ({} bytes) is too small for the limit",
        old.len()
    );
    let exe = std::env::current_exe().expect("the test binary's path");
    let out = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "trap '' XFSZ; ulimit -f {blocks} && exec \"$0\" \"$@\""
        ))
        .arg(&exe)
        .args([test, "--exact", "--nocapture", "--test-threads=1"])
        .env(FAULT_CHILD_ENV, format!("full|{}", dir.display()))
        .output()
        .expect("starting the child under a file-size limit");
    assert!(
        out.status.success(),
        "the child failed: {}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let message = std::fs::read_to_string(dir.join("error.txt"))
        .expect("the child's error (was the exact test name given?)");
    assert_eq!(
        std::fs::read(&path).expect("the old checkpoint"),
        old,
        "the old checkpoint changed"
    );
    let left = temporaries(&dir);
    assert!(left.is_empty(), "temporary files left: {left:?}");
    let _ = std::fs::remove_dir_all(&dir);
    message
}
