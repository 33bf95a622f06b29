//! The grid rules of the GPU cell list (`shaders/cells.wgsl`, exported as `CELLS_WGSL`)
//! against their Rust definitions in `CellGrid`: periodic wrap, cell of a position, minimum
//! image, run on the GPU for a sample of positions (faces, one ulp inside them, far outside
//! periodic boxes, negative coordinates), and the layout of the `NbGrid` parameter struct.
#![cfg(feature = "gpu")]

use std::mem::offset_of;

use bytemuck::{Pod, Zeroable};
use rand::{RngExt, SeedableRng};
use simkit_backend::testing::{assert_mirrors, eval_wgsl, gpu_or_skip};
use simkit_neighbor::{CELLS_WGSL, CellGrid, GpuGridParams};

#[test]
fn grid_params_mirror_the_wgsl_struct() {
    let pad = offset_of!(GpuGridParams, pad);
    assert_mirrors::<GpuGridParams>(
        CELLS_WGSL,
        "NbGrid",
        &[
            ("origin", offset_of!(GpuGridParams, origin)),
            ("length", offset_of!(GpuGridParams, length)),
            ("inv_cell", offset_of!(GpuGridParams, inv_cell)),
            ("cells", offset_of!(GpuGridParams, cells)),
            ("periodic", offset_of!(GpuGridParams, periodic)),
            ("n_particles", offset_of!(GpuGridParams, n_particles)),
            ("n_cells", offset_of!(GpuGridParams, n_cells)),
            ("clamp_out", offset_of!(GpuGridParams, clamp_out)),
            ("dim", offset_of!(GpuGridParams, dim)),
            ("cutoff2", offset_of!(GpuGridParams, cutoff2)),
            ("_pad0", pad),
            ("_pad1", pad + 4),
            ("_pad2", pad + 8),
        ],
    );
}

/// One evaluation: the grid, and two positions `p`, `q` (xyz; `w` unused).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct RuleIn {
    grid: GpuGridParams,
    p: [f32; 4],
    q: [f32; 4],
}

/// Wrapped `p` and `q`, the minimum image of their separation, and (cell of `p`, whether
/// `p` is outside a closed face).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Debug)]
struct RuleOut {
    tp: [f32; 4],
    tq: [f32; 4],
    sep: [f32; 4],
    cell: [u32; 4],
}

const HARNESS: &str = "
struct RuleIn { g: NbGrid, p: vec4<f32>, q: vec4<f32> }
struct RuleOut { tp: vec4<f32>, tq: vec4<f32>, sep: vec4<f32>, cell: vec4<u32> }
fn rules(x: RuleIn) -> RuleOut {
    let tp = nb_wrap(x.g, x.p.xyz);
    let tq = nb_wrap(x.g, x.q.xyz);
    let c = nb_cell_index(x.g, nb_cell_coord(x.g, tp));
    return RuleOut(vec4<f32>(tp, 0.0), vec4<f32>(tq, 0.0), vec4<f32>(nb_min_image(x.g, tp - tq), 0.0),
                   vec4<u32>(c, u32(nb_outside(x.g, tp)), 0u, 0u));
}
";

/// Positions along one axis of `[origin, origin + l]`: the faces, one f32 ulp inside them,
/// the middle, and (periodic axes) far outside on both sides.
fn axis_values(origin: f64, l: f64, periodic: bool, rng: &mut rand_pcg::Pcg64) -> Vec<f32> {
    let (lo, hi) = (origin as f32, (origin + l) as f32);
    let mut v = vec![
        lo,
        lo.next_up(),
        hi.next_down(),
        hi,
        (origin + 0.5 * l) as f32,
    ];
    if periodic {
        v.extend([
            (origin - 2.3 * l) as f32,
            (origin + 3.7 * l) as f32,
            lo.next_down(),
        ]);
    }
    v.extend((0..24).map(|_| (origin + rng.random::<f64>() * l) as f32));
    v
}

