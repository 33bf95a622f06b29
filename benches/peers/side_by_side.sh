#!/bin/sh
# Side-by-side speed: simkit next to the peer programs it is compared with, on this machine,
# in this session, the runs alternating, and one markdown table of medians and ratios.
#
# Usage (from anywhere in the repository):
#   sh benches/peers/side_by_side.sh [--rounds R] [--quick] [--only LIST] [--peers DIR]
#     --rounds R   alternating rounds (default 3); each round runs the peer and the simkit
#                  measurement of every row once, the order swapped every other round
#     --quick      tiny sizes, to check that every row runs: the figures are NOT comparable
#                  with anything (the table says so)
#     --only LIST  comma-separated rows: rd,neighbor,dem,md,lattice-gas,pp-coulomb
#     --peers DIR  the peer programs (default ../shared/peers, or $SIMKIT_PEERS)
#     --no-build   use the simkit examples already in target/release (the table says so)
#   The table is printed and written to target/side_by_side/<UTC date>.md.
#
# Rows (simkit / peer; the rate of each side is the median over the rounds):
#   rd           py-pde Gray-Scott 512^2 (compiled Euler stepper, JIT excluded) vs simkit rd
#                Gray-Scott f64 512^2, 2 threads; cell updates/s; and a C stencil of our own
#                (benches/peers/gray_scott.c: f64, -O3 -march=native, OpenMP over blocks
#                of rows and columns, 2 threads) vs simkit rd on the same scene at 512^2 and 4096^2, each
#                run's sums of u, v and v^2 compared with simkit's after the same steps
#   neighbor     kiddo 6 (ImmutableKdTree build + per-point within().unsorted().visit()
#                queries in tree order, rayon, 2 threads) vs simkit sorted cells (build + count
#                every pair, 2 threads), N = 1e6 uniform points at density 1, cutoff 2.5; pairs/s;
#                and list builds on the same points in a periodic cube, no skin: LAMMPS's
#                binned half-list build (the -march=native build below, benches/peers/neigh.lmp,
#                "Neigh" time of its breakdown; 1 rank and 2 MPI ranks) and freud's AABBQuery
#                (build + query to a NeighborList, 2 threads; benches/peers/freud_pairs.py) vs
#                the half list md and dem rebuild (BlockedHalfList: sort by cell, permute,
#                build; 1 and 2 threads), and simkit's VerletList (2 threads, no target: the
#                general list in the caller's particle order); unordered pairs/s
#   dem          LAMMPS (mpirun -np 2) vs simkit dem (2 threads) on
#                benches/peers/dem_gran3d.lmp, 20,000 spheres, the first 4000 steps and the
#                first 30,000 (the pile settles: dense contacts), and 1,000,000 spheres (100^3
#                lattice, 200 steps), and the first window on 1 core; particle-steps/s; two
#                models: the same physics (LAMMPS gran/hooke/history + nve/sphere vs simkit
#                LinearHistory with rotation, `dem_box_timer --model history`), and the old
#                "no rotation" rows (LAMMPS gran/hooke, which integrates rotation, vs simkit's
#                viscous friction without rotation)
#   md           LAMMPS lj/cut vs simkit md (examples/lj_fluid, f64) on benches/peers/in.lj,
#                32,000 atoms, 1 core and 2 cores; atom-steps/s. Peers: Debian's lmp (generic
#                x86-64 build, plain styles); LAMMPS built here with -O3 -march=native
#                (benches/peers/build_native.sh lammps) with each suffix (none, -sf opt, -sf omp,
#                -sf intel: mixed precision, its default; its `mode double` crashes when built
#                with GCC, and without an Intel compiler its kernels are not vectorised; MPI
#                ranks of one thread) and the best of them;
#                GROMACS 2022 in.lj (benches/peers/gromacs: the unit conversion is in lj.mdp)
#                built here with its widest SIMD (build_native.sh gromacs) and Debian's
#                SSE4.1 gmx, one rank of 1 and 2 OpenMP threads, mixed precision (GROMACS's
#                default), against simkit f64 and f32; the potential energy per atom at step 0
#                of GROMACS (mixed, and Debian's double-precision gmx_d) and of simkit printed
#   lattice-gas  STREAM-like triad (2 OpenMP threads) vs simkit lattice-gas lookup table at
#                16384^2 (2 threads), site updates/s x 2 bytes (one state byte read, one
#                written): % of the measured memory bandwidth; and the source's serial FHP
#                program vs simkit lattice-gas (automatic CPU method, 2 threads) at 1024^2
#   pp-coulomb   FMA-loop peak (2 OpenMP threads) vs simkit direct sum at N = 50,000 in f32
#                and f64 (interactions/s x 20 flops): % of peak; and the source's OpenMP
#                direct sum (2 threads) vs simkit f64 at N = 50,000; interactions/s
#
# What it installs when missing: py-pde into a venv at target/pypde and freud-analysis into
# target/freud (pip), Debian's lammps and gromacs packages (apt-get, as root), LAMMPS and
# GROMACS built for this CPU from Debian's source packages into a cache outside the
# repository (about 5 and 20 minutes on 2 cores, once; see build_native.sh), the kiddo
# peer (cargo, into target/peers/kiddo) and the C/C++ peers and our C stencil (gcc/g++ -O3
# -march=native, into target/peers). A peer that cannot be built or run is skipped with a
# line saying why. Peers are built and run from where they are; nothing of them is copied
# into the repository.
#
# Default sizes take about 27 minutes on a 2-core machine once the peers are built (the dem
# rows about half of it; `--only md,neighbor` about 12). Run it on a quiet machine (check
# `uptime`): the load before and after is in the table.

