"""Bad inputs raise ValueError/TypeError naming the argument; blow-ups raise simkit.BlowUp."""

import numpy as np
import pytest

import simkit

BOX = dict(box_lo=[0, 0, 0], box_hi=[6, 6, 6])


@pytest.mark.parametrize(
    "kwargs, error, words",
    [
        (dict(positions=[[1, 1]], **BOX), ValueError, "box_lo"),
        (dict(positions=[[1, 1, 1, 1]], **BOX), ValueError, "positions"),
        (dict(positions=[[1, 1, float("nan")]], **BOX), ValueError, "position"),
        (dict(positions=[[7, 1, 1]], periodic=False, **BOX), ValueError, "box"),
        (dict(positions=[[1, 1, 1]], velocities=[[0, 0, 0], [0, 0, 0]], **BOX), ValueError,
         "velocities"),
        (dict(positions=[[1, 1, 1]], species=[1], **BOX), ValueError, "species"),
        (dict(positions=[[1, 1, 1]], species=[-1], **BOX), ValueError, "species[0]"),
        (dict(positions=[[1, 1, 1]], masses=[-1.0], **BOX), ValueError, "mass"),
        (dict(positions=[[1, 1, 1]], cutoff=4.0, **BOX), ValueError, "cutoff"),
        (dict(positions=[[1, 1, 1]], epsilon=np.ones((2, 2)), **BOX), ValueError, "epsilon"),
        (dict(positions=[[1, 1, 1]], dt=-1.0, **BOX), ValueError, "dt"),
        (dict(positions=[[1, 1, 1]], precision="f16", **BOX), ValueError, "precision"),
        (dict(positions=[[1, 1, 1]], backend="tpu", **BOX), ValueError, "backend"),
        (dict(positions=[[1, 1, 1]], integrator="rk4", **BOX), ValueError, "integrator"),
        (dict(positions="not numbers", **BOX), TypeError, "positions"),
        (dict(positions=[[1, 1, 1]], periodic=[True, False], **BOX), ValueError, "periodic"),
    ],
)
def test_md_inputs(kwargs, error, words):
    with pytest.raises(error, match=words.replace("[", r"\[").replace("]", r"\]")):
        simkit.Md(**kwargs)


def test_md_unstable_dt_names_the_bound():
    with pytest.raises(ValueError, match="stability bound"):
        simkit.Md.fcc(4, dt=0.5)


def test_dem_inputs():
    with pytest.raises(ValueError, match="radii"):
        simkit.Dem([[1, 1]], [0.5, 0.5], box_lo=[0, 0], box_hi=[4, 4], contact_time=1e-3)
    with pytest.raises(ValueError, match="restitution"):
        simkit.Dem([[1, 1]], [0.5], box_lo=[0, 0], box_hi=[4, 4], contact_time=1e-3,
                   restitution=1.5)
    with pytest.raises(ValueError, match="contact_time"):
        simkit.Dem([[1, 1]], [0.5], box_lo=[0, 0], box_hi=[4, 4], contact_time=-1.0)
    with pytest.raises(TypeError):
        simkit.Dem([[1, 1]], [0.5], box_lo=[0, 0], box_hi=[4, 4])  # contact_time missing


def test_rd_inputs():
    with pytest.raises(ValueError, match="fields"):
        simkit.Rd.gray_scott(np.ones((8, 8)), du=1, dv=1, feed=0.1, kill=0.1, dt=0.1)
    with pytest.raises(ValueError, match="boundary"):
        simkit.Rd.gray_scott(np.ones((2, 8, 8)), du=1, dv=1, feed=0.1, kill=0.1, dt=0.1,
                             boundary="open")
    with pytest.raises(ValueError, match="stability bound"):
        simkit.Rd.gray_scott(np.ones((2, 8, 8)), du=1, dv=1, feed=0.1, kill=0.1, dt=10.0)
    with pytest.raises(ValueError, match="species 5"):
        simkit.Rd.gray_scott_square(16).total(5)


def test_lattice_gas_inputs():
    with pytest.raises(ValueError, match="cells"):
        simkit.LatticeGas(np.zeros(16, dtype=np.uint8))
    with pytest.raises(ValueError, match="rules"):
        simkit.LatticeGas(np.zeros((8, 8), dtype=np.uint8), rules="fhp_ix")
    with pytest.raises(ValueError, match="inflow"):
        simkit.LatticeGas(np.zeros((8, 8), dtype=np.uint8), inflow=True)


def test_pp_coulomb_inputs():
    with pytest.raises(ValueError, match="charges"):
        simkit.PpCoulomb([[0, 0, 0], [1, 0, 0]], [1.0, 1.0, 1.0], 1.0, dt=0.1)
    with pytest.raises(ValueError, match="softening"):
        simkit.PpCoulomb([[0, 0, 0]], 1.0, 1.0, dt=0.1, force="plummer")
    with pytest.raises(ValueError, match="positions"):
        simkit.PpCoulomb([[0, 0]], 1.0, 1.0, dt=0.1)


def test_neighbor_inputs():
    with pytest.raises(ValueError, match="box_lo"):
        simkit.NeighborSearch([0], [1], 0.5)
    with pytest.raises(ValueError, match="cutoff"):
        simkit.NeighborSearch([0, 0], [4, 4], -1.0)
    s = simkit.NeighborSearch([0, 0], [4, 4], 1.0, periodic=False)
    with pytest.raises(RuntimeError, match="build"):
        s.pairs()
    with pytest.raises(ValueError, match="points"):
        s.build([[1, 1, 1]])
    with pytest.raises(ValueError):
        s.build([[5, 1]])  # outside a non-periodic box


def test_blow_up_carries_step_and_cause():
    # A time step 20x over the stability bound (allowed explicitly) heats the crystal until
    # it turns non-finite; the guard finds it and rolls back.
    sim = simkit.Md.fcc(4, dt=0.1, allow_unstable_dt=True, check_every=10)
    with pytest.raises(simkit.BlowUp) as caught:
        sim.step(2000)
    e = caught.value
    assert isinstance(e, RuntimeError)
    assert e.step > e.rolled_back_to >= 0
    assert e.cause and e.what
    assert sim.steps_done == e.rolled_back_to
    assert np.isfinite(sim.positions).all()
