//! Collision rule sets and the lookup tables generated from the conservation laws.
//!
//! A state's six direction bits have particle number `n` and momentum `p`. Two states can be
//! exchanged by a collision exactly when they share `(n, p)`. Grouping all 64 states by
//! `(n, p)` gives groups of one (no collision), two (a deterministic swap) or three (the
//! zero-momentum head-on pairs and their complements, where the random chirality bit picks a
//! rotation by +60 or -60 degrees). [`RuleSet::Full`] uses every group; [`RuleSet::FhpI`] only
//! the zero-momentum two- and three-particle groups (head-on pairs, symmetric triples).

use std::ops::{BitAnd, BitOr, BitXor, Not};

use crate::WALL;

/// Integer momentum of each direction in units (x/2, y*sqrt(3)/2 ... scaled): direction k
/// (bit k-1) has the lattice vector (cos, sin) of angle -60 (k-1) degrees, stored doubled with
/// the y component divided by sqrt(3) so that all components are integers.
const MOMENTUM: [(i32, i32); 6] = [(2, 0), (1, -1), (-1, -1), (-2, 0), (-1, 1), (1, 1)];

/// Which collisions are active.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum RuleSet {
    /// Classic FHP-I: head-on pairs rotate by +-60 degrees at random, symmetric triples
    /// rotate by 60 degrees. Viscosity `1/(12 d (1-d)^3) - 1/8`.
    FhpI,
    /// Every exchange allowed by particle number and momentum conservation (adds the
    /// four-body collisions and the head-on pair with a spectator): lower viscosity.
    Full,
}

/// Rotates the six direction bits by one direction clockwise (direction k to k+1).
pub fn rotate_cw(s: u8) -> u8 {
    let d = s & 0x3f;
    ((d << 1) | (d >> 5)) & 0x3f
}

/// Rotates the six direction bits by one direction counter-clockwise (direction k to k-1).
pub fn rotate_ccw(s: u8) -> u8 {
    let d = s & 0x3f;
    ((d >> 1) | (d << 5)) & 0x3f
}

/// Reverses every particle of a state (bounce-back), keeping the wall bit.
pub fn reverse(s: u8) -> u8 {
    let d = s & 0x3f;
    (((d << 3) | (d >> 3)) & 0x3f) | (s & WALL)
}

/// Particle number and (integer, scaled) momentum of the six direction bits of `s`.
pub fn invariants(s: u8) -> (u32, i32, i32) {
    let mut n = 0;
    let (mut px, mut py) = (0, 0);
    for (k, m) in MOMENTUM.iter().enumerate() {
        if s & (1 << k) != 0 {
            n += 1;
            px += m.0;
            py += m.1;
        }
    }
    (n, px, py)
}

/// The collision lookup table of a rule set: `table[(state << 1) | chirality]` is the
/// post-collision state for each of the 256 byte states and both values of the random bit.
///
/// Wall sites (bit 7) reverse every particle; states with the rest bit (bit 6) set never occur
/// (lattices with it are refused) and map to themselves.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CollisionTable {
    /// 512 entries, indexed by `(state << 1) | chirality`.
    pub entries: Vec<u8>,
}

impl CollisionTable {
    /// Generates the table of `rules` from the conservation laws.
    pub fn new(rules: RuleSet) -> Self {
        let mut entries = vec![0u8; 512];
        for s in 0..=255u8 {
            for r in 0..2u8 {
                entries[(usize::from(s) << 1) | usize::from(r)] = collide_state(rules, s, r);
            }
        }
        Self { entries }
    }

    /// Post-collision state of `state` with chirality bit `chirality` (0 or 1).
    #[inline(always)]
    pub fn apply(&self, state: u8, chirality: u32) -> u8 {
        self.entries[(usize::from(state) << 1) | (chirality & 1) as usize]
    }
}

/// States sharing particle number and momentum with `s` (including `s`), ascending.
pub fn collision_group(s: u8) -> Vec<u8> {
    let key = invariants(s);
    (0..64u8).filter(|&t| invariants(t) == key).collect()
}

fn collide_state(rules: RuleSet, s: u8, r: u8) -> u8 {
    if s & WALL != 0 {
        return reverse(s);
    }
    if s & crate::REST != 0 {
        return s;
    }
    let group = collision_group(s);
    let (n, px, py) = invariants(s);
    let allowed = match rules {
        RuleSet::Full => group.len() > 1,
        RuleSet::FhpI => group.len() > 1 && px == 0 && py == 0 && (n == 2 || n == 3),
    };
    if !allowed {
        return s;
    }
    match group.len() {
        2 => group[0] ^ group[1] ^ s,
        // Three states of zero momentum: a rotation by +-60 degrees maps the group onto itself;
        // chirality 1 rotates clockwise (direction k -> k+1), 0 counter-clockwise.
        _ => {
            let out = if r == 1 { rotate_cw(s) } else { rotate_ccw(s) };
            debug_assert!(group.contains(&out) && out != s);
            out
        }
    }
}

