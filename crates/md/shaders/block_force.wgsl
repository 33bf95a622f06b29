// Forces with one workgroup per cell and one invocation per slot of the cell: each
// invocation holds its own particle; the workgroup walks the full shell of neighbour cells
// (the cell itself included) in a fixed order, stages each cell's positions and ids in
// workgroup memory and every invocation sums the pair terms of its particle over the
// staged slots in slot order (deterministic). Positions are wrapped as the cell list wraps
// them and the separations take the minimum image, as in md_force; the closing kick and
// the outputs are md_force's (see force.wgsl for KICK).
override KICK: f32 = 0.0;

@group(0) @binding(0) var<uniform> grid: NbGrid;
@group(0) @binding(1) var<uniform> prm: MdParams;
@group(0) @binding(2) var<storage, read> counts: array<u32>;
@group(0) @binding(3) var<storage, read> slots: array<u32>;
@group(0) @binding(4) var<storage, read> pos: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> coeff: array<MdCoeff>;
@group(0) @binding(6) var<storage, read> species: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> acc: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read_write> vel: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read_write> vir: array<f32>;

var<workgroup> stage_pos: array<vec4<f32>, CAP>;
var<workgroup> stage_id: array<u32, CAP>;

@compute @workgroup_size(CAP)
fn md_block_force(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let cell = linear_workgroup(wid, nwg);
    if (cell >= grid.n_cells) {
        return;
    }
    let holds = lid < min(counts[cell], CAP);
    var i = 0xffffffffu;
    var ti = vec3<f32>(0.0);
    var si = 0u;
    if (holds) {
        i = slots[cell * CAP + lid];
        let p = pos[i];
        ti = nb_wrap(grid, p.xyz);
        si = u32(p.w);
    }
    let row = si * prm.n_species;
    var f = vec3<f32>(0.0);
    var e = 0.0;
    var w = 0.0;
    let c = md_block_coord(grid, cell);
    let lo = nb_shell_lo(grid, c);
    let hi = nb_shell_hi(grid, c);
    for (var oz = lo.z; oz <= hi.z; oz++) {
        for (var oy = lo.y; oy <= hi.y; oy++) {
            for (var ox = lo.x; ox <= hi.x; ox++) {
                let nc = nb_neighbor_cell(grid, c, vec3<i32>(ox, oy, oz));
                let m = min(counts[nc], CAP);
                // The previous cell's stage has been read by every invocation.
                workgroupBarrier();
                if (lid < m) {
                    let j = slots[nc * CAP + lid];
                    let p = pos[j];
                    stage_id[lid] = j;
                    stage_pos[lid] = vec4<f32>(nb_wrap(grid, p.xyz), p.w);
                }
                workgroupBarrier();
                if (holds) {
                    for (var k = 0u; k < m; k++) {
                        if (stage_id[k] == i) {
                            continue;
                        }
                        let pj = stage_pos[k];
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
    }
    if (!holds) {
        return;
    }
    let a = f * species[si].x;
    acc[i] = vec4<f32>(a, e);
    vir[i] = w;
    if (KICK > 0.0) {
        let v = vel[i];
        vel[i] = vec4<f32>(v.xyz + a * (KICK * prm.half_dt), 0.0);
    }
}
