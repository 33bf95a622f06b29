#!/usr/bin/env python3
"""jax-md peer benchmark: LAMMPS's in.lj Lennard-Jones melt, NVE velocity Verlet.

State (as benches/peers/in.lj): C^3 FCC cells at reduced density 0.8442 (4 C^3 atoms),
velocities Gaussian scaled to T = 1.44 with zero total momentum (3N-3 degrees of freedom,
as LAMMPS's `velocity create`), LJ eps = sigma = 1 cut at 2.5 (energy NOT shifted, as
lj/cut), neighbour skin 0.3, dt = 0.005, unit mass, periodic cube, float32 (jax default).

jax-md's neighbour list is built to r_cutoff + dr_threshold (= 2.8 here) and is rebuilt,
inside `nbrs.update(pos)`, only when some atom has moved more than dr_threshold / 2 since
the last build (the same policy as simkit; in.lj itself rebuilds every 20 steps).

Energy check: with the unshifted cut, every pair crossing r = 2.5 inwards changes E by
4(2.5^-12 - 2.5^-6) = -0.0163 with no force to compensate, and melting the FCC crystal
(54 neighbours inside 2.5) into the liquid (~55 on average) gains about 0.5 pair per atom,
so E/N falls by ~0.008 over the first few hundred steps (measured -0.007 to -0.008 at
N = 864 and 600-1100 steps). With --smooth-onset 2.0 (continuous energy) E is conserved
to ~1e-5 relative, which checks the integrator itself.

stdout: exactly one CSV line `jax-md lj <N>,atom-steps/s,<rate>` (median over timed
chunks). Everything else (devices, E/N at step 0, energy drift, chunk timings) -> stderr.

jax-md and the pure-Python packages it needs that are not otherwise installed (jraph,
ml_collections) are carried as wheels in .whl/ and installed with
  python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
      --target /tmp/site .whl/*.whl && export PYTHONPATH=/tmp/site
"""

import argparse
import importlib.util
import math
import statistics
import sys
import time
import types


def log(*a):
    print(*a, file=sys.stderr, flush=True)


p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
p.add_argument("--cells", type=int, default=20,
               help="FCC cells per side (20 -> 32,000 atoms; 63 -> 1,000,188)")
p.add_argument("--steps", type=int, default=1000, help="timed steps (default 1000)")
p.add_argument("--chunk", type=int, default=100,
               help="steps per jitted lax.fori_loop chunk (default 100)")
p.add_argument("--seconds", type=float, default=120.0,
               help="max wall-clock budget for the timed chunks (default 120 s; at least "
                    "one chunk is always timed)")
p.add_argument("--format", choices=["Dense", "Sparse", "OrderedSparse"], default="Dense",
               help="jax-md neighbour-list format (default Dense, the usual fastest on GPU)")
p.add_argument("--capacity", type=float, default=1.25,
               help="neighbour-list capacity_multiplier (default 1.25, jax-md's default)")
p.add_argument("--smooth-onset", type=float, default=None,
               help="use jax-md's stock energy.lennard_jones_neighbor_list with this "
                    "r_onset (C1 multiplicative smoothing from r_onset to 2.5) instead of "
                    "the plain lj/cut truncation; not the in.lj physics")
args = p.parse_args()

import warnings

# jax-md's util.high_precision_sum asks for float64, which jax (x64 off) truncates to
# float32 with a UserWarning per trace; it is harmless noise here.
warnings.filterwarnings("ignore", message="Explicitly requested dtype float64")

import numpy as onp
import jax
import jax.numpy as jnp

# --------------------------------------------------------------------------------------
# Compatibility shims, applied before jax_md is imported. Each one only fills a gap; none
# replaces anything that exists.
# --------------------------------------------------------------------------------------

# Shim 1: jax.tree_map was removed from the top-level jax namespace (jax >= 0.6); older
# jax-md code paths (and its nn modules) may still call it.
if not hasattr(jax, "tree_map"):
    jax.tree_map = jax.tree_util.tree_map

