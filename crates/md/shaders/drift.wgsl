// Drift with the boundary rule of each axis (velocity Verlet: after the opening half kick).
// Periodic axes wrap by one box length, reflecting axes mirror the position and flip the
// velocity, as the CPU backend does; a particle still outside the box afterwards (it moved
// more than a box length in one step) gets a NaN coordinate, which the blow-up guard
// reports. pos.w holds the species (as f32) and is kept.
@group(0) @binding(0) var<uniform> prm: MdParams;
@group(0) @binding(1) var<storage, read_write> pos: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> vel: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> acc: array<vec4<f32>>;

// Moves particle i by `disp`, applies the boundary rule to the position and the new
// velocity `v`, and stores both.
fn md_place(i: u32, disp: vec3<f32>, v_in: vec3<f32>) {
    var v = v_in;
    let p = pos[i];
    var x = p.xyz;
    for (var d = 0u; d < prm.dim; d++) {
        var c = x[d] + disp[d];
        let lo = prm.lo[d];
        let hi = prm.hi[d];
        var inside: bool;
        if (prm.periodic[d] != 0u) {
            if (c < lo) {
                c = c + prm.len[d];
                if (c >= hi) {
                    c = lo;
                }
            } else if (c >= hi) {
                c = c - prm.len[d];
            }
            inside = c >= lo && c < hi;
        } else {
            if (c < lo) {
                c = lo + lo - c;
                v[d] = -v[d];
            } else if (c > hi) {
                c = hi + hi - c;
                v[d] = -v[d];
            }
            inside = c >= lo && c <= hi;
        }
        if (!inside) {
            c = bitcast<f32>(0x7fc00000u);
        }
        x[d] = c;
    }
    pos[i] = vec4<f32>(x, p.w);
    vel[i] = vec4<f32>(v, 0.0);
}

// The opening half kick of velocity Verlet (none for leapfrog, whose stored velocities are
// already at the half step).
fn md_open_kick(i: u32) -> vec3<f32> {
    var v = vel[i].xyz;
    if (prm.leapfrog == 0u) {
        v = v + acc[i].xyz * prm.half_dt;
    }
    return v;
}

@compute @workgroup_size(64)
fn md_drift(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = linear_workgroup(wid, nwg) * 64u + lid;
    if (i >= prm.n) {
        return;
    }
    let v = md_open_kick(i);
    md_place(i, v * prm.dt, v);
}
