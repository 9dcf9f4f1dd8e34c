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


def test_the_cpu_clock_of_auto_choice_patches_the_timers_the_work_records_use():
    import time

    from dd_contact.solvers import linalg, mumps_schur, worklog

    script = _script("auto_choice")
    assert {
        "pin_small",
        "pin_tests",
        "pin_demo",
        "bar_small",
        "bar_tiny",
        "bar_49k",
        "bar_124k",
    } <= set(script.SCENES)
    modules = (linalg, mumps_schur, worklog)
    before = [m.time for m in modules]
    try:
        script._cpu_clocks()
        assert [m.time.perf_counter for m in modules] == [time.process_time] * 3
    finally:
        for module, clock in zip(modules, before, strict=True):
            module.time = clock
    assert [m.time.perf_counter for m in modules] == [time.perf_counter] * 3
