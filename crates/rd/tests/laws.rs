//! Law-level tests: each model's WGSL (`Model::wgsl`: `model_update` and `model_diffusivity`)
//! runs on the GPU for one cell and its four neighbours, over a sample of species values
//! (0, 1, tiny, large, and values in between; flat stencils, where only the reaction acts,
//! and uneven ones), and is compared with the CPU law at f32: `Model::update_row` on the
//! same five-point stencil and `Model::max_cell_diffusivity` on the same cell.
//!
//! The kernels hand the model WGSL three accessors, `ld(field, dx, dy)`, `mp(k)` and
//! `put(species, value)`, and the type alias `real`. Here they read and write private
//! variables filled from the test input instead of storage buffers; the model functions
//! themselves are the shipped ones. (Where `mp(k)` reads in the real params buffer is
//! checked by the crate's unit test `shaders_read_params_where_params_vec_writes_them`.)
//!
//! Tolerance of `model_update`: `|gpu - cpu| <= 4 eps_f32 S + f32::MIN_POSITIVE`, with `S` the
//! sum of the magnitudes of the terms that make up the result (centre value, diffusive terms,
//! reaction terms). Both sides evaluate the same expression tree in f32 in the same order;
//! they may differ only because (1) the CPU folds `D dt / h^2` into one coefficient rounded
//! once from f64 while the WGSL multiplies `mp(k) * dt * ih2` in f32 (two roundings, so at
//! most 2 eps on the diffusive term), (2) the GPU compiler may contract `a * b + c` into a
//! fused multiply-add (one rounding fewer, at most eps / 2 of the running sum each), (3) WGSL
//! division is allowed 2.5 ulp (the colony reaction), and (4) a GPU may flush subnormal
//! results to zero (the absolute `f32::MIN_POSITIVE`). `model_diffusivity` takes the same
//! products or maxima in the same order, so it must match bit for bit.
#![cfg(feature = "gpu")]

use simkit_backend::GpuContext;
use simkit_backend::max_or_nan;
use simkit_backend::rng::rng_uniform;
use simkit_backend::testing::{eval_wgsl, gpu_or_skip};
use simkit_rd::{Boundaries, Colony, Diffusion, GrayScott, Grid, Model, RowIn};

/// Input of one evaluation: `[dt, 1/h^2, mp(0..4), stencil]`, the stencil holding field `f`'s
/// centre, west, east, south and north values at `6 + 5 f + 0..5` (species first, then
/// coefficient fields; at most four fields).
type Cell = [f32; 26];
/// Offset of the model parameters in a [`Cell`].
const PARAMS: usize = 2;
/// Offset of the stencil in a [`Cell`].
const STENCIL: usize = 6;
/// Stencil points of one field in a [`Cell`]: centre, west, east, south, north.
const POINTS: usize = 5;

/// The accessors the model WGSL expects, reading a [`Cell`], and the two entry points the
/// test evaluates. `ns` is the number of species (the kernels' `NS`).
fn glue(ns: usize) -> (String, &'static str) {
    let before = format!(
        "alias real = f32;
const NS: u32 = {ns}u;
var<private> stencil: array<f32, 20>;
var<private> model_params: array<f32, 4>;
var<private> written: vec4<f32>;

fn ld(f: u32, dx: i32, dy: i32) -> real {{
    var p = 0u;
    if dx < 0 {{ p = 1u; }} else if dx > 0 {{ p = 2u; }} else if dy < 0 {{ p = 3u; }} else if dy > 0 {{ p = 4u; }}
    return stencil[5u * f + p];
}}
fn mp(k: u32) -> real {{
    return model_params[k];
}}
fn put(s: u32, v: real) {{
    written[s] = v;
}}
fn load_cell(x: array<f32, 26>) {{
    for (var k = 0u; k < 4u; k++) {{ model_params[k] = x[2u + k]; }}
    for (var k = 0u; k < 20u; k++) {{ stencil[k] = x[6u + k]; }}
}}
"
    );
    let after = "
fn update(x: array<f32, 26>) -> vec4<f32> {
    load_cell(x);
    written = vec4<f32>(0.0);
    model_update(x[0], x[1]);
    return written;
}
fn diffusivity(x: array<f32, 26>) -> f32 {
    load_cell(x);
    return model_diffusivity();
}
";
    (before, after)
}

