//! Tests that run under `mpirun`: a test launches its own test binary on P ranks.

use std::process::Command;

/// Set in the environment of the ranks [`mpirun_self`] starts.
pub const MPI_CHILD_ENV: &str = "SIMKIT_MPI_CHILD";

/// Environment variable that turns a missing `mpirun` from a skip into a test failure (set
/// by `.ci/run`).
pub const REQUIRE_MPI_ENV: &str = "SIMKIT_REQUIRE_MPI";

/// Whether this process is one of the ranks [`mpirun_self`] started (then the test body
/// runs its multi-rank part and returns).
pub fn is_mpi_child() -> bool {
    std::env::var_os(MPI_CHILD_ENV).is_some()
}

/// Runs the test `test` of the current test binary under
/// `mpirun --allow-run-as-root --oversubscribe --timeout 300 -np P` for every `P` in
/// `ranks` (one rayon thread per rank: the ranks share the machine's cores) and returns
/// each run's standard output; `None` (with a message) when `mpirun` is not on the `PATH`.
///
/// # Panics
/// When a run fails (its output is in the message), and when `mpirun` is missing while
/// `SIMKIT_REQUIRE_MPI=1`.
pub fn mpirun_self(test: &str, ranks: &[usize]) -> Option<Vec<String>> {
    let have = Command::new("mpirun")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !have {
        assert!(
            std::env::var(REQUIRE_MPI_ENV).as_deref() != Ok("1"),
            "{test}: {REQUIRE_MPI_ENV}=1 but `mpirun` is not on the PATH (Debian: apt-get \
             install openmpi-bin libopenmpi-dev)"
        );
        eprintln!("{test}: skipped, `mpirun` is not on the PATH (set {REQUIRE_MPI_ENV}=1 to fail)");
        return None;
    }
    let exe = std::env::current_exe().expect("the test binary's path");
    let runs = ranks.iter().map(|p| {
        let out = Command::new("mpirun")
            // A hung rank fails the test instead of blocking it.
            .args(["--allow-run-as-root", "--oversubscribe", "--timeout", "300"])
            .args(["-np", &p.to_string()])
            .arg(&exe)
            .args([test, "--exact", "--nocapture", "--test-threads=1"])
            .env(MPI_CHILD_ENV, "1")
            .env("RAYON_NUM_THREADS", "1")
            .output()
            .expect("starting mpirun");
        let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            out.status.success(),
            "{test}: mpirun -np {p} failed ({}):\n{stdout}\n{stderr}",
            out.status
        );
        stdout
    });
    Some(runs.collect())
}

/// The whole of a test that runs `cases` on each rank count of `ranks` under `mpirun`: in
/// the test process, launches the test binary on every rank count ([`mpirun_self`]) and
/// asserts that rank 0 reported `expected` cases each time; in a rank it started, runs
/// `cases` over [`Comm::mpi`](crate::comm::Comm::mpi) and reports the number of cases it
/// checked. A failure or panic on any rank aborts every rank (the others would otherwise
/// wait for it forever), which fails the launching test with the rank's message.
///
/// # Panics
/// As [`mpirun_self`], and when a run does not report `expected` cases.
#[cfg(feature = "mpi")]
pub fn check_on_ranks(
    test: &str,
    ranks: &[usize],
    expected: usize,
    cases: impl FnOnce(&crate::comm::Comm) -> Result<usize, String>,
) {
    const MARK: &str = "SIMKIT_MPI_OK";
    if is_mpi_child() {
        let comm = crate::comm::Comm::mpi().expect("MPI initialises");
        let run = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| cases(&comm)));
        let n = match run {
            Ok(Ok(n)) => n,
            Ok(Err(e)) => {
                eprintln!("{test}: rank {}: {e}", comm.rank());
                comm.abort(1)
            }
            Err(_) => comm.abort(2),
        };
        if comm.is_root() {
            println!("{MARK} {n} cases on {} ranks", comm.size());
        }
        return;
    }
    let Some(outputs) = mpirun_self(test, ranks) else {
        return;
    };
    for (p, stdout) in ranks.iter().zip(outputs) {
        let want = format!("{MARK} {expected} cases on {p} ranks");
        assert!(
            stdout.contains(&want),
            "{test}: mpirun -np {p}: rank 0 did not report `{want}`:\n{stdout}"
        );
    }
}

/// The faults on one rank that every `Distributed*` run must survive on `comm` (run it
/// under `mpirun`, e.g. in `check_on_ranks`), each an error on every rank instead of a
/// rank waiting forever: the last rank alone asks `step` for one step more, and rank 0
/// alone is given a checkpoint path it cannot create (the others a good one); then the run
/// must still step. `run` is a fresh run on `comm`. Returns the number of checks (3).
///
/// Errors: a description of the first check that failed.
pub fn check_one_rank_faults<S: crate::Distributed>(
    comm: &crate::comm::Comm,
    mut run: S,
) -> Result<usize, String> {
    let last = comm.size() - 1;
    let steps = if comm.rank() == last { 3 } else { 2 };
    match run.step(steps) {
        Err(e) if e.to_string().contains("step count") => {}
        other => {
            return Err(format!(
                "step({steps}) on rank {} against step(2) elsewhere: expected a step-count \
                 error on every rank, got {:?}",
                comm.rank(),
                other.map(|_| ())
            ));
        }
    }
    let dir = std::env::temp_dir().join(format!("simkit-one-rank-faults-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
    // Under a regular file: no directory can be made there.
    let blocker = dir.join(format!("file-of-rank-{}", comm.rank()));
    std::fs::write(&blocker, b"not a directory").map_err(|e| e.to_string())?;
    let path = if comm.is_root() {
        blocker.join("run.ckpt")
    } else {
        dir.join("run.ckpt")
    };
    match run.write_checkpoint(&path) {
        Err(crate::Error::Io { .. }) => {}
        other => {
            return Err(format!(
                "a checkpoint path rank 0 cannot create: expected an I/O error on rank {}, \
                 got {:?}",
                comm.rank(),
                other.map(|_| ())
            ));
        }
    }
    let _ = std::fs::remove_file(&blocker);
    run.step(2)
        .map_err(|e| format!("the run does not go on after the faults: {e}"))?;
    Ok(3)
}
