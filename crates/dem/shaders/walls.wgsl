// simkit dem: wall geometry (Rust twins in src/walls.rs).

// Overlap r - (n . x - offset - lift) of a particle with the plane n . y = offset + lift
// (n: unit normal into the particle region; lift: displacement of a moving wall along n).
fn dem_plane_overlap(n: vec3<f32>, offset: f32, lift: f32, x: vec3<f32>, r: f32) -> f32 {
    return r - (dot(n, x) - offset - lift);
}

// (normal, overlap) of a particle (centre x in the plane normal to the axis, radius r) with
// the inside of a cylinder wall: overlap rho + r - R with rho = |x - center|, normal
// -(x - center) / rho towards the axis; (0, 0, 0) for a particle centred on the axis.
fn dem_cylinder_overlap(center: vec2<f32>, radius: f32, x: vec2<f32>, r: f32) -> vec3<f32> {
    let d = x - center;
    let rho = length(d);
    if (rho <= 0.0) {
        return vec3<f32>(0.0);
    }
    return vec3<f32>(-d / rho, rho + r - radius);
}

// (z_w, v_w) = (-A cos(phase), A omega sin(phase)) of a vibrating wall at phase omega t.
fn dem_wall_motion(amplitude: f32, omega: f32, phase: f32) -> vec2<f32> {
    return vec2<f32>(-amplitude * cos(phase), amplitude * omega * sin(phase));
}

// Velocity (v_x, v_y) of the surface of a cylinder wall of radius R turning at spin
// (counter-clockwise seen from +z) where it touches a particle with contact normal n:
// spin R (n_y, -n_x).
fn dem_cylinder_surface_velocity(spin: f32, radius: f32, n: vec2<f32>) -> vec2<f32> {
    let s = spin * radius;
    return vec2<f32>(s * n.y, -(s * n.x));
}
