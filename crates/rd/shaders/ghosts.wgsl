// Fills the ghost layer of one species plane (species S, for its Dirichlet values) with the
// boundary rule `ghost_value` and the boundary codes and Dirichlet values in params.
// Corners are never read.

override NX: u32;
override NY: u32;
override S: u32;

@group(0) @binding(0) var<storage, read_write> buf: array<real>;
@group(0) @binding(1) var<storage, read> params: array<real>;

fn ghost(edge: u32, inner: real, opposite: real) -> real {
    return ghost_value(boundary_code(edge), dirichlet_value(edge, S), inner, opposite);
}

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    var r = linear_workgroup(wid, nwg) * 64u + lid;
    if r >= 2u * NY + 2u * NX {
        return;
    }
    let w = NX + 2u;
    if r < NY {
        let row = (r + 1u) * w;
        buf[row] = ghost(0u, buf[row + 1u], buf[row + NX]);
        return;
    }
    r -= NY;
    if r < NY {
        let row = (r + 1u) * w;
        buf[row + NX + 1u] = ghost(1u, buf[row + NX], buf[row + 1u]);
        return;
    }
    r -= NY;
    if r < NX {
        let i = r + 1u;
        buf[i] = ghost(2u, buf[i + w], buf[i + NY * w]);
        return;
    }
    r -= NX;
    let i = r + 1u;
    buf[i + (NY + 1u) * w] = ghost(3u, buf[i + NY * w], buf[i + w]);
}
