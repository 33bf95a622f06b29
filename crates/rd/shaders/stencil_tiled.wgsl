// Tiled stencil: each workgroup copies its TX x TY tile plus a one-cell halo of every field
// into workgroup memory, synchronises, then evaluates the model from there.

override TILE_LEN: u32 = NF * (TX + 2u) * (TY + 2u);

var<workgroup> tile: array<real, TILE_LEN>;
var<private> tpos: u32;

fn ld(f: u32, dx: i32, dy: i32) -> real {
    let ts = (TX + 2u) * (TY + 2u);
    return tile[f * ts + u32(i32(tpos) + dy * i32(TX + 2u) + dx)];
}

@compute @workgroup_size(TX, TY)
fn main(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>) {
    let x0 = wid.x * TX;
    let y0 = wid.y * TY;
    let tw = TX + 2u;
    let ts = tw * (TY + 2u);
    for (var k = lid.y * TX + lid.x; k < ts; k += TX * TY) {
        let gx = min(x0 + k % tw, NX + 1u);
        let gy = min(y0 + k / tw, NY + 1u);
        let g = gy * row_width() + gx;
        for (var f = 0u; f < NF; f++) {
            tile[f * ts + k] = load_global(f, g);
        }
    }
    workgroupBarrier();
    let i = x0 + lid.x;
    let j = y0 + lid.y;
    if i < NX && j < NY {
        tpos = (lid.y + 1u) * tw + lid.x + 1u;
        cell = (j + 1u) * row_width() + i + 1u;
        model_update(param_dt(), param_inv_h2());
    }
}
