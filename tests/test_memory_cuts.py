"""What the solvers keep, and that the memory cuts keep the results (docs/solvers.md, memory).

The multi-pin joint at its tiny scale, w-v-u: the interface is eliminated first, so every
contact interface couples to every other through it and the last group is all ten walls.
"""

import weakref

from mpi4py import MPI

import numpy as np
import pytest

import dd_contact as dc
from dd_contact.paper import examples, models
from dd_contact.solvers import mumps_schur
from dd_contact.solvers.dense import DenseCholesky
from dd_contact.solvers.surface import Surface

DT = 4e-5


def _joint_problem(algorithm: str, options: dict | None = None) -> dc.TransientProblem:
    scene = models.pin_joint("tiny", clearance=0.0, comm=MPI.COMM_SELF)
    return dc.TransientProblem(
        scene, DT, algorithm=algorithm, track_energy=False, petsc_options=options
    )


def _displacements(problem: dc.TransientProblem) -> np.ndarray:
    scene = problem.scene
    parts = [s.u.x.array for s in scene.subdomains] + [c.w.x.array for c in scene.contacts]
    return np.concatenate(parts)


@pytest.fixture(scope="module")
def stepped():
    """w-v-u after three steps, and its displacements."""
    problem = _joint_problem("w-v-u")
    for _ in range(3):
        problem.advance()
    yield problem, _displacements(problem)
    problem.close()


def test_the_surface_keeps_one_copy_of_each_symmetric_pair(stepped):
    surface = stepped[0].solver.surface
    S = surface.schur_pairs
    pairs = [p for p in S if p[0] != p[1]]
    assert len(pairs) == 20  # the interface with each of the ten walls, both ways
    for a, b in pairs:
        assert np.shares_memory(S[(a, b)], S[(b, a)])
        np.testing.assert_array_equal(S[(a, b)], S[(b, a)].T)
    owners = {id(v.base if v.base is not None else v) for v in S.values()}
    assert len(owners) == len(S) - 10  # 1 (v, v) + 10 (w, w) + 10 off-diagonal


def test_no_group_keeps_its_condensation_once_eliminated(stepped):
    surface = stepped[0].solver.surface
    first, last = surface.schedule.groups
    assert [len(g.blocks) for g in first] == [1] and [len(g.blocks) for g in last] == [10]
    groups = [g for level in surface.schedule.groups for g in level]
    assert all(surface.state[g.name].subtracted is None for g in groups)
    assert surface.state[first[0].name].B is not None  # its solves still need B


def test_re_eliminating_a_pair_recomputes_the_freed_condensation(stepped):
    """A pair marked new while its group is not stale needs B^T A^-1 B again: same values."""
    surface = stepped[0].solver.surface
    pair = next(p for p in surface.eliminated if p[0] != p[1])
    before = surface.eliminated[pair].copy()
    surface.new_pairs.add(pair)
    surface.stale.add(surface.schedule.groups[-1][0].name)  # re-factorise the last group only
    surface.factorise()
    np.testing.assert_array_equal(surface.eliminated[pair], before)
    assert surface.state[surface.schedule.groups[0][0].name].subtracted is None


def test_mumps_compacts_its_workspace_and_the_results_do_not_change(stepped):
    problem, compacted = stepped
    assert len(problem.solver.subdomains) == 12  # one rank owns them all: 11 compact
    kept = _joint_problem("w-v-u", {"mat_mumps_icntl_49": 0})
    try:
        assert all(s.factor.icntl(49) == 0 for s in kept.solver.subdomains.values())
        for _ in range(3):
            kept.advance()
        np.testing.assert_array_equal(_displacements(kept), compacted)
    finally:
        kept.close()


def _compaction_per_factorisation(monkeypatch, algorithm: str, steps: int) -> list:
    """(subdomain, ICNTL(49)) of every subdomain factorisation over ``steps`` steps."""
    calls = []
    factorise = mumps_schur.SchurFactorisation.factorise

    def spy(self, values):
        calls.append((self.block.name, self.icntl(49)))
        return factorise(self, values)

    monkeypatch.setattr(mumps_schur.SchurFactorisation, "factorise", spy)
    scene = examples.parallelepiped(algorithm, elements=(8, 4, 2), comm=MPI.COMM_SELF)
    problem = dc.TransientProblem(scene, 1e-6, algorithm=algorithm, track_energy=False)
    try:
        for _ in range(steps):
            problem.advance()
    finally:
        problem.close()
    return calls


