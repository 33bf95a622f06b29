// Largest effective diffusivity over the grid: `model_diffusivity()` at every interior cell,
// folded into `dmax` as the bits of a non-negative f32 with atomicMax (for non-negative floats
// the bit patterns order like the values). Negative values are ignored, as on the CPU; a NaN
// is folded in as the quiet-NaN pattern 0x7fc00000, which is above every non-negative f32
// (infinity is 0x7f800000), so a NaN anywhere makes `dmax` NaN (the host refuses to step).
// Each workgroup folds into workgroup memory first, so `dmax` sees one atomic per workgroup.

var<workgroup> wmax: atomic<u32>;

fn ld(f: u32, dx: i32, dy: i32) -> real {
    return load_global(f, u32(i32(cell) + dy * i32(row_width()) + dx));
}

@compute @workgroup_size(TX, TY)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    if li == 0u {
        atomicStore(&wmax, 0u);
    }
    workgroupBarrier();
    if gid.x < NX && gid.y < NY {
        cell = (gid.y + 1u) * row_width() + gid.x + 1u;
        let v = f32(model_diffusivity());
        // NaN tested on the bits: compilers may assume float comparisons never see NaN.
        let bits = bitcast<u32>(v) & 0x7fffffffu;
        if bits > 0x7f800000u {
            atomicMax(&wmax, 0x7fc00000u);
        } else if v > 0.0 {
            atomicMax(&wmax, bitcast<u32>(v));
        }
    }
    workgroupBarrier();
    if li == 0u {
        // `params` is referenced so that the layout derived from this shader keeps its
        // binding (model_diffusivity() may not read it); the host binds it like the stencil.
        _ = param_dt();
        atomicMax(&dmax, atomicLoad(&wmax));
    }
}
