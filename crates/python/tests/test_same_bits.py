"""Each class gives the same bits as the Rust API on the same scene (CPU, f64)."""

import numpy as np

import simkit


def same(path, actual, dtype=np.float64):
    want = np.fromfile(path, dtype=np.dtype(dtype).newbyteorder("<"))
    got = np.ascontiguousarray(actual).ravel()
    assert got.dtype == np.dtype(dtype)
    assert got.shape == want.shape
    # Bit for bit: compare the bytes, not the values (NaN != NaN, -0.0 == 0.0).
    assert got.astype(np.dtype(dtype).newbyteorder("<")).tobytes() == want.tobytes()


def test_md(reference):
    sim = simkit.Md.fcc(4, 0.8442, 1.44, 87287, dt=0.005)
    sim.step(100)
    same(reference("md_positions"), sim.positions)
    same(reference("md_velocities"), sim.velocities)


def test_dem(reference):
    sim = simkit.Dem.vibrating_bed(64, 8, contact_time_s=5e-4)
    sim.step(500)
    same(reference("dem_positions"), sim.positions)
    same(reference("dem_velocities"), sim.velocities)


def test_rd(reference):
    sim = simkit.Rd.gray_scott_square(64, side=8, seed=1)
    sim.step(200)
    same(reference("rd_fields"), sim.fields)


def test_lattice_gas(reference):
    sim = simkit.LatticeGas.random(64, 32, 0.3, 1)
    sim.step(100)
    same(reference("lattice_gas_cells"), sim.cells, np.uint8)


def test_pp_coulomb(reference):
    sim = simkit.PpCoulomb.cold_sphere(300, 1.0, 7, dt=0.01)
    sim.step(50)
    same(reference("pp_coulomb_positions"), sim.positions)
    same(reference("pp_coulomb_velocities"), sim.velocities)


def test_neighbor(reference):
    n, side = 2000, 12.0
    a = [0.6180339887498949, 0.4142135623730951, 0.7320508075688772]
    k = np.arange(n, dtype=np.float64)[:, None]
    points = ((k * np.array(a)) % 1.0) * side
    search = simkit.NeighborSearch([0, 0, 0], [side] * 3, 1.5)
    search.build(points)
    pairs, distances = search.pairs()
    same(reference("neighbor_pairs"), pairs, np.uint32)
    # The distances are the minimum-image ones, all within the cutoff.
    d = points[pairs[:, 0]] - points[pairs[:, 1]]
    d -= side * np.round(d / side)
    np.testing.assert_allclose(distances, np.sqrt((d * d).sum(axis=1)), rtol=1e-12)
    assert distances.max() < 1.5