set -u
cd "$(dirname "$0")/../.." || exit 1
. benches/peers/lib.sh

ROUNDS=3
QUICK=0
NOBUILD=0
ONLY="rd,neighbor,dem,md,lattice-gas,pp-coulomb"
PEERS=${SIMKIT_PEERS:-../shared/peers}
while [ $# -gt 0 ]; do
  case "$1" in
    --rounds) ROUNDS=${2:-}; shift 2 ;;
    --quick) QUICK=1; shift ;;
    --only) ONLY=${2:-}; shift 2 ;;
    --peers) PEERS=${2:-}; shift 2 ;;
    --no-build) NOBUILD=1; shift ;;
    -h | --help) sed -n '2,/^$/p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "unknown argument: $1 (see --help)" >&2; exit 2 ;;
  esac
done
case "$ROUNDS" in '' | *[!0-9]*) echo "--rounds needs a positive integer" >&2; exit 2 ;; esac
[ "$ROUNDS" -ge 1 ] || { echo "--rounds needs a positive integer" >&2; exit 2; }
PEERS_ARG=$PEERS
PEERS=$(cd "$PEERS" 2>/dev/null && pwd) || PEERS=""

# Sizes: default (timed runs of about 2-5 s each on a 2-core machine) and --quick.
if [ "$QUICK" -eq 1 ]; then
  RD_N=64 RD_PEER_STEPS=50 RD_STEPS=200 CGS_RUNS="64:200 128:20"
  NB_N=20000 NB_REPS=3 KIDDO_REPS=1 NB_LMP_BUILDS=2
  DEM_STEPS=50 DEM_LONG_STEPS=100 DEM_BIG=10 DEM_BIG_STEPS=10
  MD_STEPS=10
  LG_N=1024 LG_STEPS=4 TRIAD_REPS=3
  FHP_N=128 FHP_STEPS=20
  PP_N=2000 PP_STEPS=1 FMA_ITERS=1000000
else
  RD_N=512 RD_PEER_STEPS=1000 RD_STEPS=8000 CGS_RUNS="512:4000 4096:60"
  NB_N=1000000 NB_REPS=15 KIDDO_REPS=3 NB_LMP_BUILDS=10
  DEM_STEPS=4000 DEM_LONG_STEPS=30000 DEM_BIG=100 DEM_BIG_STEPS=200
  MD_STEPS=500
  LG_N=16384 LG_STEPS=60 TRIAD_REPS=20
  FHP_N=1024 FHP_STEPS=100
  PP_N=50000 PP_STEPS=3 FMA_ITERS=20000000
fi

STAMP=$(date -u '+%Y-%m-%dT%H%MZ')
OUTDIR=target/side_by_side
PB=target/peers
mkdir -p "$OUTDIR" "$PB"
ROWS=$(mktemp)    # table rows, in order
SKIPS=$(mktemp)   # "name: skipped (why)" lines
NOTES=$(mktemp)   # per-round samples
SKLOG=$(mktemp)   # every peer_rates line
RDSUMS=$(mktemp)  # the C stencil's and simkit's lines with their field sums
trap 'rm -f "$ROWS" "$SKIPS" "$NOTES" "$SKLOG" "$RDSUMS"' EXIT

say() { echo "$*" >&2; }
skip() { echo "- $1: skipped ($2)" >>"$SKIPS"; say "$1: skipped ($2)"; }
want() { case ",$ONLY," in *",$1,"*) return 0 ;; *) return 1 ;; esac; }
# rate_of: R of a "rate=R ..." line (peer_rates' output) on stdin, or nothing.
rate_of() { sed -n 's/^rate=\([^ ]*\) .*/\1/p' | head -n 1; }
# field KEY: the value of KEY=VALUE in a peer_rates line on stdin.
field() { tr ' ' '\n' | sed -n "s/^$1=//p" | head -n 1; }
# row CRATE PEER PEER_MEDIAN SIMKIT_MEDIAN UNIT KIND TARGET: KIND "ratio" (simkit / peer, target
# "x") or "percent" (100 simkit / peer, target "%").
row() {
  awk -v c="$1" -v p="$2" -v a="$3" -v b="$4" -v u="$5" -v k="$6" -v t="$7" 'BEGIN {
    if (!(a + 0 > 0) || !(b + 0 > 0)) { r = "n/a"; m = "no figure" }
    else if (k == "percent") { v = 100 * b / a; r = sprintf("%.0f %% of peer", v) }
    else { v = b / a; r = sprintf("%.2fx", v) }
    if (r != "n/a") {
      if (t == "") { tt = "-"; m = "-" }
      else if (k == "percent") { tt = ">= " t " %"; m = (v >= t) ? "met" : "not met" }
      else { tt = ">= " t "x"; m = (v >= t) ? "met" : "not met" }
    } else { tt = (t == "") ? "-" : ((k == "percent") ? ">= " t " %" : ">= " t "x") }
    printf "| %s | %s | %.4g | %.4g | %s | %s | %s | %s |\n", c, p, a, b, u, r, tt, m }' >>"$ROWS"
}
note() { echo "- $*" >>"$NOTES"; }

say "side_by_side: rounds=$ROUNDS quick=$QUICK only=$ONLY peers=${PEERS:-none}"
LOAD0=$(uptime | sed 's/.*load average: //')

