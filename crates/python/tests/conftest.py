"""Shared fixtures: the Rust reference states and the GPU requirement."""

import os
import pathlib
import shutil
import subprocess

import pytest

import simkit

REPO = pathlib.Path(__file__).resolve().parents[3]


@pytest.fixture(scope="session")
def reference(tmp_path_factory):
    """The final states of the reference scenes, computed by the Rust API
    (crates/python/examples/reference.rs): a function from a name to the file's path."""
    out = tmp_path_factory.mktemp("reference")
    cargo = shutil.which("cargo")
    assert cargo, "cargo is needed to compute the Rust side of the equality tests"
    subprocess.run(
        [cargo, "run", "-q", "--release", "-p", "simkit-python", "--example", "reference",
         "--", str(out)],
        cwd=REPO, check=True)
    return lambda name: out / f"{name}.bin"


@pytest.fixture(scope="session")
def gpu():
    """Skips a GPU test where there is no adapter, unless SIMKIT_REQUIRE_GPU=1 (as in CI),
    where a missing adapter fails."""
    if simkit.has_gpu_support() and simkit.adapters():
        return "gpu"
    if os.environ.get("SIMKIT_REQUIRE_GPU") == "1":
        pytest.fail("SIMKIT_REQUIRE_GPU=1 but no GPU adapter (install mesa-vulkan-drivers)")
    pytest.skip("no GPU adapter")
