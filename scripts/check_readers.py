#!/usr/bin/env python3
"""Open simkit's output files with the readers people use and check what they read.

Usage: check_readers.py SAMPLES_DIR [EXAMPLE_DIR ...]

SAMPLES_DIR holds the files of `cargo run --example write_samples -- SAMPLES_DIR`; their
values follow formulas of the particle or grid index that this script recomputes (keep the
two in step). Each EXAMPLE_DIR is the output directory of an example run; there every
`.pvd` series and every file it lists, every `.vtp`, `.vti` and `.xyz` is opened and checked
for consistency (counts, array names and sizes, sizes that are finite and positive, and the
`.vtp` frames against the `.xyz` frames when a directory has both).

Readers: VTK's XML readers (vtkXMLPolyDataReader, vtkXMLImageDataReader; `.pvd` files are
parsed with xml.etree and each listed file opened), ASE (`ase.io.read(path, index=":")`),
the `gsd` package (`gsd.hoomd.open`) for `.gsd` trajectories, whose boxes and positions are
then handed to freud (its neighbour query against a direct search), and the csv module; and OVITO's `ovito.io.import_file` on the samples where the `ovito` module is
installed (optional: it is large, and CI does not install it; checked with OVITO 3.17.2,
which reads the GSD trajectories' positions, velocities, radii (half the diameters), types,
box and `log/particles/...` arrays as particle properties). Any reader error or warning, or any mismatch, is a failure; the script prints
one line per check and `N passed, M failed`, and exits non-zero when M > 0.
"""

import csv
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import ase.io
import freud
import gsd
import gsd.fl
import gsd.hoomd
import gsd.version
import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy

N = 6
KINDS = ["gas", "liquid", "solid"]
ELEMENTS = ["H", "He", "Li"]

passed = 0
failed = 0


def check(name, fn):
    """Runs one check; a raised exception or a failed assert is a failure."""
    global passed, failed
    try:
        fn()
    except Exception as e:  # noqa: BLE001 - every failure is reported, then counted
        failed += 1
        print(f"FAIL {name}: {type(e).__name__}: {e}")
    else:
        passed += 1
        print(f"ok   {name}")


def equal(got, want, what):
    got, want = np.asarray(got, dtype=float), np.asarray(want, dtype=float)
    assert got.shape == want.shape, f"{what}: shape {got.shape}, expected {want.shape}"
    assert np.array_equal(got, want), f"{what}: {got.tolist()} != {want.tolist()}"


# The formulas of examples/write_samples.rs.
def position(i, f):
    return [0.5 * i + f, 0.25 * i * i, -i / 3.0]


def velocity(i):
    return [float(i), -2.0 * i, 0.5]


def radius(i):
    return 0.1 + 0.05 * i


# The box of the GSD samples (examples/write_samples.rs): stored relative to its centre.
GSD_LO = np.array([-1.0, -1.0, -2.0])
GSD_HI = np.array([5.0, 7.0, 1.0])


def gsd_frames(path):
    """Every frame of a GSD file through gsd.hoomd, checked to be a hoomd-schema file."""
    with gsd.hoomd.open(str(path), "r") as traj:
        assert traj.file.schema == "hoomd", traj.file.schema
        return list(traj)


def check_freud_pairs(frame, r_max):
    """freud's AABBQuery on the frame's box and positions finds the pairs within r_max
    that a direct minimum-image search over all pairs finds."""
    box = freud.box.Box.from_box(frame.configuration.box, dimensions=frame.configuration.dimensions)
    pos = np.asarray(frame.particles.position, dtype=np.float32)
    q = freud.locality.AABBQuery(box, pos)
    lengths = np.asarray(frame.configuration.box[:3], dtype=float)
    d = pos[None, :, :].astype(float) - pos[:, None, :].astype(float)
    periodic = lengths > 0
    d[..., periodic] -= lengths[periodic] * np.round(d[..., periodic] / lengths[periodic])
    r = np.sqrt((d**2).sum(axis=-1))
    np.fill_diagonal(r, np.inf)
    # Pairs within rounding of r_max could go either way: move r_max off them.
    while np.any(np.abs(r - r_max) < 1e-5):
        r_max += 3e-5
    want = {(int(i), int(j)) for i, j in zip(*np.nonzero(r < r_max))}
    nlist = q.query(pos, {"r_max": r_max, "exclude_ii": True}).toNeighborList()
    got = {(int(i), int(j)) for i, j in zip(nlist.query_point_indices, nlist.point_indices)}
    assert got == want, f"freud found {len(got)} pairs, the direct search {len(want)}"
    return len(want)


