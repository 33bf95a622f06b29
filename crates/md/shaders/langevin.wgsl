// The thermostatted drift (A O A of BAOAB), twin of drift_langevin in src/cpu.rs:
// v' = c1 v + amplitude R, x += (v + v') dt / 2, v = v', then the boundary rule. R are the
// normal numbers of key (seed, step, particle); the step is tick[0], advanced on the device
// by md_tick after every step. Needs drift.wgsl, noise.wgsl and RNG_WGSL.
// Per species s: (1 / mass, c1, amplitude, 0).
@group(0) @binding(4) var<storage, read> species: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> tick: array<u32>;

@compute @workgroup_size(64)
fn md_drift_langevin(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = linear_workgroup(wid, nwg) * 64u + lid;
    if (i >= prm.n) {
        return;
    }
    let v = md_open_kick(i);
    let ou = species[u32(pos[i].w)];
    let g = md_gaussians(prm.seed, tick[0], i);
    var w = ou.y * v + ou.z * g;
    if (prm.dim < 3u) {
        w.z = 0.0;
    }
    md_place(i, (v + w) * prm.half_dt, w);
}
