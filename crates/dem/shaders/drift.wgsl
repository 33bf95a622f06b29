// Velocity Verlet first half: half kick, drift, periodic wrap, predicted velocity
// v(t) + a(t) dt for the damping force at t + dt; with ROTATION the same for the angular
// velocity (spin: per particle (w, 1 / I), (angular acceleration, 0), (predicted w, 0)).
override ROTATION: bool = false;

@group(0) @binding(0) var<uniform> grid: NbGrid;
@group(0) @binding(1) var<uniform> prm: DemParams;
@group(0) @binding(2) var<storage, read_write> pos: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> vel: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> acc: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> vpred: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> spin: array<vec4<f32>>;

@compute @workgroup_size(64)
fn dem_drift(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = linear_workgroup(wid, nwg) * 64u + lid;
    if (i >= prm.n) {
        return;
    }
    let a = acc[i].xyz;
    let v = vel[i];
    let vh = v.xyz + a * prm.half_dt;
    var x = pos[i].xyz + vh * prm.dt;
    let t = nb_wrap(grid, x);
    for (var d = 0u; d < 3u; d++) {
        if (grid.periodic[d] != 0u) {
            x[d] = grid.origin[d] + t[d];
        }
    }
    pos[i] = vec4<f32>(x, pos[i].w);
    vel[i] = vec4<f32>(vh, v.w);
    vpred[i] = vec4<f32>(vh + a * prm.half_dt, v.w);
    if (ROTATION) {
        let w = spin[3u * i];
        let alpha = spin[3u * i + 1u].xyz;
        let wh = w.xyz + alpha * prm.half_dt;
        spin[3u * i] = vec4<f32>(wh, w.w);
        spin[3u * i + 2u] = vec4<f32>(wh + alpha * prm.half_dt, 0.0);
    }
}
