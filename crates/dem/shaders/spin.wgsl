// simkit dem: rotation and the Cundall-Strack springs (Rust twins in src/spin.rs).

// The relative velocity of the surfaces at the contact point: v_rel - (r_i w_i + r_j w_j) x n
// (twin of contact_point_velocity; against a wall r_j = 0).
fn dem_contact_point_velocity(v_rel: vec3<f32>, n: vec3<f32>, r_i: f32, w_i: vec3<f32>, r_j: f32, w_j: vec3<f32>) -> vec3<f32> {
    return v_rel - cross(r_i * w_i + r_j * w_j, n);
}

// One step of a Cundall-Strack spring (twin of coulomb_spring): the displacement xi is
// turned into the plane normal to n keeping its length, advanced by v dt; the force
// -k xi - gamma v is capped at cap, and a sliding spring is reset to the capped force.
fn dem_coulomb_spring(xi: ptr<function, vec3<f32>>, n: vec3<f32>, v: vec3<f32>, dt: f32, k: f32, gamma: f32, cap: f32) -> vec3<f32> {
    var x = *xi;
    let old2 = dot(x, x);
    if (old2 > 0.0) {
        x = x - dot(x, n) * n;
        let new2 = dot(x, x);
        if (new2 > 0.0) {
            x = x * sqrt(old2 / new2);
        }
    }
    x = x + v * dt;
    var f = -(k * x) - gamma * v;
    let f2 = dot(f, f);
    if (f2 > cap * cap) {
        f = f * (cap / sqrt(f2));
        if (k > 0.0) {
            x = -(f + gamma * v) / k;
        }
    }
    *xi = x;
    return f;
}

// The tangential spring (stiffness k, damping gamma, cap mu |f_n|) and, with mu_r > 0, the
// rolling spring (k_r, gamma_r, cap mu_r |f_n|) of a contact, history values 0..2 and 3..5;
// adds the tangential force to `out` and sets its couple R* n x F_r (twin of Springs::add).
fn dem_springs_add(out: DemForce, c: DemContact, f_n: f32, h: ptr<function, DemHistory>, k: f32, gamma: f32, mu: f32, k_r: f32, gamma_r: f32, mu_r: f32) -> DemForce {
    let v_t = c.v_rel - c.v_n * c.n;
    let f_abs = abs(f_n);
    var xi = vec3<f32>((*h)[0], (*h)[1], (*h)[2]);
    let f_t = dem_coulomb_spring(&xi, c.n, v_t, c.dt, k, gamma, mu * f_abs);
    (*h)[0] = xi.x;
    (*h)[1] = xi.y;
    (*h)[2] = xi.z;
    var o = DemForce(out.force + f_t, out.torque);
    if (mu_r > 0.0) {
        let v_r = c.r_eff * cross(c.w_rel, c.n);
        var xr = vec3<f32>((*h)[3], (*h)[4], (*h)[5]);
        let f_r = dem_coulomb_spring(&xr, c.n, v_r, c.dt, k_r, gamma_r, mu_r * f_abs);
        (*h)[3] = xr.x;
        (*h)[4] = xr.y;
        (*h)[5] = xr.z;
        o.torque = c.r_eff * cross(c.n, f_r);
    }
    return o;
}
