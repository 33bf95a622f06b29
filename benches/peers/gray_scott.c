/*
 * Gray–Scott reaction–diffusion in C: the hand-written peer of simkit rd in
 * benches/peers/side_by_side.sh, written as an HPC programmer would write it for one node:
 * f64, OpenMP over blocks of rows and columns, a padded grid with a one-cell ghost ring
 * for the periodic boundary, the 5-point Laplacian and the explicit Euler update fused in
 * one sweep per step, inner loops vectorised by the compiler (-O3 -march=native).
 *
 *   u' = u + dt (Du lap(u) - u v^2 + F (1 - u))
 *   v' = v + dt (Dv lap(v) + u v^2 - (F + k) v),   lap(f) = f_W + f_E + f_S + f_N - 4 f
 *
 * with Du = 1, Dv = 0.5, F = 0.04, k = 0.06, h = 1, dt = 0.1 on a periodic n x n grid. The
 * starting state is simkit's `rd::scenes::gray_scott_square(n, 1.0, n / 8, 1)`: u = 1, v = 0,
 * a centred square of side n / 8 at u = 0.5, v = 0.25, and uniform noise of +-0.01 from
 * simkit's counter-based generator (the PCG hash of key (seed, step, index), step 0 for u,
 * 1 for v), so that both programs run the same scene and their sums can be compared.
 *
 * Usage: gray_scott N STEPS [REPS]
 * Runs STEPS steps untimed, then REPS timed runs of STEPS steps each (default 3), and prints
 *   cell_updates_per_s=<median> n=N steps=STEPS reps=REPS threads=T steps_done=D
 *   sum_u=... sum_v=... sum_vv=...
 * (sums over the final grid in row-major order, after D = (REPS + 1) STEPS steps: the
 * same steps and sums as `peer_rates rd --reps REPS`).
 *
 * Build: gcc -O3 -march=native -fopenmp gray_scott.c -o gray_scott -lm
 */
#include <omp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Columns per tile: three rows of a tile of both fields (and the two output rows) stay in
 * the L1 cache while a thread sweeps the tile upwards. Rows per band: the threads share
 * out (band, tile) blocks, so a grid narrower than a few tiles still keeps every thread
 * busy. */
#define TILE 512
#define BAND 32

static uint32_t pcg_hash(uint32_t in) {
  uint32_t state = in * 747796405u + 2891336453u;
  uint32_t word = ((state >> ((state >> 28) + 4)) ^ state) * 277803737u;
  return (word >> 22) ^ word;
}

static float rng_uniform(uint32_t seed, uint32_t step, uint32_t index) {
  uint32_t w = pcg_hash(index ^ pcg_hash(step ^ pcg_hash(seed)));
  return (float)(w >> 8) * (1.0f / 16777216.0f);
}

/* Periodic ghost ring of a padded (n + 2) x (n + 2) field: rows first, then whole columns
 * (corners included). */
static void ghosts(double *f, size_t n) {
  size_t w = n + 2;
  memcpy(f + 1, f + n * w + 1, n * sizeof(double));
  memcpy(f + (n + 1) * w + 1, f + w + 1, n * sizeof(double));
  for (size_t j = 0; j < n + 2; j++) {
    f[j * w] = f[j * w + n];
    f[j * w + n + 1] = f[j * w + 1];
  }
}

