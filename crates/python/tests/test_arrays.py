"""numpy in and out: dtypes, shapes, contiguity, conversion of array-likes."""

import numpy as np
import pytest

import simkit


def test_outputs_are_owned_contiguous_arrays():
    sim = simkit.Md.fcc(4, dt=0.005)
    for a, dtype in [(sim.positions, np.float64), (sim.velocities, np.float64),
                     (sim.forces(), np.float64)]:
        assert a.dtype == dtype and a.shape == (256, 3)
        assert a.flags.c_contiguous and a.flags.writeable
    assert sim.species.dtype == np.uint32 and sim.species.shape == (256,)
    # A snapshot: writing to it does not change the simulation.
    p = sim.positions
    p[:] = 0.0
    assert sim.positions.any()


def test_inputs_accept_array_likes_of_any_real_dtype():
    pts = [[1, 1], [2.5, 1]]  # a list of ints and floats
    a = simkit.Md(pts, box_lo=[0, 0], box_hi=[8, 8])
    b = simkit.Md(np.array(pts, dtype=np.float32), box_lo=(0, 0), box_hi=np.array([8, 8]))
    c = simkit.Md(np.asfortranarray(np.array(pts, dtype=np.float64)), box_lo=[0, 0],
                  box_hi=[8, 8])
    assert a.dim == b.dim == c.dim == 2
    assert a.positions.shape == (2, 2)
    np.testing.assert_array_equal(a.positions, c.positions)
    # A strided view (every other row) is read correctly.
    many = np.arange(24, dtype=np.float64).reshape(12, 2) % 7 + 0.5
    d = simkit.Md(many[::2], box_lo=[0, 0], box_hi=[8, 8])
    np.testing.assert_array_equal(d.positions, many[::2])


def test_shapes_of_every_class():
    dem = simkit.Dem.vibrating_bed(32, 8)
    assert dem.positions.shape == (32, 2) and dem.angular_velocities.shape == (32, 3)
    assert dem.radii.shape == (32,)
    rd = simkit.Rd.gray_scott_square(16)
    assert rd.fields.shape == (2, 16, 16) and rd.fields.dtype == np.float64
    col = simkit.Rd.colony(24, 16)
    assert col.fields.shape == (2, 16, 24) and col.fields.dtype == np.float32
    lg = simkit.LatticeGas.random(32, 16, 0.2)
    assert lg.cells.shape == (16, 32) and lg.cells.dtype == np.uint8
    f = lg.block_field(8)
    assert f["ux"].shape == (2, 4)
    pp = simkit.PpCoulomb.cold_sphere(50, dt=0.01)
    assert pp.positions.shape == (50, 3) and pp.accelerations().shape == (50, 3)


def test_rd_fields_round_trip_in_layout():
    u = np.random.default_rng(1).random((2, 8, 12))
    sim = simkit.Rd.diffusion(u, diffusivity=[0.1, 0.2], dt=0.1)
    np.testing.assert_array_equal(sim.fields, u)
    sim.step(1)
    # One explicit step of the 5-point Laplacian, periodic, h = 1.
    lap = sum(np.roll(u, s, axis=a) for s in (1, -1) for a in (1, 2)) - 4 * u
    want = u + 0.1 * np.array([0.1, 0.2])[:, None, None] * lap
    np.testing.assert_allclose(sim.fields, want, rtol=0, atol=1e-15)


def test_lattice_gas_from_cells():
    cells = np.zeros((8, 16), dtype=np.uint8)
    cells[3, 4] = 0b000001  # one particle moving along +x
    sim = simkit.LatticeGas(cells)
    assert sim.totals()["particles"] == 1
    sim.step(1)
    out = sim.cells
    assert out.sum() == 1 and out[3, 5] == 1
