"""Contact pairs corrected point by point (dd_contact/solvers/pointwise.py).

A pair's change is corrected with its points' own rows against the factorised state: the
same answers as re-factorising, each point eliminated once while the factorisation lasts,
and the capacitance matrix solved by Cholesky when every point changed the same way.
"""

import numpy as np
import pytest
import scipy.linalg as sla
from test_pairs import _tilted_scene

import dd_contact as dc
from dd_contact.solvers import pointwise
from dd_contact.solvers.lowrank import REFINEMENTS, LowRankSurface
from dd_contact.solvers.pointkernels import PointCorrection, forward_columns, local_rows
from dd_contact.solvers.pointwise import PointwiseSurface
from dd_contact.solvers.surface import Surface, kept_into

KAPPA = 1e4  # as tests/test_lowrank.py: exact solvers of these scenes agree to 1e-12 there


def _solved(order: str, enabled: bool, monkeypatch):
    """The tilted pair solved statically: fields, changes, the work log and the surface."""
    monkeypatch.setattr(LowRankSurface, "enabled", enabled)
    monkeypatch.setattr(LowRankSurface, "refactorise_seconds", lambda self, blocks: np.inf)
    scene = _tilted_scene(order != "w-u", KAPPA, kappa=KAPPA)[0]
    with dc.StaticProblem(scene, algorithm=order) as problem:
        problem.solve()
        fields = np.concatenate([s.u.x.array for s in scene.subdomains])
        surface = problem.solver.surface
        return fields, dict(problem.changes), problem.work, surface


@pytest.mark.parametrize("order", ["v-w-u", "w-v-u", "w-u"])
def test_a_pair_change_is_corrected_point_by_point_with_the_refactorised_answer(order, monkeypatch):
    reference, changes, _, _ = _solved(order, False, monkeypatch)
    fields, corrected_changes, work, surface = _solved(order, True, monkeypatch)
    assert corrected_changes == changes and changes["gamma"] >= 2
    assert np.abs(fields - reference).max() <= 1e-10 * np.abs(reference).max()
    assert isinstance(surface, PointwiseSurface) and isinstance(surface.correction, PointCorrection)
    updates = [r for r in work.records if r.kind == "dense_update"]
    assert len(updates) == changes["gamma"]
    # every point that differed from the factorised state was eliminated once: the
    # updates' new columns add up to the points the reference's cache holds
    assert sum(r.nrhs for r in updates) == len(surface._cached) > 0
    differing = sum(
        int(np.count_nonzero(surface.active[n] != surface.reference[n])) for n in surface.regions
    )
    assert updates[-1].size == surface.correction.rank == differing


@pytest.mark.parametrize(
    ("signs", "cholesky"), [((-1.0,), True), ((1.0,), True), ((1.0, -1.0), False)]
)
def test_the_capacitance_matrix_is_solved_by_cholesky_when_the_points_changed_alike(
    signs, cholesky
):
    rng = np.random.default_rng(3)
    k = 12
    Q = np.linalg.qr(rng.standard_normal((k, k)))[0]
    G = Q @ np.diag(rng.uniform(0.05, 0.9, k)) @ Q.T  # below the identity: as held points'
    D = np.resize(np.array(signs), k)
    c = PointCorrection(D=D, G=G)
    c.factorise()
    assert (c.cholesky is not None) == cholesky and c.capacitance is not None
    y = rng.standard_normal(k)
    z = c.solve(y)
    assert np.abs(z + D * (G @ z) - y).max() <= 1e-12 * np.abs(y).max()
    assert 0.0 < c.conditioned <= 1.0


def _forty_steps(kind, order, corrected, monkeypatch):
    """40 steps of an order scene, its changes corrected or re-factorised: every step's
    fields, the changes, the work log and the surface."""
    from dd_contact.paper.verify import orders as order_scenes

    monkeypatch.setattr(LowRankSurface, "enabled", corrected)
    scene = order_scenes.order_scene(kind, dynamic=True, kappa=KAPPA)
    with dc.TransientProblem(scene, 0.01, algorithm=order) as problem:
        fields = []
        for _ in range(40):
            problem.advance()
            fields.append(np.concatenate([s.u.x.array for s in scene.subdomains]))
        return np.array(fields), dict(problem.changes), problem.work, problem.solver.surface