# Shim 2: jax-md's space/partition/smap do `from jax.core import ShapedArray` (used only
# as an abstract argument to eval_shape). If a future jax drops it from jax.core, a
# ShapeDtypeStruct serves the same purpose there.
try:
    from jax.core import ShapedArray as _unused  # noqa: F401
except ImportError:
    import jax.core
    jax.core.ShapedArray = jax.ShapeDtypeStruct


def _import_jax_md():
    """Returns (space, partition, energy, simulate, quantity, smap, how)."""
    # First choice: the ordinary, full `import jax_md` (works when its optional heavy
    # dependencies e3nn-jax/sympy/pymatgen... happen to be installed).
    try:
        import jax_md  # noqa: F401
        from jax_md import space, partition, energy, simulate, quantity, smap
        return space, partition, energy, simulate, quantity, smap, "full import"
    except ImportError as e:
        log(f"# full `import jax_md` failed ({type(e).__name__}: {e}); "
            "using the core-module import with jax_md.nn stubbed")
        for k in [k for k in sys.modules if k == "jax_md" or k.startswith("jax_md.")]:
            del sys.modules[k]

    # Shim 3: jax_md/__init__.py imports jax_md.nn (neural-network potentials), which
    # needs e3nn-jax (+ sympy, attrs) — not installed and not needed for LJ. So register
    # a bare `jax_md` package object (same __path__, __init__ not executed) so that the
    # core submodules can be imported one by one.
    spec = importlib.util.find_spec("jax_md")
    if spec is None or not spec.submodule_search_locations:
        raise ImportError("jax_md is not installed (see the module docstring)")
    pkg = types.ModuleType("jax_md")
    pkg.__path__ = list(spec.submodule_search_locations)
    pkg.__file__ = spec.origin
    pkg.__spec__ = spec
    sys.modules["jax_md"] = pkg

    # Shim 4: jax_md.energy does `from jax_md import nn` and, at module level, only reads
    # attributes of it (aliases `bp = nn.behler_parrinello`, default arguments such as
    # `nn.DEFAULT_KERNEL_INIT`, `nn.util.neighbor_list_featurizer`). A stub module whose
    # every attribute is a placeholder (attribute access chains; calling raises) satisfies
    # that without importing e3nn-jax. Nothing used by this benchmark touches it.
    class _Stub:
        def __init__(self, name):
            self._name = name

        def __getattr__(self, attr):
            if attr.startswith("__"):
                raise AttributeError(attr)
            return _Stub(f"{self._name}.{attr}")

        def __call__(self, *a, **k):
            raise RuntimeError(f"{self._name} is stubbed out in this benchmark")

        def __repr__(self):
            return f"<stub {self._name}>"

    nn = types.ModuleType("jax_md.nn")

    def _nn_getattr(attr):
        if attr.startswith("__"):
            raise AttributeError(attr)
        return _Stub(f"jax_md.nn.{attr}")

    nn.__getattr__ = _nn_getattr
    sys.modules["jax_md.nn"] = nn
    pkg.nn = nn

    from jax_md import space, partition, energy, simulate, quantity, smap
    return space, partition, energy, simulate, quantity, smap, "core modules, nn stubbed"


space, partition, energy, simulate, quantity, smap, how = _import_jax_md()
try:
    from importlib.metadata import version as _v
    jmd_version = _v("jax-md")
except Exception:
    jmd_version = "?"

log(f"# jax {jax.__version__}, jax-md {jmd_version} ({how}), numpy {onp.__version__}")
log(f"# devices: {jax.devices()}")

# --------------------------------------------------------------------------------------
# The in.lj state.
# --------------------------------------------------------------------------------------
RHO, T0, RC, SKIN, DT = 0.8442, 1.44, 2.5, 0.3, 0.005
C = args.cells
a = (4.0 / RHO) ** (1.0 / 3.0)  # FCC lattice constant
L = C * a
basis = onp.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
g = onp.arange(C)
cells = onp.stack(onp.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 1, 3)
pos0 = ((cells + basis[None]) * a).reshape(-1, 3)
N = pos0.shape[0]