static void step(const double *restrict u, const double *restrict v, double *restrict ou,
                 double *restrict ov, size_t n) {
  const double dt = 0.1, feed = 0.04, fk = 0.04 + 0.06;
  const double au = 1.0 * dt, av = 0.5 * dt; /* D dt / h^2 with h = 1 */
  size_t w = n + 2, tiles = (n + TILE - 1) / TILE, bands = (n + BAND - 1) / BAND;
#pragma omp parallel for collapse(2) schedule(static)
  for (size_t b = 0; b < bands; b++) {
    for (size_t t = 0; t < tiles; t++) {
      size_t i0 = 1 + t * TILE, i1 = i0 + TILE < n + 1 ? i0 + TILE : n + 1;
      size_t j0 = 1 + b * BAND, j1 = j0 + BAND < n + 1 ? j0 + BAND : n + 1;
      for (size_t j = j0; j < j1; j++) {
        const double *uc = u + j * w, *us = uc - w, *un = uc + w;
        const double *vc = v + j * w, *vs = vc - w, *vn = vc + w;
        double *pu = ou + j * w, *pv = ov + j * w;
#pragma omp simd
        for (size_t i = i0; i < i1; i++) {
          double lu = (uc[i - 1] + uc[i + 1]) + (us[i] + un[i]) - 4.0 * uc[i];
          double lv = (vc[i - 1] + vc[i + 1]) + (vs[i] + vn[i]) - 4.0 * vc[i];
          double uvv = uc[i] * vc[i] * vc[i];
          pu[i] = uc[i] + (au * lu + dt * (feed * (1.0 - uc[i]) - uvv));
          pv[i] = vc[i] + (av * lv + dt * (uvv - fk * vc[i]));
        }
      }
    }
  }
}

static int cmp(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

int main(int argc, char **argv) {
  if (argc < 3) {
    fprintf(stderr, "usage: %s N STEPS [REPS]\n", argv[0]);
    return 2;
  }
  size_t n = strtoull(argv[1], NULL, 10);
  long steps = strtol(argv[2], NULL, 10);
  int reps = argc > 3 ? atoi(argv[3]) : 3;
  if (n < 8 || steps < 1 || reps < 1) {
    fprintf(stderr, "N >= 8, STEPS >= 1 and REPS >= 1 please\n");
    return 2;
  }
  size_t w = n + 2, cells = w * w;
  double *f[4];
  for (int k = 0; k < 4; k++) {
    f[k] = aligned_alloc(64, (cells * sizeof(double) + 63) / 64 * 64);
    if (!f[k]) {
      fprintf(stderr, "out of memory for n = %zu\n", n);
      return 1;
    }
  }
  for (int k = 0; k < 4; k++) memset(f[k], 0, cells * sizeof(double));
  size_t side = n / 8, lo = (n - side) / 2, hi = lo + side;
  for (size_t j = 0; j < n; j++) {
    for (size_t i = 0; i < n; i++) {
      int in = j >= lo && j < hi && i >= lo && i < hi;
      uint32_t k = (uint32_t)(j * n + i);
      double u0 = in ? 0.5 : 1.0, v0 = in ? 0.25 : 0.0;
      f[0][(j + 1) * w + i + 1] = u0 + 0.01 * (2.0 * (double)rng_uniform(1, 0, k) - 1.0);
      f[1][(j + 1) * w + i + 1] = v0 + 0.01 * (2.0 * (double)rng_uniform(1, 1, k) - 1.0);
    }
  }
  double *u = f[0], *v = f[1], *ou = f[2], *ov = f[3];
  double *times = malloc(reps * sizeof(double));
  for (int r = -1; r < reps; r++) {
    double t0 = omp_get_wtime();
    for (long s = 0; s < steps; s++) {
      ghosts(u, n);
      ghosts(v, n);
      step(u, v, ou, ov, n);
      double *tu = u, *tv = v;
      u = ou, v = ov, ou = tu, ov = tv;
    }
    if (r >= 0) times[r] = omp_get_wtime() - t0;
  }
  qsort(times, reps, sizeof(double), cmp);
  double su = 0, sv = 0, svv = 0;
  for (size_t j = 1; j <= n; j++) {
    for (size_t i = 1; i <= n; i++) {
      su += u[j * w + i];
      sv += v[j * w + i];
      svv += v[j * w + i] * v[j * w + i];
    }
  }
  printf("cell_updates_per_s=%.4e n=%zu steps=%ld reps=%d threads=%d steps_done=%ld "
         "sum_u=%.17e sum_v=%.17e sum_vv=%.17e\n",
         (double)n * n * steps / times[reps / 2], n, steps, reps, omp_get_max_threads(),
         (long)(reps + 1) * steps, su, sv, svv);
  for (int k = 0; k < 4; k++) free(f[k]);
  free(times);
  return 0;
}