# ---- build simkit's side -------------------------------------------------------------------
SK=target/release/examples/peer_rates
# build EXAMPLE: cargo build --release --example EXAMPLE (skipped with --no-build).
build() {
  if [ "$NOBUILD" -eq 1 ]; then [ -x "target/release/examples/$1" ]; return; fi
  _blog=$(mktemp)
  if cargo build --release --example "$1" >"$_blog" 2>&1; then rm -f "$_blog"; return 0; fi
  say "cargo build --release --example $1 failed:"; grep -A6 '^error' "$_blog" | head -n 20 >&2
  rm -f "$_blog"; return 1
}
say "building simkit examples (release)..."
build peer_rates || { say "no simkit figures without peer_rates"; exit 1; }
if want dem; then build dem_box_timer || DEM_BUILD=fail; fi
if want md; then build lj_fluid || MD_BUILD=fail; fi

# ---- build / find the peers ----------------------------------------------------------------
need_peers() { [ -n "$PEERS" ] && [ -f "$PEERS/$1" ]; }
# where FILE: where the peer FILE was looked for, for a skip line.
where() { if [ -n "$PEERS" ]; then echo "$PEERS/$1 not found"; else echo "peers directory $PEERS_ARG not found"; fi; }
# cc_peer SRC OUT COMPILER: compiles $PEERS/SRC to $PB/OUT (-O3 -march=native -fopenmp).
cc_peer() {
  need_peers "$1" || { where "$1"; return 1; }
  command -v "$3" >/dev/null 2>&1 || { echo "$3 not found"; return 1; }
  "$3" -O3 -march=native -fopenmp "$PEERS/$1" -o "$PB/$2" -lm >/dev/null 2>&1 ||
    { echo "$3 failed on $1"; return 1; }
}

# venv_python DIR MODULE PACKAGE: the python of a venv at DIR that imports MODULE, made with
# `pip install PACKAGE` when missing; skips PACKAGE (and prints nothing) when that fails.
venv_python() {
  if ! "$1/bin/python" -c "import $2" >/dev/null 2>&1; then
    say "$3: installing into $1 (pip install $3)..."
    { python3 -m venv "$1" && "$1/bin/pip" install -q "$3"; } >/dev/null 2>&1
  fi
  if "$1/bin/python" -c "import $2" >/dev/null 2>&1; then echo "$1/bin/python"
  else skip "$3" "no venv at $1 and python3 -m venv / pip install $3 failed"; fi
}

PYPDE=""
if want rd; then
  if ! need_peers pypde_grayscott.py; then skip "py-pde" "$(where pypde_grayscott.py)"
  else PYPDE=$(venv_python target/pypde pde py-pde); fi
fi

CGS=""
if want rd; then
  if ! command -v gcc >/dev/null 2>&1; then skip "C Gray-Scott stencil" "gcc not found"
  elif gcc -O3 -march=native -fopenmp benches/peers/gray_scott.c -o "$PB/gray_scott" -lm \
    >/dev/null 2>&1; then CGS="$PB/gray_scott"
  else skip "C Gray-Scott stencil" "gcc -O3 -march=native -fopenmp benches/peers/gray_scott.c failed"; fi
fi

KIDDO=""
if want neighbor; then
  if ! need_peers kiddo_bench/Cargo.toml; then
    skip "kiddo" "$(where kiddo_bench/Cargo.toml)"
  else
    say "kiddo: cargo build --release (target/peers/kiddo)..."
    if cargo build --release --manifest-path "$PEERS/kiddo_bench/Cargo.toml" \
      --target-dir "$PB/kiddo" >/dev/null 2>&1; then KIDDO="$PB/kiddo/release/kiddo_bench"
    else skip "kiddo" "cargo build of kiddo_bench failed"; fi
  fi
fi

LMP=0
if want dem || want md; then
  if lammps_ensure 2>/dev/null; then LMP=1
  else skip "LAMMPS (dem, md rows)" "lmp not found and apt-get install -y lammps not possible or failed"; fi
fi
MPI=0
if have_mpirun; then MPI=1; fi

# LAMMPS and GROMACS built for this CPU (cached; built here the first time).
LMPN="" DEM_SF="" DEM_LMP="Debian LAMMPS"
if want md || want neighbor || want dem; then
  say "LAMMPS for this CPU (benches/peers/build_native.sh lammps; about 5 minutes the first time)..."
  LMPN=$(sh benches/peers/build_native.sh lammps 2>/dev/null) ||
    { LMPN=""; skip "LAMMPS -march=native" "benches/peers/build_native.sh lammps failed (log: $(peer_cache)/lammps-native/build.log)"; }
  if [ -n "$LMPN" ]; then DEM_SF="-sf omp -pk omp 1" DEM_LMP="LAMMPS -march=native -sf omp"; fi
