//! Shear viscosity of FHP-I against 1/(12 d (1-d)^3) - 1/8, and the full table is less viscous.

use simkit_lattice_gas::RuleSet;
use simkit_lattice_gas::viscosity::{ShearWave, fhp1_viscosity};

#[test]
fn fhp1_shear_viscosity_matches_theory_within_5_percent() {
    for d in [0.15, 0.2, 0.3] {
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
            err < 0.05,
            "d {d}: measured {nu} (runs {runs:?}) theory {theory}"
        );
    }
}

#[test]
fn full_rule_set_is_less_viscous() {
    let fhp1 = ShearWave::new(2048, 128, 0.3).measure().unwrap();
    let full = ShearWave {
        rules: RuleSet::Full,
        ..ShearWave::new(2048, 128, 0.3)
    }
    .measure()
    .unwrap();
    println!(
        "d 0.3: FHP-I {:.4}, full {:.4}",
        fhp1.viscosity, full.viscosity
    );
    assert!(full.viscosity < 0.8 * fhp1.viscosity);
}
