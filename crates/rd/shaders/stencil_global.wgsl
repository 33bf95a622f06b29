// Plain stencil: every invocation reads its five neighbours straight from global memory.

fn ld(f: u32, dx: i32, dy: i32) -> real {
    return load_global(f, u32(i32(cell) + dy * i32(row_width()) + dx));
}

@compute @workgroup_size(TX, TY)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if gid.x < NX && gid.y < NY {
        cell = (gid.y + 1u) * row_width() + gid.x + 1u;
        model_update(param_dt(), param_inv_h2());
    }
}