rng = onp.random.default_rng(87287)
v = rng.standard_normal((N, 3))
v -= v.mean(axis=0)                          # zero total momentum (unit masses)
ke = 0.5 * (v * v).sum()
v *= math.sqrt(T0 * (3 * N - 3) / (2 * ke))  # T = 2 KE / (3N - 3) = 1.44 exactly

log(f"# N = {N} atoms ({C}^3 FCC cells), L = {L:.6f}, rc = {RC}, skin = {SKIN}, "
    f"dt = {DT}, format = {args.format}, capacity_multiplier = {args.capacity}")

displacement, shift = space.periodic(L)
fmt = getattr(partition.NeighborListFormat, args.format)

if args.smooth_onset is None:
    # Plain lj/cut, as LAMMPS in.lj: U(r) = 4 (r^-12 - r^-6) for r < 2.5, 0 beyond, NOT
    # shifted (so the energy jumps by 4(2.5^-12 - 2.5^-6) ~ -0.0163 at the cutoff) and no
    # smoothing; force = -dU/dr inside, 0 outside. jax-md's convenience wrapper
    # energy.lennard_jones_neighbor_list always multiplies by its C1 switch S(r) between
    # r_onset (default 2.0) and r_cutoff, and r_onset = r_cutoff is not usable (its
    # switch divides by r_cutoff^2 - r_onset^2 = 0 in the discarded branch, which gives
    # NaN gradients). So the same building blocks are composed here directly:
    # energy.lennard_jones (the pair function), a hard cutoff, smap.pair_neighbor_list
    # and partition.neighbor_list — exactly what lennard_jones_neighbor_list does inside.
    def lj_cut(dr, sigma=1.0, epsilon=1.0, **unused):
        return jnp.where(dr < RC, energy.lennard_jones(dr, sigma, epsilon), 0.0)

    neighbor_fn = partition.neighbor_list(
        displacement, L, RC, dr_threshold=SKIN, capacity_multiplier=args.capacity,
        format=fmt)
    energy_fn = smap.pair_neighbor_list(
        lj_cut, space.canonicalize_displacement_or_metric(displacement),
        ignore_unused_parameters=True, sigma=1.0, epsilon=1.0)
    pot_desc = "lj/cut 2.5, unshifted, unsmoothed"
else:
    # jax-md's stock wrapper: LJ times a C1 switch S(r) (HOOMD-style, S = 1 below r_onset,
    # 0 above 2.5), so energies differ slightly from in.lj.
    neighbor_fn, energy_fn = energy.lennard_jones_neighbor_list(
        displacement, L, sigma=1.0, epsilon=1.0, r_onset=args.smooth_onset,
        r_cutoff=RC, dr_threshold=SKIN, format=fmt, capacity_multiplier=args.capacity)
    pot_desc = f"jax-md lennard_jones_neighbor_list, smoothed from r_onset={args.smooth_onset}"
log(f"# potential: {pot_desc}")

init_fn, apply_fn = simulate.nve(energy_fn, shift, dt=DT)

R = jnp.asarray(pos0, dtype=jnp.float32)
P = jnp.asarray(v, dtype=jnp.float32)  # momenta = velocities (unit mass)
nbrs = neighbor_fn.allocate(R)
state = init_fn(jax.random.PRNGKey(0), R, kT=T0, mass=1.0, momenta=P, neighbor=nbrs)


@jax.jit
def total_energy(state, nbrs):
    pe = energy_fn(state.position, neighbor=nbrs)
    ke = quantity.kinetic_energy(momentum=state.momentum, mass=state.mass)
    return pe, ke


