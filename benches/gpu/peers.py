#!/usr/bin/env python3
"""CUDA peers of simkit's GPU rows, timed on the same card in the same run (CuPy).

- `cupy copy`: a device-to-device copy (cudaMemcpy) of 512 MiB, bytes read plus written
  per second: the bandwidth a CUDA program gets, against our WGSL copy kernel.
- `cupy nbody N`: an all-pairs gravitational-style kernel in the style of the CUDA `nbody`
  sample (f32, one body per thread, tiles of source bodies staged in shared memory, an
  unrolled inner loop, Plummer softening), interactions per second counted as N^2 like the
  sample; against pp-coulomb f32.
- `cupy gray-scott n`: one forward-Euler step of Gray-Scott on a periodic n x n grid per
  launch (5-point Laplacian, f32, one cell per thread, the two fields ping-ponged); cell
  updates per second; against rd.

Every kernel is checked against NumPy in f64 on a subset before it is timed (a fast wrong
kernel cannot pass). Timing: CUDA events around the timed launches, after a warm-up; the
median of several samples.

stdout: `name,unit,rate` lines (the format `gpu_bench --peers` reads). Progress and
checks on stderr. `--quick` runs tiny sizes (it still needs CuPy and a CUDA device).
"""

import argparse
import statistics
import sys


def log(*a):
    print(*a, file=sys.stderr, flush=True)


NBODY = r"""
extern "C" __global__ void nbody(const float4* __restrict__ pos, float4* __restrict__ acc,
                                 int n, float eps2) {
    extern __shared__ float4 tile[];
    int i = blockIdx.x * blockDim.x + threadIdx.x;
    float4 me = i < n ? pos[i] : make_float4(0.f, 0.f, 0.f, 0.f);
    float ax = 0.f, ay = 0.f, az = 0.f;
    for (int start = 0; start < n; start += blockDim.x) {
        int j = start + threadIdx.x;
        // Padding bodies carry zero mass: they add nothing.
        tile[threadIdx.x] = j < n ? pos[j] : make_float4(0.f, 0.f, 0.f, 0.f);
        __syncthreads();
#pragma unroll 16
        for (int k = 0; k < blockDim.x; ++k) {
            float4 o = tile[k];
            float dx = o.x - me.x, dy = o.y - me.y, dz = o.z - me.z;
            float r2 = fmaf(dx, dx, fmaf(dy, dy, fmaf(dz, dz, eps2)));
            float inv = rsqrtf(r2);
            float s = o.w * inv * inv * inv;
            ax = fmaf(dx, s, ax); ay = fmaf(dy, s, ay); az = fmaf(dz, s, az);
        }
        __syncthreads();
    }
    if (i < n) acc[i] = make_float4(ax, ay, az, 0.f);
}
"""

GRAY_SCOTT = r"""
extern "C" __global__ void gray_scott(const float* __restrict__ u, const float* __restrict__ v,
                                      float* __restrict__ u2, float* __restrict__ v2,
                                      int n, float du, float dv, float feed, float kill,
                                      float dt) {
    int x = blockIdx.x * blockDim.x + threadIdx.x;
    int y = blockIdx.y * blockDim.y + threadIdx.y;
    if (x >= n || y >= n) return;
    int xm = x == 0 ? n - 1 : x - 1, xp = x == n - 1 ? 0 : x + 1;
    int ym = y == 0 ? n - 1 : y - 1, yp = y == n - 1 ? 0 : y + 1;
    int c = y * n + x;
    float uc = u[c], vc = v[c];
    float lu = u[y * n + xm] + u[y * n + xp] + u[ym * n + x] + u[yp * n + x] - 4.f * uc;
    float lv = v[y * n + xm] + v[y * n + xp] + v[ym * n + x] + v[yp * n + x] - 4.f * vc;
    float r = uc * vc * vc;
    u2[c] = uc + dt * (du * lu - r + feed * (1.f - uc));
    v2[c] = vc + dt * (dv * lv + r - (feed + kill) * vc);
}
"""


def time_events(cp, launch, reps, samples):
    """Seconds per call of `launch`, median over `samples` groups of `reps` calls."""
    launch()
    cp.cuda.Device().synchronize()
    times = []
    for _ in range(samples):
        start, stop = cp.cuda.Event(), cp.cuda.Event()
        start.record()
        for _ in range(reps):
            launch()
        stop.record()
        stop.synchronize()
        times.append(cp.cuda.get_elapsed_time(start, stop) / 1e3 / reps)
    return statistics.median(times), times