def read_vtk(path):
    """Reads a `.vtp` or `.vti` file with VTK; reader errors and warnings raise."""
    kind = {".vtp": vtk.vtkXMLPolyDataReader, ".vti": vtk.vtkXMLImageDataReader}
    reader = kind[path.suffix]()
    problems = []
    for event in ("ErrorEvent", "WarningEvent"):
        reader.AddObserver(event, lambda obj, ev: problems.append(ev))
    reader.SetFileName(str(path))
    reader.Update()
    assert not problems, f"{path.name}: VTK reported {problems}"
    data = reader.GetOutput()
    assert data is not None and data.GetNumberOfPoints() > 0, f"{path.name}: no points"
    return data


def point_arrays(data):
    pd = data.GetPointData()
    out = {}
    for k in range(pd.GetNumberOfArrays()):
        a = pd.GetArray(k)
        out[a.GetName()] = vtk_to_numpy(a)
    return out


def check_sample_particles(path, frame):
    data = read_vtk(path)
    assert data.GetNumberOfPoints() == N, data.GetNumberOfPoints()
    assert data.GetNumberOfVerts() == N, f"{data.GetNumberOfVerts()} vertices"
    equal(vtk_to_numpy(data.GetPoints().GetData()), [position(i, frame) for i in range(N)], "points")
    arrays = point_arrays(data)
    assert sorted(arrays) == ["Velocity", "id", "radius", "species"], sorted(arrays)
    equal(arrays["radius"], [radius(i) for i in range(N)], "radius")
    equal(arrays["Velocity"], [velocity(i) for i in range(N)], "Velocity")
    equal(arrays["species"], [i % 3 for i in range(N)], "species")
    equal(arrays["id"], [100 + i for i in range(N)], "id")
    for name in ("species", "id"):
        assert np.issubdtype(arrays[name].dtype, np.integer), f"{name}: {arrays[name].dtype}"


def pvd_entries(path):
    root = ET.parse(path).getroot()
    assert root.get("type") == "Collection", root.get("type")
    sets = root.find("Collection").findall("DataSet")
    assert sets, "no DataSet"
    return [(float(s.get("timestep")), path.parent / s.get("file")) for s in sets]


