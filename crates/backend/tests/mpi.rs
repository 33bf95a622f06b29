//! The communication layer under `mpirun -np P` (P = 2, 3, 4): halo exchange at depths 1
//! to 3 with and without periodic axes (every ghost cell, corners included, checked against
//! the global field), gather to rank 0, the reductions and the broadcast from rank 0, the
//! particle domain (owners, ghosts against every image within the halo, refresh,
//! migration), shifts of any length, a bad input on one rank of a halo exchange, a gather
//! or a shift (an error, not a hang or an aborted job), and a rank killed mid-run ending the
//! job. Built only with the `mpi` feature; the test launches its own binary under `mpirun`
//! (skipped with a message when `mpirun` is missing, unless `SIMKIT_REQUIRE_MPI=1`).
#![cfg(feature = "mpi")]

use simkit_backend::testing::check_on_ranks;

use simkit_backend::comm::{CartDecomposition, Comm};

const NAME: &str = "halo_gather_and_reductions_across_ranks";

/// The global test field: plane `s`, cell `(x, y)`.
fn value(s: usize, x: usize, y: usize) -> f64 {
    (10_000 * s + 100 * y + x) as f64 + 0.5
}

fn child(comm: &Comm) -> Result<usize, String> {
    let (rank, size) = (comm.rank(), comm.size());
    for (global, periodic) in [
        ([13, 11], [false, false]),
        ([13, 11], [true, true]),
        ([13, 11], [true, false]),
        ([9, 17], [false, true]),
    ] {
        let d = CartDecomposition::new(global, size, periodic).expect("decomposition");
        let b = d.block(rank);
        let [nx, ny] = b.len;
        for depth in 1..=3 {
            let (w, h) = (nx + 2 * depth, ny + 2 * depth);
            let mut f = vec![-1.0f64; 2 * w * h];
            for s in 0..2 {
                for j in 0..ny {
                    for i in 0..nx {
                        f[s * w * h + (j + depth) * w + i + depth] =
                            value(s, b.start[0] + i, b.start[1] + j);
                    }
                }
            }
            d.exchange_halo(comm, &mut f, depth).expect("exchange");
            // A padded cell holds the global value at its position, wrapped on periodic
            // axes; a cell outside a non-periodic edge keeps its -1.
            let wrap = |c: isize, n: usize, p: bool| -> Option<usize> {
                let n = n as isize;
                if (0..n).contains(&c) {
                    Some(c as usize)
                } else if p {
                    Some(c.rem_euclid(n) as usize)
                } else {
                    None
                }
            };
            for s in 0..2 {
                for j in 0..h {
                    for i in 0..w {
                        let gx = b.start[0] as isize + i as isize - depth as isize;
                        let gy = b.start[1] as isize + j as isize - depth as isize;
                        let want = match (
                            wrap(gx, global[0], periodic[0]),
                            wrap(gy, global[1], periodic[1]),
                        ) {
                            (Some(x), Some(y)) => value(s, x, y),
                            _ => -1.0,
                        };
                        let got = f[s * w * h + j * w + i];
                        assert_eq!(
                            got, want,
                            "rank {rank}/{size}, {global:?} periodic {periodic:?}, depth {depth}, \
                             plane {s}, padded ({i}, {j})"
                        );
                    }
                }
            }
        }
        let local: Vec<f64> = (0..2)
            .flat_map(|s| {
                (0..ny).flat_map(move |j| {
                    (0..nx).map(move |i| value(s, b.start[0] + i, b.start[1] + j))
                })
            })
            .collect();
        let all = d.gather(comm, &local).expect("gather");
        assert_eq!(all.is_some(), rank == 0);
        if let Some(all) = all {
            let want: Vec<f64> = (0..2)
                .flat_map(|s| {
                    (0..global[1]).flat_map(move |y| (0..global[0]).map(move |x| value(s, x, y)))
                })
                .collect();
            assert_eq!(all, want, "gathered field, {global:?}");
        }
    }
    let x = 0.1 * (rank + 1) as f64;
    let in_order = (1..size).fold(0.1, |a, r| a + 0.1 * (r + 1) as f64);
    assert_eq!(comm.all_sum(x).unwrap().to_bits(), in_order.to_bits());
    assert_eq!(comm.all_max(x).unwrap(), 0.1 * size as f64);
    assert_eq!(comm.all_min(x).unwrap(), 0.1);
    let nan = if rank == size - 1 { f64::NAN } else { x };
    assert!(
        comm.all_max(nan).unwrap().is_nan(),
        "a NaN on one rank reaches all"
    );
    assert!(comm.all_any(rank == 1).unwrap());
    assert!(!comm.all_any(false).unwrap());
    // Rank 0's bytes reach every rank, whatever the others pass; an empty message too.
    let root: Vec<u8> = (0..1000u32).map(|k| (k * 7 % 251) as u8).collect();
    let mine = if rank == 0 {
        Some(root.clone())
    } else {
        Some(vec![9; 3])
    };
    assert_eq!(comm.broadcast_from_root(mine).unwrap(), root);
    let empty = comm.broadcast_from_root(Some(Vec::<f64>::new())).unwrap();
    assert!(empty.is_empty());
    // Rank 0 without data: an error on every rank, not a hang.
    let none = if rank == 0 { None } else { Some(vec![1.0f64]) };
    assert!(comm.broadcast_from_root(none).is_err());
    one_bad_rank(comm);
    Ok(1)
}

