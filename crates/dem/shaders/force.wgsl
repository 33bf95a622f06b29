// Contact forces by gathering over the full shell of neighbour cells (one invocation per
// particle, writing only its own acceleration), walls, gravity, and the second half kick.
// acc.w receives the deepest overlap of the particle's contacts over the smaller radius
// (against a wall: its radius), which the blow-up check (check.wgsl) reads; a particle with
// more contacts than its history slots hold is noted in clock[1].
// Variants (override constants, chosen once): FRICTION, INIT (initial accelerations only),
// ROTATION (torques, angular accelerations and the angular half kick), SLOTS (history slots
// per particle; 0 for a law without history).
// The contact law is the law's WGSL (dem_contact_force; the linear law's is contact.wgsl)
// after law.wgsl and spin.wgsl, the wall geometry walls.wgsl (one copy each, shared by the
// particle and the wall contacts).
//
// Contact history: each particle keeps its own copy of the history of each of its
// contacts (particle j keeps the mirror image of i's), SLOTS slots of 8 words
// (partner + 1, 0 = empty; then 7 values) per particle, in two halves of the `hist` buffer:
// a force evaluation reads the slots the previous one wrote and writes the other half, so
// the history follows the particle's index, whatever the cell list's order. Partners are
// particle indices or, from n on, wall n + w. A force evaluation at device step count c
// reads half (c + 1) & 1 and writes half c & 1 (INIT, at c = 0 before any step: reads 0,
// writes 1).
override FRICTION: bool = false;
override INIT: bool = false;
override ROTATION: bool = false;
override SLOTS: u32 = 0u;

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
// [0]: device step counter; [1]: 1 + a particle whose history slots overflowed (0: none;
// the largest such index), read by the check.
@group(0) @binding(12) var<storage, read_write> clock: array<atomic<u32>>;
// Per particle 3 records: (w, 1 / I), (angular acceleration, 0), (predicted w, 0).
@group(0) @binding(13) var<storage, read_write> spin: array<vec4<f32>>;
// History slots (see above), as words.
@group(0) @binding(14) var<storage, read_write> hist: array<u32>;

// Scratch of one invocation: where its slots are read and written, how many it wrote.
struct Slots {
    read: u32,
    write: u32,
    used: u32,
}

// The history of contact partner p from the slots read (zero if p was not in contact).
fn history_of(s: Slots, p: u32) -> DemHistory {
    var h: DemHistory;
    for (var k = 0u; k < SLOTS; k++) {
        let at = s.read + k * 8u;
        let q = hist[at];
        if (q == 0u) {
            break;
        }
        if (q == p + 1u) {
            for (var v = 0u; v < 7u; v++) {
                h[v] = bitcast<f32>(hist[at + 1u + v]);
            }
            break;
        }
    }
    return h;
}

// Stores the history of partner p in the next free slot written; false when all are used.
fn keep_history(s: ptr<function, Slots>, p: u32, h: DemHistory) -> bool {
    if ((*s).used >= SLOTS) {
        return false;
    }
    let at = (*s).write + (*s).used * 8u;
    hist[at] = p + 1u;
    for (var v = 0u; v < 7u; v++) {
        hist[at + 1u + v] = bitcast<u32>(h[v]);
    }
    (*s).used += 1u;
    return true;
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
    var torque = vec3<f32>(0.0);
    var omega_i = vec3<f32>(0.0);
    if (ROTATION) {
        omega_i = spin[3u * i + 2u].xyz;
    }
    let steps_done = atomicLoad(&clock[0]);
    var slots = Slots(0u, 0u, 0u);
    if (SLOTS > 0u) {
        var write_half = steps_done & 1u;
        if (INIT) {
            write_half = 1u - write_half;
        }
        let stride = prm.n * SLOTS * 8u;
        slots.write = write_half * stride + i * SLOTS * 8u;
        slots.read = (1u - write_half) * stride + i * SLOTS * 8u;
    }
    var overflow = false;
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
                    var vrel = vi.xyz - vj.xyz;
                    let vn = dot(vrel, n);
                    let delta = rsum - dist;
                    deepest = max(deepest, delta / min(ri, pj.w));
                    var w_rel = vec3<f32>(0.0);
                    if (ROTATION) {
                        let omega_j = spin[3u * j + 2u].xyz;
                        vrel = dem_contact_point_velocity(vrel, n, ri, omega_i, pj.w, omega_j);
                        w_rel = omega_i - omega_j;
                    }
                    let contact = DemContact(n, delta, vrel, vn, w_rel, mij, ri * pj.w / rsum, prm.dt);
                    var h: DemHistory;
                    if (SLOTS > 0u) {
                        h = history_of(slots, j);
                    }
                    let out = dem_contact_force(coeff[row + species[j]], contact, &h, FRICTION);
                    if (SLOTS > 0u && !keep_history(&slots, j, h)) {
                        overflow = true;
                    }
                    f += out.force;
                    if (ROTATION) {
                        // The force acts at the middle of the overlap, -(R_i - delta / 2) n
                        // from i's centre.
                        torque += out.torque - (ri - 0.5 * delta) * cross(n, out.force);
                    }
                }
            }
        }
    }
    if (prm.n_walls > 0u) {
        // Walls see the time of this force evaluation: t + dt (or t for INIT).
        var steps = steps_done;
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
            var vrel = vi.xyz - wv;
            let vn = dot(vrel, n);
            deepest = max(deepest, delta / ri);
            if (ROTATION) {
                vrel = dem_contact_point_velocity(vrel, n, ri, omega_i, 0.0, vec3<f32>(0.0));
            }
            let contact = DemContact(n, delta, vrel, vn, omega_i, mi, ri, prm.dt);
            var h: DemHistory;
            if (SLOTS > 0u) {
                h = history_of(slots, prm.n + w);
            }
            let out = dem_contact_force(coeff[base + w], contact, &h, FRICTION);
            if (SLOTS > 0u && !keep_history(&slots, prm.n + w, h)) {
                overflow = true;
            }
            f += out.force;
            if (ROTATION) {
                torque += out.torque - ri * cross(n, out.force);
            }
        }
    }
    if (SLOTS > 0u && slots.used < SLOTS) {
        // The lookup stops at the first empty slot: one marker ends the written ones.
        hist[slots.write + slots.used * 8u] = 0u;
    }
    if (overflow) {
        atomicMax(&clock[1], i + 1u);
    }
    let a = f / mi;
    acc[i] = vec4<f32>(a, deepest);
    if (!INIT) {
        let v = vel[i];
        vel[i] = vec4<f32>(v.xyz + a * prm.half_dt, v.w);
    }
    if (ROTATION) {
        let s = spin[3u * i];
        let alpha = torque * s.w;
        spin[3u * i + 1u] = vec4<f32>(alpha, 0.0);
        if (!INIT) {
            spin[3u * i] = vec4<f32>(s.xyz + alpha * prm.half_dt, s.w);
        }
    }
}
