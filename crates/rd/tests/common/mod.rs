//! The distributed-run cases shared by `tests/distributed.rs` (serial communicator) and
//! `tests/mpi.rs` (the same cases under `mpirun -np P`): each case runs as a
//! [`DistributedRd`] over the given communicator and, on rank 0, is compared bit for bit
//! with the single-process CPU run.

use simkit_backend::Distributed;
use simkit_backend::comm::Comm;
use simkit_backend::{Backend, Restart, Simulation};
use simkit_rd::{
    Boundaries, Boundary, Config, Diffusion, DistributedRd, GrayScott, Grid, Model, Rd, Real,
    Stepping, scenes,
};

/// Every value's bits, species after species.
fn bits<T: Real>(g: &Grid<T>) -> Vec<u64> {
    g.fields()
        .iter()
        .flatten()
        .map(|v| v.to_f64().to_bits())
        .collect()
}

/// Runs one case over `comm` and returns the run's outcome (the `step` result as text):
/// `Err` from the outer `Result` when the ranks disagree or, on rank 0, the outcome
/// (error text included), the step reached or any bit differs from the single-process CPU
/// run.
fn case<T: Real, M: Model>(
    comm: &Comm,
    label: &str,
    grid: &Grid<T>,
    model: M,
    config: &Config,
    steps: u32,
) -> Result<Result<(), String>, String> {
    let label = format!("{label} on {} rank(s)", comm.size());
    let mut dist = DistributedRd::new(grid.clone(), model.clone(), config, comm.clone())
        .map_err(|e| format!("{label}: building the distributed run: {e}"))?;
    let dist_result = dist.step(steps).map_err(|e| e.to_string());
    // Every rank must return the same result.
    let text = format!("{dist_result:?} at step {}", dist.steps_done());
    let sums = comm
        .all_gather(&[crc32fast::hash(text.as_bytes())])
        .map_err(|e| e.to_string())?;
    if sums.iter().any(|&s| s != sums[0]) {
        return Err(format!(
            "{label}: the ranks returned different results ({text} here)"
        ));
    }
    let gathered = dist.state().map_err(|e| format!("{label}: state: {e}"))?;
    let mut one = Rd::new(grid.clone(), model, config, Backend::Cpu)
        .map_err(|e| format!("{label}: building the serial run: {e}"))?;
    let one_result = one.step(steps).map_err(|e| e.to_string());
    if one_result != dist_result || one.steps_done() != dist.steps_done() {
        return Err(format!(
            "{label}: serial {one_result:?} at step {}, distributed {dist_result:?} at step {}",
            one.steps_done(),
            dist.steps_done()
        ));
    }
    let want = one.state().map_err(|e| e.to_string())?;
    let (a, b) = (bits(&want), bits(&gathered));
    if a != b {
        let k = a.iter().zip(&b).position(|(x, y)| x != y).unwrap_or(0);
        let n = grid.nx() * grid.ny();
        return Err(format!(
            "{label}: species {} cell ({}, {}) differs: serial {:e}, distributed {:e}",
            k / n,
            k % n % grid.nx(),
            k % n / grid.nx(),
            f64::from_bits(a[k]),
            f64::from_bits(b[k])
        ));
    }
    Ok(dist_result)
}

/// [`case`] for a run that must succeed.
fn ok_case<T: Real, M: Model>(
    comm: &Comm,
    label: &str,
    grid: &Grid<T>,
    model: M,
    config: &Config,
    steps: u32,
) -> Result<(), String> {
    case(comm, label, grid, model, config, steps)?.map_err(|e| format!("{label}: {e}"))
}

/// The same fields with other edges.
fn with_edges<T: Real>(g: &Grid<T>, b: Boundaries) -> Grid<T> {
    Grid::new(g.nx(), g.ny(), g.h(), b, g.fields().to_vec()).expect("a valid grid")
}

/// The edge sets every case runs with (`species` values per Dirichlet edge): each kind on
/// all edges, and mixes of periodic with the others.
fn edge_sets(species: usize, value: f64) -> Vec<(&'static str, Boundaries)> {
    let dir = Boundary::Dirichlet(vec![value; species]);
    vec![
        ("no-flux", Boundaries::no_flux()),
        ("periodic", Boundaries::periodic()),
        ("dirichlet", Boundaries::all(dir.clone())),
        (
            "periodic x, dirichlet/no-flux y",
            Boundaries {
                west: Boundary::Periodic,
                east: Boundary::Periodic,
                south: dir.clone(),
                north: Boundary::NoFlux,
            },
        ),
        (
            "no-flux/dirichlet x, periodic y",
            Boundaries {
                west: Boundary::NoFlux,
                east: dir,
                south: Boundary::Periodic,
                north: Boundary::Periodic,
            },
        ),
    ]
}