fi
# GMX_BUILDS: "tag:binary" of the GROMACS builds whose in.lj is prepared in $PB/gromacs-tag.
GMX_BUILDS="" GMX_E0=""
if want md; then
  say "GROMACS for this CPU (benches/peers/build_native.sh gromacs; about 20 minutes the first time)..."
  if g=$(sh benches/peers/build_native.sh gromacs 2>/dev/null); then GMX_BUILDS="native:$g"
  else skip "GROMACS -march=native" "benches/peers/build_native.sh gromacs failed (log: $(peer_cache)/gromacs-native/build.log)"; fi
  if ! command -v gmx >/dev/null 2>&1 && [ "$(id -u)" -eq 0 ]; then
    apt-get install -y -q gromacs >/dev/null 2>&1
  fi
  if command -v gmx >/dev/null 2>&1; then GMX_BUILDS="$GMX_BUILDS debian:gmx"
  else skip "GROMACS (Debian)" "gmx not found and apt-get install gromacs not possible or failed"; fi
  ready=""
  for g in $GMX_BUILDS; do
    t=${g%%:*}
    if gromacs_prepare "${g#*:}" "$PB/gromacs-$t"; then
      ready="$ready $g" GMX_E0="$GMX_E0 $t: $(gromacs_energy0 "${g#*:}" "$PB/gromacs-$t");"
    else skip "GROMACS ($t)" "grompp failed (see $PB/gromacs-$t/grompp.log)"; fi
  done
  GMX_BUILDS=$ready
  if command -v gmx_d >/dev/null 2>&1 && gromacs_prepare gmx_d "$PB/gromacs-double"; then
    GMX_E0="$GMX_E0 debian double precision: $(gromacs_energy0 gmx_d "$PB/gromacs-double");"
  fi
fi

FREUD=""
if want neighbor; then
  FREUD=$(venv_python target/freud freud freud-analysis)
  # freud 3.4's LinkCell ball query is not its fast path: measured here (2 threads) its time
  # grows as N^1.9 (8.6 s at N = 2e4, 174 s at 1e5), so at N = 1e6 only AABBQuery runs.
  [ -n "$FREUD" ] && skip "freud LinkCell" "not run at N=$NB_N: its ball query's time grows about as N^2 (8.6 s at N=2e4, 174 s at N=1e5 on 2 threads, 2026-12-07); AABBQuery is freud's fast path"
fi

TRIAD="" FHP="" FMA="" PPL=""
if want lattice-gas; then
  if why=$(cc_peer triad.c triad gcc); then TRIAD="$PB/triad"; else skip "triad" "$why"; fi
  if why=$(cc_peer fhp_bench.cpp fhp g++); then FHP="$PB/fhp"; else skip "fhp_bench" "$why"; fi
fi
if want pp-coulomb; then
  if why=$(cc_peer fma.c fma gcc); then FMA="$PB/fma"; else skip "fma" "$why"; fi
  if why=$(cc_peer ppl_nompi.cpp ppl g++); then PPL="$PB/ppl"; else skip "ppl_nompi" "$why"; fi
fi

# ---- one measurement each: prints one rate (or nothing when it failed) ----------------------
# sk ARGS: runs peer_rates, keeping its line for the table's list of backends.
sk() { "$SK" "$@" 2>/dev/null | tee -a "$SKLOG"; }
m_pypde() {
  NUMBA_NUM_THREADS=2 "$PYPDE" "$PEERS/pypde_grayscott.py" "$RD_N" "$RD_PEER_STEPS" 1 stepper \
    2>/dev/null | sed -n 's/.*cell_updates_per_s=\([^ ]*\).*/\1/p' | head -n 1
}
m_sk_rd() { sk rd --n "$RD_N" --steps "$RD_STEPS" --threads 2 | rate_of; }
# The C stencil and simkit on size $CN, $CS steps per timed run, both after (1 + 1) x $CS
# steps in all, their lines (with the field sums) kept in $RDSUMS.
m_cgs() {
  OMP_NUM_THREADS=2 "$CGS" "$CN" "$CS" 1 2>/dev/null | tee -a "$RDSUMS" |
    sed -n 's/^cell_updates_per_s=\([^ ]*\).*/\1/p' | head -n 1
}
m_sk_cgs() { sk rd --n "$CN" --steps "$CS" --threads 2 --reps 1 | tee -a "$RDSUMS" | rate_of; }
# kiddo: unordered pairs / (median build time + median tree-order parallel query time).
m_kiddo() {
  "$KIDDO" "$NB_N" 2 "$KIDDO_REPS" build,tord 2>/dev/null | awk '
    /^build/ { split($0, a, "= "); split(a[2], t, "/"); build = t[2] / 1e3 }
    /^tree-order par_iter/ { for (i = 1; i <= NF; i++) if ($i ~ /^pairs=/) p = substr($i, 7)
      split($0, a, "= "); split(a[2], t, "/"); q = t[2] + 0 }
    END { if (p > 0 && build + q > 0) printf "%.6g\n", p / (build + q) }'
}
m_sk_nb() { sk neighbor --n "$NB_N" --threads 2 --reps "$NB_REPS" | rate_of; }
# native CMD...: runs CMD with the -march=native LAMMPS as $LMP_BIN when it was built.
native() { (if [ -n "$LMPN" ]; then LMP_BIN=$LMPN; fi; "$@"); }
# The list builds: LAMMPS (ranks $1), freud AABBQuery, simkit's half lists (threads $1).
m_lmp_nl() { native lammps_neigh_rate "$1" "$NB_N" "$NB_LMP_BUILDS"; }
m_freud() {
  "$FREUD" benches/peers/freud_pairs.py "$NB_N" 1 2 aabb 2>/dev/null |
    sed -n 's/^pairs_per_s=\([^ ]*\).*/\1/p'
}
m_sk_nl() { sk neighbor-list --n "$NB_N" --threads "$1" --reps "$NB_REPS" | rate_of; }
m_sk_vl() { sk neighbor-list --kind verlet --n "$NB_N" --threads 2 --reps "$NB_REPS" | rate_of; }
# dem: $DM is the LAMMPS model (hooke or hooke/history), $SM simkit's (viscous or history).
# dem's LAMMPS: the -march=native build with -sf omp (one thread per rank) when it is there,
# else Debian's lmp with its plain styles.
dem_lmp() {
  # shellcheck disable=SC2086 # DEM_SF is a list of separate words
  native lammps_rate "$@" -var model "$DM" $DEM_SF
}
m_lmp_dem1() { dem_lmp "$DEM_DECK" "$DEM_N" "$DEM_STEPS" 1; }
m_sk_dem1() { dem_timer_rate 1 "$DEM_STEPS" --model "$SM"; }
m_lmp_dem2() { dem_lmp "$DEM_DECK" "$DEM_N" "$DEM_STEPS" 2; }
m_sk_dem2() { dem_timer_rate 2 "$DEM_STEPS" --model "$SM"; }
m_lmp_dem_long() { dem_lmp "$DEM_DECK" "$DEM_N" "$DEM_LONG_STEPS" 2; }
m_sk_dem_long() { dem_timer_rate 2 "$DEM_LONG_STEPS" --model "$SM"; }
DEM_BIG_N=$((DEM_BIG * DEM_BIG * DEM_BIG))
m_lmp_dem_big() {
  dem_lmp "$DEM_DECK" "$DEM_BIG_N" "$DEM_BIG_STEPS" 2 -var nx "$DEM_BIG" -var ny "$DEM_BIG" \
    -var nz "$DEM_BIG"
}
m_sk_dem_big() {
  dem_timer_rate 2 "$DEM_BIG_STEPS" --nx "$DEM_BIG" --ny "$DEM_BIG" --nz "$DEM_BIG" --model "$SM"
}
# The dem models: "tag LAMMPS-model simkit-model".
DEM_MODELS="h:hooke/history:history v:hooke:viscous"
# LAMMPS suffixes of the -march=native build, and their command-line arguments.
LMP_SF="plain opt omp intel"
sf_args() {
  case $1 in
    opt) echo "-sf opt" ;;
    omp) echo "-sf omp -pk omp 1" ;;
    intel) echo "-sf intel -pk intel 0 mode mixed omp 1" ;;
  esac
}
# md_peers / md_simkit: one measurement of every md peer / simkit md row, 1 and 2 cores.
md_peers() {
  for c in 1 2; do
    [ "$c" -eq 2 ] && [ "$MPI" -eq 0 ] && lmp_ok=0 || lmp_ok=1
    if [ "$LMP" -eq 1 ] && [ "$lmp_ok" -eq 1 ]; then
      add "lmpmd$c" "$(lammps_rate "$MD_DECK" "$MD_N" "$MD_STEPS" "$c")"
    fi
    if [ -n "$LMPN" ] && [ "$lmp_ok" -eq 1 ]; then
      for sf in $LMP_SF; do
        # shellcheck disable=SC2046 # the suffix arguments are separate words
        add "lmpn$c$sf" "$(native lammps_rate "$MD_DECK" "$MD_N" "$MD_STEPS" "$c" $(sf_args "$sf"))"
      done
    fi
    for g in $GMX_BUILDS; do
      add "gmx$c${g%%:*}" "$(gromacs_rate "${g#*:}" "$c" "$MD_STEPS" "$PB/gromacs-${g%%:*}")"
    done
  done
}
md_simkit() {
  for c in 1 2; do
    add "skmd$c" "$(lj_fluid_rate "$c" "$MD_STEPS")"
    add "skmdf$c" "$(lj_fluid_rate "$c" "$MD_STEPS" --f32)"
  done
}
m_triad() {
  OMP_NUM_THREADS=2 "$TRIAD" "$TRIAD_REPS" 2>/dev/null |
    sed -n 's/^triad GB\/s:.*median \([^ ]*\).*/\1/p'
}
# simkit lattice-gas, lookup table: GB/s at 2 bytes per site update.
m_sk_lut() {
  sk lattice-gas --n "$LG_N" --steps "$LG_STEPS" --method lut --threads 2 |
    field gb_per_s_at_2_bytes
}
m_fhp() { "$FHP" "$FHP_N" "$FHP_STEPS" 1 2>/dev/null | sed -n 's/.*site_updates_per_s=\([^ ]*\).*/\1/p'; }
m_sk_fhp() {
  sk lattice-gas --n "$FHP_N" --steps "$FHP_STEPS" --method auto --threads 2 | rate_of
}
# fma prints "SP GFLOP/s (fma=2 flops): min A median B max C" and the same for DP; both on
# one line here: "SP DP".
m_fma() {
  OMP_NUM_THREADS=2 "$FMA" "$FMA_ITERS" 2>/dev/null |
    awk '/^SP GFLOP/ {for (i = 1; i <= NF; i++) if ($i == "median") s = $(i + 1)}
         /^DP GFLOP/ {for (i = 1; i <= NF; i++) if ($i == "median") d = $(i + 1)}
         END {if (s != "" && d != "") print s, d}'
}
m_sk_pp() {
  sk pp-coulomb --n "$PP_N" --steps "$PP_STEPS" --precision "$1" --threads 2 |
    field gflops_at_20
}
m_sk_pp_rate() {
  sk pp-coulomb --n "$PP_N" --steps "$PP_STEPS" --precision f64 --threads 2 | rate_of
}
m_ppl() {
  OMP_NUM_THREADS=2 "$PPL" "$PP_N" 1 2>/dev/null | sed -n 's/.*pairs_per_s=\([^ ]*\).*/\1/p'
}

# ---- rounds --------------------------------------------------------------------------------
# Sample lists, one variable per measurement: S_<name> = " r1 r2 ...".
add() { eval "S_$1=\"\${S_$1:-} $2\""; }
# pair NAME_A FUNC_A NAME_B FUNC_B ROUND: runs A then B (B then A on even rounds).
pair() {
  if [ $(($5 % 2)) -eq 1 ]; then add "$1" "$($2)"; add "$3" "$($4)"
  else add "$3" "$($4)"; add "$1" "$($2)"; fi
}
r=1
while [ "$r" -le "$ROUNDS" ]; do
  say "round $r/$ROUNDS"
  if want rd && [ -n "$PYPDE" ]; then say "  rd"; pair pypde m_pypde skrd m_sk_rd "$r"; fi
  if want rd && [ -n "$CGS" ]; then
    say "  rd (C stencil)"
    for c in $CGS_RUNS; do
      CN=${c%:*} CS=${c#*:}
      pair "cgs$CN" m_cgs "skcgs$CN" m_sk_cgs "$r"
    done
  fi
  if want neighbor && [ -n "$KIDDO" ]; then say "  neighbor"; pair kiddo m_kiddo sknb m_sk_nb "$r"; fi
  if want neighbor; then
    say "  neighbor (list builds)"
    if [ -n "$LMPN" ]; then
      pair lmpnl1 "m_lmp_nl 1" sknl1 "m_sk_nl 1" "$r"
      if [ "$MPI" -eq 1 ]; then
        pair lmpnl2 "m_lmp_nl 2" sknl2 "m_sk_nl 2" "$r"
        add skvl2 "$(m_sk_vl)"
      fi
    fi
    if [ -n "$FREUD" ]; then pair freud m_freud sknl2 "m_sk_nl 2" "$r"; fi
  fi
  if want dem && { [ "$LMP" -eq 1 ] || [ -n "$LMPN" ]; } && [ "$MPI" -eq 1 ] && [ -z "${DEM_BUILD:-}" ]; then
    say "  dem"
    for m in $DEM_MODELS; do
      t=${m%%:*} DM=${m#*:} SM=${m##*:}
      DM=${DM%:*}
      pair "lmpdem1$t" m_lmp_dem1 "skdem1$t" m_sk_dem1 "$r"
      pair "lmpdem2$t" m_lmp_dem2 "skdem2$t" m_sk_dem2 "$r"
      pair "lmpdemlong$t" m_lmp_dem_long "skdemlong$t" m_sk_dem_long "$r"
      pair "lmpdembig$t" m_lmp_dem_big "skdembig$t" m_sk_dem_big "$r"
    done
  fi
  if want md && [ -z "${MD_BUILD:-}" ]; then
    say "  md"
    if [ $((r % 2)) -eq 1 ]; then md_peers; md_simkit; else md_simkit; md_peers; fi
  fi
  if want lattice-gas; then
    say "  lattice-gas"
    if [ -n "$TRIAD" ]; then pair triad m_triad sklut m_sk_lut "$r"; fi
    if [ -n "$FHP" ]; then pair fhp m_fhp skfhp m_sk_fhp "$r"; fi
  fi
  if want pp-coulomb; then
    say "  pp-coulomb"
    if [ -n "$FMA" ]; then
      if [ $((r % 2)) -eq 0 ]; then add skpp32 "$(m_sk_pp f32)"; add skpp64 "$(m_sk_pp f64)"; fi
      fs=$(m_fma)
      add fmasp "${fs% *}"; add fmadp "${fs#* }"
      if [ $((r % 2)) -eq 1 ]; then add skpp32 "$(m_sk_pp f32)"; add skpp64 "$(m_sk_pp f64)"; fi
    fi
    if [ -n "$PPL" ]; then pair ppl m_ppl skpprate m_sk_pp_rate "$r"; fi
  fi
  r=$((r + 1))
done
LOAD1=$(uptime | sed 's/.*load average: //')

# ---- table ---------------------------------------------------------------------------------
med() { eval "echo \"\${S_$1:-}\"" | median; }
samples() { eval "echo \"\${S_$1:-}\"" | sed 's/^ *//'; }
if want rd; then
  if [ -n "$PYPDE" ]; then
    row rd "py-pde Gray-Scott f64 ${RD_N}^2 (numba stepper)" "$(med pypde)" "$(med skrd)" \
      "cell updates/s" ratio 10
    note "rd: py-pde $RD_PEER_STEPS steps per run: $(samples pypde); simkit $RD_STEPS steps: $(samples skrd)"
  fi
fi
if want rd && [ -n "$CGS" ]; then
  for c in $CGS_RUNS; do
    CN=${c%:*} CS=${c#*:}
    # The largest relative difference of the three sums between any C run and any simkit
    # run of this size (same scene, same steps).
    agree=$(awk -v n="$CN" '
      { who = ($0 ~ /^cell_updates_per_s=/) ? "c" : "s"; ok = 0
        for (i = 1; i <= NF; i++) { split($i, kv, "=")
          if (kv[1] == "n" && kv[2] == n) ok = 1
          if (kv[1] ~ /^sum_/) v[kv[1]] = kv[2] + 0 }
        if (!ok) next
        for (k in v) { m = k SUBSEP who; if (!(m in lo) || v[k] < lo[m]) lo[m] = v[k]
          if (!(m in hi) || v[k] > hi[m]) hi[m] = v[k] } }
      END { d = -1
        for (m in lo) { split(m, p, SUBSEP); if (p[2] != "c") continue
          o = p[1] SUBSEP "s"; if (!(o in lo)) continue
          a = hi[m] - lo[o]; b = hi[o] - lo[m]; x = (a > b) ? a : b; if (x < 0) x = -x
          s = (lo[o] < 0) ? -lo[o] : lo[o]; if (s > 0) x /= s; if (x > d) d = x }
        if (d < 0) print "no check"; else printf "%.1e", d }' "$RDSUMS")
    row rd "C stencil f64 ${CN}^2 (ours: -O3 -march=native, OpenMP, blocked), 2 threads; sums differ by $agree" \
      "$(med "cgs$CN")" "$(med "skcgs$CN")" "cell updates/s" ratio 1
    note "rd ${CN}^2 vs the C stencil, $CS steps per run: C: $(samples "cgs$CN"); simkit: $(samples "skcgs$CN")"
  done
fi
if want neighbor && [ -n "$KIDDO" ]; then
  row neighbor "kiddo 6 k-d tree, build + tree-order queries, N=$NB_N, 2 threads" \
    "$(med kiddo)" "$(med sknb)" "pairs/s (build + all pairs)" ratio 12
  note "neighbor: kiddo (pairs / (median build + median query time) of $KIDDO_REPS reps per run): $(samples kiddo); simkit sorted cells (median of $NB_REPS build + count runs per run): $(samples sknb)"
fi
if want neighbor; then
  if [ -n "$LMPN" ]; then
    row neighbor "LAMMPS -march=native binned half-list build vs simkit's md/dem list, 1 rank vs 1 thread, N=$NB_N, periodic" \
      "$(med lmpnl1)" "$(med sknl1)" "pairs/s (list build)" ratio 10
    note "neighbor list 1 core: LAMMPS ($NB_LMP_BUILDS builds per run): $(samples lmpnl1); simkit md/dem list (median of $NB_REPS): $(samples sknl1)"
    if [ "$MPI" -eq 1 ]; then
      row neighbor "LAMMPS -march=native binned half-list build, 2 MPI ranks vs 2 threads" \
        "$(med lmpnl2)" "$(med sknl2)" "pairs/s (list build)" ratio 10
      note "neighbor list 2 cores: LAMMPS: $(samples lmpnl2); simkit: $(samples sknl2)"
      row neighbor "the same LAMMPS build vs simkit's VerletList (2 threads)" \
        "$(med lmpnl2)" "$(med skvl2)" "pairs/s (list build)" ratio ""
      note "neighbor VerletList 2 threads: $(samples skvl2)"
    fi
  fi
  if [ -n "$FREUD" ]; then
    row neighbor "freud $("$FREUD" -c 'import freud; print(freud.__version__)' 2>/dev/null) AABBQuery build + query to a NeighborList, 2 threads, N=$NB_N" \
      "$(med freud)" "$(med sknl2)" "pairs/s (list build)" ratio 10
    note "neighbor: freud AABBQuery (one timed run after a warm-up; its list holds both directions): $(samples freud)"
  fi
fi
if want dem && { [ "$LMP" -eq 1 ] || [ -n "$LMPN" ]; }; then
  if [ "$MPI" -eq 0 ]; then skip "dem" "mpirun not found (the target is on 2 cores)"
  elif [ -n "${DEM_BUILD:-}" ]; then skip "dem" "cargo build --example dem_box_timer failed"
  else
    for m in $DEM_MODELS; do
      t=${m%%:*}
      if [ "$t" = h ]; then
        what="$DEM_LMP gran/hooke/history + nve/sphere vs simkit LinearHistory with rotation (same physics)"
      else
        what="no rotation: $DEM_LMP gran/hooke (with rotation) vs simkit viscous friction without rotation"
      fi
      row dem "$what, 1 rank vs 1 thread, N=$DEM_N, $DEM_STEPS steps" \
        "$(med "lmpdem1$t")" "$(med "skdem1$t")" "particle-steps/s" ratio 2
      note "dem ($t) 1 core: LAMMPS: $(samples "lmpdem1$t"); simkit: $(samples "skdem1$t")"
      row dem "$what, 2 MPI ranks vs 2 threads, N=$DEM_N, $DEM_STEPS steps" \
        "$(med "lmpdem2$t")" "$(med "skdem2$t")" "particle-steps/s" ratio 2
      note "dem ($t): LAMMPS: $(samples "lmpdem2$t"); simkit: $(samples "skdem2$t")"
      row dem "$what, 2 MPI ranks vs 2 threads, N=$DEM_N, $DEM_LONG_STEPS steps (settled pile)" \
        "$(med "lmpdemlong$t")" "$(med "skdemlong$t")" "particle-steps/s" ratio 2
      note "dem ($t) long window: LAMMPS: $(samples "lmpdemlong$t"); simkit: $(samples "skdemlong$t")"
      row dem "$what, 2 MPI ranks vs 2 threads, N=$DEM_BIG_N, $DEM_BIG_STEPS steps" \
        "$(med "lmpdembig$t")" "$(med "skdembig$t")" "particle-steps/s" ratio 2
      note "dem ($t) N=$DEM_BIG_N: LAMMPS: $(samples "lmpdembig$t"); simkit: $(samples "skdembig$t")"
    done
  fi
fi
if want md; then
  if [ -n "${MD_BUILD:-}" ]; then skip "md" "cargo build --example lj_fluid failed"
  else
    for c in 1 2; do
      if [ "$c" -eq 1 ]; then cores="1 core"; else cores="2 cores"; fi
      note "md $cores: simkit f64: $(samples "skmd$c"); simkit f32: $(samples "skmdf$c")"
      if [ "$LMP" -eq 1 ] && [ -n "$(samples "lmpmd$c")" ]; then
        row md "Debian LAMMPS lj/cut in.lj (generic build), $cores (MPI ranks), N=$MD_N, $MD_STEPS steps" \
          "$(med "lmpmd$c")" "$(med "skmd$c")" "atom-steps/s" ratio ""
        note "md $cores: Debian LAMMPS: $(samples "lmpmd$c")"
      fi
      if [ -n "$LMPN" ] && [ -n "$(samples "lmpn${c}plain")" ]; then
        best=0 bsf=""
        for sf in $LMP_SF; do
          m=$(med "lmpn$c$sf")
          row md "LAMMPS -march=native, $(if [ "$sf" = plain ]; then echo lj/cut; else echo "-sf $sf"; fi), $cores (MPI ranks)" \
            "$m" "$(med "skmd$c")" "atom-steps/s" ratio ""
          note "md $cores: LAMMPS -march=native $sf: $(samples "lmpn$c$sf")"
          if awk -v a="$m" -v b="$best" 'BEGIN {exit !(a + 0 > b + 0)}'; then best=$m bsf=$sf; fi
        done
        row md "best LAMMPS build and suffix (-march=native, $bsf), $cores" "$best" \
          "$(med "skmd$c")" "atom-steps/s" ratio 1.5
      fi
      for g in $GMX_BUILDS; do
        t=${g%%:*}
        if [ "$t" = native ]; then what="GROMACS 2022 -march=native (widest SIMD)"; tg=1
        else what="Debian GROMACS 2022 (SSE4.1)"; tg=""; fi
        row md "$what mixed precision vs simkit f64, $cores (1 rank, OpenMP threads)" "$(med "gmx$c$t")" \
          "$(med "skmd$c")" "atom-steps/s" ratio "$tg"
        row md "$what mixed precision vs simkit f32, $cores (1 rank, OpenMP threads)" "$(med "gmx$c$t")" \
          "$(med "skmdf$c")" "atom-steps/s" ratio "$tg"
        note "md $cores: $what: $(samples "gmx$c$t")"
      done
    done
    if [ -n "$GMX_E0" ]; then
      e0=$(target/release/examples/lj_fluid --steps 1 --thermo-every 0 2>/dev/null |
        sed -n 's/^start .*E_pair\/N \([^ ]*\).*/\1/p')
      note "md potential energy per atom at step 0 (epsilon): simkit f64 $e0; GROMACS$GMX_E0"
    fi
  fi
fi
if want lattice-gas; then
  if [ -n "$TRIAD" ]; then
    row lattice-gas "triad memory bandwidth (2 threads) vs lookup table ${LG_N}^2 at 2 B/site" \
      "$(med triad)" "$(med sklut)" "GB/s" percent 80
    note "lattice-gas: triad GB/s: $(samples triad); simkit lookup table GB/s (site updates/s x 2 B): $(samples sklut)"
  fi
  if [ -n "$FHP" ]; then
    row lattice-gas "source FHP program (serial) vs simkit auto method (2 threads), ${FHP_N}^2" \
      "$(med fhp)" "$(med skfhp)" "site updates/s" ratio ""
    note "lattice-gas ${FHP_N}^2: source program: $(samples fhp); simkit: $(samples skfhp)"
  fi
fi
if want pp-coulomb; then
  if [ -n "$FMA" ]; then
    row pp-coulomb "FMA peak f32 (2 threads) vs direct sum f32, N=$PP_N, 20 flop/interaction" \
      "$(med fmasp)" "$(med skpp32)" "GFLOP/s" percent 70
    row pp-coulomb "FMA peak f64 (2 threads) vs direct sum f64, N=$PP_N, 20 flop/interaction" \
      "$(med fmadp)" "$(med skpp64)" "GFLOP/s" percent 50
    note "pp-coulomb: FMA SP: $(samples fmasp); simkit f32 GFLOP/s: $(samples skpp32); FMA DP: $(samples fmadp); simkit f64: $(samples skpp64)"
  fi
  if [ -n "$PPL" ]; then
    row pp-coulomb "source OpenMP direct sum f64 (2 threads), N=$PP_N" "$(med ppl)" \
      "$(med skpprate)" "interactions/s" ratio ""
    note "pp-coulomb N=$PP_N: source program: $(samples ppl); simkit f64: $(samples skpprate)"
  fi
fi

CPU=$(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo 2>/dev/null | head -n 1)
OUT="$OUTDIR/$STAMP.md"
{
  echo "## Side-by-side speed, $(date -u '+%Y-%m-%d %H:%M UTC')"
  echo
  if [ "$QUICK" -eq 1 ]; then
    echo "**QUICK MODE: tiny sizes to check that the script runs. These figures are not comparable"
    echo "with anything; quote only a run without --quick.**"
    echo
  fi
  echo "- machine: $(uname -m), ${CPU:-unknown CPU}, $(nproc) cores"
  echo "- load average (1, 5, 15 min) before: $LOAD0; after: $LOAD1"
  if [ "$NOBUILD" -eq 1 ]; then
    echo "- --no-build: the simkit examples were not rebuilt (they may predate the working tree)"
  fi
  echo "- rounds: $ROUNDS, peer and simkit alternating (order swapped every other round); medians"
  echo
  echo "| crate | peer (vs simkit) | peer | simkit | unit | simkit / peer | target | |"
  echo "|---|---|---|---|---|---|---|---|"
  cat "$ROWS"
  echo
  if [ -s "$SKIPS" ]; then echo "Skipped:"; echo; cat "$SKIPS"; echo; fi
  echo "Samples per round:"
  echo
  cat "$NOTES"
  if [ -s "$SKLOG" ]; then
    echo
    echo "simkit runs (examples/peer_rates): $(awk '{w = ""; b = ""
      for (i = 1; i <= NF; i++) { if ($i ~ /^workload=/) w = substr($i, 10)
        if ($i ~ /^backend=/) b = " on " substr($i, 9) }
      if (!seen[w b]++) printf "%s%s%s", (n++ ? "; " : ""), w, b }' "$SKLOG" | tr '_' ' ')"
  fi
} | tee "$OUT"
say "written to $OUT"
