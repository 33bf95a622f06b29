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
# ARGS, e.g. `-var nx 100` or `-sf opt`) with RANKS MPI ranks (1 = no mpirun) of one OpenMP
# thread each; prints ATOMS * STEPS / (the "Loop time" seconds): atom-steps/s.
lammps_rate() {
  _log=$(mktemp)
  _n=$2 _steps=$3
  lammps_run "$_log" "$@"
  awk -v n="$_n" -v s="$_steps" '/^Loop time/ {printf "%.6g\n", n * s / $4}' "$_log"
  rm -f "$_log"
}

# lammps_run LOG DECK ATOMS STEPS RANKS [ARGS...]: runs LAMMPS as lammps_rate does, its screen
# output into LOG. The binary is $LMP_BIN (default `lmp`, Debian's).
lammps_run() {
  _out=$1 _deck=$2 _steps=$4 _np=$5
  shift 5
  if [ "$_np" -eq 1 ]; then
    OMP_NUM_THREADS=1 "${LMP_BIN:-lmp}" -in "$_deck" -var steps "$_steps" "$@" -log none \
      -screen "$_out" >/dev/null 2>&1
  else
    OMP_NUM_THREADS=1 mpirun --allow-run-as-root --oversubscribe -np "$_np" -x OMP_NUM_THREADS \
      "${LMP_BIN:-lmp}" -in "$_deck" -var steps "$_steps" "$@" -log none -screen "$_out" \
      >/dev/null 2>&1
  fi
}

# lammps_neigh_rate RANKS N BUILDS: LAMMPS's neighbour-list build on benches/peers/neigh.lmp
# (N random points, BUILDS builds); prints pairs x builds / the "Neigh" seconds (the average
# over ranks of the timing breakdown): pairs/s.
lammps_neigh_rate() {
  _log=$(mktemp)
  lammps_run "$_log" benches/peers/neigh.lmp "$2" "$3" "$1" -var n "$2"
  awk -F'|' '/^Neigh / {t = $3 + 0}
    /^Total # of neighbors/ {split($0, a, "= "); p = a[2] + 0}
    /^Neighbor list builds/ {split($0, a, "= "); b = a[2] + 0}
    END {if (t > 0 && p > 0 && b > 0) printf "%.6g\n", p * b / t}' "$_log"
  rm -f "$_log"
}

# The in.lj system for GROMACS (benches/peers/gromacs: units and settings in lj.mdp).
GMX_DIR=benches/peers/gromacs

# gromacs_prepare GMX DIR: writes in.lj's FCC lattice (20^3 cells, density 0.8442, in nm)
# to DIR/conf.gro and runs `GMX grompp` into DIR/lj.tpr; fails (output in DIR/grompp.log)
# when grompp does.
gromacs_prepare() {
  mkdir -p "$2" || return 1
  awk 'BEGIN { c = 20; a = (4 / 0.8442) ^ (1 / 3); n = 0
    split("0 0.5 0.5 0", bx, " "); split("0 0.5 0 0.5", by, " "); split("0 0 0.5 0.5", bz, " ")
    print "in.lj FCC lattice: 20^3 cells at reduced density 0.8442 (sigma = 1 nm)"
    print 4 * c * c * c
    for (k = 0; k < c; k++) for (j = 0; j < c; j++) for (i = 0; i < c; i++)
      for (b = 1; b <= 4; b++) { n++
        printf "%5d%-5s%5s%5d%12.7f%12.7f%12.7f\n", n % 100000, "LJ", "LJ", n % 100000,
          (i + bx[b]) * a, (j + by[b]) * a, (k + bz[b]) * a }
    printf "%12.7f%12.7f%12.7f\n", c * a, c * a, c * a }' >"$2/conf.gro"
  _here=$(pwd)
  (cd "$2" && GMX_MAXBACKUP=-1 "$1" grompp -f "$_here/$GMX_DIR/lj.mdp" -p "$_here/$GMX_DIR/lj.top" \
    -c conf.gro -o lj.tpr -po mdout.mdp >grompp.log 2>&1)
}

