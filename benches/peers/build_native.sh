#!/bin/sh
# Builds a peer for this CPU from Debian's source package into a cache folder outside the
# repository, once, and prints the path of its binary:
#
#   lammps   LAMMPS (`apt-get source lammps`), CMake `-O3 -march=native`, MPI + OpenMP,
#            packages GRANULAR, OPT, OPENMP and INTEL (built with GCC: the INTEL styles run,
#            but their vectorised loops are enabled only for Intel's compilers). About 5
#            minutes on 2 cores. Binary: lammps-native/build/lmp.
#   gromacs  GROMACS (`apt-get source gromacs`), `-march=native`, the widest SIMD kernels the
#            CPU has (AVX_512 with avx512f, else AVX2_256), mixed precision, thread-MPI +
#            OpenMP, FFTW from Debian (libfftw3-dev), only the `gmx` program. Debian's own
#            `gmx` is built for SSE4.1 (any x86-64), not the GROMACS a user after speed runs.
#            About 20 minutes on 2 cores. Binary: gromacs-native/build/bin/gmx.
#
# Usage: sh benches/peers/build_native.sh lammps|gromacs [--print]
#   --print  only print the binary's path if it is already built (exit 1 if not)
# Cache: $SIMKIT_PEER_CACHE, else $XDG_CACHE_HOME/simkit-peers, else ~/.cache/simkit-peers.
# Needs apt-get with deb-src entries (added for deb.debian.org as root when missing),
# dpkg-dev, cmake, g++, and an MPI (libopenmpi-dev) for LAMMPS. The build log is
# build.log in the peer's cache folder.

set -eu
cd "$(dirname "$0")/../.."
. benches/peers/lib.sh
PEER=${1:-}
case "$PEER" in
  lammps) BIN=build/lmp ;;
  gromacs) BIN=build/bin/gmx ;;
  *) echo "usage: sh benches/peers/build_native.sh lammps|gromacs [--print]" >&2; exit 2 ;;
esac
CACHE=$(peer_cache)/$PEER-native
BIN=$CACHE/$BIN
if [ -x "$BIN" ]; then echo "$BIN"; exit 0; fi
[ "${2:-}" = "--print" ] && exit 1
say() { echo "build_native $PEER: $*" >&2; }
SRC=$(debian_source "$PEER" "$CACHE") || exit 1
cd "$CACHE"
command -v cmake >/dev/null 2>&1 || { say "cmake not found (apt-get install cmake)"; exit 1; }

if [ "$PEER" = lammps ]; then
  say "configuring $SRC (-O3 -march=native; GRANULAR OPT OPENMP INTEL)"
  cmake -S "$SRC/cmake" -B build -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_CXX_FLAGS_RELEASE="-O3 -march=native -DNDEBUG" \
    -DBUILD_MPI=on -DBUILD_OMP=on -DBUILD_SHARED_LIBS=off -DBUILD_TOOLS=off \
    -DPKG_GRANULAR=on -DPKG_OPT=on -DPKG_OPENMP=on -DPKG_INTEL=on \
    -DINTEL_ARCH=cpu -DINTEL_LRT_MODE=none -DLAMMPS_MEMALIGN=64 \
    -DWITH_JPEG=off -DWITH_PNG=off -DWITH_FFMPEG=off -DWITH_GZIP=off \
    >build.log 2>&1 || { say "cmake configure failed (see $CACHE/build.log)"; exit 1; }
  TARGET=lmp
else
  if [ ! -e /usr/include/fftw3.h ] && [ "$(id -u)" -eq 0 ]; then
    apt-get install -y -q libfftw3-dev >/dev/null 2>&1 || true
  fi
  if grep -qw avx512f /proc/cpuinfo; then SIMD=AVX_512; else SIMD=AVX2_256; fi
  # GROMACS 2022 links its modular simulator against the TNG library even when TNG is off
  # (GMX_USE_TNG=off, which spares building it): drop those two link entries.
  sed -i '/^target_link_libraries(modularsimulator PRIVATE tng_io)$/d; /^ *tng_io$/d' \
    "$SRC/src/gromacs/modularsimulator/CMakeLists.txt"
  say "configuring $SRC (GMX_SIMD=$SIMD, -march=native)"
  cmake -S "$SRC" -B build -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_C_FLAGS="-march=native" -DCMAKE_CXX_FLAGS="-march=native" \
    -DGMX_SIMD="$SIMD" -DGMX_GPU=off -DGMX_MPI=off -DGMX_THREAD_MPI=on -DGMX_OPENMP=on \
    -DGMX_FFT_LIBRARY=fftw3 -DGMX_DOUBLE=off -DGMX_HWLOC=off -DGMX_IMD=off -DGMX_USE_TNG=off \
    -DGMXAPI=off -DGMX_BUILD_HELP=off -DBUILD_TESTING=off -DGMX_BUILD_UNITTESTS=off \
    -DGMX_DEFAULT_SUFFIX=off -DGMX_BINARY_SUFFIX= -DGMX_LIBS_SUFFIX=_native \
    >build.log 2>&1 || { say "cmake configure failed (see $CACHE/build.log)"; exit 1; }
  TARGET=gmx
fi
say "building $TARGET (make -j$(nproc); log $CACHE/build.log)"
cmake --build build --target "$TARGET" -j "$(nproc)" >>build.log 2>&1 ||
  { say "build failed (see $CACHE/build.log)"; exit 1; }
[ -x "$BIN" ] || { say "no $BIN after the build"; exit 1; }
echo "$BIN"