/// A bad input on exactly one rank (the last) of a halo exchange and of a gather, and a
/// failed check on rank 0 of an indexed gather: every rank returns an error at once
/// (before, the others waited forever for its messages), the others naming the failing
/// rank with its message. A message of the wrong length in a shift: an error on its
/// receiver, not an aborted job. The next collective call works.
fn one_bad_rank(comm: &Comm) {
    let (rank, size) = (comm.rank(), comm.size());
    let bad = size - 1;
    let d = CartDecomposition::new([13, 11], size, [true, true]).expect("decomposition");
    let [nx, ny] = d.block(rank).len;
    let len = (nx + 2) * (ny + 2) * 2 - usize::from(rank == bad);
    let mut f = vec![0.0f64; len];
    let err = d
        .exchange_halo(comm, &mut f, 1)
        .expect_err("one rank's fields are short");
    let text = err.to_string();
    assert!(
        text.contains("length of the padded fields"),
        "rank {rank}: {text}"
    );
    if rank != bad {
        assert!(text.contains(&format!("rank {bad}")), "rank {rank}: {text}");
    }
    let local = vec![1.0f64; nx * ny + usize::from(rank == bad)];
    let err = d
        .gather(comm, &local)
        .expect_err("one rank's block is long");
    assert!(
        err.to_string().contains("length of the local fields"),
        "rank {rank}: {err}"
    );
    // Particles that are not each held once (every rank claims particle 0): rank 0 finds
    // it, and every rank returns the error (before, only rank 0 did).
    let mine = [[0.0f64, rank as f64]];
    let err = comm
        .gather_indexed(&mine, size)
        .expect_err("particle 0 on every rank");
    assert!(
        err.to_string().contains("gathered particles"),
        "rank {rank}: {err}"
    );
    // A shift around the ring where the last rank sends one value more than its receiver
    // (rank 0) expects: an error on rank 0 naming the sender and both lengths (before, a
    // receive too short for the message, MPI_ERR_TRUNCATE, aborted the job); the others
    // receive theirs.
    let (dest, source) = ((rank + 1) % size, (rank + size - 1) % size);
    let send = vec![rank as f64; 1 + usize::from(rank == bad)];
    let mut recv = [0.0f64];
    let got = comm.shift(&send, Some(dest), &mut recv, Some(source), 7);
    if rank == 0 {
        let text = got
            .expect_err("a message longer than the receive buffer")
            .to_string();
        assert!(
            text.contains(&format!("message from rank {bad}")) && text.contains("16 bytes"),
            "{text}"
        );
    } else {
        got.unwrap_or_else(|e| panic!("rank {rank}: {e}"));
        assert_eq!(recv, [source as f64]);
    }
    // Messages of any length (rank r sends r + 1 values): each rank gets its source's,
    // with no count sent ahead of the data.
    let send: Vec<u32> = (0..=rank as u32).collect();
    let got = comm
        .shift_vec(&send, Some(dest), Some(source), 8)
        .unwrap_or_else(|e| panic!("rank {rank}: {e}"));
    assert_eq!(got, (0..=source as u32).collect::<Vec<_>>(), "rank {rank}");
    // Nothing is left half-sent: the communicator still works.
    assert_eq!(comm.all_sum(1.0).unwrap(), size as f64);
}

