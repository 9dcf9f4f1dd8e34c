"""The lowest eigenpairs of ``A x = lambda M x``: by block solves, or by SLEPc (issue 28).

:func:`fixed_interface_modes` runs SLEPc's Krylov-Schur, shift-invert at 0, whose every
solve is one column of the factor of A; :func:`lowest_modes` (docs/solvers.md, "Reduced
subdomains") runs a thick-restart block Lanczos (the symmetric block Krylov-Schur) on
``C = A^-1 M``, self-adjoint in the M-inner product: its largest eigenvalues
``theta = 1 / lambda`` are the wanted ones. Every application of C is one multi-RHS solve
of ``block`` columns, which reads the factor of A once (as a single-vector solve does: at
85k dofs a column of a 16-column block costs a thirteenth of one), and the
orthogonalisations are BLAS-3.

The basis V (n x ``columns``) is the only n-sized array held beyond a few blocks: inner
products with M take ``M W`` of the block at hand, never ``M V``. Each new block
``W = C Q`` is first rid of Q (the last block, M Q at hand), then M-orthogonalised against
V by classical Gram-Schmidt (in place by gemm), a second pass only when the first cut its
M-norm by much (``REORTHOGONALISE``), and within itself by Cholesky QR twice (triangular
solves in place); a block that has lost
rank (an invariant subspace found) gets random columns in place of the lost ones. The
projected matrix ``H = V^T M C V`` is read off those coefficients; its Ritz pairs' residual
norms ``||C y - theta y||_M`` come from the last block's coupling, and the run stops when
each wanted pair's is at most ``tolerance`` of ``theta`` (SLEPc's relative criterion). A
restart keeps the best Ritz vectors, rotating V in place by rows (no second n x columns
array). A run whose residuals stop falling (a tolerance below round-off) is refused after
``STALL_RESTARTS`` restarts, not ``MAX_RESTARTS``.
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import scipy.linalg

from dd_contact.errors import SingularMatrixError
from dd_contact.solvers.linalg import release_freed_memory

__all__ = ["EigenStatistics", "KrylovResidual", "fixed_interface_modes", "lowest_modes"]

#: SLEPc's workspace is count + this many vectors of the interior (its default, twice the
#: count, held 640 vectors for 320 modes) ...
MODES_WORKSPACE = 64

#: Columns per solve of the block eigensolver (:func:`lowest_modes`). 160 modes at 86k
#: dofs (SLEPc: 386 single solves, 49 s CPU): 8 took 776 columns in 97 solves, 21 s; 4 took
#: 520 in 130, 22 s; 16 took 2,672 in 167, 61 s (928 in 58, 22 s, with 128 vectors more).
MODES_BLOCK = 8

#: ... and out of core, where each solve reads the factor back from disk (12 GB at the
#: paper's bar: 16 s a solve of 8 columns): a quarter of the solves, the same basis
#: (``count + max(workspace, 2 block)``: 320 + 64 columns either way).
MODES_BLOCK_OUT_OF_CORE = 32

#: ... and its largest projected problem (None: the whole workspace). 320 modes at 15k
#: dofs: 1,545 solves with 64 (as before), 1,011 with 128, 800 with None, 41 % less CPU.
MODES_PROJECTED: int | None = None


#: Rows of V rotated at once by a restart (bounds its temporary: rows x kept doubles).
ROTATION_ROWS = 4096

#: A block column whose M-norm after orthogonalisation is below this fraction of its norm
#: before it is in the span of V already: it is replaced by a random column.
RANK_FLOOR = 1e-10

#: The share of the unconverged Ritz vectors a restart keeps (SLEPc's: half). 8-column
#: blocks at 16k dofs, 160 / 320 modes: 824 / 1,664 columns with 0.5, 728 / 1,152 with 0.7,
#: 712 / 1,064 with 0.8 / 0.85 (but more restarts, each rotating V: more CPU).
RESTART_KEPT = 0.7

#: A block one Gram-Schmidt pass left with less than this fraction of a column's M-norm
#: gets a second pass. 160 modes at 2.9k dofs: 1/sqrt(2) (DGKS's) took 33 second passes
#: in 82 blocks, 0.3 took 6, the modes M-orthonormal to 9e-15 both; 0.05, 1e-13; 0.03,
#: 2e-12; 0.01 did not converge. 320 modes on the 1/16 bar: 3 second passes in 161 blocks,
#: the eigenvalues those of two passes always to 1.3e-12.
REORTHOGONALISE = 0.3

#: Restarts at most before the solver gives up.
MAX_RESTARTS = 1000

#: ... and sooner when the largest residual of the wanted pairs has not gone below
#: 1 / ``STALL_FACTOR`` of its lowest in the last ``STALL_RESTARTS`` restarts: stuck at
#: round-off (a tolerance of 1e-16 on a beam: from 1e-2 to 8e-14 in 5 restarts, then
#: between 3e-14 and 3e-13 for 1,000). The slowest converging run measured (blocks of 32
#: with a workspace of 64, 24 modes at 1e-13: 324 restarts, 0.98 a restart at the end)
#: fell by 1/0.44 in every 20 restarts, 1/0.17 in 30, 1/0.08 in 40.
STALL_RESTARTS = 40
STALL_FACTOR = 2.0


@dataclass
class EigenStatistics:
    """What a run of :func:`lowest_modes` cost: columns solved, block solves, restarts.

    ``second_passes``: blocks orthogonalised against V twice. ``residuals``: at each
    restart, the largest relative residual of the wanted pairs. ``cpu``: CPU seconds by
    part: the solves, the products with M, the projections against V (its gemms), the
    restarts' rotations, and the whole (the rest is the normalisations and the small
    problems).
    """

    columns: int = 0
    solves: int = 0
    restarts: int = 0
    second_passes: int = 0
    residuals: list = field(default_factory=list)
    cpu: dict = field(
        default_factory=lambda: dict.fromkeys(("solve", "mass", "project", "rotate", "all"), 0.0)
    )

    def timed(self, part: str, apply: Callable) -> Callable:
        """``apply`` with its CPU seconds added to ``part``."""

        def run(*args):
            start = time.process_time()
            out = apply(*args)
            self.cpu[part] += time.process_time() - start
            return out

        return run


@dataclass
class KrylovResidual:
    """What the modes X that :func:`lowest_modes` returns miss of being invariant under C.

    ``C X = X diag(theta) + Q B`` with ``C = A^-1 M`` and ``theta = 1 / lambda``: the
    Krylov relation of their space (Rayleigh-Ritz vectors: it holds to round-off whether or
    not they converged), with Q (``block``, n x b) M-orthonormal to X and B (``coupling``,
    b x count). So ``X^T M A^-1 F = (C X)^T F`` is had for any F without a solve. Exact
    eigenvectors (the small problems solved whole) have ``b = 0``.
    """

    block: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    coupling: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))

    @classmethod
    def exact(cls, n: int, count: int) -> KrylovResidual:
        """The residual of ``count`` exact eigenvectors of order n: nothing missed."""
        return cls(np.zeros((n, 0)), np.zeros((0, count)))


Apply = Callable[[np.ndarray], np.ndarray]


class _Basis:
    """The M-orthonormal basis V, in a buffer that can be shrunk to the modes in place."""

    def __init__(
        self, n: int, columns: int, mass: Apply, rng: np.random.Generator, stats: EigenStatistics
    ):
        self.n, self.mass, self.rng, self.stats = n, mass, rng, stats
        self.buffer = np.empty(n * columns)
        self.V = self.buffer.reshape(columns, n).T  # column-ordered: each column contiguous

    def orthogonalise(
        self, W: np.ndarray, filled: int, MQ: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """W M-orthogonal to V's first ``filled`` columns, in place: the coefficients and M W.

        ``W = C Q`` for Q the last ``MQ.shape[1]`` columns of V (``MQ = M Q``) is mostly Q
        itself: removed first (small products, M Q at hand), what is left is not cut by
        much by the pass against V (classical Gram-Schmidt), which is repeated only for a
        block it cut below ``REORTHOGONALISE`` of its M-norm (Daniel-Gragg-Kaufman-Stewart).
        """
        h = np.zeros((filled, W.shape[1]))
        if MQ is not None:
            local = h[filled - MQ.shape[1] :]
            local[:] = MQ.T @ W
            W -= self.V[:, filled - MQ.shape[1] : filled] @ local
        MW = self.mass(W)
        before = _norms(W, MW)
        h += self._against(W, MW, filled)
        MW = self.mass(W)
        if filled and (_norms(W, MW) < REORTHOGONALISE * before).any():
            h += self._against(W, MW, filled)
            MW = self.mass(W)
            self.stats.second_passes += 1
        return h, MW

    def _against(self, W: np.ndarray, MW: np.ndarray, filled: int) -> np.ndarray:
        """One pass: ``W -= V c`` with ``c = V^T M W`` (two gemms, W updated in place)."""
        start = time.process_time()
        V = self.V[:, :filled]
        c = V.T @ MW
        if W.flags.f_contiguous:  # W - V c in place: no n x b temporary
            scipy.linalg.blas.dgemm(-1.0, V, c, 1.0, W, overwrite_c=True)
        else:  # (the random columns of a block that lost rank)
            W -= V @ c
        self.stats.cpu["project"] += time.process_time() - start
        return c

    def normalise(
        self, W: np.ndarray, filled: int, MW: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``W = Q R`` with Q M-orthonormal (Cholesky QR twice): Q, R and M Q.

        ``MW``: M W if known. A column lost to round-off (W of lower rank) is replaced by a
        random one made M-orthogonal to V and Q; its row of R is zero there.
        """
        MW = self.mass(W) if MW is None else MW
        before = _norms(W, MW)
        R = np.eye(W.shape[1])
        for _ in range(2):
            G = W.T @ MW
            try:
                U = scipy.linalg.cholesky(0.5 * (G + G.T), lower=False)
            except np.linalg.LinAlgError:
                return self._by_columns(W, MW, R, filled, before)
            if np.diag(U).min() <= RANK_FLOOR * max(before.max(), 1e-300):
                return self._by_columns(W, MW, R, filled, before)
            W, MW = _right_solve(W, U), _right_solve(MW, U)
            R = U @ R
        return W, R, MW

    def _by_columns(self, W, MW, R, filled: int, before) -> tuple:
        """:meth:`normalise` one column at a time, lost columns replaced by random ones."""
        b = W.shape[1]
        Q, MQ, U = np.empty_like(W), np.empty_like(W), np.zeros((b, b))
        for j in range(b):
            w, mw = W[:, j].copy(), MW[:, j].copy()
            for _ in range(2):
                c = Q[:, :j].T @ mw
                w -= Q[:, :j] @ c
                mw -= MQ[:, :j] @ c
                U[:j, j] += c
            size = np.sqrt(max(w @ mw, 0.0))
            if size <= RANK_FLOOR * max(before.max(), 1e-300):
                w = np.asfortranarray(self.rng.standard_normal((self.n, 1)))
                self.orthogonalise(w, filled)
                w = w[:, 0]
                for _ in range(2):
                    w -= Q[:, :j] @ (MQ[:, :j].T @ w)
                mw = self.mass(w[:, None])[:, 0]
                w, mw, size = w / np.sqrt(w @ mw), mw / np.sqrt(w @ mw), 0.0
            else:
                w, mw = w / size, mw / size
            Q[:, j], MQ[:, j], U[j, j] = w, mw, size
        return Q, U @ R, MQ

    def rotate(self, S: np.ndarray) -> None:
        """``V[:, :l] = V[:, :k] S`` (S k x l, l <= k) in place, a band of rows at a time."""
        k, kept = S.shape
        for r0 in range(0, self.n, ROTATION_ROWS):
            rows = self.V[r0 : r0 + ROTATION_ROWS]
            rows[:, :kept] = rows[:, :k] @ S

    def modes(self, count: int, extra: int) -> np.ndarray:
        """V's first ``count`` columns as those of an n x (count + extra) array (no copy)."""
        size = self.n * (count + extra)
        del self.V
        if size <= self.buffer.size:
            try:  # realloc: the basis's other columns go back to the system
                self.buffer.resize(size, refcheck=True)
                return self.buffer.reshape(count + extra, self.n).T
            except ValueError:
                pass
        out = np.empty((self.n, count + extra), order="F")
        out.T.reshape(-1)[: self.n * count] = self.buffer[: self.n * count]
        return out