@pytest.mark.parametrize(("kind", "order"), [("single", "w-u"), ("interface", "w-v-u")])
def test_a_wall_change_is_corrected_point_by_point_with_the_refactorised_answer(
    kind, order, monkeypatch
):
    """A plane's normals never turn: its changes go through its point rows, no group is
    re-factorised, and every step's fields agree with re-factorising on every change."""

    monkeypatch.setattr(LowRankSurface, "refactorise_seconds", lambda self, blocks: np.inf)

    reference, changes, work_ref, _ = _forty_steps(kind, order, False, monkeypatch)
    fields, corrected_changes, work, surface = _forty_steps(kind, order, True, monkeypatch)
    assert corrected_changes == changes and changes["gamma"] >= 2
    assert np.abs(fields - reference).max() <= 1e-10 * np.abs(reference).max()
    assert isinstance(surface, PointwiseSurface) and list(surface.regions) == ["end"]
    groups = len({r.block for r in work_ref.records if r.kind == "dense_factor"})
    assert work.count("dense_factor") == groups < work_ref.count("dense_factor")
    # a change back to the factorised state needs none: at most one update per change
    assert 0 < work.count("dense_update") <= changes["gamma"]


@pytest.mark.parametrize(("kind", "order"), [("single", "w-u"), ("interface", "w-v-u")])
def test_a_wall_change_on_the_last_level_is_solved_in_one_pass(kind, order, monkeypatch):
    """The points' columns reach the last level alone: every corrected solve is one pass
    (W z subtracted between its substitutions), none falls back on two, and the fields
    agree with re-factorising on every change."""

    monkeypatch.setattr(LowRankSurface, "refactorise_seconds", lambda self, blocks: np.inf)
    calls = {"two": 0, "one": 0, "back": 0}
    two_passes, one_pass = LowRankSurface._corrected, PointwiseSurface._half

    def counted_two(self, c, g):
        calls["two"] += 1
        return two_passes(self, c, g)

    def counted_one(self, grp, b, trans):
        calls["one"] += trans  # one forward substitution per group and solve
        return one_pass(self, grp, b, trans)

    def counted_columns(self, grp, B):  # a first flip's points beside the forward one
        calls["one"] += 1
        return columns(self, grp, B)

    def counted_back(self, x):  # the earlier levels: once a step, at its finish
        calls["back"] += 1
        return back(self, x)

    columns, back = PointwiseSurface._columns_forward, Surface.back_substitute
    monkeypatch.setattr(LowRankSurface, "_corrected", counted_two)
    monkeypatch.setattr(PointwiseSurface, "_half", counted_one)
    monkeypatch.setattr(PointwiseSurface, "_columns_forward", counted_columns)
    monkeypatch.setattr(Surface, "back_substitute", counted_back)

    reference, *_ = _forty_steps(kind, order, False, monkeypatch)
    plain, calls["back"] = calls["back"], 0
    assert calls == {"two": 0, "one": 0, "back": 0} and plain > 0
    fields, _, _, surface = _forty_steps(kind, order, True, monkeypatch)
    assert np.abs(fields - reference).max() <= 1e-10 * np.abs(reference).max()
    assert calls["two"] == 0 and calls["one"] == len(surface.applications) > 0
    assert set(surface.applications) == {1}
    # a corrected solve inside the contact iteration leaves the earlier levels to the
    # finish, as a plain solve does (w-v-u: the interface's substitution each time)
    assert calls["back"] == plain


