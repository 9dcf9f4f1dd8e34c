"""The block eigensolver of reduced subdomains against SLEPc's (dd_contact.solvers.eigen)."""

from __future__ import annotations

from mpi4py import MPI

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp

import dd_contact as dd
from dd_contact import meshes
from dd_contact.assembly import assemble
from dd_contact.errors import InputError, SingularMatrixError
from dd_contact.paper.verify.reduced import STEEL, cantilever, locator
from dd_contact.solvers import eigen
from dd_contact.solvers.eigen import EigenStatistics, fixed_interface_modes, lowest_modes
from dd_contact.solvers.interior import InteriorMatrix, PlainInterior
from dd_contact.solvers.worklog import WorkLog


class Pencil:
    """A clamped beam's free stiffness and mass, factorised, for both eigensolvers."""

    def __init__(self, cells=(30, 2, 2), size=(1.0, 0.1, 0.1)):
        mesh = meshes.box(MPI.COMM_SELF, [0, 0, 0], list(size), list(cells))
        sub = dd.Subdomain(mesh, STEEL, "beam").fix(locator(0, 0.0))
        model = assemble(dd.Scene(MPI.COMM_SELF, [sub]))
        A = sp.csr_array(model.system.block(sub.block, sub.block))
        free = np.setdiff1d(np.arange(A.shape[0]), model.dirichlet[sub.block][0])
        self.A, self.M = A[free][:, free], sp.csr_array(model.mass[sub.block])[free][:, free]
        self.n = free.size
        self.log = WorkLog()
        self.mass = InteriorMatrix(self.M)
        self.stiffness = InteriorMatrix(self.A)
        self.factor = PlainInterior(self.stiffness, sp.csr_array((self.n, 0)), self.log, "beam")

    def block(self, count, block=16, workspace=64, stats=None, extra=0, tolerance=1e-12):
        return lowest_modes(
            lambda X: self.factor.solve(X, "modes"),
            self.mass.__matmul__,
            self.n,
            count,
            tolerance,
            "beam",
            block,
            workspace,
            extra,
            stats,
        )

    def slepc(self, count):
        return fixed_interface_modes(
            self.stiffness.mat, self.factor, self.mass.mat, count, 1e-12, "beam"
        )

    def destroy(self):
        self.factor.destroy()
        self.stiffness.release()
        self.mass.mat.destroy()


@pytest.fixture(scope="module")
def beam():
    pencil = Pencil()
    yield pencil
    pencil.destroy()


def _same_span(pencil, X, Y) -> float:
    """The smallest cosine of the principal angles between two M-orthonormal bases."""
    return float(np.linalg.svd(X.T @ (pencil.M @ Y), compute_uv=False).min())


def _cluster_edge(values, count) -> bool:
    """Whether the ``count``-th and next eigenvalues are apart (no cluster split)."""
    return values[count] - values[count - 1] > 1e-6 * values[count]


def test_block_modes_equal_slepcs_on_a_beam_with_repeated_eigenvalues(beam):
    """A square cross-section: its bending modes come in equal pairs (y and z)."""
    values, modes = beam.slepc(41)
    assert abs(values[1] / values[0] - 1) < 1e-8  # a repeated pair: the hard case
    count = next(c for c in range(40, 0, -1) if _cluster_edge(values, c))
    stats = EigenStatistics()
    mine, X = beam.block(count, stats=stats, extra=2)
    assert X.shape == (beam.n, count + 2) and X.flags.f_contiguous
    assert X.base is not None and X.base.size == X.size  # the basis shrunk, not copied
    X = X[:, :count]
    np.testing.assert_allclose(mine, values[:count], rtol=1e-10, atol=0)
    assert np.abs(X.T @ (beam.M @ X) - np.eye(count)).max() < 1e-12
    assert stats.second_passes < stats.solves / 2  # one pass against V for most blocks
    assert _same_span(beam, X, modes[:, :count]) > 1 - 1e-9
    residual = beam.A @ X - (beam.M @ X) * mine
    assert np.linalg.norm(residual) <= 1e-8 * np.linalg.norm((beam.M @ X) * mine)
    # every block solve is one record of the work log, its columns as its solves
    solves = [r for r in beam.log.records if r.what == "modes" and r.nrhs == 16]
    assert stats.solves >= 3 and stats.columns == 16 * stats.solves
    assert len(solves) >= stats.solves


@pytest.mark.parametrize("block, workspace", [(4, 32), (8, 64), (32, 64)])
def test_any_block_size_gives_the_same_modes(beam, block, workspace):
    values, _ = beam.slepc(25)
    count = next(c for c in range(24, 0, -1) if _cluster_edge(values, c))
    mine, _ = beam.block(count, block, workspace)
    np.testing.assert_allclose(mine, values[:count], rtol=1e-10, atol=0)


def test_a_small_pencil_is_solved_whole():
    """Too few dofs for two blocks beyond the modes: C whole, then a dense eigensolve."""
    pencil = Pencil((4, 1, 1), (1.0, 0.25, 0.25))
    try:
        stats = EigenStatistics()
        count = pencil.n - 6
        values, X = pencil.block(count, stats=stats)
        assert stats.columns == pencil.n
        dense = np.linalg.eigvals(np.linalg.solve(pencil.M.toarray(), pencil.A.toarray()))
        np.testing.assert_allclose(values, np.sort(dense.real)[:count], rtol=1e-9)
        assert np.abs(X.T @ (pencil.M @ X) - np.eye(count)).max() < 1e-9
    finally:
        pencil.destroy()


