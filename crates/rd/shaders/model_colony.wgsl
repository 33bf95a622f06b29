// Bacterial colony in conservative flux form: field 0 = b, 1 = n, 2 = d (coefficient);
// mp(0) = gamma. Face diffusivity = mean of kappa = d n b of the two cells.
fn kappa(dx: i32, dy: i32) -> real {
    return ld(2u, dx, dy) * ld(1u, dx, dy) * ld(0u, dx, dy);
}

fn model_update(dt: real, ih2: real) {
    let bc = ld(0u, 0, 0);
    let nc = ld(1u, 0, 0);
    let kc = kappa(0, 0);
    let flux = ((kc + kappa(-1, 0)) * (ld(0u, -1, 0) - bc) + (kc + kappa(1, 0)) * (ld(0u, 1, 0) - bc))
        + ((kc + kappa(0, -1)) * (ld(0u, 0, -1) - bc) + (kc + kappa(0, 1)) * (ld(0u, 0, 1) - bc));
    let r = nc * bc / (real(1.0) + mp(0u) * nc);
    let lap_n = (ld(1u, -1, 0) + ld(1u, 1, 0)) + (ld(1u, 0, -1) + ld(1u, 0, 1)) - real(4.0) * nc;
    put(0u, bc + ((real(0.5) * dt * ih2) * flux + dt * r));
    put(1u, nc + ((dt * ih2) * lap_n - dt * r));
}

// Effective diffusivity at the current cell: max(d b n, 1) (b's kappa; n diffuses with D = 1).
fn model_diffusivity() -> real {
    let dbn = ld(2u, 0, 0) * ld(0u, 0, 0) * ld(1u, 0, 0);
    // `max` may drop a NaN operand: pass a NaN (tested on the f32 bits) through unchanged.
    if (bitcast<u32>(f32(dbn)) & 0x7fffffffu) > 0x7f800000u {
        return dbn;
    }
    return max(dbn, real(1.0));
}