fn check<const D: usize>(ctx: &simkit_backend::GpuContext, grid: &CellGrid<D>, seed: u64) {
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let params = GpuGridParams::new(grid, 0).unwrap();
    let axes: Vec<Vec<f32>> = (0..D)
        .map(|d| {
            axis_values(
                grid.origin()[d],
                grid.lengths()[d],
                grid.periodic()[d],
                &mut rng,
            )
        })
        .collect();
    let mut inputs = Vec::new();
    for k in 0..400 {
        let pick = |rng: &mut rand_pcg::Pcg64| -> [f32; 4] {
            let mut p = [0.0f32; 4];
            for d in 0..D {
                p[d] = axes[d][rng.random_range(0..axes[d].len())];
            }
            p
        };
        let (p, q) = (pick(&mut rng), pick(&mut rng));
        inputs.push(RuleIn {
            grid: params,
            p,
            q: if k % 7 == 0 { p } else { q },
        });
    }
    let src = [CELLS_WGSL, HARNESS];
    let out: Vec<RuleOut> = eval_wgsl(ctx, &src, "RuleIn", "RuleOut", "rules(x)", &inputs).unwrap();
    // The GPU works in f32 with the f32-rounded box; the Rust rules in f64. Positions agree
    // to a few f32 ulps of the box length; a cell may differ only for a position within that
    // distance of a cell face.
    let tol: Vec<f64> = (0..D)
        .map(|d| 8.0 * f64::from(f32::EPSILON) * grid.lengths()[d])
        .collect();
    let size = grid.cell_size();
    let mut exact_cells = 0;
    for (x, g) in inputs.iter().zip(&out) {
        let p: [f64; D] = std::array::from_fn(|d| f64::from(x.p[d]));
        let q: [f64; D] = std::array::from_fn(|d| f64::from(x.q[d]));
        let (tp, tq) = (grid.wrap(0, p).unwrap(), grid.wrap(1, q).unwrap());
        let (sep, _) = grid.separation(tp, tq);
        for d in 0..D {
            // Wrapping may land on either side of a periodic face under rounding: compare
            // modulo the box length there.
            let close = |a: f64, b: f64| {
                let e = (a - b).abs();
                e <= tol[d] || (grid.periodic()[d] && (e - grid.lengths()[d]).abs() <= tol[d])
            };
            assert!(
                close(f64::from(g.tp[d]), tp[d]),
                "wrap {p:?} axis {d}: {} vs {}",
                g.tp[d],
                tp[d]
            );
            assert!(close(f64::from(g.tq[d]), tq[d]), "wrap {q:?} axis {d}");
            // The minimum image is unique except within rounding of half the box length.
            let half = 0.5 * grid.lengths()[d];
            let ambiguous = grid.periodic()[d] && (sep[d].abs() - half).abs() <= tol[d];
            assert!(
                (f64::from(g.sep[d]) - sep[d]).abs() <= tol[d] || ambiguous,
                "min image {p:?} - {q:?} axis {d}: {} vs {}",
                g.sep[d],
                sep[d]
            );
        }
        let near_face = (0..D).any(|d| {
            let r = tp[d] / size[d];
            (r - r.round()).abs() * size[d] <= tol[d]
                || tp[d] <= tol[d]
                || grid.lengths()[d] - tp[d] <= tol[d]
        });
        if !near_face {
            assert_eq!(g.cell[0] as usize, grid.cell_of(tp), "cell of {p:?}");
            exact_cells += 1;
        }
        assert_eq!(g.cell[1], 0, "{p:?} is inside every closed face");
    }
    assert!(
        exact_cells > 100,
        "the sample must hold positions away from cell faces"
    );
}

#[test]
fn wrap_cell_and_minimum_image_match_their_rust_rules() {
    let Some(ctx) = gpu_or_skip("wrap_cell_and_minimum_image_match_their_rust_rules") else {
        return;
    };
    check(
        &ctx,
        &CellGrid::new([0.0; 3], [10.0; 3], [true; 3], 2.5).unwrap(),
        1,
    );
    check(
        &ctx,
        &CellGrid::new([-3.0, 1.5, 0.25], [7.0, 4.0, 9.5], [true, false, true], 1.1).unwrap(),
        2,
    );
    check(
        &ctx,
        &CellGrid::new([0.0; 3], [2.0, 5.0, 5.0], [true, true, false], 1.0).unwrap(),
        3,
    );
    check(
        &ctx,
        &CellGrid::new([0.0; 2], [6.0, 3.0], [false, true], 0.7).unwrap(),
        4,
    );
    check(
        &ctx,
        &CellGrid::new([-1.0; 2], [100.0; 2], [true; 2], 3.3).unwrap(),
        5,
    );
}