def test_a_block_that_lost_rank_gets_random_columns():
    """Cholesky QR fails on a block with a repeated column: the columns one by one."""
    rng = np.random.default_rng(3)
    n = 200
    M = sp.diags_array(rng.uniform(1.0, 2.0, n))
    basis = eigen._Basis(n, 20, lambda X: M @ X, rng, EigenStatistics())
    Q0, _, _ = basis.normalise(rng.standard_normal((n, 4)), 0)
    basis.V[:, :4] = Q0
    W = rng.standard_normal((n, 4))
    W[:, 2] = W[:, 0] + basis.V[:, 1]  # in the span of V and the block
    W0 = W.copy()
    h, _ = basis.orthogonalise(W, 4)
    Q, R, MQ = basis.normalise(W, 4)
    V = np.hstack([basis.V[:, :4], Q])
    assert np.abs(V.T @ (M @ V) - np.eye(8)).max() < 1e-12
    assert np.abs(MQ - M @ Q).max() < 1e-12
    assert R[2, 2] == 0.0  # the lost column: random, no part of W
    np.testing.assert_allclose(basis.V[:, :4] @ h + Q @ R, W0, atol=1e-10)


def test_no_convergence_in_the_budget_is_refused(beam, monkeypatch):
    monkeypatch.setattr(eigen, "MAX_RESTARTS", 1)
    with pytest.raises(
        SingularMatrixError, match=r"'beam'.*found .* of the 30.*eigensolver='slepc'"
    ):
        beam.block(30, 16, 32)


def test_a_tolerance_below_round_off_is_refused_once_progress_stops(beam):
    """1e-16: the residuals stop at round-off (about 1e-13) within a few restarts."""
    stats = EigenStatistics()
    with pytest.raises(
        SingularMatrixError,
        match=r"'beam'.* of the 30 .* tolerance of 1\.0e-16, no progress in its last 40 "
        r"restarts: .* got down to \d\.\de-1[2-5]; .*above ~1e-13.*eigensolver='slepc'",
    ):
        beam.block(30, 8, 64, stats=stats, tolerance=1e-16)
    assert eigen.STALL_RESTARTS < stats.restarts <= 2 * eigen.STALL_RESTARTS  # not 1,000
    best = min(stats.residuals)
    assert min(stats.residuals[-eigen.STALL_RESTARTS :]) * eigen.STALL_FACTOR > best


@pytest.mark.parametrize("tolerance", [1e-8, 1e-13])
def test_a_reachable_tolerance_converges(beam, tolerance):
    values, _ = beam.slepc(31)
    stats = EigenStatistics()
    mine, _ = beam.block(30, 8, 64, stats=stats, tolerance=tolerance)
    assert stats.residuals[-1] <= tolerance < stats.residuals[0]
    np.testing.assert_allclose(mine, values[:30], rtol=max(tolerance, 1e-10) * 10, atol=0)


@pytest.mark.parametrize("rate, stalled", [(0.98, False), (0.99, True), (1.0, True), (1e-3, False)])
def test_a_slow_but_steady_fall_is_not_taken_for_a_stall(rate, stalled):
    """40 restarts must bring the residual below half its lowest before: a rate of 0.98 a
    restart does (0.45), 0.99 does not (0.67)."""
    history = [1e-2 * rate**k for k in range(eigen.STALL_RESTARTS + 1)]
    assert eigen._stalled(history) is stalled
    assert eigen._stalled(history[:-1]) is False  # too few restarts to tell


@pytest.mark.parametrize("bad", [0.0, -1e-12, 1.0, 2.0, float("nan"), float("inf"), "1e-12"])
def test_reduce_refuses_a_tolerance_outside_zero_one(bad):
    sub = cantilever(8).subdomains[0]
    with pytest.raises(InputError, match=r"subdomain 'part0'.*reduce\(tolerance"):
        sub.reduce(modes=4, tolerance=bad)


def test_reduce_takes_either_eigensolver_and_refuses_others():
    scene = cantilever(8)
    sub = scene.subdomains[0]
    with pytest.raises(InputError, match=r"eigensolver='lanczos'.*'block', 'slepc'"):
        sub.reduce(modes=4, eigensolver="lanczos")
    assert sub.reduce(modes=4).reduction.eigensolver == "block"
    assert sub.reduce(modes=4, eigensolver="slepc").reduction.eigensolver == "slepc"


def test_a_reduced_basis_is_the_same_with_either_eigensolver():
    from dd_contact.solvers.reduced import ReducedBasis
    from dd_contact.solvers.reduced_model import tied_dofs
    from dd_contact.solvers.subdomains import coupling_layout

    scene = cantilever(12)
    model = assemble(scene)
    block = scene.subdomains[0].block
    A, M = model.system.block(block, block), model.mass[block]
    tied, dofs = tied_dofs(coupling_layout(block, model.system)[1]), model.dirichlet[block][0]
    bases = {
        how: ReducedBasis(A, M, tied, dofs, (), 20, WorkLog(), "cantilever", 1e-12, how)
        for how in ("block", "slepc")
    }
    try:
        block_, slepc = bases["block"], bases["slepc"]
        np.testing.assert_allclose(block_.omega2, slepc.omega2, rtol=1e-10, atol=0)
        low = [sla.eigh(b.M_r, b.A_r, eigvals_only=True)[::-1][:20] for b in (block_, slepc)]
        np.testing.assert_allclose(low[0], low[1], rtol=1e-10, atol=0)
    finally:
        for b in bases.values():
            b.destroy()
