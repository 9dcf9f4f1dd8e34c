"""Problems own their PETSc objects: close() frees them once, ``with`` closes."""

from __future__ import annotations

import pytest

import dd_contact as dd
from dd_contact.paper import verify
from dd_contact.solvers import MonolithicSolver


def _petsc_objects(solver) -> list:
    """The factorisations' KSPs and the matrices a problem's solver holds."""
    if isinstance(solver, MonolithicSolver):
        return [solver.matrix.A]
    out = []
    for sub in solver.subdomains.values():
        if sub.matrix.A is not None:  # none with the Schur factorisation (upper COO only)
            out.append(sub.matrix.A)
        if sub.factor is not None:  # SparseCholesky's KSP, or the SchurFactorisation itself
            out.append(getattr(sub.factor, "ksp", sub.factor))
    return out


@pytest.mark.parametrize("algorithm", ["FULL", "v-w-u"])
def test_close_destroys_the_solver_once(algorithm):
    problem = dd.StaticProblem(verify.order_scene("interface", False, 1e4), algorithm)
    problem.solve()
    held = _petsc_objects(problem.solver)
    assert held and all(obj.handle != 0 for obj in held)
    problem.close()
    # A destroyed petsc4py object drops its handle (calling it would crash, not raise).
    assert all(obj.handle == 0 for obj in held)
    problem.close()  # harmless
    with pytest.raises(RuntimeError, match="StaticProblem was closed"):
        problem.solve()


def test_with_closes_the_problem_and_keeps_the_results():
    scene = verify.order_scene("single", True, 1e4)
    with dd.TransientProblem(scene, 0.01, algorithm="w-u") as problem:
        history = problem.run(2, progress=False, summary=False)
        held = _petsc_objects(problem.solver)
        assert all(obj.handle != 0 for obj in held)
    assert all(obj.handle == 0 for obj in held)
    assert len(history) == 2 and problem.step == 2
    assert problem.energy()["total"] > 0  # the state stays readable after closing
    with pytest.raises(RuntimeError, match="TransientProblem was closed"):
        problem.advance()


def test_with_closes_on_an_error():
    with pytest.raises(KeyError, match="stop"):
        with dd.StaticProblem(verify.order_scene("single", False, 1e4)) as problem:
            problem.solve()
            held = _petsc_objects(problem.solver)
            raise KeyError("stop")
    assert all(obj.handle == 0 for obj in held)