def copy_row(cp, quick):
    nbytes = (4 << 20) if quick else (512 << 20)
    src = cp.arange(nbytes // 4, dtype=cp.float32)
    dst = cp.empty_like(src)

    def launch():
        dst.data.copy_from_device(src.data, nbytes)

    t, _ = time_events(cp, launch, 10, 5)
    if not bool((dst[:: max(1, dst.size // 1000)] == src[:: max(1, src.size // 1000)]).all()):
        raise RuntimeError("copy: destination differs from the source")
    return 2 * nbytes / t


def nbody_row(cp, np, n):
    kernel = cp.RawKernel(NBODY, "nbody")
    rng = np.random.default_rng(7)
    host = np.empty((n, 4), dtype=np.float32)
    host[:, :3] = rng.random((n, 3), dtype=np.float32) * 100.0
    host[:, 3] = rng.random(n, dtype=np.float32) + 0.5
    eps2 = np.float32(0.01)
    pos = cp.asarray(host)
    acc = cp.full((n, 4), np.nan, dtype=cp.float32)
    block = 256
    grid = ((n + block - 1) // block,)

    def launch():
        kernel(grid, (block,), (pos, acc, np.int32(n), eps2), shared_mem=block * 16)

    launch()
    cp.cuda.Device().synchronize()
    # Check 16 bodies against f64.
    got = cp.asnumpy(acc)
    x = host[:, :3].astype(np.float64)
    m = host[:, 3].astype(np.float64)
    idx = rng.integers(0, n, 16)
    d = x[None, :, :] - x[idx][:, None, :]
    r2 = (d * d).sum(-1) + float(eps2)
    ref = (d * (m / r2**1.5)[..., None]).sum(1)
    err = np.linalg.norm(got[idx, :3] - ref) / np.linalg.norm(ref)
    if not err < 1e-3:
        raise RuntimeError(f"nbody {n}: rel. L2 error {err:.1e} of 16 bodies")
    log(f"nbody {n}: rel. L2 error {err:.1e} of 16 bodies against f64")
    reps = 1 if n >= 500_000 else 10
    t, _ = time_events(cp, launch, reps, 5)
    return float(n) * n / t


def gray_scott_row(cp, np, n):
    kernel = cp.RawKernel(GRAY_SCOTT, "gray_scott")
    rng = np.random.default_rng(3)
    u0 = (1.0 - 0.5 * rng.random((n, n))).astype(np.float32)
    v0 = (0.25 * rng.random((n, n))).astype(np.float32)
    p = dict(du=1.0, dv=0.5, feed=0.04, kill=0.06, dt=0.1)
    args = [np.float32(p[k]) for k in ("du", "dv", "feed", "kill", "dt")]
    u, v = cp.asarray(u0), cp.asarray(v0)
    u2, v2 = cp.empty_like(u), cp.empty_like(v)
    block = (32, 8)
    grid = ((n + 31) // 32, (n + 7) // 8)
    state = [u, v, u2, v2]

    def launch():
        a, b, c, d = state
        kernel(grid, block, (a, b, c, d, np.int32(n), *args))
        state[:] = [c, d, a, b]

    for _ in range(3):
        launch()
    cp.cuda.Device().synchronize()
    uu, vv = u0.astype(np.float64), v0.astype(np.float64)
    for _ in range(3):
        lap = lambda f: (np.roll(f, 1, 0) + np.roll(f, -1, 0) + np.roll(f, 1, 1)
                         + np.roll(f, -1, 1) - 4 * f)
        r = uu * vv * vv
        uu, vv = (uu + p["dt"] * (p["du"] * lap(uu) - r + p["feed"] * (1 - uu)),
                  vv + p["dt"] * (p["dv"] * lap(vv) + r - (p["feed"] + p["kill"]) * vv))
    err = max(np.abs(cp.asnumpy(state[0]) - uu).max(), np.abs(cp.asnumpy(state[1]) - vv).max())
    if not err < 1e-5:
        raise RuntimeError(f"gray-scott {n}: max error {err:.1e} after 3 steps")
    log(f"gray-scott {n}: max error {err:.1e} after 3 steps against f64")
    t, _ = time_events(cp, launch, 100, 5)
    return float(n) * n / t


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="tiny sizes")
    args = ap.parse_args()
    try:
        import cupy as cp
        import numpy as np
        cp.cuda.Device(0).compute_capability
    except Exception as e:  # no CuPy or no CUDA device: no peer rows, said once
        log(f"peers skipped: CuPy or a CUDA device is missing ({e})")
        return 0
    log(f"CuPy {cp.__version__}, device {cp.cuda.runtime.getDeviceProperties(0)['name'].decode()}")
    rows = [("cupy copy", "B/s", lambda: copy_row(cp, args.quick))]
    for n in ((1024, 2048) if args.quick else (100_000, 1_000_000)):
        rows.append((f"cupy nbody {n}", "interactions/s", lambda n=n: nbody_row(cp, np, n)))
    for n in ((128, 256) if args.quick else (4096, 8192)):
        rows.append((f"cupy gray-scott {n}", "cell-updates/s",
                     lambda n=n: gray_scott_row(cp, np, n)))
    print("name,unit,rate", flush=True)
    for name, unit, run in rows:
        try:
            rate = run()
            print(f"{name},{unit},{rate:.6e}", flush=True)
            log(f"{name}: {rate:.4e} {unit}")
        except Exception as e:  # one failed peer must not stop the others
            log(f"{name}: FAILED ({e})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
