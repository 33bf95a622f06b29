# Type stubs of the native module (crates/python/src). Keep in step with the #[pyo3(signature)]
# of each method; tests/test_stubs.py checks that every name here exists and every public
# name there is here.
from os import PathLike
from typing import Any, Literal, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

ArrayLike = npt.ArrayLike
Backend = Literal["cpu", "gpu"]
Precision = Literal["f64", "f32"]
Path = Union[str, "PathLike[str]"]
Flags = Union[bool, Sequence[bool]]

class BlowUp(RuntimeError):
    """A run turned non-finite or left its physical limits during ``step(n)``."""

    step: int
    rolled_back_to: int
    what: str
    cause: str

def adapters() -> list[str]:
    """The GPU adapters this process can use, best first."""

def has_gpu_support() -> bool:
    """Whether this build has the GPU backends."""

class Md:
    """Molecular dynamics with Lennard-Jones pairs (velocity Verlet, constant energy)."""

    def __init__(
        self,
        positions: ArrayLike,
        velocities: Optional[ArrayLike] = None,
        *,
        box_lo: ArrayLike,
        box_hi: ArrayLike,
        species: Optional[ArrayLike] = None,
        masses: Optional[ArrayLike] = None,
        epsilon: Optional[Union[float, ArrayLike]] = None,
        sigma: Optional[Union[float, ArrayLike]] = None,
        cutoff: Optional[Union[float, ArrayLike]] = None,
        periodic: Optional[Flags] = None,
        dt: Optional[float] = None,
        shift: bool = False,
        integrator: Literal["velocity_verlet", "leapfrog"] = "velocity_verlet",
        precision: Precision = "f64",
        skin: Optional[float] = None,
        check_every: Optional[int] = None,
        allow_unstable_dt: bool = False,
        backend: Backend = "cpu",
    ) -> None: ...
    @staticmethod
    def fcc(
        cells: Optional[Union[int, Sequence[int]]] = None,
        density: float = 0.8442,
        temperature: float = 1.44,
        seed: int = 87287,
        *,
        epsilon: float = 1.0,
        sigma: float = 1.0,
        cutoff: float = 2.5,
        dt: Optional[float] = None,
        shift: bool = False,
        integrator: Literal["velocity_verlet", "leapfrog"] = "velocity_verlet",
        precision: Precision = "f64",
        skin: Optional[float] = None,
        check_every: Optional[int] = None,
        allow_unstable_dt: bool = False,
        backend: Backend = "cpu",
    ) -> "Md": ...
    def step(self, n: int) -> None: ...
    @property
    def positions(self) -> npt.NDArray[np.float64]: ...
    @property
    def velocities(self) -> npt.NDArray[np.float64]: ...
    @property
    def species(self) -> npt.NDArray[np.uint32]: ...
    def forces(self) -> npt.NDArray[np.float64]: ...
    def diagnostics(self) -> dict[str, Any]: ...
    def write_checkpoint(self, path: Path) -> None: ...
    @staticmethod
    def resume(path: Path, backend: Backend = "cpu") -> "Md": ...
    @property
    def time(self) -> float: ...
    @property
    def steps_done(self) -> int: ...
    @property
    def dt(self) -> float: ...
    @property
    def dim(self) -> int: ...
    @property
    def backend_name(self) -> str: ...
    @property
    def precision(self) -> Precision: ...
    def __len__(self) -> int: ...

