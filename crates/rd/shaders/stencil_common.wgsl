// Shared part of the rd stencil kernels. Prepended by the host: `alias real = f32|f64;` and
// the generated bindings (one storage buffer per species for the source `src<s>` and the
// destination `dst<s>`, then `coef` and `params`) with `load_global(f, idx)` and `put(s, v)`.
// Storage is padded with one ghost layer: plane = (NX + 2) * (NY + 2) values per field.
// params: read through the accessors of params.wgsl (dt, 1/h^2, boundaries, model `mp(k)`).

override NX: u32;
override NY: u32;
override NS: u32;          // species advanced
override NF: u32;          // species + coefficient fields read by the stencil
override TX: u32 = 16u;    // tile width (threads per workgroup along x)
override TY: u32 = 16u;    // tile height
override AVERAGE: bool = false; // Heun second stage: dst = (dst + new) / 2

// Padded index of the cell being updated by this invocation.
var<private> cell: u32;

fn row_width() -> u32 {
    return NX + 2u;
}

fn plane() -> u32 {
    return (NX + 2u) * (NY + 2u);
}
