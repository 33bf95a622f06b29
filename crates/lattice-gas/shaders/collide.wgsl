// The FHP collision of 32 sites as boolean logic (bit b of every word is site b): s[d] is
// direction d + 1, r the chirality bits, wall the wall flags; full selects the full rule set,
// else FHP-I. Twin of rules::collide_bits (src/rules.rs); tests/laws.rs compares the two.

fn fhp_collide(s: array<u32, 6>, r: u32, wall: u32, full: bool) -> array<u32, 6> {
    let a = s[0];
    let b = s[1];
    let c = s[2];
    let dd = s[3];
    let e = s[4];
    let f = s[5];
    let p1 = a & dd;
    let p2 = b & e;
    let p3 = c & f;
    let z1 = ~(a | dd);
    let z2 = ~(b | e);
    let z3 = ~(c | f);
    var rot = (p1 & z2 & z3) | (p2 & z1 & z3) | (p3 & z1 & z2)
        | ((a ^ b) & (b ^ c) & (c ^ dd) & (dd ^ e) & (e ^ f));
    var fl1 = 0u;
    var fl2 = 0u;
    var fl3 = 0u;
    if (full) {
        rot = rot | (p1 & p2 & z3) | (p1 & p3 & z2) | (p2 & p3 & z1);
        // A head-on pair with a spectator on one axis moves to the third axis.
        let s1 = (a ^ dd) & ((p2 & z3) | (p3 & z2));
        let s2 = (b ^ e) & ((p1 & z3) | (p3 & z1));
        let s3 = (c ^ f) & ((p1 & z2) | (p2 & z1));
        fl1 = s2 | s3;
        fl2 = s1 | s3;
        fl3 = s1 | s2;
    }
    // Chirality 1 rotates clockwise: new direction d holds old d - 1.
    let cw = array<u32, 6>(f, a, b, c, dd, e);
    let ccw = array<u32, 6>(b, c, dd, e, f, a);
    let flips = array<u32, 6>(fl1, fl2, fl3, fl1, fl2, fl3);
    let rev = array<u32, 6>(dd, e, f, a, b, c);
    var o: array<u32, 6>;
    for (var d = 0u; d < 6u; d++) {
        let rotated = (r & cw[d]) | (~r & ccw[d]);
        let fluid = (rot & rotated) | (~rot & (s[d] ^ flips[d]));
        o[d] = (wall & rev[d]) | (~wall & fluid);
    }
    return o;
}