class Dem:
    """Granular discs (2D) or spheres (3D), linear spring-dashpot contacts."""

    def __init__(
        self,
        positions: ArrayLike,
        radii: ArrayLike,
        masses: Optional[ArrayLike] = None,
        velocities: Optional[ArrayLike] = None,
        angular_velocities: Optional[ArrayLike] = None,
        *,
        box_lo: ArrayLike,
        box_hi: ArrayLike,
        contact_time: float,
        restitution: float = 0.9,
        mu_s: float = 0.0,
        mu_k: float = 0.0,
        wall_restitution: Optional[float] = None,
        walls: bool = True,
        periodic: Optional[Flags] = None,
        gravity: float = 0.0,
        vibration: Optional[Tuple[float, float]] = None,
        rotation: bool = False,
        dt: Optional[float] = None,
        integrator: Literal["velocity_verlet", "position_verlet"] = "velocity_verlet",
        precision: Precision = "f64",
        skin: Optional[float] = None,
        check_every: Optional[int] = None,
        max_overlap: Optional[float] = None,
        allow_unstable_dt: bool = False,
        backend: Backend = "cpu",
    ) -> None: ...
    @staticmethod
    def vibrating_bed(
        n: int = 128,
        width: int = 16,
        *,
        gamma: float = 3.0,
        freq_hz: float = 20.0,
        e_pp: float = 0.9,
        e_pw: float = 0.8,
        mu: float = 0.3,
        contact_time_s: float = 5e-4,
        precision: Precision = "f64",
        backend: Backend = "cpu",
    ) -> "Dem": ...
    @staticmethod
    def granular_box(
        nx: int,
        ny: int,
        nz: int,
        seed: int = 1,
        *,
        precision: Precision = "f64",
        backend: Backend = "cpu",
    ) -> "Dem": ...
    def step(self, n: int) -> None: ...
    @property
    def positions(self) -> npt.NDArray[np.float64]: ...
    @property
    def velocities(self) -> npt.NDArray[np.float64]: ...
    @property
    def angular_velocities(self) -> npt.NDArray[np.float64]: ...
    @property
    def radii(self) -> npt.NDArray[np.float64]: ...
    def diagnostics(self) -> dict[str, Any]: ...
    def write_checkpoint(self, path: Path) -> None: ...
    @staticmethod
    def resume(path: Path, backend: Backend = "cpu") -> "Dem": ...
    @property
    def time(self) -> float: ...
    @property
    def steps_done(self) -> int: ...
    @property
    def dt(self) -> float: ...
    @property
    def dim(self) -> int: ...
    @property
    def backend_name(self) -> str: ...
    @property
    def precision(self) -> Precision: ...
    def __len__(self) -> int: ...

class Rd:
    """Reaction-diffusion on a 2D grid; fields of shape (species, ny, nx)."""

    @staticmethod
    def gray_scott(
        fields: ArrayLike,
        *,
        du: float,
        dv: float,
        feed: float,
        kill: float,
        dt: float,
        h: float = 1.0,
        boundary: Optional[Union[Literal["periodic", "no_flux"], Sequence[float]]] = None,
        integrator: Literal["euler", "heun"] = "euler",
        precision: Precision = "f64",
        backend: Backend = "cpu",
    ) -> "Rd": ...
    @staticmethod
    def gray_scott_square(
        n: int,
        *,
        side: Optional[int] = None,
        seed: int = 1,
        h: Optional[float] = None,
        du: float = 2e-5,
        dv: float = 1e-5,
        feed: float = 0.04,
        kill: float = 0.06,
        dt: float = 1.0,
        integrator: Literal["euler", "heun"] = "euler",
        precision: Precision = "f64",
        backend: Backend = "cpu",
    ) -> "Rd": ...
    @staticmethod
    def diffusion(
        fields: ArrayLike,
        *,
        diffusivity: ArrayLike,
        dt: float,
        h: float = 1.0,
        boundary: Optional[Union[Literal["periodic", "no_flux"], Sequence[float]]] = None,
        integrator: Literal["euler", "heun"] = "euler",
        precision: Precision = "f64",
        backend: Backend = "cpu",
    ) -> "Rd": ...
    @staticmethod
    def colony(
        nx: int,
        ny: int,
        seed: int = 7,
        *,
        dt: float = 0.005,
        integrator: Literal["euler", "heun"] = "euler",
        precision: Precision = "f32",
        backend: Backend = "cpu",
    ) -> "Rd": ...
    def step(self, n: int) -> None: ...
    @property
    def fields(self) -> npt.NDArray[Any]: ...
    def total(self, s: int) -> float: ...
    def stable_dt(self) -> float: ...
    def write_checkpoint(self, path: Path) -> None: ...
    @staticmethod
    def resume(path: Path, backend: Backend = "cpu") -> "Rd": ...
    @property
    def time(self) -> float: ...
    @property
    def steps_done(self) -> int: ...
    @property
    def backend_name(self) -> str: ...