# gromacs_energy0 GMX DIR: the potential energy per atom at step 0 of DIR/lj.tpr (kJ/mol,
# which is epsilon: the same number as the reduced energy), or nothing.
gromacs_energy0() {
  (cd "$2" && GMX_MAXBACKUP=-1 "$1" mdrun -s lj.tpr -deffnm e0 -nsteps 0 -ntmpi 1 -ntomp 1 \
    >e0.out 2>&1 && echo Potential | GMX_MAXBACKUP=-1 "$1" energy -f e0.edr -o e0.xvg \
    >>e0.out 2>&1) || return 0
  awk -v n="$MD_N" '!/^[#@]/ {e = $2} END {if (e != "") printf "%.7f\n", e / n}' "$2/e0.xvg"
}

# gromacs_rate GMX THREADS STEPS DIR: mdrun on DIR/lj.tpr, one thread-MPI rank with THREADS
# OpenMP threads (pinned), 2 x STEPS steps of which the second half is timed (-resethway);
# prints atom-steps/s from the "Performance" line (ns/day at dt = 0.005 ps).
gromacs_rate() {
  (cd "$4" && GMX_MAXBACKUP=-1 OMP_NUM_THREADS="$2" "$1" mdrun -s lj.tpr -deffnm run -ntmpi 1 \
    -ntomp "$2" -pin on -nb cpu -nsteps $((2 * $3)) -resethway -noconfout >run.out 2>&1) ||
    return 0
  awk -v n="$MD_N" '/^Performance:/ {printf "%.6g\n", n * $2 * 1000 / 0.005 / 86400}' "$4/run.log"
}

# dem_timer_rate THREADS STEPS [ARGS...]: simkit dem on the LAMMPS comparison box
# (examples/dem_box_timer, built; ARGS e.g. `--nx 100`), CPU f64; prints particle-steps/s.
dem_timer_rate() {
  _threads=$1 _steps=$2
  shift 2
  RAYON_NUM_THREADS=$_threads target/release/examples/dem_box_timer --steps "$_steps" "$@" 2>/dev/null |
    awk '{for (i = 2; i <= NF; i++) if ($i == "particle-steps/s") print $(i - 1)}'
}

# lj_fluid_rate THREADS STEPS [ARGS...]: simkit md on in.lj's system (examples/lj_fluid,
# built), CPU f64 (or `--f32` in ARGS), stepping time only; prints atom-steps/s.
lj_fluid_rate() {
  _threads=$1 _steps=$2
  shift 2
  RAYON_NUM_THREADS=$_threads target/release/examples/lj_fluid --steps "$_steps" --thermo-every 0 \
    "$@" 2>/dev/null | awk '{for (i = 2; i <= NF; i++) if ($i == "atom-steps/s") print $(i - 1)}'
}

# peer_cache: the folder outside the repository where peers built from source live
# ($SIMKIT_PEER_CACHE, else $XDG_CACHE_HOME/simkit-peers, else ~/.cache/simkit-peers).
peer_cache() {
  echo "${SIMKIT_PEER_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/simkit-peers}"
}

# debian_source PACKAGE DIR: unpacks Debian's source package PACKAGE into DIR (once; as root,
# adding the deb-src type to deb.debian.org's entries and installing dpkg-dev when missing)
# and prints the absolute path of the unpacked tree; says why on stderr and fails otherwise.
debian_source() {
  mkdir -p "$2" || return 1
  _src=$(find "$2" -mindepth 1 -maxdepth 1 -type d -name "$1-*" | head -n 1)
  if [ -z "$_src" ]; then
    if [ "$(id -u)" -eq 0 ]; then
      _f=/etc/apt/sources.list.d/debian.sources
      if [ -f "$_f" ] && grep -q '^Types: deb$' "$_f"; then
        sed -i 's/^Types: deb$/Types: deb deb-src/' "$_f"
      fi
      command -v dpkg-source >/dev/null 2>&1 || apt-get install -y -q dpkg-dev >/dev/null 2>&1
      apt-get update -q >/dev/null 2>&1
    fi
    echo "apt-get source $1 (into $2)" >&2
    (cd "$2" && apt-get source -q "$1" >/dev/null 2>&1) ||
      { echo "apt-get source $1 failed (deb-src entries? dpkg-dev?)" >&2; return 1; }
    _src=$(find "$2" -mindepth 1 -maxdepth 1 -type d -name "$1-*" | head -n 1)
    [ -n "$_src" ] || { echo "no $1-* folder in $2 after apt-get source" >&2; return 1; }
  fi
  (cd "$_src" && pwd)
}
