//! The distributed-run cases shared by `tests/distributed.rs` (serial communicator) and
//! `tests/mpi.rs` (the same cases under `mpirun -np P`): each case runs as a
//! [`DistributedLatticeGas`] over the given communicator and, on rank 0, is compared bit for
//! bit with the single-process run.

use simkit_backend::comm::Comm;
use simkit_backend::{Backend, Distributed, Restart, Simulation};
use simkit_lattice_gas::{
    Config, CpuMethod, DistributedLatticeGas, Lattice, LatticeGas, Obstacle, RuleSet,
};

/// `Err` naming the case on any failure of `r`.
fn named<T>(label: &str, what: &str, r: simkit_backend::Result<T>) -> Result<T, String> {
    r.map_err(|e| format!("{label}: {what}: {e}"))
}

/// The first site where `got` differs from `want`, described; `None` if they are equal.
fn first_difference(want: &Lattice, got: &Lattice) -> Option<String> {
    if (want.width(), want.height()) != (got.width(), got.height()) {
        return Some(format!(
            "size {} x {} instead of {} x {}",
            got.width(),
            got.height(),
            want.width(),
            want.height()
        ));
    }
    let k = want
        .cells()
        .iter()
        .zip(got.cells())
        .position(|(a, b)| a != b)?;
    Some(format!(
        "site ({}, {}) is {:#010b}, the single-process run has {:#010b}",
        k % want.width(),
        k / want.width(),
        got.cells()[k],
        want.cells()[k]
    ))
}

/// Runs one case over `comm` for `steps` steps and compares the gathered lattice (on rank
/// 0) with the single-process CPU run of `config` (whose `cpu` picks the method); returns
/// the blocks along x and y the lattice was cut into.
fn case(
    comm: &Comm,
    label: &str,
    lattice: &Lattice,
    config: &Config,
    steps: u32,
) -> Result<[usize; 2], String> {
    case_on(comm, Backend::Cpu, label, lattice, config, steps)
}

/// [`case`] with the distributed run stepping its blocks on `backend`.
fn case_on(
    comm: &Comm,
    backend: Backend<'_>,
    label: &str,
    lattice: &Lattice,
    config: &Config,
    steps: u32,
) -> Result<[usize; 2], String> {
    let label = format!(
        "{label}, {} x {}, on {} rank(s), {}",
        lattice.width(),
        lattice.height(),
        comm.size(),
        backend.name()
    );
    let mut dist = named(
        &label,
        "building the distributed run",
        DistributedLatticeGas::with_backend(lattice.clone(), config, comm.clone(), backend),
    )?;
    // In two calls: the step counter carries over between them.
    named(&label, "step", dist.step(steps / 2))?;
    named(&label, "step", dist.step(steps - steps / 2))?;
    let count = named(&label, "particle count", dist.particle_count())?;
    let gathered = named(&label, "state", dist.state())?;
    let dims = dist.decomposition().dims();
    let mut one = named(
        &label,
        "building the serial run",
        LatticeGas::new(lattice.clone(), config, Backend::Cpu),
    )?;
    named(&label, "serial step", one.step(steps))?;
    let want = named(&label, "serial state", one.state())?;
    if want == *lattice {
        return Err(format!(
            "{label}: the lattice did not change; the case tests nothing"
        ));
    }
    if let Some(d) = first_difference(&want, &gathered) {
        return Err(format!("{label}: after {steps} steps {d}"));
    }
    if dist.steps_done() != u64::from(steps) || count != want.particle_count() {
        return Err(format!(
            "{label}: {} steps done, {count} particles; the serial run: {steps}, {}",
            dist.steps_done(),
            want.particle_count()
        ));
    }
    Ok(dims)
}

