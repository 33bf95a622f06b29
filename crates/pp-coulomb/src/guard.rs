//! The blow-up checks both engines run inside `step(n)` (see [`crate::Config::check_every`]):
//! what a call's checks need ([`Checks`]), the exact law's energy-jump test, and the
//! messages of the [`simkit_backend::Error::BlowUp`] they return.

use serde::{Deserialize, Serialize};
use simkit_backend::guard::blow_up;
use simkit_backend::{Error, max_or_nan};

use crate::config::Integrator;
use crate::particles::PositionsVelocities;

/// Kinetic and potential energy of one state (f64 sums).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct Energy {
    /// `sum m v^2 / 2`.
    pub kinetic: f64,
    /// `sum_{i<j} q_i q_j / r_ij`.
    pub potential: f64,
}

impl Energy {
    fn total(&self) -> f64 {
        self.kinetic + self.potential
    }

    fn scale(&self) -> f64 {
        self.kinetic.abs() + self.potential.abs()
    }

    /// Both parts finite.
    pub fn is_finite(&self) -> bool {
        self.kinetic.is_finite() && self.potential.is_finite()
    }
}

/// `|E - E_ref| / max(K_ref + |U_ref|, K + |U|)`: the relative energy jump between two
/// checks (NaN when either energy is not finite; 0 when both scales are 0).
pub(crate) fn energy_jump(reference: Energy, now: Energy) -> f64 {
    if !(reference.is_finite() && now.is_finite()) {
        return f64::NAN;
    }
    let scale = reference.scale().max(now.scale());
    let change = (now.total() - reference.total()).abs();
    if scale > 0.0 { change / scale } else { 0.0 }
}

/// Whether a jump fails the tolerance (NaN fails).
pub(crate) fn jump_fails(jump: f64, tolerance: f64) -> bool {
    jump.is_nan() || jump > tolerance
}

/// What one `step(n)` call's checks need, lent by [`crate::PpCoulomb`] to its engine.
pub(crate) struct Checks<'a> {
    /// Steps done before the call.
    pub done: u64,
    /// Check interval (0: end of call only).
    pub every: u32,
    /// The energy-jump tolerance, `Some` only under the exact law with interval checks on.
    pub energy_tolerance: Option<f64>,
    /// The energy of the last interval check that passed (updated by the engine).
    pub energy_ref: &'a mut Option<Energy>,
    /// Per-particle charge and mass (host copies, for the messages).
    pub charge: &'a [f64],
    /// Per-particle mass.
    pub mass: &'a [f64],
    /// The time step.
    pub dt: f64,
    /// The integrator (for the messages).
    pub integrator: Integrator,
}

impl Checks<'_> {
    /// Whether the check after reaching step `at` is an interval check.
    pub fn is_interval(&self, at: u64) -> bool {
        self.every > 0 && at.is_multiple_of(u64::from(self.every))
    }
}

/// The usual cause of a non-finite state.
const NON_FINITE_CAUSE: &str = "the time step is too large for the closest encounters (under \
    ForceLaw::Exact a close pair gets an unbounded kick): use a smaller dt, or \
    ForceLaw::Plummer / ForceLaw::Exclusion";

/// The first particle whose position or velocity is not finite in `state`, as
/// `"particle i: position y = NaN"`.
pub(crate) fn first_non_finite(state: &PositionsVelocities) -> Option<String> {
    let (x, v) = state;
    let find = |a: &[[f64; 3]], name: &str| {
        a.iter().enumerate().find_map(|(i, c)| {
            c.iter()
                .position(|c| !c.is_finite())
                .map(|k| (i, format!("{name} {} = {}", ["x", "y", "z"][k], c[k])))
        })
    };
    match (find(x, "position"), find(v, "velocity")) {
        (Some(a), Some(b)) => Some(if a.0 <= b.0 { a } else { b }),
        (a, b) => a.or(b),
    }
    .map(|(i, what)| format!("particle {i}: {what}"))
}

/// The blow-up for a non-finite value `what` found by the check at step `step`.
pub(crate) fn non_finite_blow_up(step: u64, rolled_back_to: u64, what: String) -> Error {
    blow_up(step, rolled_back_to, what, NON_FINITE_CAUSE)
}

