//! Shear viscosity of FHP-I against 1/(12 d (1-d)^3) - 1/8 (shear wave and Poiseuille
//! channel), and the full table's viscosity.

use simkit_lattice_gas::PoiseuilleChannel;
use simkit_lattice_gas::RuleSet;
use simkit_lattice_gas::{ShearWave, fhp1_viscosity};

#[test]
fn fhp1_shear_viscosity_matches_theory() {
    // Measured errors (this test, 4 seeds): +0.45 / +0.93 / +1.8 %; the standard error of a
    // 4-seed mean is about 1.1 % (single-run spread 0.006 - 0.008 in nu). Bounds: 3 %, 3 %
    // and 5 % (about 3x the larger of the measured error and the standard error).
    for (d, bound) in [(0.15, 0.03), (0.2, 0.03), (0.3, 0.05)] {
        // Wavelength 80 sqrt(3)/2 = 69 lattice units; 4 seeds of 8192 x 80 sites averaged.
        let runs: Vec<f64> = (1..=4)
            .map(|seed| {
                let wave = ShearWave {
                    seed,
                    ..ShearWave::new(8192, 80, d)
                };
                wave.measure().unwrap().viscosity
            })
            .collect();
        let nu = runs.iter().sum::<f64>() / runs.len() as f64;
        let theory = fhp1_viscosity(d);
        let err = (nu / theory - 1.0).abs();
        println!(
            "d {d}: nu {nu:.4}, theory {theory:.4}, error {:.2} %",
            100.0 * err
        );
        assert!(
            err < bound,
            "d {d}: measured {nu} (runs {runs:?}) theory {theory}"
        );
    }
}

/// The full collision table at d = 0.3 (no closed-form theory here): the shear wave of the
/// FHP-I test (8192 x 80), 4 seeds, against the value the `fhp_viscosity` example measures
/// with 8 independent runs, 0.1962 +- 0.0015 (docs/lattice-gas.md). Six single runs here gave
/// 0.1921 - 0.2012 (sd 0.0034), so a 4-seed mean has a standard error of 0.0017; bound
/// 0.006 (3.5 standard errors). FHP-I on the same runs is 3.5x more viscous.
#[test]
fn full_rule_set_viscosity_is_the_measured_value() {
    let runs: Vec<f64> = (1..=4u32)
        .map(|seed| {
            let wave = ShearWave {
                seed,
                rules: RuleSet::Full,
                ..ShearWave::new(8192, 80, 0.3)
            };
            wave.measure().unwrap().viscosity
        })
        .collect();
    let nu = runs.iter().sum::<f64>() / 4.0;
    println!(
        "full table, d 0.3: nu {nu:.4} (runs {runs:?}); FHP-I theory {:.4}",
        fhp1_viscosity(0.3)
    );
    assert!((nu - 0.1962).abs() < 0.006, "nu {nu}, runs {runs:?}");
}

/// Plane Poiseuille flow (`simkit_lattice_gas::poiseuille`), fast-sized: 2048 x 48 sites,
/// d = 0.3, p = 0.001, three seeds. Measured (2 cores): the local-acceleration viscosity
/// +3.2 / +1.6 / +3.8 % over the FHP-I theory (mean +2.9 %, the slow growth of the FHP
/// viscosity with the length scale also seen in the shear-wave measurements), the at-rest
/// acceleration +13.2 / +10.3 / +14.6 % (it overstates the force in a flowing channel).
/// Bounds: the mean local error within [-1 %, +6 %] (2x the measured mean above, about 4
/// standard errors of the seed spread below), and the at-rest estimate at least 5 % above
/// the local one (measured 10 %).
#[test]
fn poiseuille_profile_gives_the_fhp_viscosity() {
    let (mut local, mut rest) = (0.0, 0.0);
    for seed in [9u32, 10, 11] {
        let r = PoiseuilleChannel {
            seed,
            ..PoiseuilleChannel::new(2048, 48, 0.3, 0.001)
        }
        .measure()
        .unwrap();
        println!(
            "seed {seed}: nu local {:.4}, at rest {:.4}, theory {:.4}, centre u {:.3}",
            r.nu_local, r.nu_at_rest, r.theory, r.centre_velocity
        );
        local += (r.nu_local / r.theory - 1.0) / 3.0;
        rest += (r.nu_at_rest / r.theory - 1.0) / 3.0;
    }
    println!(
        "mean error: local {:+.2} %, at rest {:+.2} %",
        100.0 * local,
        100.0 * rest
    );
    assert!((-0.01..0.06).contains(&local), "local {local}");
    assert!(rest > local + 0.05, "at rest {rest}, local {local}");
}

#[test]
fn channel_defaults_and_seeds_do_not_overflow() {
    // 16 000 H^2 overflowed usize before the H^2 / 4096 scaling for H = 2^30 (the product
    // wrapped to 0 in release and gave the 4000-step floor instead of the 2^30 cap).
    let c = PoiseuilleChannel::new(64, 1 << 30, 0.3, 0.01);
    assert_eq!((c.relax, c.average), (1 << 30, 1 << 30));
    let c = PoiseuilleChannel::new(64, usize::MAX, 0.3, 0.01);
    assert_eq!(c.relax, 1 << 30);
}