@pytest.mark.parametrize(("kind", "order"), [("single", "w-u"), ("interface", "w-v-u")])
def test_a_first_flip_s_points_are_eliminated_by_the_solve_s_own_substitution(
    kind, order, monkeypatch
):
    """On the last level, points eliminated for the first time ride along the corrected
    solve's forward substitution (one reading of the factor): none is eliminated apart, each
    one new column of a substitution (:func:`forward_columns`), and the fields agree with
    re-factorising."""

    monkeypatch.setattr(LowRankSurface, "refactorise_seconds", lambda self, blocks: np.inf)
    two_passes = []  # a corrected solve found inaccurate is made again in two passes
    original = LowRankSurface._corrected
    monkeypatch.setattr(
        LowRankSurface, "_corrected", lambda s, c, g: two_passes.append(1) or original(s, c, g)
    )
    reference, *_ = _forty_steps(kind, order, False, monkeypatch)
    fields, _, work, surface = _forty_steps(kind, order, True, monkeypatch)
    assert np.abs(fields - reference).max() <= 1e-10 * np.abs(reference).max()
    assert not [r for r in work.records if r.what == "lowrank"]  # no elimination apart
    new = sum(r.nrhs for r in work.records if r.kind == "dense_update")  # points first seen
    riding = sum(r.nrhs - 1 for r in work.records if r.kind == "dense_solve" and r.what == "x")
    assert riding == new > 0 and not two_passes
    assert not len(surface._pending) and surface._cache.rank == len(surface._cached)
    # the rows the points touch (the end's normal dofs) are factorised last, so a new
    # column's elimination is a solve with their trailing triangle alone
    P, at, _ = surface.joined()
    for grp in surface.schedule.groups[-1]:
        local = local_rows(grp.blocks, surface.sizes, np.unique(P.indices[P.data != 0]), dict(at))
        touched = local[local >= 0]
        factor = surface.state[grp.name].factor
        assert 0 < len(touched) < factor.size and factor.order is not None
        assert set(factor.order[-len(touched) :].tolist()) == set(touched.tolist())
        for r in work.records:
            if r.block == grp.name and r.what == "x" and r.nrhs > 1:  # b and new columns
                assert r.flops - r.size**2 <= (r.nrhs - 1) * len(touched) ** 2


def _bar_steps(corrected: bool, monkeypatch, steps: int = 20):
    """The paper's bar (25 x 6 x 5, its default penalty) striking its wall in w-u: every
    step's fields, the changes, the surface and how many solves were made in two passes."""
    from mpi4py import MPI

    from dd_contact.paper import models

    monkeypatch.setattr(LowRankSurface, "enabled", corrected)
    monkeypatch.setattr(LowRankSurface, "refactorise_seconds", lambda self, blocks: np.inf)
    two_passes, original = [], LowRankSurface._corrected
    monkeypatch.setattr(
        LowRankSurface, "_corrected", lambda s, c, g: two_passes.append(1) or original(s, c, g)
    )
    scene = models.parallelepiped((25, 6, 5), algorithm="w-u", comm=MPI.COMM_SELF)
    with dc.TransientProblem(scene, 1e-4, "w-u", track_energy=False) as problem:
        fields = []
        for _ in range(steps):
            problem.advance()
            fields.append(np.concatenate([s.u.x.array for s in scene.subdomains]))
        return np.array(fields), dict(problem.changes), problem.solver.surface, len(two_passes)


@pytest.mark.filterwarnings("ignore::dd_contact.CoarseTimeStepWarning")
def test_stiff_points_corrected_in_one_pass_are_refined_not_solved_again(monkeypatch):
    """Points far stiffer than the rest of S, added to a factor without them, cancel digits
    in ``W z``: the one-pass answer misses the tolerance (by 1e5-1e6 on the bar) and is
    refined with its true residual, one more pass, instead of being made again in two
    passes. The fields agree with re-factorising as the two-pass solves' did (3.5e-8 of
    the largest: the penalised system's conditioning)."""

    reference, changes, _, _ = _bar_steps(False, monkeypatch)
    fields, corrected_changes, surface, two_passes = _bar_steps(True, monkeypatch)
    assert corrected_changes == changes and changes["end"] >= 10
    assert np.abs(fields - reference).max() <= 1e-7 * np.abs(reference).max()
    assert two_passes == 0 and isinstance(surface, PointwiseSurface)
    assert surface._refinements and max(surface._refinements) >= 1


