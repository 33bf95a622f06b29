// The update of one site of the byte layout, shared by the whole-lattice kernel (step.wgsl)
// and the block kernel of a distributed run (block.wgsl). Include after the backend's
// rng.wgsl and this crate's random.wgsl; the including kernel declares FLAGS (bit 2 inflow,
// 3 outflow, 4 body force), the workgroup table `lut` (512 entries, loaded) and
// `site_byte(i, j)`, the byte of a site of its buffer or of a neighbour one outside it.

// The new byte of site (i, j) of the kernel's buffer: pull streaming from its six
// neighbours (the offsets of a row of global parity `odd`), the collision table with the
// chirality bit of global site `s`, then the body force and, on global column `gi`, the
// inflow (column 0) and outflow (column `last`) rules.
fn fhp_site(i: i32, j: i32, odd: bool, s: u32, gi: i32, last: i32, key: u32, fkey: u32,
            threshold: u32) -> u32 {
    let own = site_byte(i, j);
    var n = (own & 128u) | (site_byte(i - 1, j) & 1u) | (site_byte(i + 1, j) & 8u);
    if (odd) {
        n |= (site_byte(i, j + 1) & 2u) | (site_byte(i + 1, j + 1) & 4u)
           | (site_byte(i + 1, j - 1) & 16u) | (site_byte(i, j - 1) & 32u);
    } else {
        n |= (site_byte(i - 1, j + 1) & 2u) | (site_byte(i, j + 1) & 4u)
           | (site_byte(i, j - 1) & 16u) | (site_byte(i - 1, j - 1) & 32u);
    }
    let r = fhp_chirality(key, s);
    var v = lut[(n << 1u) | r];
    if ((FLAGS & 16u) != 0u) {
        if ((v & 137u) == 8u && fhp_force_hit(fkey, s, threshold)) {
            v = v ^ 9u;
        }
    }
    if ((FLAGS & 4u) != 0u && gi == 0 && (v & 128u) == 0u) { v = 1u; }
    if ((FLAGS & 8u) != 0u && gi == last && (v & 128u) == 0u) { v = 0u; }
    return v;
}
