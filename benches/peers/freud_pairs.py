"""freud's neighbour queries for simkit's neighbour-list row: N uniform random points at
number density 1 in a periodic cube, every pair within r_max = 2.5 (no self pairs), as a
freud NeighborList; the structure (LinkCell or AABBQuery) is built inside the timed region.

Usage: python freud_pairs.py N REPS THREADS METHOD   (METHOD: linkcell or aabb)
Prints one line: pairs_per_s=R pairs=P median_s=T method=M n=N threads=K, where P is the
number of unordered pairs (freud's list holds each pair in both directions: 2 P entries) and
T the median time of REPS timed runs after one untimed warm-up.
"""

import statistics
import sys
import time

import freud
import numpy as np

R_MAX = 2.5


def main():
    n, reps, threads, method = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
    freud.parallel.set_num_threads(threads)
    side = n ** (1.0 / 3.0)
    box = freud.box.Box.cube(side)
    rng = np.random.default_rng(42)
    points = (rng.random((n, 3), dtype=np.float64) * side - side / 2).astype(np.float32)
    query = {"mode": "ball", "r_max": R_MAX, "exclude_ii": True}

    def run():
        if method == "linkcell":
            nq = freud.locality.LinkCell(box, points, cell_width=R_MAX)
        elif method == "aabb":
            nq = freud.locality.AABBQuery(box, points)
        else:
            raise SystemExit(f"unknown method {method!r}: use linkcell or aabb")
        return nq.query(points, query).toNeighborList()

    entries = len(run())  # warm-up
    times = []
    for _ in range(reps):
        t = time.perf_counter()
        nl = run()
        times.append(time.perf_counter() - t)
        entries = len(nl)
        del nl
    med = statistics.median(times)
    pairs = entries // 2
    print(f"pairs_per_s={pairs / med:.6g} pairs={pairs} median_s={med:.4f} method={method} "
          f"n={n} threads={threads}")


if __name__ == "__main__":
    main()