/// WGSL `fhp_collide(s: array<u32, 6>, r: u32, wall: u32, full: bool) -> array<u32, 6>`: the
/// GPU twin of [`collide_bits`] on `u32` words (`full` selects the full rule set), used by
/// the bit-plane step kernel.
pub const COLLIDE_WGSL: &str = simkit_backend::wgsl!("collide.wgsl");

/// The collision of one word of sites as boolean logic, bit-parallel: bit `b` of `s[d]` is
/// direction `d + 1` of site `b`, of `r` its chirality bit, of `wall` its wall flag. `FULL`
/// selects [`RuleSet::Full`], else [`RuleSet::FhpI`]. Site by site it equals the
/// [`CollisionTable`] of the rule set (the multi-spin backend uses `u64` words, the GPU
/// twin `fhp_collide` of `shaders/collide.wgsl` `u32` words).
#[inline(always)]
pub fn collide_bits<W, const FULL: bool>(s: [W; 6], r: W, wall: W) -> [W; 6]
where
    W: Copy
        + Default
        + BitAnd<Output = W>
        + BitOr<Output = W>
        + BitXor<Output = W>
        + Not<Output = W>,
{
    let [a, b, c, d, e, f] = s;
    let (p1, p2, p3) = (a & d, b & e, c & f);
    let (z1, z2, z3) = (!(a | d), !(b | e), !(c | f));
    let two = (p1 & z2 & z3) | (p2 & z1 & z3) | (p3 & z1 & z2);
    let tri = (a ^ b) & (b ^ c) & (c ^ d) & (d ^ e) & (e ^ f);
    let zero = W::default();
    let (rot, flip1, flip2, flip3) = if FULL {
        let four = (p1 & p2 & z3) | (p1 & p3 & z2) | (p2 & p3 & z1);
        // A head-on pair with a spectator on axis X moves to the third axis.
        let s1 = (a ^ d) & ((p2 & z3) | (p3 & z2));
        let s2 = (b ^ e) & ((p1 & z3) | (p3 & z1));
        let s3 = (c ^ f) & ((p1 & z2) | (p2 & z1));
        (two | tri | four, s2 | s3, s1 | s3, s1 | s2)
    } else {
        (two | tri, zero, zero, zero)
    };
    // Rotation clockwise (chirality 1): new direction k holds old k - 1.
    let cw = [f, a, b, c, d, e];
    let ccw = [b, c, d, e, f, a];
    let flips = [flip1, flip2, flip3, flip1, flip2, flip3];
    let rev = [d, e, f, a, b, c];
    let mut out = [zero; 6];
    for k in 0..6 {
        let rotated = (r & cw[k]) | (!r & ccw[k]);
        let fluid = (rot & rotated) | (!rot & (s[k] ^ flips[k]));
        out[k] = (wall & rev[k]) | (!wall & fluid);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The source's table, transcribed as pairs and triples of exchanged states.
    fn source_changes(s: u8, r: u8) -> u8 {
        let triples: [[u8; 3]; 2] = [[9, 18, 36], [27, 54, 45]];
        for t in triples {
            if let Some(pos) = t.iter().position(|&x| x == s) {
                // Within each triple the states are successive clockwise rotations.
                return if r == 1 {
                    t[(pos + 1) % 3]
                } else {
                    t[(pos + 2) % 3]
                };
            }
        }
        let pairs: [(u8, u8); 7] = [
            (21, 42),
            (11, 38),
            (13, 22),
            (19, 37),
            (25, 52),
            (26, 44),
            (41, 50),
        ];
        for (a, b) in pairs {
            if s == a {
                return b;
            }
            if s == b {
                return a;
            }
        }
        s
    }

    #[test]
    fn full_table_matches_the_source() {
        let t = CollisionTable::new(RuleSet::Full);
        for s in 0..64u8 {
            for r in 0..2u8 {
                assert_eq!(
                    t.apply(s, r.into()),
                    source_changes(s, r),
                    "state {s} bit {r}"
                );
            }
        }
    }

    #[test]
    fn fhp1_table_is_the_two_and_three_body_subset() {
        let t = CollisionTable::new(RuleSet::FhpI);
        for s in 0..64u8 {
            for r in 0..2u8 {
                let want = if [9, 18, 36, 21, 42].contains(&s) {
                    source_changes(s, r)
                } else {
                    s
                };
                assert_eq!(t.apply(s, r.into()), want, "state {s} bit {r}");
            }
        }
    }

    #[test]
    fn walls_bounce_back_and_tables_conserve() {
        for rules in [RuleSet::FhpI, RuleSet::Full] {
            let t = CollisionTable::new(rules);
            for s in 0..64u8 {
                for r in 0..2u32 {
                    let w = t.apply(s | WALL, r);
                    let want = (0..6)
                        .filter(|k| s & (1 << k) != 0)
                        .fold(WALL, |acc, k| acc | (1 << ((k + 3) % 6)));
                    assert_eq!(w, want, "wall state {s}");
                    assert_eq!(invariants(t.apply(s, r)), invariants(s));
                }
            }
        }
        // Source examples: 1 -> 8, 7 (1,2,3) -> 56 (4,5,6).
        assert_eq!(reverse(1 | WALL), 8 | WALL);
        assert_eq!(reverse(7 | WALL), 56 | WALL);
    }
}