class LatticeGas:
    """The FHP lattice gas; cells of shape (height, width), uint8."""

    def __init__(
        self,
        cells: ArrayLike,
        *,
        rules: Literal["fhp_i", "full"] = "fhp_i",
        seed: int = 1,
        periodic_x: bool = True,
        periodic_y: bool = True,
        inflow: bool = False,
        outflow: bool = False,
        body_force: float = 0.0,
        cpu_method: Literal["auto", "lut", "lut_portable", "multi_spin"] = "auto",
        backend: Backend = "cpu",
    ) -> None: ...
    @staticmethod
    def channel(
        width: int = 256,
        height: int = 128,
        *,
        density_forward: float = 0.5,
        density_other: float = 0.15,
        fill_seed: int = 3,
        seed: int = 2026,
        backend: Backend = "cpu",
    ) -> "LatticeGas": ...
    @staticmethod
    def random(
        width: int,
        height: int,
        density: float,
        fill_seed: int = 1,
        *,
        rules: Literal["fhp_i", "full"] = "fhp_i",
        seed: int = 1,
        backend: Backend = "cpu",
    ) -> "LatticeGas": ...
    def step(self, n: int) -> None: ...
    @property
    def cells(self) -> npt.NDArray[np.uint8]: ...
    def totals(self) -> dict[str, Any]: ...
    def block_field(self, block: int = 8) -> dict[str, npt.NDArray[np.float64]]: ...
    def write_checkpoint(self, path: Path) -> None: ...
    @staticmethod
    def resume(path: Path, backend: Backend = "cpu") -> "LatticeGas": ...
    @property
    def steps_done(self) -> int: ...
    @property
    def backend_name(self) -> str: ...

class PpCoulomb:
    """Direct-sum Coulomb dynamics of point charges."""

    def __init__(
        self,
        positions: ArrayLike,
        charges: Union[float, ArrayLike],
        masses: Union[float, ArrayLike],
        velocities: Optional[ArrayLike] = None,
        *,
        dt: float,
        force: Literal["exact", "plummer", "exclusion"] = "exact",
        softening: Optional[float] = None,
        integrator: Literal["leapfrog", "symplectic_euler"] = "leapfrog",
        precision: Precision = "f64",
        check_every: Optional[int] = None,
        backend: Backend = "cpu",
    ) -> None: ...
    @staticmethod
    def cold_sphere(
        n: int,
        radius: float = 1.0,
        seed: int = 7,
        *,
        dt: float,
        force: Literal["exact", "plummer", "exclusion"] = "exact",
        softening: Optional[float] = None,
        integrator: Literal["leapfrog", "symplectic_euler"] = "leapfrog",
        precision: Precision = "f64",
        check_every: Optional[int] = None,
        backend: Backend = "cpu",
    ) -> "PpCoulomb": ...
    def step(self, n: int) -> None: ...
    @property
    def positions(self) -> npt.NDArray[np.float64]: ...
    @property
    def velocities(self) -> npt.NDArray[np.float64]: ...
    def accelerations(self) -> npt.NDArray[np.float64]: ...
    def diagnostics(self) -> dict[str, Any]: ...
    def set_dt(self, dt: float) -> None: ...
    def write_checkpoint(self, path: Path) -> None: ...
    @staticmethod
    def resume(path: Path, backend: Backend = "cpu") -> "PpCoulomb": ...
    @property
    def time(self) -> float: ...
    @property
    def interactions_per_step(self) -> float: ...
    @property
    def steps_done(self) -> int: ...
    @property
    def backend_name(self) -> str: ...
    @property
    def precision(self) -> Precision: ...
    def __len__(self) -> int: ...

class NeighborSearch:
    """All pairs of points closer than a cutoff, in 2D or 3D."""

    def __init__(
        self,
        box_lo: ArrayLike,
        box_hi: ArrayLike,
        cutoff: float,
        *,
        periodic: Optional[Flags] = None,
        method: Literal["sorted", "linked", "verlet", "brute", "gpu"] = "sorted",
        skin: float = 0.3,
    ) -> None: ...
    def build(self, points: ArrayLike) -> None: ...
    def pairs(self) -> Tuple[npt.NDArray[np.uint32], npt.NDArray[np.float64]]: ...
    def pair_count(self) -> int: ...
    def neighbor_counts(self) -> npt.NDArray[np.uint32]: ...
    @property
    def dim(self) -> int: ...
    @property
    def method(self) -> str: ...
