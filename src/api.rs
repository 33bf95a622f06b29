//! The shape of every simulation crate, as compiled examples: the same calls build, step,
//! read, checkpoint and resume a run in `rd`, `lattice_gas`, `pp_coulomb`, `dem` and `md`,
//! and their distributed twins.
//!
//! | step | single process | distributed twin |
//! |---|---|---|
//! | build | `Sim::new(input, &config, backend)` (the input by value; `Rd` also takes the model) | `DistributedSim::new(input, &config, comm)` |
//! | advance | `Simulation::step(n)`, `step_observed(n, every, f)` | the same (collective) |
//! | read | `Simulation::state()`, `steps_done()`, `backend_name()`; `config()` | the same, the whole run on every rank; `Distributed::comm()` |
//! | checkpoint | `Restart::checkpoint()`, `write_checkpoint(path)` | `Distributed::checkpoint()` (on every rank), `write_checkpoint(path)` (from rank 0) |
//! | resume | `Restart::resume(&bytes, backend)`, `resume_file(path, backend)` | `Distributed::resume(&bytes, comm)`, `resume_file(path, comm)` (rank 0 reads) |
//!
//! A checkpoint of a distributed twin is the single-process checkpoint of the same run, so a
//! run moves between one process (on the CPU, in `f64` for `dem` and `md`) and any rank count.
//! Each example below is a doctest: if a crate's shape drifted, it would stop compiling.
//! The generic functions show code written once for every crate:
//!
//! ```
//! use simkit::prelude::*;
//!
//! /// Steps a run, checkpoints it and resumes the checkpoint on the same backend.
//! pub fn round_trip<S: Restart>(sim: &mut S, steps: u32, backend: Backend<'_>) -> Result<S> {
//!     sim.step(steps)?;
//!     S::resume(&sim.checkpoint()?, backend)
//! }
//!
//! /// The same for any distributed twin, over its communicator.
//! pub fn round_trip_distributed<S: Distributed>(sim: &mut S, steps: u32) -> Result<S> {
//!     sim.step(steps)?;
//!     S::resume(&sim.checkpoint()?, sim.comm().clone())
//! }
//! ```
//!
//! ## rd
//!
//! ```
//! use simkit::backend::comm::Comm;
//! use simkit::prelude::*;
//! use simkit::rd::{Config, DistributedRd, GrayScott, Stepping, scenes::gray_scott_square};
//! # fn main() -> Result<()> {
//! let grid = gray_scott_square::<f64>(32, 1.0, 6, 1)?;
//! let config = Config::new(Stepping::euler(0.2));
//! let mut sim = Rd::new(grid.clone(), GrayScott::spots(), &config, Backend::Cpu)?;
//! sim.step(20)?;
//! let state = sim.state()?;
//! let mut resumed = Rd::<f64, GrayScott>::resume(&sim.checkpoint()?, Backend::Cpu)?;
//! assert_eq!((resumed.steps_done(), resumed.state()?), (20, state.clone()));
//!
//! let mut twin = DistributedRd::new(grid, GrayScott::spots(), &config, Comm::serial())?;
//! twin.step(20)?;
//! assert_eq!(twin.state()?, state); // bit for bit on any rank count
//! let mut moved = DistributedRd::<f64, GrayScott>::resume(&twin.checkpoint()?, Comm::serial())?;
//! assert_eq!(moved.state()?, state);
//! # Ok(())
//! # }
//! ```
//!
//! ## lattice_gas
//!
//! ```
//! use simkit::backend::comm::Comm;
//! use simkit::lattice_gas::{Config, DistributedLatticeGas};
//! use simkit::prelude::*;
//! # fn main() -> Result<()> {
//! let mut lattice = Lattice::new(64, 32)?;
//! lattice.fill_random(0.3, 7)?;
//! let config = Config::default();
//! let mut sim = LatticeGas::new(lattice.clone(), &config, Backend::Cpu)?;
//! sim.step(20)?;
//! let state = sim.state()?;
//! let mut resumed = LatticeGas::resume(&sim.checkpoint()?, Backend::Cpu)?;
//! assert_eq!((resumed.steps_done(), resumed.state()?), (20, state.clone()));
//!
//! let mut twin = DistributedLatticeGas::new(lattice, &config, Comm::serial())?;
//! twin.step(20)?;
//! assert_eq!(twin.state()?, state); // bit for bit on any rank count
//! let mut moved = DistributedLatticeGas::resume(&twin.checkpoint()?, Comm::serial())?;
//! assert_eq!(moved.state()?, state);
//! # Ok(())
//! # }
//! ```
//!
//! ## pp_coulomb
//!
//! ```
//! use simkit::backend::comm::Comm;
//! use simkit::pp_coulomb::{Config, DistributedCoulomb, ForceLaw, Particles, Region, Species};
//! use simkit::pp_coulomb::Velocities;
//! use simkit::prelude::*;
//! # fn main() -> Result<()> {
//! let mut particles = Particles::new();
//! let e = particles.add_species(Species::new("electron", -1.0, 1.0))?;
//! let cube = Region::Cube { min: [0.0; 3], length: 10.0 };
//! particles.fill(e, 64, cube, Velocities::Maxwellian { thermal_speed: 0.3 }, 7)?;
//! let config = Config::new(0.05, ForceLaw::Plummer { epsilon: 0.5 });
//! let mut sim = PpCoulomb::new(particles.clone(), &config, Backend::Cpu)?;
//! sim.step(20)?;
//! let state = sim.state()?;
//! let mut resumed = PpCoulomb::resume(&sim.checkpoint()?, Backend::Cpu)?;
//! assert_eq!((resumed.steps_done(), resumed.state()?), (20, state.clone()));
//!
//! let mut twin = DistributedCoulomb::new(particles, &config, Comm::serial())?;
//! twin.step(20)?;
//! assert_eq!(twin.state()?, state); // bit for bit on any rank count
//! let mut moved = DistributedCoulomb::resume(&twin.checkpoint()?, Comm::serial())?;
//! assert_eq!(moved.state()?, state);
//! # Ok(())
//! # }
//! ```
//!
//! ## dem
//!
//! ```
//! use simkit::backend::comm::Comm;
//! use simkit::dem::scenes::{BedParams, vibrating_bed};
//! use simkit::dem::{Config, DistributedDem};
//! use simkit::prelude::*;
//! # fn main() -> Result<()> {
//! let (scene, _units) = vibrating_bed(&BedParams { n: 64, width: 8, ..BedParams::default() })?;
//! let config = Config::default();
//! let mut sim = Dem::new(scene.clone(), &config, Backend::Cpu)?;
//! sim.step(20)?;
//! let state = sim.state()?;
//! let mut resumed: Dem = Dem::resume(&sim.checkpoint()?, Backend::Cpu)?;
//! assert_eq!((resumed.steps_done(), resumed.state()?), (20, state));
//!
//! // The twin's results do not depend on the rank count (its own order of summation).
//! let mut twin = DistributedDem::new(scene, &config, Comm::serial())?;
//! twin.step(20)?;
//! let here = twin.state()?;
//! let mut moved: DistributedDem = DistributedDem::resume(&twin.checkpoint()?, Comm::serial())?;
//! assert_eq!((moved.steps_done(), moved.state()?), (20, here));
//! # Ok(())
//! # }
//! ```
//!
//! ## md
//!
//! ```
//! use simkit::backend::comm::Comm;
//! use simkit::md::{Config, DistributedMd, LennardJones, PairTable, scenes};
//! use simkit::prelude::*;
//! # fn main() -> Result<()> {
//! let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5))?;
//! let system = scenes::fcc_lattice([3; 3], 0.8442, 1.44, table, &[0], 7)?;
//! let config = Config::default().with_dt(0.005);
//! let mut sim = Md::new(system.clone(), &config, Backend::Cpu)?;
//! sim.step(20)?;
//! let state = sim.state()?;
//! let mut resumed: Md = Md::resume(&sim.checkpoint()?, Backend::Cpu)?;
//! assert_eq!((resumed.steps_done(), resumed.state()?), (20, state));
//!
//! // The twin's results do not depend on the rank count (its own order of summation).
//! let mut twin = DistributedMd::new(system, &config, Comm::serial())?;
//! twin.step(20)?;
//! let here = twin.state()?;
//! let mut moved: DistributedMd = DistributedMd::resume(&twin.checkpoint()?, Comm::serial())?;
//! assert_eq!((moved.steps_done(), moved.state()?), (20, here));
//! # Ok(())
//! # }
//! ```
