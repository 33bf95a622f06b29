//! Law-level tests: each WGSL function of the GPU kernels evaluated on the GPU against its
//! Rust twin, over every input state, bit for bit.
#![cfg(feature = "gpu")]

use simkit_backend::rng::RNG_WGSL;
use simkit_backend::testing::{eval_wgsl, gpu_or_skip};
use simkit_lattice_gas::laws::{COLLIDE_WGSL, collide_bits};
use simkit_lattice_gas::laws::{
    RANDOM_WGSL, chirality, chirality_word, force_hit, force_threshold, step_key,
};
use simkit_lattice_gas::{CollisionTable, RuleSet, WALL};

/// Bit-parallel collision inputs `[s0..s5, r, wall]` of 32 sites each: the first eight words
/// hold every (state, wall flag, chirality bit) case once (256 cases, case `c` at bit `c % 32`
/// of word `c / 32`; `c = state | wall << 6 | r << 7`), then pseudo-random words.
fn collision_inputs() -> Vec<[u32; 8]> {
    let mut words = vec![[0u32; 8]; 8];
    for c in 0..256u32 {
        let (state, wall, r) = (c & 63, (c >> 6) & 1, c >> 7);
        let (w, b) = ((c / 32) as usize, c % 32);
        for (d, plane) in words[w][..6].iter_mut().enumerate() {
            *plane |= ((state >> d) & 1) << b;
        }
        words[w][6] |= r << b;
        words[w][7] |= wall << b;
    }
    let mut x = 0x9e37_79b9u32;
    for _ in 0..248 {
        words.push(std::array::from_fn(|_| {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x
        }));
    }
    words
}

#[test]
fn collision_wgsl_equals_rust_for_every_state_both_rule_sets() {
    let Some(ctx) = gpu_or_skip("lattice-gas collision law") else {
        return;
    };
    let inputs = collision_inputs();
    for rules in [RuleSet::FhpI, RuleSet::Full] {
        let full = rules == RuleSet::Full;
        let expr = format!(
            "fhp_collide(array<u32, 6>(x[0], x[1], x[2], x[3], x[4], x[5]), x[6], x[7], {full})"
        );
        let gpu: Vec<[u32; 6]> = eval_wgsl(
            &ctx,
            &[COLLIDE_WGSL],
            "array<u32, 8>",
            "array<u32, 6>",
            &expr,
            &inputs,
        )
        .unwrap();
        let cpu: Vec<[u32; 6]> = inputs
            .iter()
            .map(|x| {
                let s = [x[0], x[1], x[2], x[3], x[4], x[5]];
                if full {
                    collide_bits::<u32, true>(s, x[6], x[7])
                } else {
                    collide_bits::<u32, false>(s, x[6], x[7])
                }
            })
            .collect();
        let differing = gpu.iter().zip(&cpu).filter(|(g, c)| g != c).count();
        assert_eq!(
            differing,
            0,
            "{rules:?}: {differing} of {} words",
            cpu.len()
        );
        // The exhaustive words, site by site, against the collision table.
        let table = CollisionTable::new(rules);
        for c in 0..256u32 {
            let (state, wall, r) = ((c & 63) as u8, (c >> 6) & 1, c >> 7);
            let (w, b) = ((c / 32) as usize, c % 32);
            let got = (0..6).fold(if wall == 1 { WALL } else { 0 }, |acc, d| {
                acc | ((((gpu[w][d] >> b) & 1) as u8) << d)
            });
            let byte = state | if wall == 1 { WALL } else { 0 };
            assert_eq!(
                got,
                table.apply(byte, r),
                "{rules:?} state {state} wall {wall} r {r}"
            );
        }
    }
}

#[test]
fn random_bits_wgsl_equal_rust() {
    let Some(ctx) = gpu_or_skip("lattice-gas random bits law") else {
        return;
    };
    // (seed, step, site, threshold): edge values of each, then a spread of sites.
    let mut inputs: Vec<[u32; 4]> = Vec::new();
    for seed in [0u32, 1, 2026, u32::MAX] {
        for step in [0u32, 1, 999, u32::MAX] {
            for site in [0u32, 1, 31, 32, 33, 63, 64, 1 << 20, u32::MAX - 1, u32::MAX] {
                for p in [0.0, 0.01, 0.5, 1.0] {
                    inputs.push([seed, step, site, force_threshold(p)]);
                }
            }
        }
    }
    inputs.extend((0..4096u32).map(|i| [7, i / 64, i.wrapping_mul(2_654_435_761), 1 << 22]));
    let sources = [RNG_WGSL, RANDOM_WGSL];
    let gpu: Vec<[u32; 4]> = eval_wgsl(
        &ctx,
        &sources,
        "vec4<u32>",
        "vec4<u32>",
        "vec4<u32>(fhp_step_key(x.x, x.y), \
         fhp_chirality_word(fhp_step_key(x.x, x.y), x.z), \
         fhp_chirality(fhp_step_key(x.x, x.y), x.z), \
         select(0u, 1u, fhp_force_hit(fhp_step_key(x.x, x.y), x.z, x.w)))",
        &inputs,
    )
    .unwrap();
    let cpu: Vec<[u32; 4]> = inputs
        .iter()
        .map(|&[seed, step, site, threshold]| {
            let key = step_key(seed, step);
            assert_eq!(
                chirality(seed, step, site),
                (chirality_word(key, site >> 5) >> (site & 31)) & 1
            );
            [
                key,
                chirality_word(key, site),
                chirality(seed, step, site),
                u32::from(force_hit(key, site, threshold)),
            ]
        })
        .collect();
    let differing = gpu.iter().zip(&cpu).filter(|(g, c)| g != c).count();
    assert_eq!(differing, 0, "{differing} of {} inputs differ", cpu.len());
    // Both force outcomes occur.
    assert!(cpu.iter().any(|c| c[3] == 1) && cpu.iter().any(|c| c[3] == 0));
}