def check_samples(d):
    check("particles.vtp (binary)", lambda: check_sample_particles(d / "particles.vtp", 0))
    check("particles_ascii.vtp", lambda: check_sample_particles(d / "particles_ascii.vtp", 0))

    def series():
        entries = pvd_entries(d / "series.pvd")
        assert [t for t, _ in entries] == [0.0, 0.5], entries
        for f, (_, file) in enumerate(entries):
            check_sample_particles(file, f)

    check("series.pvd of .vtp", series)

    def grid():
        g = read_vtk(d / "grid.vti")
        assert g.GetDimensions() == (4, 3, 2), g.GetDimensions()
        equal(g.GetOrigin(), [0.0, -1.0, 0.5], "origin")
        equal(g.GetSpacing(), [0.5, 0.25, 1.0], "spacing")
        a = point_arrays(g)
        assert sorted(a) == ["rho", "u"], sorted(a)
        idx = [(i, j, k) for k in range(2) for j in range(3) for i in range(4)]
        equal(a["rho"], [i + 10 * j + 100 * k for i, j, k in idx], "rho")
        equal(a["u"], [[i / 2.0, -j, k] for i, j, k in idx], "u")

    check("grid.vti (binary)", grid)

    def grid_ascii():
        g = read_vtk(d / "grid_ascii.vti")
        assert g.GetDimensions() == (5, 4, 1), g.GetDimensions()
        equal(g.GetOrigin(), [1.0, 2.0, 0.0], "origin")
        equal(g.GetSpacing(), [0.1, 0.2, 1.0], "spacing")
        a = point_arrays(g)
        idx = [(i, j) for j in range(4) for i in range(5)]
        equal(a["phi"], [i * j / 7.0 for i, j in idx], "phi")
        equal(a["g"], [[i, j, 0.0] for i, j in idx], "g (padded to 3)")

    check("grid_ascii.vti", grid_ascii)

    def traj():
        frames = ase.io.read(d / "traj.xyz", index=":")
        assert len(frames) == 2, len(frames)
        for f, atoms in enumerate(frames):
            assert len(atoms) == N, len(atoms)
            symbols = atoms.get_chemical_symbols()
            assert symbols == [ELEMENTS[i % 3] for i in range(N)], symbols
            kinds = list(atoms.arrays["kind"])
            assert kinds == [KINDS[i % 3] for i in range(N)], kinds
            equal(atoms.positions, [position(i, f) for i in range(N)], "positions")
            equal(atoms.arrays["velo"], [velocity(i) for i in range(N)], "velo")
            equal(atoms.arrays["Radius"], [radius(i) for i in range(N)], "Radius")
            equal(atoms.cell[:], np.diag([10.0, 8.0, 6.0]), "cell")
            assert list(atoms.pbc) == [True, True, False], atoms.pbc
            assert atoms.info["Time"] == 0.5 * f, atoms.info

    check("traj.xyz (ASE)", traj)

    def elements():
        (atoms,) = ase.io.read(d / "elements.xyz", index=":")
        assert atoms.get_chemical_symbols() == ["Ar"] * N
        assert np.all(atoms.numbers == 18)
        equal(atoms.positions, [position(i, 0) for i in range(N)], "positions")

    check("elements.xyz (ASE)", elements)

    def table():
        with open(d / "series.csv", newline="") as fh:
            rows = list(csv.reader(fh))
        assert rows[0] == ["t", "energy"], rows[0]
        equal([[float(v) for v in r] for r in rows[1:]], [[0.1 * k, -1.5 * k] for k in range(5)], "rows")

    check("series.csv", table)

    def gsd_traj(name, dtype, schema):
        frames = gsd_frames(d / name)
        with gsd.fl.open(str(d / name), "r") as f:
            assert f.schema_version == schema, f.schema_version
        assert len(frames) == 2, len(frames)
        centre = 0.5 * (GSD_LO + GSD_HI)
        for f, frame in enumerate(frames):
            assert frame.configuration.step == 100 * f, frame.configuration.step
            assert frame.configuration.dimensions == 3
            equal(frame.configuration.box, list(GSD_HI - GSD_LO) + [0, 0, 0], "box")
            assert frame.particles.N == N, frame.particles.N
            want = np.array([position(i, f) for i in range(N)]) - centre
            assert frame.particles.position.dtype == dtype, frame.particles.position.dtype
            equal(frame.particles.position, want.astype(dtype), "position")
            equal(frame.particles.velocity, np.array([velocity(i) for i in range(N)], dtype), "velocity")
            assert frame.particles.types == KINDS, frame.particles.types
            equal(frame.particles.typeid, [i % 3 for i in range(N)], "typeid")
            diameters = np.array([2 * radius(i) for i in range(N)], dtype)
            equal(frame.particles.diameter, diameters, "diameter (frame 0's in frame 1)")
            equal(frame.particles.mass, [1 + i for i in range(N)], "mass")
            spin = [[i, 0, -i] for i in range(N)]
            equal(frame.log["particles/angular_velocity"], spin, "log angular velocity")
            equal(frame.log["energy/kinetic"], [0.5 * f], "log kinetic energy")

    check(f"traj.gsd (f32, gsd {gsd.version.version})", lambda: gsd_traj("traj.gsd", np.float32, (1, 4)))
    check("traj64.gsd (f64, schema 2.0)", lambda: gsd_traj("traj64.gsd", np.float64, (2, 0)))

    def gsd_flat():
        (frame,) = gsd_frames(d / "flat.gsd")
        assert frame.configuration.step == 7 and frame.configuration.dimensions == 2
        equal(frame.configuration.box, [6, 8, 0, 0, 0, 0], "2D box")
        centre = 0.5 * (GSD_LO + GSD_HI)
        want = [[p[0] - centre[0], p[1] - centre[1], 0] for p in (position(i, 0) for i in range(N))]
        equal(frame.particles.position, np.float32(want), "2D position")
        equal(frame.particles.velocity, np.float32([velocity(i)[:2] + [0] for i in range(N)]), "2D velocity")

    check("flat.gsd (2D)", gsd_flat)

    def gsd_freud():
        for name in ("traj.gsd", "traj64.gsd", "flat.gsd"):
            for frame in gsd_frames(d / name):
                assert check_freud_pairs(frame, 1.3) > 0, "no pairs to compare"

    check(f"traj.gsd, traj64.gsd and flat.gsd in freud {freud.__version__} (AABBQuery)", gsd_freud)


