#!/usr/bin/env bash
# simkit's GPU paths and their CUDA peers on one card in one run (see benches/gpu/README.md).
#
#   bash benches/gpu/run.sh OUT [--quick] [more gpu_bench options]
#
# OUT receives machine.txt (host, card, driver, clocks), peers.csv and peers.log (CuPy and
# jax-md, when present), gpu_bench.log, adapter.md, table.md and samples.csv. The simkit
# binary is .gpubin/gpu_bench when present (a release build carried to a GPU machine), else
# target/release/examples/gpu_bench, built if missing. A carried Vulkan loader (.gl/*.deb)
# and carried wheels (.whl/*.whl, jax-md) are unpacked when the machine lacks them.
set -uo pipefail
cd "$(dirname "$0")/../.."
if [ $# -lt 1 ] || [[ "$1" == -* ]]; then
  echo "usage: bash benches/gpu/run.sh OUT [--quick] [gpu_bench options]" >&2
  exit 2
fi
out="$1"
shift
quick=""
for a in "$@"; do [ "$a" = "--quick" ] && quick="--quick"; done
mkdir -p "$out"
start=$SECONDS
say() { echo "== [$((SECONDS - start)) s] $*"; }

# The Vulkan loader: carried as Debian packages where the machine has none.
if ! ldconfig -p 2>/dev/null | grep -q 'libvulkan.so.1' && ls .gl/*.deb >/dev/null 2>&1; then
  say "unpacking the carried Vulkan loader"
  for f in .gl/*.deb; do dpkg -x "$f" /; done
  ldconfig
fi
if ! ls /usr/share/vulkan/icd.d/*.json /etc/vulkan/icd.d/*.json >/dev/null 2>&1 &&
  [ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ]; then
  export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
fi
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"

{
  date -u
  uname -srm
  grep -m1 'model name' /proc/cpuinfo
  echo "threads: $(nproc)"
  if command -v nvidia-smi >/dev/null; then
    nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.sm,clocks.max.sm,clocks.mem,power.draw,temperature.gpu --format=csv
  fi
} >"$out/machine.txt" 2>&1
cat "$out/machine.txt"

bin=.gpubin/gpu_bench
if [ ! -x "$bin" ]; then
  bin=target/release/examples/gpu_bench
  if [ ! -x "$bin" ]; then
    say "building gpu_bench (release)"
    cargo build -q --release --example gpu_bench || exit 1
  fi
fi

# Peers first, on the same card, each bounded in time: a peer that fails or hangs loses
# its row only.
: >"$out/peers.log"
if python3 -c 'import cupy' >/dev/null 2>&1; then
  say "CuPy peers"
  timeout 100 python3 benches/gpu/peers.py $quick >"$out/peers.csv" 2>>"$out/peers.log" ||
    echo "peers.py: exit $?" >>"$out/peers.log"
else
  echo "name,unit,rate" >"$out/peers.csv"
  echo "CuPy not installed: no CUDA peers" >>"$out/peers.log"
fi
if python3 -c 'import jax' >/dev/null 2>&1 && ls .whl/jax_md-*.whl >/dev/null 2>&1; then
  say "jax-md peer"
  python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
    --target /tmp/simkit-site .whl/*.whl >>"$out/peers.log" 2>&1
  if [ -n "$quick" ]; then sizes="6"; else sizes="20 63"; fi
  for cells in $sizes; do
    PYTHONPATH=/tmp/simkit-site timeout 75 python3 benches/gpu/jax_md_lj.py --cells "$cells" \
      --seconds 15 >>"$out/peers.csv" 2>>"$out/peers.log" ||
      echo "jax_md_lj.py --cells $cells: exit $?" >>"$out/peers.log"
  done
else
  echo "jax or the carried jax-md wheels missing: no jax-md peer" >>"$out/peers.log"
fi
cat "$out/peers.csv"

say "simkit ($bin)"
timeout 360 "$bin" --out "$out" --peers "$out/peers.csv" "$@" 2>&1 | tee "$out/gpu_bench.log"
status=${PIPESTATUS[0]}
say "done (gpu_bench exit $status)"
exit "$status"
