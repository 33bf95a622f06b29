"""The GPU backends from Python agree with the CPU (on lavapipe in CI)."""

import numpy as np

import simkit


def test_md_gpu_matches_cpu(gpu):
    cpu = simkit.Md.fcc(4, dt=0.005, precision="f32")
    dev = simkit.Md.fcc(4, dt=0.005, precision="f32", backend=gpu)
    assert dev.backend_name.startswith("gpu"), dev.backend_name
    cpu.step(20)
    dev.step(20)
    np.testing.assert_allclose(dev.positions, cpu.positions, atol=1e-4)


def test_rd_gpu_matches_cpu(gpu):
    cpu = simkit.Rd.gray_scott_square(64, precision="f32")
    dev = simkit.Rd.gray_scott_square(64, precision="f32", backend=gpu)
    assert dev.backend_name.startswith("gpu"), dev.backend_name
    cpu.step(50)
    dev.step(50)
    np.testing.assert_allclose(dev.fields, cpu.fields, atol=1e-5)


def test_lattice_gas_gpu_is_bit_identical(gpu):
    cpu = simkit.LatticeGas.random(64, 32, 0.3)
    dev = simkit.LatticeGas.random(64, 32, 0.3, backend=gpu)
    assert dev.backend_name.startswith("gpu"), dev.backend_name
    cpu.step(50)
    dev.step(50)
    assert np.array_equal(cpu.cells, dev.cells)


def test_neighbor_gpu_pairs_equal_cpu(gpu):
    pts = np.random.default_rng(5).random((3000, 3)) * 12
    a = simkit.NeighborSearch([0, 0, 0], [12] * 3, 1.5)
    b = simkit.NeighborSearch([0, 0, 0], [12] * 3, 1.5, method="gpu")
    assert b.method.startswith("GPU"), b.method
    a.build(pts)
    b.build(pts)
    assert np.array_equal(a.pairs()[0], b.pairs()[0])
