"""simkit from Python: particle and field simulations on CPU and GPU.

Classes (one per simulation library of the Rust workspace):

- ``Md``: multi-species molecular dynamics with Lennard-Jones pairs (``Md.fcc`` builds
  LAMMPS's ``in.lj`` state);
- ``Dem``: granular discs and spheres, linear spring-dashpot contacts with friction and
  rotation (``Dem.vibrating_bed``, ``Dem.granular_box``);
- ``Rd``: reaction-diffusion on a 2D grid (``Rd.gray_scott``, ``Rd.gray_scott_square``,
  ``Rd.diffusion``, ``Rd.colony``);
- ``LatticeGas``: the FHP lattice gas (``LatticeGas.channel``, ``LatticeGas.random``);
- ``PpCoulomb``: direct-sum Coulomb dynamics (``PpCoulomb.cold_sphere``);
- ``NeighborSearch``: all pairs closer than a cutoff (cell lists, Verlet lists, GPU).

Every simulation has ``step(n)`` (the GIL is released while it runs), its state as numpy
arrays (new arrays holding a snapshot: writing to them does not change the simulation),
``diagnostics()`` as a dict, ``write_checkpoint(path)`` and ``Cls.resume(path)``, and a
``backend`` keyword: ``"cpu"`` (multi-threaded) or ``"gpu"`` (see ``adapters()``).
A bad argument raises ``ValueError`` or ``TypeError`` naming it; a run that turns
non-finite raises ``BlowUp`` (a ``RuntimeError``) with ``step``, ``rolled_back_to``,
``what`` and ``cause``, the simulation holding the last state that passed the check.

Pair laws and reaction models are the built-in ones: a law written in Python would run
at Python's speed in the innermost loop, so custom laws stay on the Rust side (the Rust
``PairLaw`` and ``Model`` traits).

Run ``python -m simkit.tour`` for a tour of every class.
"""

from ._native import (
    BlowUp,
    Dem,
    LatticeGas,
    Md,
    NeighborSearch,
    PpCoulomb,
    Rd,
    __version__,
    adapters,
    has_gpu_support,
)

__all__ = [
    "BlowUp",
    "Dem",
    "LatticeGas",
    "Md",
    "NeighborSearch",
    "PpCoulomb",
    "Rd",
    "__version__",
    "adapters",
    "best_backend",
    "has_gpu_support",
]


def best_backend() -> str:
    """``"gpu"`` when this build has GPU support and an adapter is present, else ``"cpu"``."""
    return "gpu" if has_gpu_support() and adapters() else "cpu"