/// Runs every case over `comm`; returns how many were compared (on every rank).
pub fn check_all(comm: &Comm) -> Result<usize, String> {
    let mut n = 0;
    let (nx, ny) = (37, 23);
    let every = |s: Stepping| Config::new(s).with_check_every(10);
    // Diffusion of a random field, Euler and Heun.
    let u: Vec<f64> = (0..nx * ny)
        .map(|k| f64::from(simkit_backend::rng::rng_uniform(7, 0, k as u32)))
        .collect();
    let diffusion = Grid::new(nx, ny, 1.0, Boundaries::no_flux(), vec![u]).expect("grid");
    let gs = {
        let sq = scenes::gray_scott_square::<f64>(nx.max(ny), 1.0, 9, 3).expect("grid");
        // Cut the square to nx x ny.
        let m = nx.max(ny);
        let f = |s: usize| -> Vec<f64> {
            (0..ny)
                .flat_map(|j| sq.field(s)[j * m..j * m + nx].to_vec())
                .collect()
        };
        Grid::new(nx, ny, 1.0, Boundaries::periodic(), vec![f(0), f(1)]).expect("grid")
    };
    let gray_scott = GrayScott::new(1.0, 0.5, 0.04, 0.06).expect("model");
    let (colony_grid, colony) = scenes::colony_scene::<f64>(nx, ny, 5).expect("scene");
    for (edges, b) in edge_sets(1, 0.25) {
        let g = with_edges(&diffusion, b);
        let model = Diffusion::new(&[1.0]).expect("model");
        for s in [Stepping::euler(0.2), Stepping::heun(0.2)] {
            let label = format!("diffusion, {edges}, {:?}", s.integrator);
            ok_case(comm, &label, &g, model.clone(), &every(s), 23)?;
            n += 1;
        }
    }
    for (edges, b) in edge_sets(2, 0.5) {
        let g = with_edges(&gs, b.clone());
        let label = format!("gray-scott f64, {edges}");
        ok_case(
            comm,
            &label,
            &g,
            gray_scott.clone(),
            &every(Stepping::euler(0.2)),
            23,
        )?;
        let label = format!("gray-scott f32, {edges}, Heun");
        let g32 = g.convert::<f32>();
        ok_case(
            comm,
            &label,
            &g32,
            gray_scott.clone(),
            &every(Stepping::heun(0.2)),
            17,
        )?;
        let label = format!("colony, {edges}");
        let g = with_edges(&colony_grid, with_dirichlet_values(b, 0.1));
        ok_case(
            comm,
            &label,
            &g,
            colony.clone(),
            &every(Stepping::euler(0.05)),
            21,
        )?;
        n += 3;
    }
    // A blow-up that starts on one rank only (a huge spike next to a corner, dt four times
    // the bound): every rank must roll back to the same step and return the serial error.
    let mut spike = vec![0.0f64; nx * ny];
    spike[nx + 1] = 1e305;
    let g = Grid::new(nx, ny, 1.0, Boundaries::no_flux(), vec![spike]).expect("grid");
    let model = Diffusion::new(&[1.0]).expect("model");
    let config = Config::new(Stepping::euler(1.0).unguarded()).with_check_every(1);
    match case(comm, "blow-up", &g, model, &config, 10)? {
        Err(e) if e.contains("blow-up detected by step") => n += 1,
        other => return Err(format!("blow-up: expected a blow-up error, got {other:?}")),
    }
    checkpoint_case(comm, &with_edges(&gs, Boundaries::periodic()), &gray_scott)?;
    Ok(n + 1)
}

/// A checkpoint moves between rank counts: one process (10 steps) -> `comm.size()` ranks
/// (8 steps) -> `comm.size()` ranks again from its checkpoint (5 steps) and one process
/// (13 steps), each continuing bit for bit, simulated time included, with the
/// uninterrupted single-process run.
fn checkpoint_case(comm: &Comm, grid: &Grid<f64>, model: &GrayScott) -> Result<(), String> {
    let label = format!("checkpoint 1 -> {0} -> {0} and 1 rank(s)", comm.size());
    let e = |what: &'static str| {
        let label = label.clone();
        move |e: simkit_backend::Error| format!("{label}: {what}: {e}")
    };
    let config = Config::new(Stepping::euler(0.2)).with_check_every(4);
    let serial = |steps: u32| -> Result<Rd<f64, GrayScott>, String> {
        let mut run =
            Rd::new(grid.clone(), model.clone(), &config, Backend::Cpu).map_err(e("serial run"))?;
        run.step(steps).map_err(e("serial step"))?;
        Ok(run)
    };
    let saved = serial(10)?.checkpoint().map_err(e("serial checkpoint"))?;
    let mut dist =
        DistributedRd::<f64, GrayScott>::resume(&saved, comm.clone()).map_err(e("resume"))?;
    dist.step(8).map_err(e("distributed step"))?;
    let saved = dist.checkpoint().map_err(e("distributed checkpoint"))?;
    let mut dist =
        DistributedRd::<f64, GrayScott>::resume(&saved, comm.clone()).map_err(e("resume"))?;
    dist.step(5).map_err(e("distributed step"))?;
    let gathered = dist.state().map_err(e("state"))?;
    let mut want = serial(23)?;
    if bits(&gathered) != bits(&want.state().map_err(e("state"))?) || dist.steps_done() != 23 {
        return Err(format!(
            "{label}: the distributed run differs after 23 steps"
        ));
    }
    let mut last =
        Rd::<f64, GrayScott>::resume(&saved, Backend::Cpu).map_err(e("serial resume"))?;
    last.step(13).map_err(e("serial step"))?;
    want.step(8).map_err(e("serial step"))?;
    let (got, want_grid) = (
        last.state().map_err(e("state"))?,
        want.state().map_err(e("state"))?,
    );
    if bits(&got) != bits(&want_grid) || last.time().to_bits() != want.time().to_bits() {
        return Err(format!(
            "{label}: after 31 steps the resumed run differs (time {} vs {})",
            last.time(),
            want.time()
        ));
    }
    Ok(())
}

/// `b` with every Dirichlet edge's values set to `v`.
fn with_dirichlet_values(b: Boundaries, v: f64) -> Boundaries {
    let f = |e: Boundary| match e {
        Boundary::Dirichlet(x) => Boundary::Dirichlet(vec![v; x.len()]),
        other => other,
    };
    Boundaries {
        west: f(b.west),
        east: f(b.east),
        south: f(b.south),
        north: f(b.north),
    }
}
