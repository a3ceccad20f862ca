"""Types: the stubs generated at build time match the module (mypy's stubtest), inspect.signature
works on every function and method, every public name has a docstring, each TypedDict lists exactly
the keys the module returns, and a typed study passes mypy --strict (and a wrong key does not)."""
import inspect
import os
import pathlib
import subprocess
import sys
import typing

import numpy as np
import pytest

import haustra
import haustra.types as types
from conftest import SOURCE, rod

PACKAGE = pathlib.Path(haustra.__file__).parent
TOOLS = SOURCE / "python" / "tools"


def module_env():
    """This process's environment (a sanitizer build's preloads included), the package first on the path."""
    return {**os.environ, "PYTHONPATH": str(PACKAGE.parent), "MYPY_CACHE_DIR": "/dev/null"}


def public_world_members():
    return [(n, v) for n, v in vars(haustra.World).items() if not n.startswith("_")]


def test_the_package_ships_its_stubs_and_py_typed():
    assert (PACKAGE / "py.typed").exists()
    stub = (PACKAGE / "_haustra.pyi").read_text()
    assert "def step(self, n: int = ..., record: None = ...) -> None:" in stub  # overloads: the recording
    assert "def step(self, n: int, record: List[str]) -> dict[str, numpy.typing.NDArray" in stub  # when asked
    assert "def profile(self) -> haustra.types.Profile:" in stub


def test_the_stubs_match_the_module():
    out = subprocess.run([sys.executable, "-m", "mypy.stubtest", "haustra._haustra", "--allowlist",
                          str(TOOLS / "stubtest-allowlist.txt")], capture_output=True, text=True, env=module_env())
    assert out.returncode == 0, out.stdout + out.stderr


def test_inspect_signature_works_everywhere():
    assert str(inspect.signature(haustra.World.step)) == "(self, n=1, record=None)"
    assert str(inspect.signature(haustra.World.from_scene)) == "(path, overrides=None)"
    w = haustra.World(rod(nodes=5))
    assert str(inspect.signature(w.step)) == "(n=1, record=None)"  # bound: self dropped
    assert str(inspect.signature(w.set_external_load)) == "(node, force, moment=None)"
    functions = [getattr(haustra, n) for n in ("validate", "save_mesh", "estimate_memory")]
    methods = [v for _, v in public_world_members() if callable(v)]
    for f in functions + methods:
        inspect.signature(f)  # raises ValueError where a builtin has no signature


def test_every_public_name_has_a_docstring():
    undocumented = [n for n in haustra.__all__ if not (getattr(haustra, n).__doc__ or "").strip()]
    for name, value in public_world_members():
        doc = value.__doc__ or ""
        if not isinstance(value, property):
            doc = doc.split("\n", 1)[1] if "\n" in doc else ""  # after pybind11's signature line
        if not doc.strip():
            undocumented.append(f"World.{name}")
    assert not undocumented


def keys_of(typed_dict):
    return set(typing.get_type_hints(typed_dict))


def test_typed_dicts_list_exactly_the_keys_returned(scenes):
    w = haustra.World.from_scene(scenes / "grasp-pull.toml")
    w.step(3)
    assert set(w.profile) == keys_of(types.Profile)
    assert set(w.instrument(0)) == keys_of(types.Instrument)
    assert set(w.contacts) == keys_of(types.ContactSummary)
    assert set(w.energy) == keys_of(types.Energy)
    assert set(w.segments[0]) == keys_of(types.Segment)
    assert set(haustra.estimate_memory(scenes / "drop.toml")) == keys_of(types.MemoryEstimate)
    desc = rod(nodes=20, youngs_modulus=33.2e3, dt=0.1)  # a recovery (test_world: robust mode events)
    desc["solver"] = {"mode": "lagged", "on_instability": "recover"}
    recovering = haustra.World(desc)
    recovering.step(30)
    assert recovering.events and set(recovering.events[0]) == keys_of(types.Event)


def test_validation_cases_have_the_typed_keys():
    case = haustra.validate()[0]
    assert set(case) == keys_of(types.ValidationCase)


def mypy(path):
    return subprocess.run([sys.executable, "-m", "mypy", "--strict", "--no-incremental", str(path)],
                          capture_output=True, text=True, env=module_env())


def test_a_typed_study_passes_mypy_strict_and_a_wrong_key_does_not(tmp_path):
    out = mypy(SOURCE / "python" / "examples" / "typed_study.py")
    assert out.returncode == 0, out.stdout + out.stderr
    wrong = tmp_path / "wrong.py"
    wrong.write_text("import haustra\n"
                     "w = haustra.World.from_scene('x.toml')\n"
                     "s: float = w.profile['frame_second']\n"
                     "w.step('ten')\n"
                     "frames = w.step(10)['frame']\n")  # no record=: step() returns None
    out = mypy(wrong)
    assert out.returncode == 1
    assert "frame_second" in out.stdout, out.stdout
    assert "No overload variant of \"step\"" in out.stdout, out.stdout
    assert "\"None\" is not indexable" in out.stdout, out.stdout


def test_contact_records_and_recordings_are_structured(scenes):
    w = haustra.World.from_scene(scenes / "drop.toml")
    recording = w.step(2, record=["profile", "contacts"])
    assert recording["profile"].dtype.names[:3] == ("frame_seconds", "seconds", "calls")
    assert set(recording["profile"]["seconds"].dtype.names) == set(w.profile["seconds"])
    assert recording["contacts"].dtype.names == tuple(types.ContactSummary.__annotations__)
    assert w.contact_records.dtype.names == ("bead", "other", "kind", "point", "normal", "force", "direction",
                                             "stiffness", "depth", "coupled")
    assert np.issubdtype(w.contact_records["point"].dtype, np.floating)