#[test]
fn halo_gather_and_reductions_across_ranks() {
    check_on_ranks(NAME, &[2, 3, 4], 1, child);
}

/// 300 particles `[x, y, id]` in a 10 x 7 box, pseudo-random and the same on every rank.
fn particles() -> Vec<[f64; 3]> {
    (0..300u32)
        .map(|k| {
            let u = |s: u32| f64::from(simkit_backend::rng::rng_uniform(3, s, k));
            [10.0 * u(0), 7.0 * u(1), f64::from(k)]
        })
        .collect()
}

fn shift(p: &mut [f64; 3], s: [f64; 2]) {
    p[0] += s[0];
    p[1] += s[1];
}

/// `ParticleDomain` on P ranks: owners tile the particles, the ghosts are exactly every
/// particle and periodic image within the halo of an owned particle's region (none
/// missing, each with the shifted coordinates its sender computes), a refresh moves them
/// with their owners, and migration after a move gives every particle to its new owner.
fn domain_child(comm: &Comm) -> Result<usize, String> {
    use simkit_backend::comm::ParticleDomain;
    let (len, halo) = ([10.0, 7.0], 1.3);
    let mut checked = 0;
    for periodic in [[true, true], [false, true], [true, false], [false, false]] {
        let d = ParticleDomain::new([0.0; 2], len, periodic, halo, None, comm.size())
            .map_err(|e| e.to_string())?;
        let all = particles();
        let mut local: Vec<[f64; 3]> = all
            .iter()
            .filter(|p| d.owner([p[0], p[1]]) == comm.rank())
            .copied()
            .collect();
        let owned = local.len();
        let total = comm.all_sum(owned as f64).map_err(|e| e.to_string())?;
        if total != 300.0 {
            return Err(format!(
                "{periodic:?}: the regions own {total} of 300 particles"
            ));
        }
        let plan = d
            .ghosts(comm, &mut local, |p| [p[0], p[1]], shift)
            .map_err(|e| e.to_string())?;
        // Every image of every particle within the halo of the region: present.
        let (lo, hi) = d.region(comm.rank());
        let images = |p: &[f64; 3]| -> Vec<[f64; 3]> {
            let mut out = Vec::new();
            for sx in [-1.0, 0.0, 1.0] {
                for sy in [-1.0, 0.0, 1.0] {
                    if (sx != 0.0 && !periodic[0]) || (sy != 0.0 && !periodic[1]) {
                        continue;
                    }
                    let mut q = *p;
                    shift(&mut q, [sx * len[0], sy * len[1]]);
                    out.push(q);
                }
            }
            out
        };
        // In the region grown by the halo on every side.
        let near = |q: &[f64; 3]| (0..2).all(|a| q[a] >= lo[a] - halo && q[a] < hi[a] + halo);
        for p in &all {
            for q in images(p) {
                let inside = (0..2).all(|a| q[a] >= lo[a] && q[a] < hi[a]);
                // Needed: within the halo of the region but not an owned particle.
                let needed = near(&q) && !inside;
                if needed && !local[owned..].contains(&q) && !local[..owned].contains(&q) {
                    return Err(format!(
                        "{periodic:?} rank {}: particle {} at ({}, {}) within the halo of \
                         [{lo:?}, {hi:?}) is missing",
                        comm.rank(),
                        q[2],
                        q[0],
                        q[1]
                    ));
                }
            }
        }
        if local[owned..].iter().any(|q| !near(q)) {
            return Err(format!("{periodic:?}: a ghost outside the halo"));
        }
        // A refresh sends the same entries into the same slots: mark every owned particle
        // (id + 1000) and every ghost must come back marked, in place.
        let before = local.clone();
        for p in &mut local[..owned] {
            p[2] += 1000.0;
        }
        plan.refresh(comm, &mut local, shift)
            .map_err(|e| e.to_string())?;
        for (g, b) in local[owned..].iter().zip(&before[owned..]) {
            if *g != [b[0], b[1], b[2] + 1000.0] {
                return Err(format!("{periodic:?}: ghost {b:?} refreshed as {g:?}"));
            }
        }
        // Move every owned particle by less than half the halo and migrate.
        let mut mine: Vec<[f64; 3]> = all
            .iter()
            .filter(|p| d.owner([p[0], p[1]]) == comm.rank())
            .map(|p| {
                let k = p[2] as u32;
                let u = |s: u32| f64::from(simkit_backend::rng::rng_uniform(4, s, k)) - 0.5;
                let mut q = [p[0] + 0.6 * halo * u(0), p[1] + 0.6 * halo * u(1), p[2]];
                for a in 0..2 {
                    if periodic[a] {
                        q[a] = q[a].rem_euclid(len[a]);
                    }
                }
                q
            })
            .collect();
        mine = d
            .migrate(comm, mine, |p| [p[0], p[1]])
            .map_err(|e| e.to_string())?;
        if mine.iter().any(|p| d.owner([p[0], p[1]]) != comm.rank()) {
            return Err(format!(
                "{periodic:?}: a migrated particle is not this rank's"
            ));
        }
        let total = comm.all_sum(mine.len() as f64).map_err(|e| e.to_string())?;
        if total != 300.0 {
            return Err(format!("{periodic:?}: {total} particles after migration"));
        }
        checked += 1;
    }
    Ok(checked)
}