def lowest_modes(
    solve: Apply,
    mass: Apply,
    n: int,
    count: int,
    tolerance: float,
    name: str,
    block: int = 16,
    workspace: int = 64,
    extra: int = 0,
    stats: EigenStatistics | None = None,
    krylov_residual: KrylovResidual | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The ``count`` lowest ``lambda`` of ``A x = lambda M x`` and their M-orthonormal x.

    Args:
        solve: ``X -> A^-1 X`` for n x b arrays (a multi-RHS solve of A's factor).
        mass: ``X -> M X``.
        n: The order of A and M.
        count: How many of the lowest eigenpairs (fewer than n).
        tolerance: Relative residual ``||C y - theta y|| / theta`` each must reach.
        name: The subdomain's name, for a refusal.
        block: Columns per solve.
        workspace: The basis holds ``count`` + this many columns (at least two blocks more).
        extra: Columns left after the modes in the returned array (the load modes).
        stats: Filled with the columns solved, the block solves and the restarts.
        krylov_residual: Filled with the modes' :class:`KrylovResidual` (the last block's copy).

    Returns:
        ``lambda`` ascending, and the modes as the first ``count`` columns of an
        n x (count + extra) array (column-ordered).
    """
    stats = stats if stats is not None else EigenStatistics()
    start = time.process_time()
    solve, mass = stats.timed("solve", solve), stats.timed("mass", mass)
    if count + 2 * block > n:  # a small problem: C whole, in blocks
        return _dense(solve, mass, n, count, block, extra, stats, krylov_residual)
    columns = min(n, count + max(workspace, 2 * block))
    rng = np.random.default_rng(20260528)
    basis = _Basis(n, columns, mass, rng, stats)
    rotate = stats.timed("rotate", basis.rotate)
    H = np.zeros((columns, columns))
    Q, _, MQ = basis.normalise(np.asfortranarray(rng.standard_normal((n, block))), 0)
    basis.V[:, :block] = Q
    filled = block
    for restart in range(MAX_RESTARTS + 1):
        while filled + block <= columns:  # expand: C times the last block
            j0 = filled - block
            W = solve(MQ)
            stats.columns, stats.solves = stats.columns + block, stats.solves + 1
            H[:filled, j0:filled], MW = basis.orthogonalise(W, filled, MQ)
            Q, H[filled : filled + block, j0:filled], MQ = basis.normalise(W, filled, MW)
            basis.V[:, filled : filled + block] = Q
            filled += block
        k = filled - block
        theta, S = np.linalg.eigh(0.5 * (H[:k, :k] + H[:k, :k].T))
        theta, S = theta[::-1], S[:, ::-1]  # the largest theta: the lowest lambda
        coupling = H[k:filled, :k] @ S
        residual = np.linalg.norm(coupling, axis=0)
        done = residual[:count] <= tolerance * np.abs(theta[:count])
        stats.residuals.append(float(np.max(residual[:count] / np.abs(theta[:count]))))
        if done.all() or restart == MAX_RESTARTS or _stalled(stats.residuals):
            break
        kept = _kept(int(done.sum()), count, k, columns, block)
        rotate(S[:, :kept])
        basis.V[:, kept : kept + block] = basis.V[:, k:filled]
        H[:] = 0.0
        H[:kept, :kept] = np.diag(theta[:kept])
        H[kept : kept + block, :kept] = coupling[:, :kept]
        filled = kept + block
        stats.restarts += 1
    if not done.all():
        raise _refusal(name, count, int(done.sum()), tolerance, stats.residuals)
    if krylov_residual is not None:  # C V_k S = V_k S diag(theta) + Q (H_qk S), before V goes
        krylov_residual.block = np.array(basis.V[:, k:filled], order="F")
        krylov_residual.coupling = coupling[:, :count].copy()
    rotate(S[:, :count])
    del Q, MQ, W
    stats.cpu["all"] += time.process_time() - start
    return 1.0 / theta[:count], basis.modes(count, extra)


def _stalled(history: list[float]) -> bool:
    """Whether the residual stopped falling (a tolerance below round-off's reach).

    True when the last ``STALL_RESTARTS`` restarts made no new low by ``STALL_FACTOR``.
    """
    if len(history) <= STALL_RESTARTS:
        return False
    return min(history[-STALL_RESTARTS:]) * STALL_FACTOR > min(history[:-STALL_RESTARTS])


def _refusal(name: str, count: int, found: int, tolerance: float, history: list[float]):
    """The error of a run that stopped short: stalled, or out of restarts."""
    why = (
        f"no progress in its last {STALL_RESTARTS} restarts"
        if len(history) <= MAX_RESTARTS
        else f"in {MAX_RESTARTS} restarts"
    )
    return SingularMatrixError(
        f"subdomain {name!r}: the block eigensolver found {found} of the {count} "
        f"fixed-interface modes asked for to a relative tolerance of {tolerance:.1e}, "
        f"{why}: the largest relative residual got down to {min(history):.1e}; ask for a "
        "tolerance above ~1e-13 (Subdomain.reduce(tolerance=...)), fewer modes "
        "(reduce(modes=...)), or eigensolver='slepc'"
    )


def _right_solve(W: np.ndarray, U: np.ndarray) -> np.ndarray:
    """``W U^-1`` (U upper triangular): in place for a column-ordered W."""
    if W.flags.f_contiguous:
        return scipy.linalg.blas.dtrsm(1.0, U, W, side=1, lower=0, overwrite_b=True)
    return scipy.linalg.solve_triangular(U, W.T, trans="T", lower=False).T


def _norms(W: np.ndarray, MW: np.ndarray) -> np.ndarray:
    """The M-norms of W's columns."""
    return np.sqrt(np.maximum(np.einsum("ij,ij->j", W, MW), 0.0))


def _kept(done: int, count: int, k: int, columns: int, block: int) -> int:
    """Ritz vectors a restart keeps: the converged and RESTART_KEPT of the rest.

    Rounded up so the room left is whole blocks, one at least.
    """
    room = columns - block - (done + int(RESTART_KEPT * (k - done)))
    return columns - block - block * max(room // block, 1)


def _dense(
    solve: Apply, mass: Apply, n: int, count: int, block: int, extra: int, stats, krylov_residual
):
    """:func:`lowest_modes` of a small pencil: ``M A^-1 M y = theta M y``, whole."""
    if krylov_residual is not None:  # exact eigenvectors
        exact = KrylovResidual.exact(n, count)
        krylov_residual.block, krylov_residual.coupling = exact.block, exact.coupling
    eye = np.eye(n)
    M = mass(eye)
    C = np.hstack([solve(M[:, j0 : j0 + block]) for j0 in range(0, n, block)])
    stats.columns, stats.solves = n, -(-n // block)
    K = M @ C
    theta, Y = scipy.linalg.eigh(0.5 * (K + K.T), 0.5 * (M + M.T))
    theta, Y = theta[::-1][:count], Y[:, ::-1][:, :count]
    out = np.zeros((n, count + extra), order="F")
    out[:, :count] = Y
    return 1.0 / theta, out


class _FactorSolve:
    """A shell preconditioner applying a sparse factor's solve (SLEPc's shift-invert)."""

    def __init__(self, factor):
        self.factor, self.solves = factor, 0

    def apply(self, pc, x: PETSc.Vec, y: PETSc.Vec) -> None:
        """Y = A^-1 x."""
        y.array[:] = self.factor.solve(x.array_r, None)  # logged together by the caller
        self.solves += 1


def fixed_interface_modes(
    A: PETSc.Mat,
    factor,
    M: PETSc.Mat,
    count: int,
    tolerance: float,
    name: str,
    extra: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """The ``count`` lowest eigenpairs of ``A phi = omega^2 M phi`` (SLEPc, shift-invert at 0).

    The spectral transform's solves are ``factor``'s (``factor.solve(b, None)``: ``A^-1 b``,
    with its ``entries``, ``log`` and ``block``): SLEPc's operator at shift 0 is A itself,
    and its KSP applies the factor through a shell preconditioner (SLEPc resets a KSP it
    is given; this one keeps ``factor`` whole), so nothing is factorised again.
    Returns ``omega^2`` ascending and the modes, M-orthonormal, as the first ``count``
    columns of an array with ``extra`` more (left for the load modes: no copy of the modes).
    """
    from slepc4py import SLEPc  # the reduction's only user of SLEPc

    eps = SLEPc.EPS().create(MPI.COMM_SELF)
    try:
        eps.setOperators(A, M)
        eps.setProblemType(SLEPc.EPS.ProblemType.GHEP)
        n = A.getSize()[0]
        ncv = min(n, count + max(15, min(count, MODES_WORKSPACE)))
        eps.setDimensions(count, ncv, min(ncv, MODES_PROJECTED or ncv))
        eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_MAGNITUDE)
        eps.setTarget(0.0)
        st = eps.getST()
        st.setType(SLEPc.ST.Type.SINVERT)
        st.setShift(0.0)
        ksp = st.getKSP()
        ksp.setType(PETSc.KSP.Type.PREONLY)
        pc = ksp.getPC()
        pc.setType(PETSc.PC.Type.PYTHON)
        shell = _FactorSolve(factor)
        pc.setPythonContext(shell)
        eps.setTolerances(tolerance, 1000)
        start = time.perf_counter()
        eps.solve()
        seconds = time.perf_counter() - start
        flops = 4.0 * factor.entries * shell.solves
        factor.log.add(
            factor.block, "sparse_solve", n, shell.solves, seconds, flops, "modes", factor.entries
        )
        found = eps.getConverged()
        if found < count:
            raise SingularMatrixError(
                f"subdomain {name!r}: SLEPc found {found} of the {count} fixed-interface modes "
                "asked for; ask for fewer (Subdomain.reduce(modes=...)) or a looser tolerance"
            )
        values = np.array([eps.getEigenvalue(k).real for k in range(found)])
        order = np.argsort(values)[:count]
        # through a file: SLEPc's basis is freed before their array exists (issue 28)
        spill = tempfile.TemporaryFile()
        x = A.createVecRight()
        for k in order:
            eps.getEigenvector(k, x)
            spill.write(x.getArray().tobytes())
        x.destroy()
    finally:
        eps.destroy()
    release_freed_memory()
    spill.seek(0)
    vectors = np.empty((n, count + extra), order="F")  # columns contiguous: read in place
    for slot in range(count):
        spill.readinto(vectors[:, slot])
    spill.close()
    return values[order], vectors
