"""The benchmark scripts' hooks into the package still name what the package has."""

import importlib.util
import sys
from pathlib import Path

BENCHMARKS = Path(__file__).parent.parent / "benchmarks"


def _script(name: str):
    if str(BENCHMARKS) not in sys.path:  # scripts import their siblings (pinned, ...)
        sys.path.insert(0, str(BENCHMARKS))
    spec = importlib.util.spec_from_file_location(name, BENCHMARKS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_part_the_step_profile_times_is_a_function_of_the_package():
    parts = _script("step_profile")._parts()
    assert len(parts) == 17
    missing = [f"{owner.__name__}.{name}" for _, owner, name in parts if not hasattr(owner, name)]
    assert missing == []


def test_every_part_the_pin_joint_profile_reads_is_a_function_of_the_package():
    import importlib

    parts = _script("pin_joint_reduced").PARTS
    assert len(parts) == 17
    missing = []
    for functions in parts.values():
        for module, name in functions:
            owner = importlib.import_module(f"dd_contact.{module}")
            for attribute in name.split("."):
                owner = getattr(owner, attribute, None)
            if owner is None or not hasattr(owner, "__code__"):
                missing.append(f"{module}.{name}")
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


def test_the_iterative_peer_patches_what_full_solves_with_and_repeats_its_answers():
    """benchmarks/iterative_peer.py: FULL's solver with CG for its substitution, installed
    where the analysis builds FULL's solver; a few steps of a small bar pressed on its
    wall (its contact changing) equal the direct FULL's to the peers' tolerance."""
    import sys

    from mpi4py import MPI

    import numpy as np

    import dd_contact as dd
    import dd_contact.analysis as analysis
    from dd_contact.paper.examples import parallelepiped
    from dd_contact.solvers.full import MonolithicSolver

    sys.path.insert(0, str(BENCHMARKS))
    peer = _script("iterative_peer")
    assert analysis.MonolithicSolver is MonolithicSolver
    assert all(hasattr(MonolithicSolver, name) for name in ("_refactorise", "_apply"))

    def run(label):
        scene = parallelepiped("FULL", (12, 3, 2), comm=MPI.COMM_SELF)
        with peer.peer(label, scene) if label else _nothing():
            problem = dd.TransientProblem(scene, 1e-6, "FULL", track_energy=False)
        assert analysis.MonolithicSolver is MonolithicSolver  # put back
        fields, changes = [], 0
        for _ in range(6):
            changes += problem.advance()["changes"]
            fields.append(np.concatenate(list(problem.solver.finish().values())))
        iterations = getattr(problem.solver, "iterations", None)
        problem.close()
        return np.array(fields), changes, iterations

    direct, changes, _ = run(None)
    assert changes >= 1
    for label in peer.PEERS:
        x, peer_changes, iterations = run(label)
        assert peer_changes == changes
        assert len(iterations) == 6 + changes  # one CG solve per contact iteration
        assert np.abs(x - direct).max() <= 1e-11 * np.abs(direct).max()


def _nothing():
    import contextlib

    return contextlib.nullcontext()


def test_the_pair_friction_cost_worker_counts_and_times_each_change(monkeypatch):
    """benchmarks/pair_friction_cost.py: a small run of each kind; every change is a timed
    contact iteration, and with friction each re-factorises the pair's group (LU).

    Measured (6x6x4 and 5x5x4 cells): 7 changes without friction, 5 with, 5 factorisations
    of the pair's group.
    """
    import argparse
    import sys

    monkeypatch.syspath_prepend(str(BENCHMARKS))
    script = _script("pair_friction_cost")
    for mu in (0.0, 0.3):
        run = script.worker(argparse.Namespace(worker="w-u", mu=mu, cells=6, steps=10))
        timed = sum(len(step["iterations"]) - 1 for step in run["steps"])
        assert run["changes"] == timed >= 3
        pair = [f for f in run["factorisations"] if f[0] == "w:bottom+w:top"]
        if mu:  # the low-rank update does not take unsymmetric changes: each re-factorises
            assert len(pair) >= run["changes"]
    assert "decomposition_speed" in sys.modules


def test_the_low_rank_accuracy_check_measures_every_solver_against_its_reference(monkeypatch):
    """benchmarks/lowrank_accuracy.py on the smallest elastic-pin joint (5,460 dofs): the
    extended-precision reference has a backward error far below double's; every solver of
    the flipped state is backward stable, and the corrected w-v-u (one update, no
    factorisation) is as far from the reference as the exact solvers are (9.5e-6 measured)."""
    import numpy as np

    from dd_contact.solvers.lowrank import LowRankSurface

    monkeypatch.setattr(LowRankSurface, "enabled", LowRankSurface.enabled)  # the script sets it
    script = _script("lowrank_accuracy")
    solutions, (system, (rhs, contact), info) = script.orders(script._scene("3,2,1,4"), 0.01)
    assert info["points_changed"] == 2
    whole = script.Whole(system, rhs, contact)
    reference = script.reference(whole)
    x_ref = reference["x"].astype(float)
    assert whole.backward_error(reference["x"]) <= 1e-18
    differences = {}
    for label, s in solutions.items():
        x = whole.vector(s["x"])
        # the unrefined correction is shown for what refinement buys (9.8e-15 here)
        assert whole.backward_error(x) <= (1e-12 if label == "corrected_unrefined" else 1e-15)
        w, w_ref = whole.w(x), whole.w(x_ref)
        differences[label] = np.abs(w - w_ref).max() / np.abs(w_ref).max()
    assert solutions["corrected"]["work"]["dense_update"] == 1
    assert solutions["corrected"]["work"]["dense_factor"] == 0
    assert solutions["refactorised"]["work"]["dense_factor"] == 1
    exact = max(differences[k] for k in ("refactorised", "v-w-u", "FULL"))
    assert 0.0 < differences["corrected"] <= 2.0 * exact


def test_the_paper_scale_labels_name_reduce_s_arguments():
    """A run's label is the order and ``Subdomain.reduce``'s arguments, which must exist."""
    import inspect

    import dd_contact as dd

    case_of = _script("paper_scale").case_of
    assert case_of("FULL") == ("FULL", None, False)
    assert case_of("w-u reduced m=320") == ("w-u", {"modes": 320}, False)
    label = "w-u reduced m=320 tol=0.5 ooc"
    want = {"modes": 320, "tolerance": 0.5, "out_of_core": True}
    assert case_of(label) == ("w-u", want, False)
    assert set(want) <= set(inspect.signature(dd.Subdomain.reduce).parameters)
