#!/bin/sh
# Runs LAMMPS (1 and 2 MPI ranks) on benches/peers/dem_gran3d.lmp and the simkit dem bench
# on the same scene (CPU, 1 and 2 threads), and prints particle-steps/s and the ratios.
# Usage (from the repository root): [MODEL=history] sh benches/peers/dem_vs_lammps.sh [STEPS]
# Without STEPS: the deck's 2000 steps, dem timed by the criterion bench. With STEPS: that
# many steps on both sides, dem timed by `examples/dem_box_timer` (one run from the start).
# MODEL=history compares the same physics (LAMMPS gran/hooke/history + nve/sphere, simkit
# LinearHistory with rotation; always through dem_box_timer); the default, viscous, is the
# old "no rotation" comparison (LAMMPS gran/hooke, simkit without rotation).
# Needs `lmp` (Debian package `lammps`: installed with apt-get when missing and running as
# root) and `mpirun` on PATH for the LAMMPS half. Shared functions: benches/peers/lib.sh.
set -e
. "$(dirname "$0")/lib.sh"
N=$DEM_N
STEPS=${1:-2000}
MODEL=${MODEL:-viscous}
case "$MODEL" in
  history) LMODEL=hooke/history ;;
  viscous) LMODEL=hooke ;;
  *) echo "MODEL must be history or viscous, not $MODEL" >&2; exit 2 ;;
esac
lammps_ensure || exit 1
L1=$(lammps_rate "$DEM_DECK" "$N" "$STEPS" 1 -var model "$LMODEL")
L2=$(lammps_rate "$DEM_DECK" "$N" "$STEPS" 2 -var model "$LMODEL")
if [ -z "${1:-}" ] && [ "$MODEL" = viscous ]; then
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
  D1=$(dem_timer_rate 1 "$STEPS" --model "$MODEL")
  D2=$(dem_timer_rate 2 "$STEPS" --model "$MODEL")
fi
echo "window: $STEPS steps"
echo "LAMMPS gran/$LMODEL: 1 rank $L1, 2 ranks $L2 particle-steps/s"
echo "simkit dem (f64, $MODEL): 1 thread $D1, 2 threads $D2 particle-steps/s"
awk -v a="$D1" -v b="$L1" -v c="$D2" -v d="$L2" \
  'BEGIN {printf "ratio dem/LAMMPS: 1 core %.2f, 2 cores %.2f (target >= 2 on 2 cores, in both windows)\n", a / b, c / d}'
