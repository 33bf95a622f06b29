#!/bin/sh
# Strong scaling of the distributed runs on this machine, 1 -> 2 MPI ranks (one rayon thread
# per rank), next to LAMMPS's own 1 -> 2 rank scaling on the granular deck: the runs of each
# problem alternate (1 rank, 2 ranks, 1 rank, ...) over several rounds and the medians give
# the parallel efficiency t(1) / (2 t(2)), printed with the date and the load.
# Usage (from the repository root): sh benches/peers/mpi_scaling.sh [ROUNDS]
# Default 3 rounds: rd Gray–Scott f64 4096^2 (100 steps), lattice-gas FHP-I 4096^2 (400
# steps), pp-coulomb f64 N = 50,000 (3 steps), dem granular pile N = 200,000 (200 steps),
# md in.lj N = 32,000 (200 steps) through examples/mpi_scaling (built here with
# the `mpi` feature), and LAMMPS on benches/peers/dem_gran3d.lmp (2000 steps; skipped
# without `lmp`). Needs mpirun (Debian: openmpi-bin libopenmpi-dev libclang-dev); quiet
# machines only: check `uptime` first. Shared functions: benches/peers/lib.sh.
set -e
. "$(dirname "$0")/lib.sh"
ROUNDS=${1:-3}
if ! have_mpirun; then
  echo "mpirun not found: install OpenMPI (apt-get install openmpi-bin libopenmpi-dev libclang-dev)" >&2
  exit 1
fi
cargo build --release --features mpi --example mpi_scaling >/dev/null 2>&1
EXE=target/release/examples/mpi_scaling
load_before=$(cut -d' ' -f1-3 /proc/loadavg)

# seconds RANKS ARGS...: one run of the driver; prints its timed seconds.
seconds() {
  _p=$1
  shift
  RAYON_NUM_THREADS=1 mpirun --allow-run-as-root --oversubscribe -np "$_p" -x RAYON_NUM_THREADS \
    "$EXE" "$@" | sed -n 's/.*seconds=\([^ ]*\).*/\1/p'
}

row() {
  # row LABEL ARGS...: alternates 1 and 2 ranks; prints a table row.
  _label=$1
  shift
  _t1=""
  _t2=""
  for _r in $(seq "$ROUNDS"); do
    _t1="$_t1 $(seconds 1 "$@")"
    _t2="$_t2 $(seconds 2 "$@")"
  done
  _m1=$(echo "$_t1" | median)
  _m2=$(echo "$_t2" | median)
  _eff=$(awk -v a="$_m1" -v b="$_m2" 'BEGIN {printf "%.2f", a / (2 * b)}')
  echo "| $_label | $_m1 s | $_m2 s | **$_eff** | 1 rank:$_t1; 2 ranks:$_t2 |"
}

echo "# Strong scaling 1 -> 2 ranks, $(date -u '+%Y-%m-%d %H:%M UTC'), $(nproc) cores," \
  "$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $ROUNDS rounds"
echo
echo "| problem | 1 rank | 2 ranks | efficiency | samples (s) |"
echo "|---|---|---|---|---|"
row "rd Gray–Scott f64 4096^2, 100 steps" --steps 100 rd --size 4096
row "lattice-gas FHP-I 4096^2, 400 steps" --steps 400 lattice-gas --size 4096
row "pp-coulomb f64 N = 50,000, 3 steps" --steps 3 --warmup 1 pp-coulomb --n 50000
row "dem granular pile N = 200,000, 200 steps" --steps 200 dem --nx 100 --ny 100 --nz 20
row "md in.lj N = 32,000, 200 steps" --steps 200 md --cells 20
if lammps_ensure 2>/dev/null; then
  _l1=""
  _l2=""
  for _r in $(seq "$ROUNDS"); do
    _l1="$_l1 $(lammps_rate "$DEM_DECK" "$DEM_N" 2000 1)"
    _l2="$_l2 $(lammps_rate "$DEM_DECK" "$DEM_N" 2000 2)"
  done
  _m1=$(echo "$_l1" | median)
  _m2=$(echo "$_l2" | median)
  _eff=$(awk -v a="$_m1" -v b="$_m2" 'BEGIN {printf "%.2f", b / (2 * a)}')
  echo "| LAMMPS gran/hooke $DEM_N particles, 2000 steps (atom-steps/s) | $_m1 | $_m2 | **$_eff** | 1 rank:$_l1; 2 ranks:$_l2 |"
else
  echo "| LAMMPS granular deck | skipped: no lmp | | | |"
fi
echo
echo "load average before: $load_before; after: $(cut -d' ' -f1-3 /proc/loadavg)"