/// A checkpoint moves between rank counts: 1 process -> `comm.size()` ranks -> 1 process,
/// continuing bit for bit with the uninterrupted single-process run.
fn checkpoint_case(comm: &Comm, lattice: &Lattice, config: &Config) -> Result<(), String> {
    let label = format!("checkpoint 1 -> {} -> 1 rank(s)", comm.size());
    let e = |what: &str| {
        let label = label.clone();
        let what = what.to_string();
        move |e: simkit_backend::Error| format!("{label}: {what}: {e}")
    };
    let mut whole = LatticeGas::new(lattice.clone(), config, Backend::Cpu).map_err(e("serial"))?;
    whole.step(30).map_err(e("serial step"))?;
    let mut first = LatticeGas::new(lattice.clone(), config, Backend::Cpu).map_err(e("serial"))?;
    first.step(10).map_err(e("serial step"))?;
    let saved = first.checkpoint().map_err(e("serial checkpoint"))?;
    let mut dist = DistributedLatticeGas::resume(&saved, comm.clone()).map_err(e("resume"))?;
    dist.step(10).map_err(e("distributed step"))?;
    let saved = dist.checkpoint().map_err(e("distributed checkpoint"))?;
    // And once more onto the distributed run, through a file that rank 0 writes and reads
    // (its path chosen on rank 0 and sent to the others).
    let dir = comm.is_root().then(|| {
        let d = std::env::temp_dir().join(format!("simkit-lg-{}", std::process::id()));
        d.display().to_string().into_bytes()
    });
    let dir = comm.broadcast_from_root(dir).map_err(e("broadcast"))?;
    let dir = std::path::PathBuf::from(String::from_utf8(dir).map_err(|_| "path".to_string())?);
    let path = dir.join("run.ckpt");
    dist.write_checkpoint(&path)
        .map_err(e("write_checkpoint"))?;
    // A missing file is an error on every rank (no rank left waiting).
    if DistributedLatticeGas::resume_file(dir.join("missing.ckpt"), comm.clone()).is_ok() {
        return Err(format!("{label}: a missing checkpoint file was accepted"));
    }
    let mut dist = DistributedLatticeGas::resume_file(&path, comm.clone()).map_err(e("resume"))?;
    if comm.is_root() {
        let _ = std::fs::remove_dir_all(&dir);
    }
    dist.step(5).map_err(e("distributed step"))?;
    let gathered = dist.state().map_err(e("state"))?;
    let mut last = LatticeGas::resume(&saved, Backend::Cpu).map_err(e("serial resume"))?;
    last.step(10).map_err(e("serial step"))?;
    let want = whole.state().map_err(e("state"))?;
    if let Some(d) = first_difference(&want, &last.state().map_err(e("state"))?) {
        return Err(format!("{label}: after 30 steps {d}"));
    }
    let mut part = LatticeGas::new(lattice.clone(), config, Backend::Cpu).map_err(e("serial"))?;
    part.step(25).map_err(e("serial step"))?;
    if let Some(d) = first_difference(&part.state().map_err(e("state"))?, &gathered) {
        return Err(format!("{label}: after 25 steps {d}"));
    }
    Ok(())
}

/// A random lattice of `w x h` sites at reduced density `d`.
fn random(w: usize, h: usize, d: f64, seed: u32) -> Lattice {
    let mut l = Lattice::new(w, h).expect("a valid size");
    l.fill_random(d, seed).expect("a valid density");
    l
}

/// The source's open channel, 37 x 23: wall rows, a plate, inflow and outflow columns, a
/// weak body force.
fn open_channel() -> (Lattice, Config) {
    let mut open = random(37, 23, 0.2, 3);
    open.add_wall_rows();
    open.add_obstacle(&Obstacle::Rect {
        x0: 20,
        x1: 22,
        y0: 6,
        y1: 15,
    })
    .expect("a plate inside");
    let inflow = Config {
        periodic_x: false,
        periodic_y: false,
        inflow: true,
        outflow: true,
        body_force: 0.01,
        seed: 11,
        ..Config::default()
    };
    (open, inflow)
}

