"""What a reduced run's step and contact change cost beyond their dense solves.

The paper's bar shaken on its wall with its subdomain reduced (benchmarks/paper_scale.py,
small): a load part is projected once, not every step; the supports' reaction is summed
per component once; a release's settle eliminates the dense wall once per zone and gives
the answer of solving its whole matrix.
"""

import warnings

import numpy as np
import scipy.sparse as sp

import dd_contact as dc
from dd_contact import impact, settle
from dd_contact.paper import models
from dd_contact.solvers.reduced import ReducedBasis


def _bar(modes=20):
    scene = models.parallelepiped((16, 4, 4), algorithm="w-u")
    for sub in scene.subdomains:
        sub.reduce(modes=modes)
    return dc.TransientProblem(scene, 1e-4, algorithm="w-u", track_energy=False)


def _steps(problem, n):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", dc.CoarseTimeStepWarning)
        return [problem.advance() for _ in range(n)]


def test_a_reduced_load_is_projected_once_per_part(monkeypatch):
    calls = []
    project = ReducedBasis.project_load
    monkeypatch.setattr(ReducedBasis, "project_load", lambda s, v: calls.append(1) or project(s, v))
    with _bar() as problem:
        _steps(problem, 2)
        before = len(calls)
        _steps(problem, 8)
        assert len(calls) == before > 0  # every part kept: no projection in 8 more steps
        (sub,) = problem.analysis.owned
        basis, load = problem.analysis.reduced[sub.block], problem.analysis._load[sub.block]
        loads, supports = problem.analysis.loads(problem.t)
        whole = load()
        exact = project(basis, whole)
        assert np.abs(loads[sub.block] - exact).max() <= 1e-12 * np.abs(exact).max()
        assert np.array_equal(supports[sub.block], whole[basis.fixed])


def test_a_reduced_reaction_summed_per_component_is_the_rows_sum():
    with _bar() as problem:
        _steps(problem, 3)
        (sub,) = problem.analysis.owned
        basis = problem.analysis.reduced[sub.block]
        q = problem.analysis.state_now()[sub.block]
        a = problem.kinematics.now(sub)[2]
        f = np.linspace(-1.0, 1.0, len(basis.fixed))
        rows = basis.reaction(q, a, f)
        exact = np.bincount(basis.fixed % 3, weights=rows, minlength=3)
        reactions = problem.analysis.agreed.reactions
        summed = reactions.of({sub.block: q}, {}, {sub.block: a}, {sub.block: f})[sub.block]
        assert np.abs(summed - exact).max() <= 1e-12 * np.abs(rows).max()


def test_a_settle_eliminates_its_dense_wall_once_with_the_whole_matrixs_answer(monkeypatch):
    built, gaps = [], []
    eliminate, solve = settle.Kept.eliminate, settle.in_equilibrium
    monkeypatch.setattr(settle.Kept, "eliminate", lambda s: built.append(1) or eliminate(s))

    def checked(system, z, x, *args):
        out = solve(system, z, x, *args)
        with monkeypatch.context() as m:  # the whole matrix, solved sparse, made anew
            m.setattr(settle, "_held", lambda rows, moves, contact: [])
            whole = solve(system, z, x, *args[:-1], settle.Settles())
        gaps.append(max(np.abs(out[b] - whole[b]).max() / np.abs(whole[b]).max() for b in out))
        return out

    monkeypatch.setattr(impact, "in_equilibrium", checked)
    with _bar() as problem:
        _steps(problem, 30)
        (kept,) = problem._settles.kept.values()
    assert len(gaps) >= 2 and len(built) == 1  # one zone: eliminated at its first settle
    assert kept.points is not None  # a plane wall: its point rows corrected, not factorised
    # round-off of the penalised wall rows: 3.5e-11 to 1.02e-10, by BLAS threads and the
    # reduced matrices' last bits (ed178ca and its successor alike)
    assert max(gaps) <= 1e-9


def test_a_walls_moves_multiply_as_its_whole_directions():
    rng = np.random.default_rng(3)
    P = np.zeros((12, 4))
    P[[1, 4, 6, 9], [2, 0, 3, 1]] = 1.0  # the wall's own coordinates: unit rows
    P[10:] = rng.standard_normal((2, 4))  # the modes' rows: dense
    moves = settle.Moves(P)
    assert (len(moves.unit_rows), len(moves.dense_rows)) == (4, 2)
    A = sp.random_array((12, 12), density=0.4, random_state=rng, format="csr")
    d, r = rng.standard_normal(4), rng.standard_normal(12)
    dense = A.toarray()
    for got, exact in [
        (moves.times(A), dense @ P),
        (moves.transposed_times(A), P.T @ dense),
        (moves.move(d), P @ d),
        (moves.project(r), P.T @ r),
    ]:
        assert np.abs(got - exact).max() <= 1e-14 * np.abs(exact).max()


def test_a_settles_woodbury_correction_is_the_direct_solve():
    rng = np.random.default_rng(5)
    n, p = 30, 12
    B = rng.standard_normal((n, n))
    S = B @ B.T + n * np.eye(n)
    F = sp.csr_array(1e3 * sp.random_array((p, n), density=0.2, random_state=rng))
    L = np.linalg.cholesky(S)
    Y = np.linalg.solve(S, F.T.toarray())
    points = settle.Points(F, Y, F @ Y)
    r = rng.standard_normal(n)
    for active in (np.zeros(p, bool), rng.random(p) < 0.5, np.ones(p, bool)):
        Fa = F[active].toarray()
        exact = np.linalg.solve(S + Fa.T @ Fa, r)
        got = points.solve(L, active, r)
        assert np.abs(got - exact).max() <= 1e-10 * np.abs(exact).max()
