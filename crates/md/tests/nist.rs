//! A published reference state point of the truncated Lennard-Jones fluid (NIST's
//! "Lennard-Jones Fluid Properties", NVT Monte Carlo, `T* = 0.85`, `rho* = 0.776`,
//! `r_c = 3`, long-range corrections included: `U/N = -5.5121 +- 4.55e-4`), see
//! `simkit_md::reference`.
//!
//! Fast size: NIST's 500 atoms, 3000 steps to melt and relax, 500 samples 20 steps apart.
//! Its standard error (about 4e-3) is some 9 times NIST's: the test asserts agreement
//! within three combined standard errors, which this run's error dominates; the full-size
//! check is `reference::nist_lj_state_point` with more samples.

use simkit_backend::{Backend, Result};
use simkit_md::reference::{NIST_ENERGY, nist_lj_state_point};

#[test]
fn nist_truncated_lj_energy_at_t085_rho0776() -> Result<()> {
    let r = nist_lj_state_point(5, 3000, 500, 20, Backend::Cpu, 31)?;
    eprintln!(
        "{} atoms: U/N = {:.5} (truncated) + {:.5} (lrc) = {:.5} +- {:.5}; NIST {NIST_ENERGY}; \
         z = {:.2}",
        r.atoms, r.truncated, r.correction, r.energy, r.standard_error, r.z
    );
    assert_eq!(r.atoms, 500);
    assert!(r.z.abs() < 3.0, "{r:?}");
    assert!(nist_lj_state_point(3, 1, 10, 1, Backend::Cpu, 0).is_err());
    assert!(nist_lj_state_point(5, 1, 9, 1, Backend::Cpu, 0).is_err());
    assert!(nist_lj_state_point(5, 1, 10, 0, Backend::Cpu, 0).is_err());
    Ok(())
}