@pytest.mark.filterwarnings("ignore::dd_contact.CoarseTimeStepWarning")
def test_refinements_that_cost_a_re_factorisation_re_factorise(monkeypatch):
    """The bar on its wall: its stiff points keep the one-pass solves refined while they
    differ from the reference. With each update's re-factorisation priced at two
    refinements, the groups are re-factorised once two were made (the reference then holds
    the points), the count starting afresh; the fields are re-factorising's."""
    reference, *_ = _bar_steps(False, monkeypatch)
    update, fired, counts = PointwiseSurface._point_update, [], []

    def priced(surface, rest):  # after the update: its re-factorisation at two refinements
        done = update(surface, rest)
        surface._refactorise_price = 2.0 * surface.solve_seconds(1.0)
        return done

    factorise = PointwiseSurface.factorise

    def watched(surface):
        due = surface._refined >= surface._refactorise_price and surface.correction.rank
        counts.append(surface._refined / surface.solve_seconds(1.0))
        factorise(surface)
        if due:
            fired.append(surface.correction.rank == 0 and surface._refined == 0.0)

    monkeypatch.setattr(PointwiseSurface, "_point_update", priced)
    monkeypatch.setattr(PointwiseSurface, "factorise", watched)
    fields, *_ = _bar_steps(True, monkeypatch)
    assert fired and all(fired)  # re-factorised, its count reset
    assert max(counts) < 2.0 + REFINEMENTS + 1e-9  # never a solve's refinements past the price
    assert np.abs(fields - reference).max() <= 1e-7 * np.abs(reference).max()


@pytest.mark.filterwarnings("ignore::dd_contact.CoarseContactWarning")
def test_a_refined_one_pass_solve_keeps_the_earlier_levels_it_solved(monkeypatch):
    """w-v-u, the reduced cantilever in two tied pieces pressed on its wall (``dd-contact
    verify`` 's reduced-static): a corrected solve refined with its residual leaves the
    earlier levels' state at the refinement's right-hand side, so its answer's interface
    blocks are its own, not back-substituted again from that state (which answered with a
    whole-system residual of 1.9e-3). The reduced answer equals the unreduced one."""
    from dd_contact.paper.verify.reduced import static_difference

    monkeypatch.setattr(LowRankSurface, "refactorise_seconds", lambda self, blocks: np.inf)
    passes, one_pass = [], PointwiseSurface._one_pass
    monkeypatch.setattr(
        PointwiseSurface,
        "_one_pass",
        lambda s, c, u, size: passes.append(1) or one_pass(s, c, u, size),
    )
    per_solve, solve = [], PointwiseSurface.solve

    def counted(surface, g, complete):  # the one-pass passes each solve made
        before = len(passes)
        out = solve(surface, g, complete)
        per_solve.append(len(passes) - before)
        return out

    monkeypatch.setattr(PointwiseSurface, "solve", counted)
    du, df = static_difference(2, "w-v-u", [3, 0])
    assert du <= 1e-8 and df <= 1e-8
    assert max(per_solve) >= 2  # a refined solve among them


def test_a_first_flip_with_an_ill_conditioned_capacitance_matrix_is_re_factorised(monkeypatch):
    """Its capacitance matrix is made by the solve that eliminates the new points: when that
    is ill-conditioned the solve re-factorises, as a change checked at once would."""

    monkeypatch.setattr(LowRankSurface, "refactorise_seconds", lambda self, blocks: np.inf)
    reference, _, work_ref, _ = _forty_steps("single", "w-u", False, monkeypatch)
    monkeypatch.setattr(pointwise, "CAPACITANCE_RCOND", (1e-10, 2.0))  # none well enough
    fields, _, work, _ = _forty_steps("single", "w-u", True, monkeypatch)
    assert np.abs(fields - reference).max() <= 1e-10 * np.abs(reference).max()
    assert work.count("dense_factor") == work_ref.count("dense_factor")
    assert work.count("dense_update") > 0  # corrections made, then found ill-conditioned


