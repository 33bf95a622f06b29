# Shared functions of the peer comparison scripts in benches/peers (POSIX sh; source it from
# the repository root: `. benches/peers/lib.sh`). Used by dem_vs_lammps.sh, md_vs_lammps.sh
# and side_by_side.sh.

DEM_DECK=benches/peers/dem_gran3d.lmp
DEM_N=20000
MD_DECK=benches/peers/in.lj
MD_N=32000

# Reads numbers separated by blanks or newlines on stdin; prints their median ("nan" if none).
median() {
  tr ' ' '\n' | grep . | sort -g |
    awk '{a[NR] = $1} END {if (NR == 0) print "nan"; else if (NR % 2) print a[(NR + 1) / 2];
      else print (a[NR / 2] + a[NR / 2 + 1]) / 2}'
}

# Succeeds when `lmp` is on PATH, installing Debian's lammps package first when it is missing
# and this is root with apt-get; otherwise says why on stderr and fails.
lammps_ensure() {
  if command -v lmp >/dev/null 2>&1; then return 0; fi
  if [ "$(id -u)" -eq 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "lmp not found: installing Debian's lammps package" >&2
    apt-get install -y lammps >/dev/null 2>&1 ||
      { apt-get update >/dev/null 2>&1 && apt-get install -y lammps >/dev/null 2>&1; }
  fi
  if command -v lmp >/dev/null 2>&1; then return 0; fi
  # A ratio counts only against a peer run on this machine in this session.
  echo "lmp not found: install LAMMPS (apt-get install lammps) to compare side by side" >&2
  return 1
}

# Succeeds when `mpirun` is on PATH (LAMMPS on 2 ranks).
have_mpirun() {
  command -v mpirun >/dev/null 2>&1
}

# lammps_rate DECK ATOMS STEPS RANKS [ARGS...]: runs LAMMPS on DECK (`-var steps STEPS`, then
# ARGS, e.g. `-var nx 100`) with RANKS MPI ranks (1 = no mpirun); prints ATOMS * STEPS / (the
# "Loop time" seconds): atom-steps/s.
lammps_rate() {
  _log=$(mktemp)
  _deck=$1 _n=$2 _steps=$3 _np=$4
  shift 4
  if [ "$_np" -eq 1 ]; then
    lmp -in "$_deck" -var steps "$_steps" "$@" -log none -screen "$_log" >/dev/null 2>&1
  else
    mpirun --allow-run-as-root --oversubscribe -np "$_np" lmp -in "$_deck" -var steps "$_steps" \
      "$@" -log none -screen "$_log" >/dev/null 2>&1
  fi
  awk -v n="$_n" -v s="$_steps" '/^Loop time/ {printf "%.6g\n", n * s / $4}' "$_log"
  rm -f "$_log"
}

# dem_timer_rate THREADS STEPS [ARGS...]: simkit dem on the LAMMPS comparison box
# (examples/dem_box_timer, built; ARGS e.g. `--nx 100`), CPU f64; prints particle-steps/s.
dem_timer_rate() {
  _threads=$1 _steps=$2
  shift 2
  RAYON_NUM_THREADS=$_threads target/release/examples/dem_box_timer --steps "$_steps" "$@" 2>/dev/null |
    awk '{for (i = 2; i <= NF; i++) if ($i == "particle-steps/s") print $(i - 1)}'
}

# lj_fluid_rate THREADS STEPS: simkit md on in.lj's system (examples/lj_fluid, built), CPU
# f64, stepping time only; prints atom-steps/s.
lj_fluid_rate() {
  RAYON_NUM_THREADS=$1 target/release/examples/lj_fluid --steps "$2" --thermo-every 0 2>/dev/null |
    awk '{for (i = 2; i <= NF; i++) if ($i == "atom-steps/s") print $(i - 1)}'
}
