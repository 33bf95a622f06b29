"""The simkit tour from Python: every class's flagship scene at a small size.

    python -m simkit.tour          # GPU if one is present, else the CPU
    python -m simkit.tour --cpu    # the CPU backends

Prints the adapters, one line per scene (backend, throughput, a validation figure) and
exits non-zero if a scene fails.
"""

import argparse
import math
import sys
import time

import numpy as np

import simkit


def md(backend):
    """500 Lennard-Jones atoms (the in.lj state) at constant energy: energy drift."""
    sim = simkit.Md.fcc(5, 0.8442, 1.44, 87287, dt=0.005, shift=True, backend=backend)
    n = len(sim)
    totals = []
    t = time.perf_counter()
    for _ in range(30):
        sim.step(20)
        totals.append(sim.diagnostics()["total"] / n)
    secs = time.perf_counter() - t
    settled = totals[5:]  # after t = 0.5, once the lattice has melted
    spread = max(settled) - min(settled)
    return (f"md: LJ liquid, {n} atoms", sim.backend_name, n * 600 / secs, "atom-steps/s",
            f"total energy spread {spread:.1e} per atom after t = 0.5")


def dem(backend):
    """A 2D vibrated bed of 128 discs, two cycles: the bed is lifted and stays in the box."""
    sim = simkit.Dem.vibrating_bed(128, 16, contact_time_s=5e-4, backend=backend)
    rest = sim.diagnostics()["com_height"]
    per_cycle = round(2 * math.pi / sim.dt)
    t = time.perf_counter()
    com, worst = 0.0, 0.0
    for _ in range(32):
        sim.step(per_cycle // 16)
        d = sim.diagnostics()
        com += d["com_height"] / 32
        worst = max(worst, d["max_overlap_ratio"])
    secs = time.perf_counter() - t
    return ("dem: vibrated bed, 128 discs", sim.backend_name, 128 * sim.steps_done / secs,
            "particle-steps/s",
            f"COM height {com:.2f} (at rest {rest:.2f}); max overlap {worst:.1e} R")


def lattice_gas(backend):
    """FHP channel past a disc, 256 x 128, 1200 steps; bit-identical to the scalar CPU path."""
    sim = simkit.LatticeGas.channel(256, 128, backend=backend)
    t = time.perf_counter()
    sim.step(1200)
    secs = time.perf_counter() - t
    ux = sim.block_field(8)["ux"]
    reference = simkit.LatticeGas(sim_start_cells(), rules="full", seed=2026,
                                  periodic_x=False, periodic_y=False, inflow=True,
                                  outflow=True, cpu_method="lut_portable")
    reference.step(1200)
    same = np.array_equal(reference.cells, sim.cells)
    return ("lattice_gas: FHP channel 256x128", sim.backend_name, 256 * 128 * 1200 / secs,
            "site updates/s",
            f"mean u_x {ux.mean():.3f}; bit-identical to the portable CPU path: "
            f"{'yes' if same else 'NO'}")


def sim_start_cells():
    """The channel's starting lattice (as LatticeGas.channel builds it)."""
    return simkit.LatticeGas.channel(256, 128).cells


def rd(backend):
    """Bacterial colony 128 x 128, 3000 Euler steps in f32: b + n conserved."""
    sim = simkit.Rd.colony(128, 128, 7, backend=backend)
    start = sim.total(0) + sim.total(1)
    t = time.perf_counter()
    sim.step(3000)
    secs = time.perf_counter() - t
    drift = abs(sim.total(0) + sim.total(1) - start) / start
    return ("rd: bacterial colony 128^2", sim.backend_name, 128 * 128 * 3000 / secs,
            "cell updates/s", f"b + n drift {drift:.1e} (f32, want < 1e-5)")


def pp_coulomb(backend):
    """Coulomb explosion of 2000 charges in f32: energy conservation."""
    sim = simkit.PpCoulomb.cold_sphere(2000, 1.0, 7, dt=0.02, precision="f32",
                                       backend=backend)
    e0 = sim.diagnostics()["total"]
    t = time.perf_counter()
    sim.step(100)
    secs = time.perf_counter() - t
    r = np.sqrt((sim.positions ** 2).sum(axis=1)).max()
    drift = abs(sim.diagnostics()["total"] - e0) / abs(e0)
    return ("pp_coulomb: explosion, 2000 charges", sim.backend_name,
            sim.interactions_per_step * 100 / secs, "pair interactions/s",
            f"outer radius 1 -> {r:.2f}; energy drift {drift:.1e}")


def neighbor(backend):
    """All pairs within 2.5 among 20,000 random points (density 1): counts vs linked cells."""
    n, rc = 20_000, 2.5
    side = n ** (1 / 3)
    points = np.random.default_rng(3).random((n, 3)) * side
    method = "gpu" if backend == "gpu" else "sorted"
    search = simkit.NeighborSearch([0, 0, 0], [side] * 3, rc, method=method)
    t = time.perf_counter()
    for _ in range(5):
        search.build(points)
        pairs = search.pair_count()
    secs = time.perf_counter() - t
    linked = simkit.NeighborSearch([0, 0, 0], [side] * 3, rc, method="linked")
    linked.build(points)
    same = np.array_equal(search.neighbor_counts(), linked.neighbor_counts())
    ideal = 4 / 3 * math.pi * rc ** 3
    return ("neighbor: 20k points, rc 2.5", search.method, pairs * 5 / secs,
            "pairs/s", f"mean {2 * pairs / n:.2f} neighbours (ideal gas {ideal:.2f}); "
            f"counts equal to linked cells: {'yes' if same else 'NO'}")


SCENES = [dem, neighbor, lattice_gas, rd, pp_coulomb, md]


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m simkit.tour", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cpu", action="store_true",
                        help="run every scene on the CPU, even when a GPU is available")
    args = parser.parse_args(argv)
    print(f"simkit {simkit.__version__} tour\n")
    found = simkit.adapters()
    print("GPU adapters (best first):" if found else "GPU adapters: none found")
    for a in found:
        print(f"  - {a}")
    backend = "cpu" if args.cpu else simkit.best_backend()
    print(f"\nrunning every scene on: {backend}\n")
    rows, failures = [], 0
    for scene in SCENES:
        print(f"running {scene.__name__} ... ", end="", flush=True)
        t = time.perf_counter()
        try:
            rows.append(scene(backend))
            print(f"done in {time.perf_counter() - t:.2f} s")
        except (ValueError, RuntimeError, OSError) as e:
            print(f"FAILED: {e}")
            failures += 1
    print()
    for name, used, rate, unit, check in rows:
        print(f"{name:<36} {used:<28} {rate:>10.3e} {unit:<20} {check}")
    if failures:
        print(f"\n{failures} scene(s) failed", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