@pytest.mark.parametrize("n", [1, 255, 256, 600])
@pytest.mark.parametrize("per_column_rows", [0, 10**6])  # block by block, column by column
def test_forward_columns_solves_each_column_from_its_first_row(n, per_column_rows):
    """Columns starting at any row (a dense one, zero ones) against a triangular solve."""
    rng = np.random.default_rng(n)
    A = rng.standard_normal((n, n))
    A = A @ A.T + n * np.eye(n)
    L = sla.cho_factor(A, lower=True)[0]  # its upper triangle holds A's: never read
    B = np.zeros((n, 9), order="F")  # its last column zero
    B[:, 0] = rng.standard_normal(n)
    for j, first in enumerate(rng.integers(0, n, 7), start=1):
        B[first : first + 5, j] = rng.standard_normal(len(B[first : first + 5, j]))
    expected = sla.solve_triangular(np.tril(L), B, lower=True)
    flops = forward_columns(L, B, per_column_rows)
    assert np.abs(B - expected).max() <= 1e-13 * np.abs(expected).max()
    assert n * n <= flops <= 9 * n * n
    with pytest.raises(ValueError, match="Fortran-ordered"):
        forward_columns(L, B.astype(np.float32, order="F"))  # raw BLAS: checked first


def test_kept_columns_added_in_place_keep_their_values_when_the_scratch_is_reused():
    """``kept_into(spare=True)`` writes new columns after the kept ones: never into the
    array they were eliminated in (a scratch the next elimination overwrites)."""
    rng = np.random.default_rng(5)
    kept: dict = {}
    G, scratch = np.zeros((5, 5)), np.zeros((6, 64), order="F")
    first = scratch[:, 1:3]
    first[:] = rng.standard_normal((6, 2))
    kept_into(kept, G, "g", np.arange(2), first, first, spare=True)
    expected = first.copy()
    scratch[:] = 0.0
    second = scratch[:, 1:4]
    second[:] = rng.standard_normal((6, 3))
    kept_into(kept, G, "g", np.arange(2, 5), second, second, spare=True)
    expected = np.hstack([expected, second])
    scratch[:] = 0.0
    assert np.array_equal(kept["g"][0], np.arange(5))
    assert np.array_equal(kept["g"][1], expected)
    assert np.abs(G - expected.T @ expected).max() <= 1e-14 * np.abs(G).max()


def test_a_dense_cholesky_in_another_row_order_solves_as_the_group_s_own():
    """Rows factorised in another order (the points' last): solves, congruences and the
    two halves in and out of the factor's order give the unpermuted factor's answers."""
    from dd_contact.solvers.dense import DenseCholesky
    from dd_contact.solvers.worklog import WorkLog

    rng = np.random.default_rng(7)
    n = 40
    A = rng.standard_normal((n, n))
    A = A @ A.T + n * np.eye(n)
    order = rng.permutation(n)
    plain = DenseCholesky(A.copy(), WorkLog(), "g")
    ordered = DenseCholesky(A[np.ix_(order, order)].copy(), WorkLog(), "g", order)
    B = rng.standard_normal((n, 3))
    B[:10] = 0.0  # leading zero rows: the congruence starts at the first non-zero
    tol = 1e-12 * np.abs(np.linalg.solve(A, B)).max()
    assert np.abs(ordered.solve(B) - np.linalg.solve(A, B)).max() <= tol
    assert np.abs(ordered.solve(B[:, 0]) - plain.solve(B[:, 0])).max() <= tol
    assert (
        np.abs(ordered.congruence(B) - plain.congruence(B)).max()
        <= 1e-12 * np.abs(plain.congruence(B)).max()
    )
    y = ordered.half(B, 1)  # L^-1 B in the factor's order: its products are the same
    assert np.abs(y.T @ y - plain.half(B, 1).T @ plain.half(B, 1)).max() <= 1e-12 * n
    assert np.abs(ordered.half(y, 0) - np.linalg.solve(A, B)).max() <= tol
    rows = np.array([3, 17])
    moved = ordered.into_order(np.eye(n)[:, rows])  # a group's rows: where the factor has them
    assert np.array_equal(moved[ordered.rows(rows), [0, 1]], [1.0, 1.0])
