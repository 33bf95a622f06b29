// Forces by gathering over the full shell of neighbour cells of neighbor's GpuCellList (one
// invocation per particle, writing only its own entries), then the kick that closes the
// step: v += a * KICK * dt / 2 (KICK = 1: velocity Verlet's closing half kick, 2: the fused
// leapfrog kick, 0: forces only, 1 also for the leapfrog start v(dt/2) = v(0) + a(0) dt/2).
// acc.w receives sum_j phi_ij, vir[i] sum_j r_ij . F_ij.
override KICK: f32 = 0.0;

@group(0) @binding(0) var<uniform> grid: NbGrid;
@group(0) @binding(1) var<uniform> prm: MdParams;
@group(0) @binding(2) var<storage, read> cell_start: array<u32>;
@group(0) @binding(3) var<storage, read> sorted_ids: array<u32>;
@group(0) @binding(4) var<storage, read> sorted_pos: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> wrapped: array<vec4<f32>>;
// n_species^2 pair coefficients of the law, entry si * n_species + sj.
@group(0) @binding(6) var<storage, read> coeff: array<MdCoeff>;
// Per species: (1 / mass, c1, amplitude, 0).
@group(0) @binding(7) var<storage, read> species: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read_write> acc: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read_write> vel: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read_write> vir: array<f32>;

@compute @workgroup_size(64)
fn md_force(
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
    let si = u32(wi.w);
    let row = si * prm.n_species;
    var f = vec3<f32>(0.0);
    var e = 0.0;
    var w = 0.0;
    let c = nb_cell_coord(grid, ti);
    let lo = nb_shell_lo(grid, c);
    let hi = nb_shell_hi(grid, c);
    for (var oz = lo.z; oz <= hi.z; oz++) {
        for (var oy = lo.y; oy <= hi.y; oy++) {
            for (var ox = lo.x; ox <= hi.x; ox++) {
                let cell = nb_neighbor_cell(grid, c, vec3<i32>(ox, oy, oz));
                let end = cell_start[cell + 1u];
                for (var k = cell_start[cell]; k < end; k++) {
                    if (sorted_ids[k] == i) {
                        continue;
                    }
                    let pj = sorted_pos[k];
                    let sep = nb_min_image(grid, ti - pj.xyz);
                    let r2 = dot(sep, sep);
                    let fe = md_pair_force_energy(coeff[row + u32(pj.w)], r2);
                    f += fe.x * sep;
                    e += fe.y;
                    w += fe.x * r2;
                }
            }
        }
    }
    let a = f * species[si].x;
    acc[i] = vec4<f32>(a, e);
    vir[i] = w;
    if (KICK > 0.0) {
        let v = vel[i];
        vel[i] = vec4<f32>(v.xyz + a * (KICK * prm.half_dt), 0.0);
    }
}
