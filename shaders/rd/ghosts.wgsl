// Fills the ghost layer of every species plane from the boundary codes in params:
// 0 no-flux (copy the adjacent cell), 1 periodic (copy the opposite cell),
// 2 Dirichlet (2 g - adjacent, so the face value is g). Corners are never read.

override NX: u32;
override NY: u32;
override NS: u32;

@group(0) @binding(0) var<storage, read_write> buf: array<real>;
@group(0) @binding(1) var<storage, read> params: array<real>;

fn ghost(edge: u32, s: u32, inner: real, opposite: real) -> real {
    let code = u32(params[2u + edge]);
    if code == 1u {
        return opposite;
    }
    if code == 2u {
        return real(2.0) * params[6u + edge * 4u + s] - inner;
    }
    return inner;
}

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let k = linear_workgroup(wid, nwg) * 64u + lid;
    let per = 2u * NY + 2u * NX;
    if k >= NS * per {
        return;
    }
    let s = k / per;
    var r = k % per;
    let w = NX + 2u;
    let base = s * w * (NY + 2u);
    if r < NY {
        let row = base + (r + 1u) * w;
        buf[row] = ghost(0u, s, buf[row + 1u], buf[row + NX]);
        return;
    }
    r -= NY;
    if r < NY {
        let row = base + (r + 1u) * w;
        buf[row + NX + 1u] = ghost(1u, s, buf[row + NX], buf[row + 1u]);
        return;
    }
    r -= NY;
    if r < NX {
        let i = base + r + 1u;
        buf[i] = ghost(2u, s, buf[i + w], buf[i + NY * w]);
        return;
    }
    r -= NX;
    let i = base + r + 1u;
    buf[i + (NY + 1u) * w] = ghost(3u, s, buf[i + NY * w], buf[i + w]);
}
