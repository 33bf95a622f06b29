// Linear workgroup index of a dispatch spread over a 2D grid (see backend::Kernel).
fn linear_workgroup(wid: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return wid.x + wid.y * nwg.x;
}