/// Runs every case over `comm`; returns how many were compared (on every rank).
pub fn check_all(comm: &Comm) -> Result<usize, String> {
    let mut cuts = Vec::new();
    // Sizes that split unevenly over 2, 3 and 4 ranks, along x, y or both (the
    // decomposition follows the shape and the periodic axes; see each case); blocks start
    // on odd rows and at site indices that are not multiples of 32.
    let (w, h) = (37, 22);
    let periodic = Config {
        seed: 5,
        ..Config::default()
    };
    // Cut along x.
    cuts.push(case(
        comm,
        "periodic box, FHP-I",
        &random(w, h, 0.3, 1),
        &periodic,
        24,
    )?);
    // Cut along y (38 rows: blocks of 19 or 13 rows start on odd and even rows).
    let forced = Config {
        rules: RuleSet::Full,
        body_force: 0.05,
        ..periodic.clone()
    };
    cuts.push(case(
        comm,
        "tall periodic box, full rules, body force",
        &random(22, 38, 0.3, 8),
        &forced,
        24,
    )?);
    // A channel (cut along y on 2 ranks): wall rows, a disc, periodic x, closed y, body force.
    let mut chan = random(w, h, 0.25, 2);
    chan.add_wall_rows();
    chan.add_obstacle(&Obstacle::Disc {
        cx: 12.0,
        cy: 9.0,
        radius: 4.5,
    })
    .expect("a disc inside");
    let channel = Config {
        rules: RuleSet::Full,
        seed: 9,
        periodic_y: false,
        body_force: 0.03,
        ..Config::default()
    };
    cuts.push(case(
        comm,
        "force-driven channel with a disc",
        &chan,
        &channel,
        24,
    )?);
    // The source's open channel: inflow and outflow columns, a plate, odd height (cut in
    // 2 x 2 on 4 ranks).
    let (open, inflow) = open_channel();
    cuts.push(case(
        comm,
        "inflow/outflow channel with a plate",
        &open,
        &inflow,
        24,
    )?);
    // Open edges everywhere (particles leave), a bitmap obstacle.
    let mut lost = random(w, h + 1, 0.35, 4);
    let data = (0..w * (h + 1))
        .map(|s| (s % w + 2 * (s / w)) % 11 == 0)
        .collect();
    lost.add_obstacle(&Obstacle::Mask {
        width: w,
        height: h + 1,
        data,
    })
    .expect("a mask of the lattice's size");
    let closed = Config {
        periodic_x: false,
        periodic_y: false,
        seed: 13,
        ..Config::default()
    };
    cuts.push(case(
        comm,
        "no periodic edge, a bitmap obstacle",
        &lost,
        &closed,
        24,
    )?);
    // Periodic in y only, with force.
    let y_only = Config {
        periodic_x: false,
        body_force: 0.1,
        seed: 17,
        ..Config::default()
    };
    cuts.push(case(
        comm,
        "periodic y only, body force",
        &random(w, h, 0.3, 5),
        &y_only,
        24,
    )?);
    // Rows longer than 64 sites in every block (the AVX-512 VBMI path where the CPU has
    // it), against the multi-spin backend (boolean collisions, another implementation).
    let wide = Config {
        rules: RuleSet::Full,
        body_force: 0.02,
        cpu: CpuMethod::MultiSpin,
        seed: 19,
        ..Config::default()
    };
    cuts.push(case(
        comm,
        "wide box against multi-spin",
        &random(320, 12, 0.3, 6),
        &wide,
        16,
    )?);
    // Periodic in y only, cut in 2 x 2 on 4 ranks (the y neighbours wrap).
    let mut square = random(30, 28, 0.3, 7);
    square
        .add_obstacle(&Obstacle::Disc {
            cx: 15.0,
            cy: 12.0,
            radius: 5.0,
        })
        .expect("a disc inside");
    let square_config = Config {
        periodic_x: false,
        seed: 23,
        ..Config::default()
    };
    cuts.push(case(
        comm,
        "square, periodic y, a disc",
        &square,
        &square_config,
        24,
    )?);
    checkpoint_case(comm, &chan, &channel)?;
    // The cases cut the lattice along x, along y and, on 4 ranks, along both.
    let p = comm.size();
    let want: &[[usize; 2]] = match p {
        1 => &[[1, 1]],
        4 => &[[4, 1], [1, 4], [2, 2]],
        _ => &[[p, 1], [1, p]],
    };
    if let Some(missing) = want.iter().find(|d| !cuts.contains(d)) {
        return Err(format!(
            "no case was cut into {missing:?} blocks on {p} rank(s): {cuts:?}"
        ));
    }
    Ok(cuts.len() + 1)
}

/// Cases of [`check_all`] with every rank stepping its block on its own GPU
/// (`GpuContext::for_local_rank`), the halo through the host: the same bits as the
/// single-process CPU run. Returns how many were compared.
///
/// Errors (on every rank): a rank without an adapter, or any difference.
#[cfg(feature = "gpu")]
pub fn check_gpu(comm: &Comm) -> Result<usize, String> {
    use simkit_backend::GpuContext;
    let (local, _) = comm.local_rank();
    let ctx = comm
        .agree(GpuContext::for_local_rank(local))
        .map_err(|e| format!("rank {}: no GPU for local rank {local}: {e}", comm.rank()))?;
    let gpu = Backend::Gpu(&ctx);
    let (w, h) = (37, 22);
    let forced = Config {
        rules: RuleSet::Full,
        body_force: 0.05,
        seed: 6,
        ..Config::default()
    };
    case_on(
        comm,
        gpu,
        "periodic box, full rules, body force",
        &random(w, h, 0.3, 1),
        &forced,
        16,
    )?;
    let (open, inflow) = open_channel();
    case_on(
        comm,
        gpu,
        "inflow/outflow channel with a plate",
        &open,
        &inflow,
        16,
    )?;
    // Resumed from a single-process checkpoint onto the GPUs.
    let mut first =
        LatticeGas::new(open.clone(), &inflow, Backend::Cpu).map_err(|e| e.to_string())?;
    first.step(7).map_err(|e| e.to_string())?;
    let saved = first.checkpoint().map_err(|e| e.to_string())?;
    let mut dist = DistributedLatticeGas::resume_with_backend(&saved, comm.clone(), gpu)
        .map_err(|e| format!("resume on the GPUs: {e}"))?;
    dist.step(9).map_err(|e| e.to_string())?;
    first.step(9).map_err(|e| e.to_string())?;
    let got = dist.state().map_err(|e| e.to_string())?;
    let want = first.state().map_err(|e| e.to_string())?;
    if let Some(d) = first_difference(&want, &got) {
        return Err(format!("resumed on the GPUs: after 16 steps {d}"));
    }
    if !dist.backend_name().starts_with("gpu") {
        return Err(format!("stepped on {}", dist.backend_name()));
    }
    Ok(3)
}