/// The blow-up for coincident particles `i < j` found at step `step`.
pub(crate) fn coincident_blow_up(
    step: u64,
    rolled_back_to: u64,
    i: usize,
    j: usize,
    at: [f64; 3],
) -> Error {
    blow_up(
        step,
        rolled_back_to,
        format!(
            "particles {i} and {j} at the same position ({}, {}, {})",
            at[0], at[1], at[2]
        ),
        "coincident particles make the exact Coulomb force infinite: separate them, or use \
         ForceLaw::Plummer or ForceLaw::Exclusion",
    )
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn norm(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

/// The blow-up for an energy jump at step `step` (state `bad`) against the last good
/// check at `rolled_back_to` (state `good`): names the particle whose velocity changed most,
/// its nearest neighbour in the good state, and a time step that resolves their encounter.
pub(crate) fn energy_blow_up(
    step: u64,
    rolled_back_to: u64,
    checks: &Checks<'_>,
    jump: f64,
    good: &PositionsVelocities,
    bad: &PositionsVelocities,
) -> Error {
    if let Some(what) = first_non_finite(bad) {
        return non_finite_blow_up(step, rolled_back_to, what);
    }
    let tol = checks.energy_tolerance.unwrap_or(0.0);
    // The particle whose velocity changed most (NaN-safe: the bad state is finite here).
    let i = (0..bad.1.len())
        .map(|i| (i, norm(sub(bad.1[i], good.1[i]))))
        .fold((0, f64::NEG_INFINITY), |a, b| if b.1 > a.1 { b } else { a })
        .0;
    let nearest = (0..good.0.len())
        .filter(|&j| j != i)
        .map(|j| (j, norm(sub(good.0[i], good.0[j]))))
        .fold(None, |a: Option<(usize, f64)>, b| match a {
            Some(a) if a.1 <= b.1 => Some(a),
            _ => Some(b),
        });
    let speed = |s: &PositionsVelocities| norm(s.1[i]);
    let mut what = format!(
        "total energy changed by {jump:.3e} of its scale since step {rolled_back_to} \
         (tolerance {tol:e}); particle {i} went from speed {:.3e} to {:.3e}",
        speed(good),
        speed(bad)
    );
    let mut fix = String::from("use ForceLaw::Exclusion or ForceLaw::Plummer");
    if let Some((j, r)) = nearest {
        // The pair's encounter is resolved when dt is well below both its crossing time
        // r / v_rel and its two-body dynamical time sqrt(mu r^3 / |q_i q_j|).
        let v_rel = norm(sub(good.1[i], good.1[j]));
        let mu = checks.mass[i] * checks.mass[j] / (checks.mass[i] + checks.mass[j]);
        let qq = (checks.charge[i] * checks.charge[j]).abs();
        let t_dyn = if qq > 0.0 {
            (mu * r * r * r / qq).sqrt()
        } else {
            f64::INFINITY
        };
        let t_cross = if v_rel > 0.0 {
            r / v_rel
        } else {
            f64::INFINITY
        };
        let bound = 0.1 * max_or_nan(0.0, t_dyn.min(t_cross));
        what.push_str(&format!(
            "; its nearest neighbour at step {rolled_back_to} was particle {j}, {r:.3e} apart"
        ));
        if bound.is_finite() && bound > 0.0 {
            fix.push_str(&format!(
                ", or dt <= {bound:.3e} (a tenth of the pair's crossing or two-body time at \
                 step {rolled_back_to}; the run used dt = {:e} with {:?})",
                checks.dt, checks.integrator
            ));
        }
    }
    blow_up(
        step,
        rolled_back_to,
        what,
        format!("close approach under the exact law: {fix}"),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jumps_are_relative_to_the_larger_scale_and_nan_fails() {
        let a = Energy {
            kinetic: 1.0,
            potential: -3.0,
        };
        let b = Energy {
            kinetic: 1.5,
            potential: -3.0,
        };
        assert_eq!(energy_jump(a, b), 0.5 / 4.5);
        assert_eq!(energy_jump(a, a), 0.0);
        let nan = Energy {
            kinetic: f64::NAN,
            potential: 0.0,
        };
        assert!(jump_fails(energy_jump(a, nan), 1.0));
        assert!(!jump_fails(energy_jump(a, b), 0.2));
        assert!(jump_fails(energy_jump(a, b), 0.1));
        let zero = Energy {
            kinetic: 0.0,
            potential: 0.0,
        };
        assert_eq!(energy_jump(zero, zero), 0.0);
    }
}