/// One cell for `model`: `dt`, `1 / h^2`, its GPU parameters and the stencils of `fields`
/// (each `[centre, west, east, south, north]`).
fn cell<M: Model>(model: &M, dt: f32, ih2: f32, fields: &[[f32; POINTS]]) -> Cell {
    let mut x = [0.0f32; 26];
    x[0] = dt;
    x[1] = ih2;
    for (k, p) in model.gpu_params().into_iter().enumerate() {
        x[PARAMS + k] = p as f32;
    }
    for (f, st) in fields.iter().enumerate() {
        x[STENCIL + POINTS * f..STENCIL + POINTS * (f + 1)].copy_from_slice(st);
    }
    x
}

/// The stencil of field `f` in `x`.
fn stencil(x: &Cell, f: usize) -> [f32; POINTS] {
    x[STENCIL + POINTS * f..STENCIL + POINTS * (f + 1)]
        .try_into()
        .unwrap()
}

/// Field `f`'s stencil written into a padded 3 x 3 plane (the layout `RowIn` reads).
fn plane(st: [f32; POINTS]) -> [f32; 9] {
    let [c, w, e, s, n] = st;
    [0.0, s, 0.0, w, c, e, 0.0, n, 0.0]
}

/// The CPU law: `Model::update_row` at f32 on the one-cell row of `x`.
fn cpu_update<M: Model>(model: &M, x: &Cell) -> Vec<f32> {
    let ns = model.species();
    let nc = model.coefficients().len();
    let species: Vec<f32> = (0..ns).flat_map(|f| plane(stencil(x, f))).collect();
    let coefficients: Vec<f32> = (ns..ns + nc).flat_map(|f| plane(stencil(x, f))).collect();
    let input = RowIn {
        species: &species,
        species_plane: 9,
        species_row: 1,
        coefficients: &coefficients,
        coefficient_plane: 9,
        row: 1,
        width: 3,
        i0: 1,
        i1: 2,
    };
    let mut out = vec![[0.0f32; 1]; ns];
    let mut outs: Vec<&mut [f32]> = out.iter_mut().map(|o| &mut o[..]).collect();
    model.update_row(&input, f64::from(x[0]), f64::from(x[1]), &mut outs, false);
    out.into_iter().map(|o| o[0]).collect()
}

/// The CPU law: `Model::max_cell_diffusivity` at f32 on the centre cell of `x`.
fn cpu_diffusivity<M: Model>(model: &M, x: &Cell) -> f64 {
    let ns = model.species();
    let nc = model.coefficients().len();
    let centre: Vec<[f32; 1]> = (0..ns + nc).map(|f| [stencil(x, f)[0]]).collect();
    let species: Vec<&[f32]> = centre[..ns].iter().map(|c| &c[..]).collect();
    let coefficients: Vec<&[f32]> = centre[ns..].iter().map(|c| &c[..]).collect();
    model.max_cell_diffusivity(&species, &coefficients)
}

/// Species values of the sample: 0, 1, tiny, large and two in between.
const VALUES: [f32; 6] = [0.0, 1.0, 1e-20, 1e4, 0.25, 0.7];

/// A stencil around `centre`: flat (`uneven == 0`, only the reaction acts) or with
/// neighbours up to 50 % and 0.1 away from the centre, drawn from the shared RNG.
fn around(centre: f32, uneven: u32, key: u32) -> [f32; POINTS] {
    let mut st = [centre; POINTS];
    if uneven > 0 {
        for (p, v) in st.iter_mut().enumerate().skip(1) {
            let u = rng_uniform(uneven, key, p as u32);
            let w = rng_uniform(uneven + 1000, key, p as u32);
            *v = (centre * (1.0 + (u - 0.5)) + 0.1 * w).max(0.0);
        }
    }
    st
}

