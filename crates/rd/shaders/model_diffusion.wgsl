// Linear diffusion: mp(s) = D_s.
fn model_update(dt: real, ih2: real) {
    for (var s = 0u; s < NS; s++) {
        let c = ld(s, 0, 0);
        let lap = (ld(s, -1, 0) + ld(s, 1, 0)) + (ld(s, 0, -1) + ld(s, 0, 1)) - real(4.0) * c;
        put(s, c + (mp(s) * dt * ih2) * lap);
    }
}

// Effective diffusivity at the current cell: the largest D_s (constant).
fn model_diffusivity() -> real {
    var d = real(0.0);
    for (var s = 0u; s < NS; s++) {
        d = max(d, mp(s));
    }
    return d;
}