def check_particle_file(path):
    """A `.vtp` from an example: counts, array sizes, a positive finite radius."""
    data = read_vtk(path)
    n = data.GetNumberOfPoints()
    assert data.GetNumberOfVerts() == n, f"{data.GetNumberOfVerts()} vertices, {n} points"
    arrays = point_arrays(data)
    assert "radius" in arrays, f"no radius array: {sorted(arrays)}"
    for name, a in arrays.items():
        assert len(a) == n, f"{name}: {len(a)} tuples for {n} points"
    r = arrays["radius"]
    assert np.all(np.isfinite(r)) and np.all(r > 0), f"radius: {r.min()}..{r.max()}"
    return data, arrays


def check_example(d):
    series = sorted(d.glob("*.pvd"))
    listed = set()
    vtp_frames = []
    for pvd in series:
        entries = pvd_entries(pvd)
        files = [f for _, f in entries]
        listed.update(files)

        def each(files=files):
            times = [t for t, _ in entries]
            assert times == sorted(times), f"times not increasing: {times}"
            for f in files:
                assert f.exists(), f"{f.name} listed but missing"
                if f.suffix == ".vtp":
                    vtp_frames.append(check_particle_file(f))
                else:
                    read_vtk(f)

        check(f"{d.name}/{pvd.name} ({len(files)} files)", each)
    for f in sorted(d.glob("*.vtp")):
        if f not in listed:
            check(f"{d.name}/{f.name}", lambda f=f: vtp_frames.append(check_particle_file(f)))
    for f in sorted(d.glob("*.vti")):
        check(f"{d.name}/{f.name}", lambda f=f: read_vtk(f))
    for f in sorted(d.glob("*.xyz")):

        def xyz(f=f):
            frames = ase.io.read(f, index=":")
            assert frames, "no frames"
            for atoms in frames:
                r = atoms.arrays.get("Radius")
                assert r is not None and np.all(r > 0), "no positive Radius column"
                assert "velo" in atoms.arrays, sorted(atoms.arrays)
            if vtp_frames:
                # The examples write their .xyz frames at the same times as their .vtp files.
                assert len(frames) == len(vtp_frames), (
                    f"{len(frames)} xyz frames, {len(vtp_frames)} vtp frames"
                )
                for atoms, (data, arrays) in zip(frames, vtp_frames):
                    pts = vtk_to_numpy(data.GetPoints().GetData())
                    equal(atoms.positions, pts, "xyz positions vs vtp points")
                    equal(atoms.arrays["Radius"], arrays["radius"], "xyz Radius vs vtp radius")
                    equal(atoms.arrays["velo"], arrays["Velocity"], "xyz velo vs vtp Velocity")

        check(f"{d.name}/{f.name} (ASE)", xyz)

    for f in sorted(d.glob("*.gsd")):

        def trajectory(f=f):
            frames = gsd_frames(f)
            assert frames, "no frames"
            steps = [int(fr.configuration.step) for fr in frames]
            assert steps == sorted(set(steps)), f"steps not increasing: {steps}"
            for fr in frames:
                n = fr.particles.N
                assert n > 0 and fr.particles.position.shape == (n, 3), fr.particles.position.shape
                assert np.all(fr.particles.diameter > 0), "diameters not positive"
                half = 0.5 * np.asarray(fr.configuration.box[:3])
                inside = np.abs(fr.particles.position[:, : fr.configuration.dimensions])
                assert np.all(inside <= half[: fr.configuration.dimensions] * (1 + 1e-6)), "outside the box"
            check_freud_pairs(frames[-1], 0.5 * float(np.min(frames[-1].particles.diameter)) + 0.731)
            return frames

        check(f"{d.name}/{f.name} (gsd, freud)", trajectory)

    def not_empty():
        kinds = ("*.pvd", "*.vtp", "*.vti", "*.xyz", "*.gsd")
        assert any(any(d.glob(k)) for k in kinds), f"no VTK or XYZ files in {d}"

    check(f"{d.name} has files", not_empty)


