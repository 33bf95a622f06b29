#!/bin/sh
# Times LAMMPS (1 MPI rank, and 2 ranks when mpirun exists) on benches/peers/in.lj and
# simkit's examples/lj_fluid (CPU, f64, 1 and 2 rayon threads) on the same system, the
# runs alternating over several rounds on this machine, and prints the median atom-steps/s
# of each with the ratios, the date and the load.
# Usage (from the repository root): sh benches/peers/md_vs_lammps.sh [ROUNDS] [STEPS]
# Defaults: 5 rounds of 100 steps (the window of LAMMPS's in.lj). Both sides start from
# the FCC lattice and count the time stepping only (LAMMPS's "Loop time"; lj_fluid's
# stepping time). Needs `lmp` (Debian package `lammps`: installed with apt-get when
# missing and running as root); quiet machines only: check `uptime` first. Shared
# functions: benches/peers/lib.sh.
set -e
. "$(dirname "$0")/lib.sh"
ROUNDS=${1:-5}
STEPS=${2:-100}
N=$MD_N
lammps_ensure || exit 1
MPI=0
if have_mpirun; then MPI=1; fi
cargo build --release --example lj_fluid >/dev/null 2>&1
L1="" L2="" S1="" S2=""
LOAD0=$(cut -d' ' -f1-3 /proc/loadavg)
r=1
while [ "$r" -le "$ROUNDS" ]; do
  L1="$L1 $(lammps_rate "$MD_DECK" "$N" "$STEPS" 1)"
  S1="$S1 $(lj_fluid_rate 1 "$STEPS")"
  if [ "$MPI" -eq 1 ]; then L2="$L2 $(lammps_rate "$MD_DECK" "$N" "$STEPS" 2)"; fi
  S2="$S2 $(lj_fluid_rate 2 "$STEPS")"
  echo "round $r/$ROUNDS done" >&2
  r=$((r + 1))
done
LOAD1=$(cut -d' ' -f1-3 /proc/loadavg)
mL1=$(echo "$L1" | median)
mS1=$(echo "$S1" | median)
mS2=$(echo "$S2" | median)
if [ "$MPI" -eq 1 ]; then mL2=$(echo "$L2" | median); else mL2=nan; fi
echo "date: $(date -u '+%Y-%m-%d %H:%M UTC'); $(nproc) cores; load before $LOAD0, after $LOAD1"
echo "in.lj, $N atoms, $STEPS steps, $ROUNDS alternating rounds; median atom-steps/s:"
printf '%-34s %14s %14s\n' "code" "1 core" "2 cores"
printf '%-34s %14s %14s\n' "LAMMPS lj/cut (1 rank / mpirun -np 2)" "$mL1" "$mL2"
printf '%-34s %14s %14s\n' "simkit md lj_fluid (f64, threads)" "$mS1" "$mS2"
awk -v a="$mS1" -v b="$mL1" -v c="$mS2" -v d="$mL2" 'BEGIN {
  r2 = (d == "nan" || d == 0) ? "n/a" : sprintf("%.2f", c / d);
  printf "ratio simkit/LAMMPS: 1 core %.2f, 2 cores %s\n", a / b, r2 }'
echo "samples: LAMMPS 1:$L1 | LAMMPS 2:$L2 | simkit 1:$S1 | simkit 2:$S2"