/// Runs `model_update` and `model_diffusivity` of `model` on the GPU for every cell and
/// compares them with the CPU law; `scale(x, s)` is the magnitude `S` of output `s` (see the
/// module docs). Returns the largest `|gpu - cpu| / (eps_f32 S)`.
fn check<M: Model>(
    ctx: &GpuContext,
    name: &str,
    model: &M,
    cells: &[Cell],
    scale: impl Fn(&Cell, usize) -> f64,
) -> f64 {
    let ns = model.species();
    let (before, after) = glue(ns);
    let sources = [before.as_str(), model.wgsl(), after];
    let ty = "array<f32, 26>";
    let got: Vec<[f32; 4]> = eval_wgsl(ctx, &sources, ty, "vec4<f32>", "update(x)", cells).unwrap();
    let got_d: Vec<f32> = eval_wgsl(ctx, &sources, ty, "f32", "diffusivity(x)", cells).unwrap();
    let eps = f64::from(f32::EPSILON);
    let mut worst = 0.0f64;
    for (k, x) in cells.iter().enumerate() {
        let want = cpu_update(model, x);
        for s in 0..ns {
            let (g, w) = (f64::from(got[k][s]), f64::from(want[s]));
            let sc = scale(x, s);
            let diff = (g - w).abs();
            assert!(
                diff <= 4.0 * eps * sc + f64::from(f32::MIN_POSITIVE),
                "{name}: species {s} of {x:?}: GPU {g:e}, CPU {w:e} (scale {sc:e})"
            );
            if sc > 0.0 {
                worst = max_or_nan(worst, diff / (eps * sc));
            }
        }
        let want_d = cpu_diffusivity(model, x) as f32;
        assert_eq!(
            got_d[k].to_bits(),
            want_d.to_bits(),
            "{name}: diffusivity of {x:?}: GPU {:e}, CPU {want_d:e}",
            got_d[k]
        );
    }
    println!(
        "{name}: {} cells, largest |gpu - cpu| = {worst:.3} eps_f32 S",
        cells.len()
    );
    worst
}

/// `sum(|neighbours|) + 4 |centre|` of field `f`: the magnitude of its Laplacian terms.
fn lap_mag(x: &Cell, f: usize) -> f64 {
    let [c, w, e, s, n] = stencil(x, f).map(|v| f64::from(v).abs());
    w + e + s + n + 4.0 * c
}

#[test]
fn diffusion_wgsl_matches_cpu() {
    let Some(ctx) = gpu_or_skip("diffusion_wgsl_matches_cpu") else {
        return;
    };
    let (dt, ih2) = (0.2f32, 1.0f32);
    let mut worst = 0.0f64;
    for d in [
        vec![1.0],
        vec![1.0, 0.5, 0.0, 0.25],
        vec![0.0],
        vec![3e-3, 7.5],
    ] {
        let model = Diffusion::new(&d).unwrap();
        let ns = d.len();
        let mut cells = Vec::new();
        for k in 0..VALUES.len() {
            for uneven in 0..3 {
                let fields: Vec<[f32; POINTS]> = (0..ns)
                    .map(|s| around(VALUES[(k + s) % VALUES.len()], uneven, (k * 8 + s) as u32))
                    .collect();
                cells.push(cell(&model, dt, ih2, &fields));
            }
        }
        let scale = |x: &Cell, s: usize| {
            let a = d[s] * f64::from(dt) * f64::from(ih2);
            f64::from(stencil(x, s)[0]).abs() + a * lap_mag(x, s)
        };
        worst = max_or_nan(
            worst,
            check(&ctx, &format!("diffusion {d:?}"), &model, &cells, scale),
        );
    }
    assert!(worst <= 4.0);
}

#[test]
fn gray_scott_wgsl_matches_cpu_for_pearson_sets() {
    let Some(ctx) = gpu_or_skip("gray_scott_wgsl_matches_cpu_for_pearson_sets") else {
        return;
    };
    let (dt, ih2) = (
        1.0f32,
        (1.0 / (GrayScott::PEARSON_H * GrayScott::PEARSON_H)) as f32,
    );
    for (name, model) in [
        ("spots", GrayScott::spots()),
        ("stripes", GrayScott::stripes()),
        ("worms", GrayScott::worms()),
        (
            "no diffusion, fast",
            GrayScott::new(0.0, 0.0, 0.5, 0.25).unwrap(),
        ),
    ] {
        let mut cells = Vec::new();
        for (i, &u) in VALUES.iter().enumerate() {
            for (j, &v) in VALUES.iter().enumerate() {
                for uneven in 0..2 {
                    let key = (i * 8 + j) as u32;
                    let fields = [around(u, uneven, key), around(v, uneven, key + 100)];
                    cells.push(cell(&model, dt, ih2, &fields));
                }
            }
        }
        let (fk, feed) = (model.feed + model.kill, model.feed);
        let scale = |x: &Cell, s: usize| {
            let (u, v) = (
                f64::from(x[STENCIL]).abs(),
                f64::from(x[STENCIL + POINTS]).abs(),
            );
            let d = if s == 0 { model.du } else { model.dv };
            let diffusive = d * f64::from(dt) * f64::from(ih2) * lap_mag(x, s);
            let uvv = u * v * v;
            let reaction = if s == 0 {
                feed * (1.0 + u) + uvv
            } else {
                uvv + fk * v
            };
            [u, v][s] + diffusive + f64::from(dt) * reaction
        };
        let worst = check(&ctx, &format!("gray-scott {name}"), &model, &cells, scale);
        assert!(worst <= 4.0);
    }
}

