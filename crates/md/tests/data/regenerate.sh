#!/bin/sh
# Regenerates the LAMMPS reference data of crates/md/tests/lammps.rs.
#
# Needs LAMMPS (Debian: `apt-get install lammps`, binary `lmp`; these files were made with
# "29 Sep 2021 - Update 2"). Each deck builds its configuration deterministically with
# LAMMPS itself (create_atoms on an FCC lattice, displace_atoms random and velocity create
# with fixed seeds, `loop geom` so the result does not depend on the process count),
# writes it, reads it back and evaluates it with `run 0`; the dump holds every atom's
# type, position, velocity and force at full precision (%.17g), the .thermo file the box,
# potential and kinetic energy and the pressure (total and virial part).
set -eu
cd "$(dirname "$0")"
LMP=${LMP:-lmp}
for deck in lj_liquid three_species morse yukawa mie buck wca; do
    "$LMP" -in "$deck.in" -log none -screen none
    rm -f "$deck.data"
done
# The step-0 thermo of the in.lj melt (E_pair per atom, Press), copied into
# tests/physics.rs by hand.
"$LMP" -in lj_melt.in -log none | grep -A1 '^Step'
