// Contact forces by gathering over the full shell of neighbour cells (one invocation per
// particle, writing only its own acceleration), walls, gravity, and the second half kick.
// Variants (override constants, chosen once): FRICTION, INIT (initial accelerations only).
override FRICTION: bool = false;
override INIT: bool = false;

@group(0) @binding(0) var<uniform> grid: NbGrid;
@group(0) @binding(1) var<uniform> prm: DemParams;
@group(0) @binding(2) var<storage, read> cell_start: array<u32>;
@group(0) @binding(3) var<storage, read> sorted_ids: array<u32>;
@group(0) @binding(4) var<storage, read> sorted_pos: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> wrapped: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read> vpred: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read> species: array<u32>;
// Species-pair coefficients (kappa, 2b, mu_s, mu_k), n_species^2 entries, then 4 entries
// per wall: (normal, offset), (center.xy, radius, kind), coefficients, (vibrating, 0, 0, 0).
@group(0) @binding(8) var<storage, read> table: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read_write> acc: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read_write> vel: array<vec4<f32>>;
@group(0) @binding(11) var<storage, read> clock: array<u32>;

fn tangential(n: vec3<f32>, vn: f32, vrel: vec3<f32>, fnorm: f32, mij: f32, c: vec4<f32>) -> vec3<f32> {
    if (!FRICTION) {
        return vec3<f32>(0.0);
    }
    let vt = vrel - vn * n;
    let vt2 = dot(vt, vt);
    if (vt2 <= 0.0) {
        return vec3<f32>(0.0);
    }
    let vtn = sqrt(vt2);
    let ft = min(c.z * abs(fnorm), c.w * mij * vtn);
    return -(ft / vtn) * vt;
}

@compute @workgroup_size(64)
fn dem_force(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = linear_workgroup(wid, nwg) * 64u + lid;
    if (i >= prm.n) {
        return;
    }
    let wi = wrapped[i];
    let ti = wi.xyz;
    let ri = wi.w;
    let vi = vpred[i];
    let mi = vi.w;
    let row = species[i] * prm.n_species;
    var f = prm.gravity.xyz * mi;
    let c = nb_cell_coord(grid, ti);
    let lo = nb_shell_lo(grid, c);
    let hi = nb_shell_hi(grid, c);
    for (var oz = lo.z; oz <= hi.z; oz++) {
        for (var oy = lo.y; oy <= hi.y; oy++) {
            for (var ox = lo.x; ox <= hi.x; ox++) {
                let cell = nb_neighbor_cell(grid, c, vec3<i32>(ox, oy, oz));
                let end = cell_start[cell + 1u];
                for (var k = cell_start[cell]; k < end; k++) {
                    let j = sorted_ids[k];
                    let pj = sorted_pos[k];
                    let sep = nb_min_image(grid, ti - pj.xyz);
                    let rsum = ri + pj.w;
                    let r2 = dot(sep, sep);
                    if (j == i || r2 >= rsum * rsum) {
                        continue;
                    }
                    let dist = sqrt(r2);
                    let n = sep / dist;
                    let vj = vpred[j];
                    let mij = mi * vj.w / (mi + vj.w);
                    let cf = table[row + species[j]];
                    let vrel = vi.xyz - vj.xyz;
                    let vn = dot(vrel, n);
                    let fnorm = mij * (cf.x * (rsum - dist) - cf.y * vn);
                    f += fnorm * n + tangential(n, vn, vrel, fnorm, mij, cf);
                }
            }
        }
    }
    if (prm.n_walls > 0u) {
        // Walls see the time of this force evaluation: t + dt (or t for INIT).
        var steps = clock[0];
        if (!INIT) {
            steps = steps + 1u;
        }
        let phase = f32(steps) * prm.omega_dt;
        let zw = -prm.amplitude * cos(phase);
        let vw = prm.amplitude * prm.omega * sin(phase);
        let base = prm.n_species * prm.n_species;
        for (var w = 0u; w < prm.n_walls; w++) {
            let g0 = table[base + 4u * w];
            let g1 = table[base + 4u * w + 1u];
            let cf = table[base + 4u * w + 2u];
            let vib = table[base + 4u * w + 3u].x;
            var n: vec3<f32>;
            var delta: f32;
            if (g1.w > 0.5) {
                let d = ti.xy - g1.xy;
                let rho = length(d);
                delta = rho + ri - g1.z;
                if (rho <= 0.0) {
                    continue;
                }
                n = vec3<f32>(-d / rho, 0.0);
            } else {
                n = g0.xyz;
                delta = ri - (dot(n, ti) - g0.w - vib * zw * n[prm.vertical]);
            }
            if (delta <= 0.0) {
                continue;
            }
            var wv = vec3<f32>(0.0);
            wv[prm.vertical] = vib * vw;
            let vrel = vi.xyz - wv;
            let vn = dot(vrel, n);
            let fnorm = mi * (cf.x * delta - cf.y * vn);
            f += fnorm * n + tangential(n, vn, vrel, fnorm, mi, cf);
        }
    }
    let a = f / mi;
    acc[i] = vec4<f32>(a, 0.0);
    if (!INIT) {
        let v = vel[i];
        vel[i] = vec4<f32>(v.xyz + a * prm.half_dt, v.w);
    }
}
