"""The package's surface: stubs in step with the module, the tour runs."""

import ast
import inspect
import pathlib
import subprocess
import sys

import simkit
from simkit import _native

STUB = pathlib.Path(simkit.__file__).with_name("_native.pyi")


def stub_names():
    """Module-level classes (with their members) and functions declared in the stub."""
    out = {}
    for node in ast.parse(STUB.read_text()).body:
        if isinstance(node, ast.ClassDef):
            members = set()
            for n in node.body:
                if isinstance(n, ast.FunctionDef):
                    members.add(n.name)
                elif isinstance(n, ast.AnnAssign):
                    members.add(n.target.id)
            out[node.name] = members
        elif isinstance(node, ast.FunctionDef):
            out[node.name] = None
    return out


def test_stubs_match_the_module():
    stubs = stub_names()
    public = {n for n in dir(_native) if not n.startswith("_")}
    assert public == set(stubs), public ^ set(stubs)
    for name, members in stubs.items():
        obj = getattr(_native, name)
        if members is None or not inspect.isclass(obj) or issubclass(obj, Exception):
            continue
        real = {n for n in dir(obj) if not n.startswith("_")}
        declared = {m for m in members if not m.startswith("_")}
        assert real == declared, (name, real ^ declared)


def test_every_public_method_has_a_docstring():
    for name in dir(_native):
        obj = getattr(_native, name)
        if name.startswith("_") or not inspect.isclass(obj):
            continue
        assert obj.__doc__, name
        for m in dir(obj):
            if not m.startswith("_") and not issubclass(obj, Exception):
                assert getattr(obj, m).__doc__, f"{name}.{m}"


def test_tour_runs():
    r = subprocess.run([sys.executable, "-m", "simkit.tour", "--cpu"], capture_output=True,
                       text=True, timeout=600)
    assert r.returncode == 0, r.stdout + r.stderr
    for scene in ("md", "dem", "lattice_gas", "rd", "pp_coulomb", "neighbor"):
        assert f"running {scene} ... done" in r.stdout
    assert "bit-identical to the portable CPU path: yes" in r.stdout
    assert "counts equal to linked cells: yes" in r.stdout