@pytest.mark.parametrize(
    ("algorithm", "first"),
    [
        ("w-v-u", [("Omega1", 1), ("Omega2", 0)]),
        ("v-u", [("Omega2", 1), ("Omega1", 0)]),  # contact on Omega1: factorised last
    ],
)
def test_only_the_first_factorisation_of_all_but_the_last_subdomain_is_compacted(
    monkeypatch, algorithm, first
):
    """The compaction copies the factors on top of all a rank holds (docs/solvers.md): it
    pays before another subdomain's factorisation, not after the last or on a contact change.
    """
    calls = _compaction_per_factorisation(monkeypatch, algorithm, 3)
    assert calls[:2] == first
    refactorised = calls[2:]  # v-u re-factorises the subdomain in contact on each change
    assert all(compact == 0 for _, compact in refactorised)
    if algorithm == "v-u":
        assert len(refactorised) >= 1
        assert {name for name, _ in refactorised} == {"Omega1"}
    else:
        assert refactorised == []  # w-v-u's contact is on w: no subdomain re-factorises


def test_a_single_subdomain_is_not_compacted(monkeypatch):
    """Its compaction, a copy of its factors, would set the peak (docs/solvers.md)."""
    assert _compaction_per_factorisation(monkeypatch, "w-u", 1) == [("Omega1", 0)]


def test_a_refactorised_group_frees_its_old_factor_before_assembling_the_new(stepped, monkeypatch):
    surface = stepped[0].solver.surface
    last = surface.schedule.groups[-1][0].name
    old = weakref.ref(surface.state[last].factor)
    alive = []

    def spy(A, log, block, order=None):
        alive.append(old() is not None)
        return DenseCholesky(A, log, block, order)

    monkeypatch.setattr("dd_contact.solvers.surface.DenseCholesky", spy)
    x = surface.state[last].factor.solve(np.ones(surface.state[last].factor.size))
    surface.stale.add(last)
    surface.factorise()
    assert alive == [False]  # one dense copy of the group at a time
    np.testing.assert_array_equal(surface.state[last].factor.solve(np.ones(len(x))), x)


def test_the_surface_frees_each_condensation_once_its_pairs_hold_it(monkeypatch):
    """Unless a subdomain can be re-factorised (contact on its own boundary), bit for bit."""
    scene = examples.parallelepiped("w-v-u", elements=(8, 4, 2), comm=MPI.COMM_SELF)
    freed = dc.TransientProblem(scene, 1e-6, algorithm="w-v-u", track_energy=False)
    monkeypatch.setattr(Surface, "__init__", _keeping(Surface.__init__))
    scene = examples.parallelepiped("w-v-u", elements=(8, 4, 2), comm=MPI.COMM_SELF)
    kept = dc.TransientProblem(scene, 1e-6, algorithm="w-v-u", track_energy=False)
    try:
        for _ in range(3):
            freed.advance()
            kept.advance()
        assert freed.solver.surface.condensed == {}
        assert len(kept.solver.surface.condensed) == 2
        np.testing.assert_array_equal(_displacements(freed), _displacements(kept))
        with pytest.raises(RuntimeError, match="second condensation"):
            freed.solver.surface.set_condensed("u:Omega1", np.zeros((1, 1)))
    finally:
        freed.close()
        kept.close()


def _keeping(init):
    def keep(self, schedule, log, recondensed=True, *rest):
        init(self, schedule, log, True, *rest)

    return keep


def test_a_surface_whose_subdomains_are_re_factorised_keeps_their_condensations():
    scene = examples.parallelepiped("v-u", elements=(8, 4, 2), comm=MPI.COMM_SELF)
    problem = dc.TransientProblem(scene, 1e-6, algorithm="v-u", track_energy=False)
    try:
        for _ in range(3):
            problem.advance()
        surface = problem.solver.surface
        assert surface.recondensed
        assert set(surface.condensed) == {"u:Omega1", "u:Omega2"}
    finally:
        problem.close()