#[test]
fn colony_wgsl_matches_cpu() {
    let Some(ctx) = gpu_or_skip("colony_wgsl_matches_cpu") else {
        return;
    };
    let (dt, ih2) = (0.005f32, 4.0f32);
    for gamma in [0.0, 0.5, 3.0] {
        let model = Colony::new(gamma, 1, 1, vec![0.75]).unwrap();
        let mut cells = Vec::new();
        for (i, &b) in VALUES.iter().enumerate() {
            for (j, &n) in VALUES.iter().enumerate() {
                for (m, d) in [0.0f32, 1.0, 0.45, 1.05].into_iter().enumerate() {
                    for uneven in 0..2 {
                        let key = (i * 64 + j * 8 + m) as u32;
                        let fields = [
                            around(b, uneven, key),
                            around(n, uneven, key + 1000),
                            around(d, uneven, key + 2000),
                        ];
                        cells.push(cell(&model, dt, ih2, &fields));
                    }
                }
            }
        }
        let scale = |x: &Cell, s: usize| {
            let [bs, ns, ds] = [0, 1, 2].map(|f| stencil(x, f).map(|v| f64::from(v).abs()));
            let r = ns[0] * bs[0] / (1.0 + gamma * ns[0]);
            let reaction = f64::from(dt) * r;
            if s == 0 {
                let kappa = |p: usize| ds[p] * ns[p] * bs[p];
                let flux: f64 = (1..POINTS)
                    .map(|p| (kappa(0) + kappa(p)) * (bs[p] + bs[0]))
                    .sum();
                bs[0] + 0.5 * f64::from(dt) * f64::from(ih2) * flux + reaction
            } else {
                ns[0] + f64::from(dt) * f64::from(ih2) * lap_mag(x, 1) + reaction
            }
        };
        let worst = check(
            &ctx,
            &format!("colony gamma {gamma}"),
            &model,
            &cells,
            scale,
        );
        assert!(worst <= 4.0);
    }
}

/// The colony's nonlinear diffusivity `max(d b n, 1)` at `b = 0` (it is 1: `n` diffuses with
/// `D = 1`) and in range, on the GPU against both CPU forms: `max_cell_diffusivity` at f32
/// (bit for bit) and `max_diffusivity` of a one-cell grid (the f64 product with `d` in f64:
/// within 2.5 eps_f32 relative: five roundings of at most eps / 2, of `d`, `b` and `n` to
/// f32 and of the two f32 products).
#[test]
fn colony_diffusivity_at_zero_and_in_range() {
    let Some(ctx) = gpu_or_skip("colony_diffusivity_at_zero_and_in_range") else {
        return;
    };
    let (before, after) = glue(2);
    let samples = [
        (0.0f32, 1.0f32, 0.75f32),
        (0.0, 1e4, 1.7),
        (0.7, 1.0, 0.75),
        (0.7, 1.1, 1.05),
        (2.5, 1.0, 1.05),
        (1e-20, 1e4, 1.0),
        (1e3, 1e2, 0.45),
    ];
    for gamma in [0.0, 0.5] {
        let model = Colony::new(gamma, 1, 1, vec![0.75]).unwrap();
        let sources = [before.as_str(), model.wgsl(), after];
        let cells: Vec<Cell> = samples
            .iter()
            .map(|&(b, n, d)| cell(&model, 0.005, 4.0, &[[b; 5], [n; 5], [d; 5]]))
            .collect();
        let got: Vec<f32> = eval_wgsl(
            &ctx,
            &sources,
            "array<f32, 26>",
            "f32",
            "diffusivity(x)",
            &cells,
        )
        .unwrap();
        for (&(b, n, d), (x, g)) in samples.iter().zip(cells.iter().zip(&got)) {
            let cell_form = cpu_diffusivity(&model, x);
            assert_eq!(f64::from(*g), cell_form, "b {b}, n {n}, d {d}");
            let one = Colony::new(gamma, 1, 1, vec![f64::from(d)]).unwrap();
            let grid = Grid::new(1, 1, 0.5, Boundaries::no_flux(), vec![vec![b], vec![n]]).unwrap();
            let grid_form = one.max_diffusivity(&grid);
            let rel = (f64::from(*g) - grid_form).abs() / grid_form;
            assert!(
                rel <= 2.5 * f64::from(f32::EPSILON),
                "b {b}, n {n}, d {d}: {rel:e}"
            );
            if b == 0.0 {
                assert_eq!(*g, 1.0, "b = 0 gives the floor D = 1");
            }
        }
    }
}