def check_ovito(d):
    """With OVITO's Python module installed (optional, not in CI: `pip install ovito`),
    checks that OVITO maps the sample files to its standard particle properties."""
    try:
        from ovito.io import import_file
    except ImportError:
        print("skip OVITO checks (no ovito module)")
        return

    def particles(path, frames):
        pipeline = import_file(str(path))
        assert pipeline.source.num_frames == frames, pipeline.source.num_frames
        for f in range(frames):
            p = pipeline.compute(f).particles
            assert p.count == N, p.count
            equal(p["Position"][...], [position(i, f) for i in range(N)], "Position")
            equal(p["Velocity"][...], [velocity(i) for i in range(N)], "Velocity")
            # OVITO stores radii in single precision.
            r = np.asarray(p["Radius"][...], dtype=float)
            assert np.allclose(r, [radius(i) for i in range(N)], rtol=1e-7), r
            yield p

    def series():
        for p in particles(d / "series.pvd", 2):
            equal(p["Particle Identifier"][...], [100 + i for i in range(N)], "id")

    check("OVITO series.pvd of .vtp", series)

    def grid():
        data = import_file(str(d / "grid.vti")).compute()
        (g,) = [o for o in data.objects if type(o).__name__ == "VoxelGrid"]
        assert tuple(g.shape) == (4, 3, 2), g.shape
        idx = [(i, j, k) for k in range(2) for j in range(3) for i in range(4)]
        equal(g["rho"][...], [i + 10 * j + 100 * k for i, j, k in idx], "rho")

    check("OVITO grid.vti", grid)

    def traj():
        for p in particles(d / "traj.xyz", 2):
            names = [p.particle_types.type_by_id(t).name for t in p["Particle Type"][...]]
            assert names == [ELEMENTS[i % 3] for i in range(N)], names

    check("OVITO traj.xyz", traj)

    def traj_gsd(name, dtype):
        centre = 0.5 * (GSD_LO + GSD_HI)
        pipeline = import_file(str(d / name))
        assert pipeline.source.num_frames == 2, pipeline.source.num_frames
        for f in range(2):
            data = pipeline.compute(f)
            p = data.particles
            want = np.array([position(i, f) for i in range(N)]) - centre
            equal(p["Position"][...], want.astype(dtype), "GSD Position")
            equal(p["Velocity"][...], np.array([velocity(i) for i in range(N)], dtype), "GSD Velocity")
            # OVITO keeps radii in f32 (half the diameter, exact in either file).
            equal(p["Radius"][...], np.float32([radius(i) for i in range(N)]), "GSD Radius")
            names = [p.particle_types.type_by_id(t).name for t in p["Particle Type"][...]]
            assert names == [KINDS[i % 3] for i in range(N)], names
            equal(p["angular_velocity"][...], [[i, 0, -i] for i in range(N)], "GSD angular_velocity")
            equal(data.cell[...][:, 3], -0.5 * (GSD_HI - GSD_LO), "GSD cell origin")

    check("OVITO traj.gsd (f32)", lambda: traj_gsd("traj.gsd", np.float32))
    check("OVITO traj64.gsd (f64)", lambda: traj_gsd("traj64.gsd", np.float64))


def main():
    if len(sys.argv) < 2:
        print(__doc__)
        return 2
    check_samples(Path(sys.argv[1]))
    check_ovito(Path(sys.argv[1]))
    for d in sys.argv[2:]:
        check_example(Path(d))
    versions = f"vtk {vtk.vtkVersion.GetVTKVersion()}, ase {ase.__version__}, gsd {gsd.version.version}, freud {freud.__version__}"
    print(f"{passed} passed, {failed} failed ({versions})")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
