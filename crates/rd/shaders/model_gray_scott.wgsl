// Gray-Scott: mp(0) = Du, mp(1) = Dv, mp(2) = F, mp(3) = F + k.
fn model_update(dt: real, ih2: real) {
    let uc = ld(0u, 0, 0);
    let vc = ld(1u, 0, 0);
    let lu = (ld(0u, -1, 0) + ld(0u, 1, 0)) + (ld(0u, 0, -1) + ld(0u, 0, 1)) - real(4.0) * uc;
    let lv = (ld(1u, -1, 0) + ld(1u, 1, 0)) + (ld(1u, 0, -1) + ld(1u, 0, 1)) - real(4.0) * vc;
    let uvv = uc * vc * vc;
    put(0u, uc + ((mp(0u) * dt * ih2) * lu + dt * (mp(2u) * (real(1.0) - uc) - uvv)));
    put(1u, vc + ((mp(1u) * dt * ih2) * lv + dt * (uvv - mp(3u) * vc)));
}

// Effective diffusivity at the current cell: max(Du, Dv) (constant).
fn model_diffusivity() -> real {
    return max(mp(0u), mp(1u));
}
