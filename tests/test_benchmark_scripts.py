"""The benchmark scripts' hooks into the package still name what the package has."""

import importlib.util
from pathlib import Path

BENCHMARKS = Path(__file__).parent.parent / "benchmarks"


def _script(name: str):
    spec = importlib.util.spec_from_file_location(name, BENCHMARKS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_part_the_step_profile_times_is_a_function_of_the_package():
    parts = _script("step_profile")._parts()
    assert len(parts) == 17
    missing = [f"{owner.__name__}.{name}" for _, owner, name in parts if not hasattr(owner, name)]
    assert missing == []
