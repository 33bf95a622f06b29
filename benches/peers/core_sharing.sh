#!/bin/sh
# What a second busy core costs the first: splits the 1 -> 2 rank parallel efficiency of the
# compute-bound distributed runs (pp-coulomb, md) into the part the hardware takes and the part
# the distribution takes, and says where the hardware part comes from.
#
#   E = t(1 rank) / (2 t(2 ranks)) = [t(1) / t(1 | twin)] x [t(1 | twin) / (2 t(2))]
#
# t(1 | twin) is one single-rank run timed while an identical single-rank run works on the
# other core (each pinned to its own core, nothing shared between them but the machine). The
# first factor is what the machine loses when both cores work (clock, shared execution units,
# shared cache and memory bandwidth); the second is what the distributed run loses on top of
# that (halo exchange, reductions, load imbalance, work done twice). Probes, each alone on
# core 0 and then with a twin on core 1:
#   clock   a chain of dependent register adds (benches/peers/clock.c): the core's clock;
#   clock+fma  the clock on core 0 while core 1 runs the FMA loop (AVX-512 where present);
#   fma     the FMA-throughput loop of the peers folder (fma.c, one OpenMP thread), SP and DP;
#   triad   the STREAM-like triad of the peers folder (triad.c, one thread): memory bandwidth.
# Rounds alternate alone / paired; medians are printed. Usage (repository root):
#   sh benches/peers/core_sharing.sh [ROUNDS]      (default 5; about 7 minutes at 5)
# Needs gcc, taskset, mpirun (the distributed rows; examples/mpi_scaling is built with the
# `mpi` feature) and the peers folder ($SIMKIT_PEERS, default ../shared/peers) for fma.c and
# triad.c (those rows are skipped without it). Quiet machines only: check `uptime` first.
set -e
. "$(dirname "$0")/lib.sh"
ROUNDS=${1:-5}
PEERS=${SIMKIT_PEERS:-../shared/peers}
PB=target/peers
mkdir -p "$PB"
command -v taskset >/dev/null 2>&1 || { echo "taskset not found (util-linux)" >&2; exit 1; }
[ "$(nproc)" -ge 2 ] || { echo "needs 2 CPUs; this machine has $(nproc)" >&2; exit 1; }
gcc -O2 benches/peers/clock.c -o "$PB/clock"
FMA="" TRIAD=""
if [ -f "$PEERS/fma.c" ] && gcc -O3 -march=native -fopenmp "$PEERS/fma.c" -o "$PB/fma" 2>/dev/null; then
  FMA="$PB/fma"
else echo "fma rows skipped: $PEERS/fma.c not found or not compiled" >&2; fi
if [ -f "$PEERS/triad.c" ] && gcc -O3 -march=native -fopenmp "$PEERS/triad.c" -o "$PB/triad" 2>/dev/null; then
  TRIAD="$PB/triad"
else echo "triad rows skipped: $PEERS/triad.c not found or not compiled" >&2; fi
EXE=""
if have_mpirun && cargo build --release --features mpi --example mpi_scaling >/dev/null 2>&1; then
  EXE=target/release/examples/mpi_scaling
else echo "distributed rows skipped: no mpirun, or examples/mpi_scaling did not build" >&2; fi
load_before=$(cut -d' ' -f1-3 /proc/loadavg)

# The probes: each prints one number (higher = faster), on the CPU that $PIN names.
PIN="taskset -c 0"
p_clock() { $PIN "$PB/clock" 1.0 | sed -n 's/^ghz=\([^ ]*\).*/\1/p'; }
p_fma_sp() { fma_field SP; }
p_fma_dp() { fma_field DP; }
fma_field() {
  OMP_NUM_THREADS=1 $PIN "$FMA" 20000000 2>/dev/null |
    awk -v want="$1" '$1 == want {for (i = 1; i <= NF; i++) if ($i == "median") print $(i + 1)}'
}
p_triad() {
  OMP_NUM_THREADS=1 $PIN "$TRIAD" 10 2>/dev/null |
    sed -n 's/^triad GB\/s:.*median \([^ ]*\).*/\1/p'
}
# p_mpi RANKS ARGS...: one run of the distributed driver (RANKS 1: pinned by $PIN; 2: one
# rank per core, mpirun's binding); prints 1 / its timed seconds.
p_mpi() {
  _np=$1
  shift
  if [ "$_np" = 1 ]; then _run="$PIN mpirun --bind-to none"; else _run=mpirun; fi
  RAYON_NUM_THREADS=1 $_run --allow-run-as-root -np "$_np" -x RAYON_NUM_THREADS "$EXE" "$@" |
    sed -n 's/.*seconds=\([^ ]*\).*/\1/p' | awk '{printf "%.6g\n", 1 / $1}'
}

