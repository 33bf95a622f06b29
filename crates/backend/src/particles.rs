//! What the particle crates (`dem`, `md`) share above the numbers: the host-side view of a
//! state ([`State`]) and the dynamic state as a checkpoint stores it ([`Dynamics`]).

use serde::{Deserialize, Serialize};

use crate::{Error, Result};

/// Host-side snapshot of a particle simulation, in the system's particle order: time,
/// positions and velocities (`[x, y, 0]` in 2D), species.
#[derive(Clone, Debug, PartialEq)]
pub struct State {
    /// Simulation time.
    pub time: f64,
    /// Positions (periodic axes wrapped into the box).
    pub positions: Vec<[f64; 3]>,
    /// Velocities at `time`.
    pub velocities: Vec<[f64; 3]>,
    /// Angular velocities at `time` (`[0, 0, w_z]` in 2D); empty when the particles do not
    /// spin.
    pub angular_velocities: Vec<[f64; 3]>,
    /// Species of every particle.
    pub species: Vec<u32>,
}

impl State {
    /// The positions as `glam::DVec3` values (a view, no copy).
    pub fn positions_dvec3(&self) -> &[glam::DVec3] {
        crate::vector::as_dvec3(&self.positions)
    }

    /// The velocities as `glam::DVec3` values (a view, no copy).
    pub fn velocities_dvec3(&self) -> &[glam::DVec3] {
        crate::vector::as_dvec3(&self.velocities)
    }
}

/// The dynamic state of a particle engine as a checkpoint stores it: everything beyond the
/// inputs and settings that the next steps read. Vectors are flat, `width` values per
/// slot, and hold the engine's numbers exactly (`f32` widens to `f64` without rounding); a
/// column the engine does not keep is empty.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Dynamics {
    /// Steps done.
    pub steps: u64,
    /// Simulated time (an engine that accumulates `t += dt` stores its sum).
    pub time: f64,
    /// Whether the first force evaluation has happened (engines that defer it).
    pub started: bool,
    /// Values per slot in the vectors below (the dimension, or the GPU's 4).
    pub width: u32,
    /// The particle in each slot (its index in the system): the engine's order, e.g. cell
    /// order as of the last list build; empty: the system order.
    pub order: Vec<u32>,
    /// Positions as the engine holds them.
    pub pos: Vec<f64>,
    /// Velocities as the integrator stores them.
    pub vel: Vec<f64>,
    /// Accelerations of the last force evaluation, where the next step reads them.
    pub acc: Vec<f64>,
    /// A second velocity-like column (predicted velocities, last displacements).
    pub aux: Vec<f64>,
    /// Positions at the last neighbour-list build (the list, hence the order of the force
    /// sums, is rebuilt from them on resume).
    pub reference: Vec<f64>,
    /// Rotating particles: angular velocities, angular accelerations and predicted angular
    /// velocities, 3 values per slot each, in that order (9 per slot); empty otherwise.
    #[serde(default)]
    pub spin: Vec<f64>,
    /// Per-contact history of a contact law that keeps one: the contacts as `(particle,
    /// partner)` pairs, the partner being a particle index or, from `n` on, wall
    /// `partner - n`.
    #[serde(default)]
    pub contacts: Vec<[u32; 2]>,
    /// The history values of `contacts`, the law's count per contact.
    #[serde(default)]
    pub history: Vec<f64>,
}

impl Dynamics {
    /// Checks that the state fits a system of `n` particles at `width` values per slot:
    /// the width, the slot order (empty or a permutation of `0..n`), `n * width` finite
    /// values in every column that `required` names (`"pos"`, `"vel"`, `"acc"`, `"aux"`,
    /// `"reference"`) and in every other column that is not empty.
    ///
    /// Errors: [`Error::Checkpoint`] naming the first mismatch.
    pub fn check(&self, n: usize, width: usize, required: &[&str]) -> Result<()> {
        let bad = |what: String| {
            Error::checkpoint(format!("{what}; the file does not belong to this system"))
        };
        if self.width as usize != width {
            return Err(bad(format!(
                "{} values per particle, expected {width}",
                self.width
            )));
        }
        if !self.order.is_empty() {
            if self.order.len() != n {
                return Err(bad(format!(
                    "{} particle slots for {n} particles",
                    self.order.len()
                )));
            }
            let mut seen = vec![false; n];
            for &i in &self.order {
                match seen.get_mut(i as usize) {
                    Some(f) if !*f => *f = true,
                    _ => {
                        return Err(bad(format!(
                            "the particle order lists {i} twice or out of range"
                        )));
                    }
                }
            }
        }
        for (name, v) in [
            ("pos", &self.pos),
            ("vel", &self.vel),
            ("acc", &self.acc),
            ("aux", &self.aux),
            ("reference", &self.reference),
        ] {
            if v.is_empty() && !required.contains(&name) {
                continue;
            }
            if Some(v.len()) != n.checked_mul(width) {
                return Err(bad(format!(
                    "column {name} holds {} values, expected {n} x {width}",
                    v.len()
                )));
            }
            if let Some(k) = v.iter().position(|x| !x.is_finite()) {
                return Err(Error::checkpoint(format!(
                    "the stored column {name} holds {} at slot {}; the file is corrupt",
                    v[k],
                    k / width.max(1)
                )));
            }
        }
        Ok(())
    }

    /// The particle in slot `k` (the system order when `order` is empty).
    pub fn particle(&self, k: usize) -> usize {
        self.order.get(k).map_or(k, |&i| i as usize)
    }

    /// Slot `k` of a column, as `D` values.
    pub fn at<const D: usize>(column: &[f64], k: usize) -> [f64; D] {
        std::array::from_fn(|d| column[k * D + d])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stored_state_is_checked_column_by_column() {
        let s = Dynamics {
            width: 2,
            order: vec![1, 0],
            pos: vec![0.0, 1.0, 2.0, 3.0],
            vel: vec![0.0; 4],
            ..Dynamics::default()
        };
        s.check(2, 2, &["pos", "vel"]).unwrap();
        assert!(s.check(2, 3, &["pos"]).is_err());
        assert!(s.check(2, 2, &["acc"]).is_err());
        let mut t = s.clone();
        t.order = vec![1, 1];
        assert!(t.check(2, 2, &[]).is_err());
        t.order.clear();
        t.pos[3] = f64::NAN;
        assert!(t.check(2, 2, &[]).is_err());
        assert_eq!((s.particle(0), t.particle(0)), (1, 0));
        assert_eq!(Dynamics::at::<2>(&s.pos, 1), [2.0, 3.0]);
    }
}
