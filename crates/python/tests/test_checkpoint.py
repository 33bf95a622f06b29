"""Checkpoints: a resumed run continues bit for bit as the uninterrupted one."""

import numpy as np
import pytest

import simkit

SCENES = {
    "md": (lambda: simkit.Md.fcc(4, dt=0.005), simkit.Md, "positions"),
    "dem": (lambda: simkit.Dem.vibrating_bed(64, 8), simkit.Dem, "positions"),
    "rd": (lambda: simkit.Rd.gray_scott_square(32), simkit.Rd, "fields"),
    "rd_f32": (lambda: simkit.Rd.colony(32, 32), simkit.Rd, "fields"),
    "lattice_gas": (lambda: simkit.LatticeGas.random(32, 16, 0.3), simkit.LatticeGas, "cells"),
    "pp_coulomb": (lambda: simkit.PpCoulomb.cold_sphere(200, dt=0.01), simkit.PpCoulomb,
                   "positions"),
}


@pytest.mark.parametrize("name", sorted(SCENES))
def test_round_trip(name, tmp_path):
    make, cls, field = SCENES[name]
    a = make()
    a.step(30)
    path = tmp_path / f"{name}.ckpt"
    a.write_checkpoint(path)
    a.step(30)
    b = cls.resume(str(path))
    assert b.steps_done == 30
    b.step(30)
    assert b.steps_done == a.steps_done == 60
    assert getattr(a, field).tobytes() == getattr(b, field).tobytes()


def test_resume_errors(tmp_path):
    with pytest.raises(OSError):
        simkit.Md.resume(tmp_path / "missing.ckpt")
    bad = tmp_path / "bad.ckpt"
    bad.write_bytes(b"not a checkpoint")
    with pytest.raises(ValueError, match="bad.ckpt"):
        simkit.Md.resume(bad)
    # A checkpoint of another model is refused by name, not misread.
    other = tmp_path / "lattice.ckpt"
    simkit.LatticeGas.random(16, 8, 0.2).write_checkpoint(other)
    with pytest.raises(ValueError):
        simkit.Md.resume(other)
    with pytest.raises(ValueError):
        simkit.Rd.resume(other)