# paired MAIN TWIN ARGS...: MAIN on core 0 while TWIN runs over and over on core 1 (started
# first, so that it runs through the whole of MAIN's run); prints MAIN's figure. The twin
# finishes the run it is in before this returns.
STOP=$PB/core_sharing.stop
paired() {
  _main=$1 _twin=$2
  shift 2
  rm -f "$STOP"
  (PIN="taskset -c 1"; while [ ! -e "$STOP" ]; do "$_twin" "$@" >/dev/null; done) &
  _pid=$!
  sleep 0.5
  _fig=$("$_main" "$@")
  touch "$STOP"
  wait "$_pid" 2>/dev/null || true
  rm -f "$STOP"
  echo "$_fig"
}

# row LABEL UNIT MAIN TWIN ARGS...: ROUNDS of (MAIN alone, MAIN with TWIN on the other core);
# prints the medians and their ratio.
row() {
  _label=$1 _unit=$2 _m=$3 _t=$4
  shift 4
  _a="" _p=""
  for _r in $(seq "$ROUNDS"); do
    _a="$_a $("$_m" "$@")"
    _p="$_p $(paired "$_m" "$_t" "$@")"
  done
  _ma=$(echo "$_a" | median)
  _mp=$(echo "$_p" | median)
  _ratio=$(awk -v a="$_ma" -v b="$_mp" 'BEGIN {printf "%.2f", b / a}')
  echo "| $_label | $_ma | $_mp | $_unit | **$_ratio** | alone:$_a; paired:$_p |"
}

# dist LABEL ARGS...: the distributed split: t(1) alone, t(1 | twin), t(2); prints E and its
# two factors.
dist() {
  _label=$1
  shift
  _a="" _p="" _d=""
  for _r in $(seq "$ROUNDS"); do
    _a="$_a $(p_mpi 1 "$@")"
    _p="$_p $(paired p_mpi p_mpi 1 "$@")"
    _d="$_d $(p_mpi 2 "$@")"
  done
  _ma=$(echo "$_a" | median) _mp=$(echo "$_p" | median) _md=$(echo "$_d" | median)
  awk -v a="$_ma" -v p="$_mp" -v d="$_md" -v l="$_label" -v s="1 rank:$_a; twin:$_p; 2 ranks:$_d" \
    'BEGIN {printf "| %s | %.4g | %.4g | %.4g | **%.2f** | %.2f | %.2f | %s |\n",
      l, 1 / a, 1 / p, 1 / d, d / (2 * a), p / a, d / (2 * p), s}'
}

echo "# What a second busy core costs, $(date -u '+%Y-%m-%d %H:%M UTC'), $(nproc) CPUs," \
  "$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $ROUNDS rounds"
echo
echo "| probe (core 0) | alone | other core busy | unit | busy / alone | samples |"
echo "|---|---|---|---|---|---|"
row "clock, other core: the same chain" GHz p_clock p_clock
if [ -n "$FMA" ]; then
  row "clock, other core: DP FMA loop" GHz p_clock p_fma_dp
  row "FMA loop SP, other core: the same" "GFLOP/s" p_fma_sp p_fma_sp
  row "FMA loop DP, other core: the same" "GFLOP/s" p_fma_dp p_fma_dp
fi
if [ -n "$TRIAD" ]; then
  row "triad, other core: the same" "GB/s" p_triad p_triad
fi
if [ -n "$EXE" ]; then
  echo
  echo "| distributed run | t(1 rank) s | t(1 rank, twin busy) s | t(2 ranks) s | E = t1 / 2 t2 | hardware t1 / t1' | distribution t1' / 2 t2 | samples (1/s) |"
  echo "|---|---|---|---|---|---|---|---|"
  dist "pp-coulomb f64 N = 50,000, 2 steps" --steps 2 --warmup 1 pp-coulomb --n 50000
  dist "md in.lj N = 32,000, 100 steps" --steps 100 md --cells 20
  dist "rd Gray–Scott f64 4096^2, 50 steps" --steps 50 rd --size 4096
fi
echo
echo "load average before: $load_before; after: $(cut -d' ' -f1-3 /proc/loadavg)"
