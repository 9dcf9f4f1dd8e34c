"""Ties stiffer than KAPPA_SPLIT: assembled softer, the rest carried by iteration."""

from __future__ import annotations

from mpi4py import MPI

import numpy as np
import pytest

import dd_contact as dd
from dd_contact.paper import verify
from dd_contact.paper.examples import parallelepiped
from dd_contact.scene import KAPPA_ASSEMBLED, KAPPA_ASSEMBLED_PROJECTED, KAPPA_SPLIT
from dd_contact.solvers.stiff_ties import AugmentedTies


@pytest.mark.parametrize("kappa", [1e8, 1e14])
def test_a_stiff_matching_tie_reproduces_one_mesh(kappa):
    # Matching meshes: the tie's own error is 0.22 / kappa (measured at 1e4-1e6), nothing at
    # these penalties; what is left is round-off (measured 8.4e-9 at 1e14; before the
    # split: 2.3e-3 at 1e12 and a wrong answer at 1e14).
    tied, single = verify.bent_bar(1, kappa, matching=True)
    assert tied == pytest.approx(single, rel=2e-8)


@pytest.mark.parametrize("order", ["v-w-u", "w-v-u"])
def test_a_stiff_tie_adds_substitutions_not_factorisations(order):
    def work(kappa):
        scene = verify.pressed_scene("interface", kappa=kappa, comm=MPI.COMM_SELF)
        with dd.StaticProblem(scene, algorithm=order) as problem:
            problem.solve()
            return problem.work, problem.tie_solver

    moderate, plain = work(KAPPA_SPLIT)
    stiff, augmented = work(1e14)
    assert plain is not None and not isinstance(plain, AugmentedTies)
    assert isinstance(augmented, AugmentedTies) and len(augmented.ties) == 2
    for kind in ("sparse_factor", "dense_factor"):
        assert stiff.count(kind) == moderate.count(kind), kind
    # Each extra solve of the iteration substitutes each of the 2 subdomains once more: a
    # forward sweep (u_hat) and a backward sweep (u).
    extra = augmented.solves - 1
    assert 1 <= extra <= 10
    for kind in ("sparse_forward", "sparse_backward"):
        assert stiff.count(kind) == moderate.count(kind) + 2 * extra, kind


def _decomposed_bar(kappa):
    bar = dd.meshes.box(MPI.COMM_SELF, [0, 0, 0], [4, 1, 1], [8, 2, 2])
    scene = dd.decompose(bar, dd.Material(E=210e9, nu=0.3, rho=7850.0), parts=2, kappa=kappa)
    return scene.fix(lambda x: np.isclose(x[0], 0.0))


@pytest.mark.parametrize(
    ("build", "names", "assembled"),
    [  # the pressed scene's interface does not match its blocks' facets: projected
        (
            lambda: verify.pressed_scene("interface", kappa=1e12, comm=MPI.COMM_SELF),
            {"'interface' on 'A'", "'interface' on 'B'"},
            KAPPA_ASSEMBLED_PROJECTED,
        ),
        (
            lambda: _decomposed_bar(1e12),
            {"'interface' on 'part0'", "'interface' on 'part1'"},
            KAPPA_ASSEMBLED,
        ),
    ],
)
def test_the_assembled_part_of_a_stiff_tie_is_kappa_assembled(build, names, assembled):
    problem = dd.StaticProblem(build())
    ties = problem.model.system.stiff_ties
    assert {t.name for t in ties} == names
    for tie in ties:
        # rho + sigma = 1 / eps of the tie; rho = the assembled kappa's share.
        eps = problem.penalties[(tie.u.name, tie.s.name)]
        assert tie.rho + tie.sigma == pytest.approx(1.0 / eps, rel=1e-12)
        assert tie.rho / (tie.rho + tie.sigma) == pytest.approx(assembled / 1e12)
    problem.close()


@pytest.mark.parametrize("algorithm", ["w-v-u", "w-u", "v-u"])
def test_a_tie_at_the_default_kappa_is_assembled_whole(algorithm):
    # The requested kappa decides, not h / (E eps) computed back (which can be 1e6 + 1 ulp).
    scene = parallelepiped(algorithm, (12, 4, 2), comm=MPI.COMM_SELF)
    problem = dd.TransientProblem(scene, 1e-6, algorithm=algorithm, track_energy=False)
    assert problem.model.system.kappas and not problem.model.system.stiff_ties
    assert problem.tie_solver is problem.solver
    problem.close()
