// Linear diffusion: mp(s) = D_s.
fn model_update(dt: real, ih2: real) {
    for (var s = 0u; s < NS; s++) {
        let c = ld(s, 0, 0);
        let lap = (ld(s, -1, 0) + ld(s, 1, 0)) + (ld(s, 0, -1) + ld(s, 0, 1)) - real(4.0) * c;
        put(s, c + (mp(s) * dt * ih2) * lap);
    }
}