#[test]
fn particle_domain_across_ranks() {
    check_on_ranks("particle_domain_across_ranks", &[2, 3, 4], 4, domain_child);
}

/// Set in the ranks of `a_rank_killed_mid_run_ends_the_job`.
const KILL_ENV: &str = "SIMKIT_KILLED_RANK_CHILD";

#[test]
fn a_rank_killed_mid_run_ends_the_job() {
    // Under `mpirun -np 2`: both ranks exchange (all-reduce) in a loop; after 50 rounds the
    // last rank kills itself (SIGKILL, no goodbye). The other must not wait forever: the
    // job ends, with an error, well within the 60 s a hung collective would take here.
    if std::env::var_os(KILL_ENV).is_some() {
        let comm = Comm::mpi().expect("MPI");
        let start = std::time::Instant::now();
        for round in 0.. {
            comm.all_max(f64::from(round)).expect("an exchange");
            if round == 50 && comm.rank() == comm.size() - 1 {
                let me = std::process::id().to_string();
                let _ = std::process::Command::new("kill")
                    .args(["-9", &me])
                    .status();
            }
            if start.elapsed() > std::time::Duration::from_secs(120) {
                // Never reached when the job ends as it must.
                std::process::exit(0);
            }
        }
        return;
    }
    let have = std::process::Command::new("mpirun")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !have {
        assert!(
            std::env::var("SIMKIT_REQUIRE_MPI").as_deref() != Ok("1"),
            "SIMKIT_REQUIRE_MPI=1 but `mpirun` is not on the PATH"
        );
        eprintln!("a_rank_killed_mid_run_ends_the_job: skipped, no `mpirun`");
        return;
    }
    let exe = std::env::current_exe().expect("the test binary");
    let start = std::time::Instant::now();
    let out = std::process::Command::new("mpirun")
        .args(["--allow-run-as-root", "--oversubscribe", "--timeout", "60"])
        .args(["-np", "2"])
        .arg(&exe)
        .args([
            "a_rank_killed_mid_run_ends_the_job",
            "--exact",
            "--nocapture",
        ])
        .env(KILL_ENV, "1")
        .output()
        .expect("starting mpirun");
    let took = start.elapsed().as_secs_f64();
    let stderr = String::from_utf8_lossy(&out.stderr);
    println!("the job ended after {took:.1} s ({}): {stderr}", out.status);
    assert!(
        !out.status.success(),
        "the job with a killed rank succeeded"
    );
    assert!(took < 30.0, "the job took {took:.1} s to end");
}
