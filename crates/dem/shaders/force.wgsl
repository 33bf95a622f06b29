// Contact forces by gathering over the full shell of neighbour cells (one invocation per
// particle, writing only its own acceleration), walls, gravity, and the second half kick.
// acc.w receives the deepest overlap of the particle's contacts over the smaller radius
// (against a wall: its radius), which the blow-up check (check.wgsl) reads.
// Variants (override constants, chosen once): FRICTION, INIT (initial accelerations only).
// The contact law is the law's WGSL (dem_contact_force; the linear law's is contact.wgsl),
// the wall geometry walls.wgsl (one copy each, shared by the particle and the wall
// contacts).
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
// The law's coefficients: n_species^2 species pairs, then one entry per wall.
@group(0) @binding(8) var<storage, read> coeff: array<DemCoeff>;
// Wall geometry, one record per wall.
@group(0) @binding(9) var<storage, read> walls: array<DemWall>;
@group(0) @binding(10) var<storage, read_write> acc: array<vec4<f32>>;
@group(0) @binding(11) var<storage, read_write> vel: array<vec4<f32>>;
@group(0) @binding(12) var<storage, read> clock: array<u32>;

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
    var deepest = 0.0;
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
                    let mij = dem_reduced_mass(mi, vj.w);
                    let vrel = vi.xyz - vj.xyz;
                    let vn = dot(vrel, n);
                    deepest = max(deepest, (rsum - dist) / min(ri, pj.w));
                    f += dem_contact_force(coeff[row + species[j]], mij, rsum - dist, n, vrel, vn, FRICTION);
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
        let motion = dem_wall_motion(prm.amplitude, prm.omega, f32(steps) * prm.omega_dt);
        let base = prm.n_species * prm.n_species;
        for (var w = 0u; w < prm.n_walls; w++) {
            let wall = walls[w];
            let vib = wall.motion.x;
            var n: vec3<f32>;
            var delta: f32;
            if (wall.cylinder.w > 0.5) {
                let cyl = dem_cylinder_overlap(wall.cylinder.xy, wall.cylinder.z, ti.xy, ri);
                n = vec3<f32>(cyl.xy, 0.0);
                delta = cyl.z;
            } else {
                n = wall.plane.xyz;
                delta = dem_plane_overlap(n, wall.plane.w, vib * motion.x * n[prm.vertical], ti, ri);
            }
            if (delta <= 0.0) {
                continue;
            }
            var wv = vec3<f32>(0.0);
            wv[prm.vertical] = vib * motion.y;
            if (wall.cylinder.w > 0.5) {
                wv = vec3<f32>(wv.xy + dem_cylinder_surface_velocity(wall.motion.y, wall.cylinder.z, n.xy), wv.z);
            }
            let vrel = vi.xyz - wv;
            let vn = dot(vrel, n);
            deepest = max(deepest, delta / ri);
            f += dem_contact_force(coeff[base + w], mi, delta, n, vrel, vn, FRICTION);
        }
    }
    let a = f / mi;
    acc[i] = vec4<f32>(a, deepest);
    if (!INIT) {
        let v = vel[i];
        vel[i] = vec4<f32>(v.xyz + a * prm.half_dt, v.w);
    }
}
