#!/bin/sh
# Times LAMMPS (1 MPI rank, and 2 ranks when mpirun exists) on benches/peers/in.lj and
# simkit's examples/lj_fluid (CPU, f64, 1 and 2 rayon threads) on the same system, the
# runs alternating over several rounds on this machine, and prints the median atom-steps/s
# of each with the ratios, the date and the load.
# Usage (from the repository root): sh benches/peers/md_vs_lammps.sh [ROUNDS] [STEPS]
# Defaults: 5 rounds of 100 steps (the window of LAMMPS's in.lj). Both sides start from
# the FCC lattice and count the time stepping only (LAMMPS's "Loop time"; lj_fluid's
# stepping time). Needs `lmp` (Debian package `lammps`: installed with apt-get when
# missing and running as root); quiet machines only: check `uptime` first.
set -e
ROUNDS=${1:-5}
STEPS=${2:-100}
N=32000
deck=benches/peers/in.lj
if ! command -v lmp >/dev/null 2>&1; then
  if [ "$(id -u)" -eq 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "lmp not found: installing Debian's lammps package" >&2
    apt-get install -y lammps >/dev/null
  else
    # A ratio counts only against a peer run on this machine in this session.
    echo "lmp not found: install LAMMPS (apt-get install lammps) to compare side by side" >&2
    exit 1
  fi
fi
MPI=0
if command -v mpirun >/dev/null 2>&1; then MPI=1; fi
cargo build --release --example lj_fluid >/dev/null 2>&1
lammps_rate() {
  # $1 = MPI ranks; prints atom-steps/s from the "Loop time of T on P procs" line.
  log=$(mktemp)
  if [ "$1" -eq 1 ]; then
    lmp -in "$deck" -var steps "$STEPS" -log none -screen "$log" >/dev/null 2>&1
  else
    mpirun --allow-run-as-root --oversubscribe -np "$1" lmp -in "$deck" -var steps "$STEPS" \
      -log none -screen "$log" >/dev/null 2>&1
  fi
  awk -v n=$N -v s="$STEPS" '/^Loop time/ {printf "%.6g\n", n * s / $4}' "$log"
  rm -f "$log"
}
simkit_rate() {
  # $1 = rayon threads; lj_fluid prints "<rate> atom-steps/s (...)".
  RAYON_NUM_THREADS=$1 target/release/examples/lj_fluid --steps "$STEPS" --thermo-every 0 |
    awk '{for (i = 2; i <= NF; i++) if ($i == "atom-steps/s") print $(i - 1)}'
}
median() {
  tr ' ' '\n' | grep . | sort -g |
    awk '{a[NR] = $1} END {if (NR == 0) print "nan"; else if (NR % 2) print a[(NR + 1) / 2];
      else print (a[NR / 2] + a[NR / 2 + 1]) / 2}'
}
L1="" L2="" S1="" S2=""
LOAD0=$(cut -d' ' -f1-3 /proc/loadavg)
r=1
while [ "$r" -le "$ROUNDS" ]; do
  L1="$L1 $(lammps_rate 1)"
  S1="$S1 $(simkit_rate 1)"
  if [ "$MPI" -eq 1 ]; then L2="$L2 $(lammps_rate 2)"; fi
  S2="$S2 $(simkit_rate 2)"
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
