#!/bin/sh
# Runs LAMMPS (1 and 2 MPI ranks) on benches/peers/dem_gran3d.lmp and the simkit dem bench
# on the same scene (CPU, 1 and 2 threads), and prints particle-steps/s and the ratios.
# Usage (from the repository root): sh benches/peers/dem_vs_lammps.sh [STEPS]
# Without STEPS: the deck's 2000 steps, dem timed by the criterion bench. With STEPS: that
# many steps on both sides, dem timed by `examples/dem_box_timer` (one run from the start).
# Needs `lmp` (Debian package `lammps`) and `mpirun` on PATH for the LAMMPS half.
set -e
N=20000
STEPS=${1:-2000}
deck=benches/peers/dem_gran3d.lmp
lammps_rate() {
  # $1 = number of MPI ranks; prints particle-steps/s from the "Loop time" line.
  log=$(mktemp)
  if [ "$1" -eq 1 ]; then
    lmp -in "$deck" -var steps "$STEPS" -log none -screen "$log" >/dev/null 2>&1
  else
    mpirun --allow-run-as-root --oversubscribe -np "$1" lmp -in "$deck" -var steps "$STEPS" -log none -screen "$log" >/dev/null 2>&1
  fi
  awk -v n=$N -v s=$STEPS '/^Loop time/ {printf "%.4g\n", n * s / $4}' "$log"
  rm -f "$log"
}
if command -v lmp >/dev/null 2>&1; then
  L1=$(lammps_rate 1)
  L2=$(lammps_rate 2)
else
  # A ratio counts only against a peer run on this machine in this session.
  echo "lmp not found: install LAMMPS (apt-get install lammps) to compare side by side" >&2
  exit 1
fi
if [ -z "$1" ]; then
  out=$(mktemp)
  cargo bench --bench dem -- dem_box3d_20000/cpu 2>/dev/null | tee "$out" >/dev/null
  # criterion prints "thrpt: [low unit mid unit high unit]" (1 elem = 1 particle-step); the
  # "change" block below it also has a "thrpt:" line, in percent, which is skipped.
  rates=$(awk '/thrpt:/ && /elem\/s/ {
    m = ($5 ~ /^G/) ? 1e9 : ($5 ~ /^M/) ? 1e6 : ($5 ~ /^K/) ? 1e3 : 1; print $4 * m }' "$out")
  D1=$(echo "$rates" | sed -n 1p)
  D2=$(echo "$rates" | sed -n 2p)
  rm -f "$out"
else
  cargo build --release --example dem_box_timer 2>/dev/null
  timer() {
    RAYON_NUM_THREADS=$1 target/release/examples/dem_box_timer --steps "$STEPS" |
      awk '{for (i = 1; i <= NF; i++) if ($i == "particle-steps/s") print $(i - 1)}'
  }
  D1=$(timer 1)
  D2=$(timer 2)
fi
echo "window: $STEPS steps"
echo "LAMMPS gran/hooke: 1 rank $L1, 2 ranks $L2 particle-steps/s"
echo "simkit dem (f64): 1 thread $D1, 2 threads $D2 particle-steps/s"
awk -v a="$D1" -v b="$L1" -v c="$D2" -v d="$L2" \
  'BEGIN {printf "ratio dem/LAMMPS: 1 core %.2f, 2 cores %.2f (target >= 1.5 on 2 cores)\n", a / b, c / d}'