def make_chunk(n):
    @jax.jit
    def run_chunk(state, nbrs):
        def body(i, sn):
            s, nb = sn
            s = apply_fn(s, neighbor=nb)
            nb = nb.update(s.position)
            return s, nb
        return jax.lax.fori_loop(0, n, body, (state, nbrs))
    return run_chunk


run_chunk = make_chunk(args.chunk)
reallocs = 0
steps_done = 0


def advance(state, nbrs):
    """One chunk; on neighbour-buffer overflow reallocate and redo it from `state`."""
    global reallocs, steps_done
    extra = 0
    while True:
        s2, n2 = run_chunk(state, nbrs)
        s2.position.block_until_ready()
        if not bool(n2.did_buffer_overflow):
            steps_done += args.chunk
            return s2, n2
        reallocs += 1
        # Re-size from the chunk's starting positions; those alone may fit the old size
        # (the overflow happened later in the chunk), so add headroom that doubles on
        # each retry. A new max_occupancy means one recompile of the chunk.
        extra = max(8, 2 * extra)
        nbrs = neighbor_fn.allocate(state.position, extra_capacity=extra)
        log(f"# neighbour buffer overflow: reallocated (max_occupancy {nbrs.max_occupancy}),"
            " redoing the chunk")
        if reallocs > 50:
            raise RuntimeError("neighbour list keeps overflowing")


pe0, ke0 = (float(x) for x in total_energy(state, nbrs))
e0 = pe0 + ke0
log(f"# step 0: PE/N = {pe0 / N:.7f} (LAMMPS in.lj step 0: -6.773368053), KE/N = {ke0 / N:.7f}, "
    f"T = {2 * ke0 / (3 * N - 3):.5f}, E/N = {e0 / N:.7f}, "
    f"max_occupancy = {nbrs.max_occupancy}")

t = time.perf_counter()
state, nbrs = advance(state, nbrs)  # warm-up: compiles the chunk
log(f"# warm-up chunk ({args.chunk} steps, incl. compile): {time.perf_counter() - t:.2f} s")

nchunks = max(1, math.ceil(args.steps / args.chunk))
rates = []
t_start = time.perf_counter()
for k in range(nchunks):
    if k > 0 and time.perf_counter() - t_start > args.seconds:
        log(f"# budget of {args.seconds} s reached after {k} chunks")
        break
    r0 = reallocs
    t = time.perf_counter()
    state, nbrs = advance(state, nbrs)
    dt_wall = time.perf_counter() - t
    if reallocs != r0:
        # the overflow path recompiled / redid work: not a representative timing
        log(f"# chunk {k}: {dt_wall:.4f} s (reallocated; not timed)")
        continue
    rates.append(N * args.chunk / dt_wall)
    log(f"# chunk {k}: {dt_wall:.4f} s, {rates[-1]:.4e} atom-steps/s")

if not rates:  # every chunk reallocated: time one more
    t = time.perf_counter()
    state, nbrs = advance(state, nbrs)
    rates.append(N * args.chunk / (time.perf_counter() - t))

pe1, ke1 = (float(x) for x in total_energy(state, nbrs))
e1 = pe1 + ke1
log(f"# after {steps_done} steps: PE/N = {pe1 / N:.7f}, T = {2 * ke1 / (3 * N - 3):.5f}, "
    f"E/N = {e1 / N:.7f}; drift (E1-E0)/N = {(e1 - e0) / N:+.3e}, "
    f"relative {(e1 - e0) / abs(e0):+.3e}; reallocations {reallocs}")
if not (math.isfinite(e1) and math.isfinite(pe0)):
    log("# FAILED: non-finite energy; no rate reported")
    sys.exit(1)
rate = statistics.median(rates)
log(f"# median {rate:.4e} atom-steps/s over {len(rates)} chunks of {args.chunk} steps "
    f"(min {min(rates):.4e}, max {max(rates):.4e})")

print(f"jax-md lj {N},atom-steps/s,{rate:.6g}", flush=True)
