"""A subdomain's Schur-complement factorisation driven through MUMPS's C interface.

PETSc's MUMPS interface computes the Schur complement but, in a solve, always solves the
Schur system itself between MUMPS's reduction and expansion phases. The engine needs them
apart: the reduction gives the subdomain's condensed right-hand side ``-C^T K^-1 b`` (one
forward sweep), the surface system is solved elsewhere, and the expansion gives
``u = K^-1 (b - C xs)`` from the surface solution ``xs`` (one backward sweep, reusing the
forward sweep MUMPS kept). So a time step costs one substitution per subdomain, not two.

:class:`SchurFactorisation` calls ``dmumps_c`` of the MUMPS that PETSc links (the same
library, version and defaults as :class:`~dd_contact.solvers.linalg.SparseCholesky`: the
complements agree bit for bit) on ``COMM_SELF``, with the ``DMUMPS_STRUC_C`` layout of
MUMPS 5.8 (``dmumps_c.h``). The layout is checked against the version string the library
writes at initialisation. MUMPS references: Users' guide 5.8, sections 5.16 (Schur
complement, reduction and expansion) and 6.1 (ICNTL).
"""

from __future__ import annotations

import ctypes
import functools
import time

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np

from dd_contact.errors import InputError, SingularMatrixError
from dd_contact.solvers.linalg import (
    ICNTL_RHS_FORMAT,
    ICNTL_SCHUR_SOLUTION,
    INFOG_FACTOR_ENTRIES,
    INFOG_FACTOR_ENTRIES_ESTIMATED,
    INFOG_NULL_PIVOTS,
    INFOG_STATUS,
    MATRIX_READERS,
    RINFOG_FLOPS,
    RINFOG_FLOPS_ESTIMATED,
    SCHUR_SOLVE_INTERNAL,
    SPARSE_RHS,
    SparseStatistics,
    _libpetsc,
    _mumps_count,
)
from dd_contact.solvers.petsc_options import REQUIRED_ICNTL, _check_required_options, options_prefix
from dd_contact.solvers.worklog import WorkLog

__all__ = [
    "ICNTL_COMPACT",
    "MUMPS_LAYOUT_VERSION",
    "PACKAGE_ICNTL",
    "SchurFactorisation",
    "bordered",
]

#: MUMPS versions whose ``DMUMPS_STRUC_C`` has the layout below (5.8.x).
MUMPS_LAYOUT_VERSION = "5.8."

_INT = ctypes.c_int32  # MUMPS_INT of a default (32-bit integer) MUMPS build
_INT8 = ctypes.c_int64
_REAL = ctypes.c_double
_PINT: type[ctypes._Pointer] = ctypes.POINTER(_INT)  # typed alike: mypy joins lists of both
_PREAL: type[ctypes._Pointer] = ctypes.POINTER(_REAL)


class _DmumpsStruc(ctypes.Structure):
    """``DMUMPS_STRUC_C`` of MUMPS 5.8 (field order and widths of ``dmumps_c.h``)."""

    _fields_ = [
        *[(name, _INT) for name in ("sym", "par", "job", "comm_fortran")],
        ("icntl", _INT * 60),
        ("keep", _INT * 500),
        ("cntl", _REAL * 15),
        ("dkeep", _REAL * 230),
        ("keep8", _INT8 * 150),
        *[(name, _INT) for name in ("n", "nblk", "nz_alloc", "nz")],
        ("nnz", _INT8),
        *[("irn", _PINT), ("jcn", _PINT), ("a", _PREAL)],  # centralised assembled matrix
        ("nz_loc", _INT),
        ("nnz_loc", _INT8),
        *[("irn_loc", _PINT), ("jcn_loc", _PINT), ("a_loc", _PREAL)],
        ("nelt", _INT),
        *[("eltptr", _PINT), ("eltvar", _PINT), ("a_elt", _PREAL)],
        *[(name, _PINT) for name in ("blkptr", "blkvar", "perm_in", "sym_perm", "uns_perm")],
        *[("colsca", _PREAL), ("rowsca", _PREAL)],
        *[("colsca_from_mumps", _INT), ("rowsca_from_mumps", _INT)],
        *[("colsca_loc", _PREAL), ("rowsca_loc", _PREAL)],
        *[("rowind", _PINT), ("colind", _PINT), ("pivots", _PREAL)],
        *[(name, _PREAL) for name in ("rhs", "redrhs", "rhs_sparse", "sol_loc", "rhs_loc")],
        ("rhsintr", _PREAL),
        *[(name, _PINT) for name in ("irhs_sparse", "irhs_ptr", "isol_loc", "irhs_loc")],
        *[("glob2loc_rhs", _PINT), ("glob2loc_sol", _PINT)],
        *[(name, _INT) for name in ("nrhs", "lrhs", "lredrhs", "nz_rhs", "lsol_loc")],
        *[(name, _INT) for name in ("nloc_rhs", "lrhs_loc", "nsol_loc")],
        *[(name, _INT) for name in ("schur_mloc", "schur_nloc", "schur_lld")],
        *[(name, _INT) for name in ("mblock", "nblock", "nprow", "npcol", "ld_rhsintr")],
        *[("info", _INT * 80), ("infog", _INT * 80)],
        *[("rinfo", _REAL * 40), ("rinfog", _REAL * 40)],
        ("deficiency", _INT),
        *[("pivnul_list", _PINT), ("mapping", _PINT), ("singular_values", _PREAL)],
        ("size_schur", _INT),
        *[("listvar_schur", _PINT), ("schur", _PREAL), ("wk_user", _PREAL)],
        ("version_number", ctypes.c_char * 32),
        ("ooc_tmpdir", ctypes.c_char * 1024),
        ("ooc_prefix", ctypes.c_char * 256),
        ("write_problem", ctypes.c_char * 1024),
        ("lwk_user", _INT),
        ("save_dir", ctypes.c_char * 1024),
        ("save_prefix", ctypes.c_char * 256),
        ("metis_options", _INT * 40),
        ("instance_number", _INT),
    ]


# MUMPS jobs (JOB) and settings (ICNTL(k) is icntl[k - 1]).
JOB_INIT, JOB_END, JOB_ANALYSE, JOB_FACTORISE, JOB_SOLVE = -1, -2, 1, 2, 3
SYM_SPD, HOST_WORKS = 1, 1
SCHUR_REDUCTION, SCHUR_EXPANSION = 1, 2  # ICNTL(26)
ICNTL_SCHUR = 19  # 1: centralised Schur complement, lower triangle by rows
# Room after the structure, so a MUMPS with a longer one cannot write past it before its
# version is checked.
SLACK_BYTES = 1 << 16

#: ICNTL the package sets on its Schur factorisations, index -> value: output streams off
#: (1-4), a centralised assembled matrix (5, 18), dense right-hand sides (20, 21), the
#: Schur complement (19), plus :data:`REQUIRED_ICNTL`. Options that change them are refused.
PACKAGE_ICNTL = {
    **{k: 0 for k in (1, 2, 3, 4, 5, 18, ICNTL_RHS_FORMAT, 21)},
    ICNTL_SCHUR: 1,
    **REQUIRED_ICNTL,
}


#: ICNTL(49) = 1 compacts MUMPS's workspace to the factors at the end of a factorisation
#: (MUMPS otherwise keeps its contribution-block stack too; docs/benchmarks.md measures what it
#: saves). The compaction copies the factors, so while it runs it adds them
#: to everything the process holds: it pays only when more factorisations follow that the
#: smaller workspace leaves room for. A factorisation is compacted only when asked
#: (``compact=True``; the engine asks for each of a rank's subdomains but the last it
#: factorises) and only the first time: a re-factorisation (a contact change) would copy its
#: factors on top of every other subdomain's. An option ``mat_mumps_icntl_49`` decides for
#: every factorisation.
ICNTL_COMPACT = 49


@functools.cache
def _dmumps_c():
    function = _libpetsc().dmumps_c
    function.argtypes = [ctypes.POINTER(_DmumpsStruc)]
    function.restype = None
    return function


class MumpsLayoutError(RuntimeError):
    """The MUMPS PETSc links is not the version whose C layout this module knows."""


@functools.cache
def mumps_version() -> str:
    """The version of the MUMPS inside PETSc ("" if it cannot be read)."""
    memory = ctypes.create_string_buffer(ctypes.sizeof(_DmumpsStruc) + SLACK_BYTES)
    probe = _DmumpsStruc.from_buffer(memory)
    probe.sym, probe.par, probe.job = SYM_SPD, HOST_WORKS, JOB_INIT
    probe.comm_fortran = MPI.COMM_SELF.py2f()
    _dmumps_c()(ctypes.byref(probe))
    try:
        version = probe.version_number.decode(errors="replace").strip("\x00 ")
    finally:
        for k in (1, 2, 3, 4):  # no output streams
            probe.icntl[k - 1] = 0
        probe.job = JOB_END
        _dmumps_c()(ctypes.byref(probe))
    return version


def layout_known() -> bool:
    """Whether :class:`SchurFactorisation` can drive this MUMPS (its version is 5.8.x)."""
    return mumps_version().startswith(MUMPS_LAYOUT_VERSION)


def _user_controls() -> tuple[dict[int, int], dict[int, float]]:
    """ICNTL and CNTL given under the active options prefix (``mat_mumps_icntl_<k>``, ...)."""
    _check_required_options()
    prefix = options_prefix()
    options = PETSc.Options(prefix)
    icntl = {
        k: options.getInt(f"mat_mumps_icntl_{k}")
        for k in range(1, 61)
        if options.hasName(f"mat_mumps_icntl_{k}")
    }
    for k, value in icntl.items():
        if k in PACKAGE_ICNTL and value != PACKAGE_ICNTL[k] and k not in (1, 2, 3, 4):
            raise InputError(
                f"-{prefix}mat_mumps_icntl_{k} = {value}: dd_contact sets MUMPS "
                f"ICNTL({k}) = {PACKAGE_ICNTL[k]} for its Schur factorisations; remove the option"
            )
    cntl = {
        k: options.getReal(f"mat_mumps_cntl_{k}")
        for k in range(1, 16)
        if options.hasName(f"mat_mumps_cntl_{k}")
    }
    return icntl, cntl


class SchurFactorisation:
    """MUMPS Cholesky of ``[[K, C], [C^T, 0]]`` with the trailing ``m`` rows as Schur block.

    :meth:`factorise` returns ``S = -C^T K^-1 C`` (dense, symmetric, a new array the caller
    owns: the factorisation keeps no copy), and per right-hand side b one forward sweep
    (:meth:`reduce`: ``-C^T K^-1 b``) and one backward sweep (:meth:`expand`:
    ``K^-1 (b - C xs)`` for the last reduced b). Serial (COMM_SELF).

    Args:
        rows, cols: The matrix pattern in COO, duplicates allowed (summed), the Schur block's
            zero diagonal included so its pattern is known. The upper triangle alone
            (``rows <= cols``) is used as given: MUMPS then reads the values passed to
            :meth:`factorise` in place, without a copy. Both triangles are accepted too.
        size: Rows of the matrix, Schur block included.
        schur: Size m of the Schur block (> 0).
        log: Where to record the work.
        block: Name of the block, for the log.
        compact: Compact MUMPS's workspace after the first factorisation (ICNTL(49) = 1;
            see :data:`ICNTL_COMPACT`).
    """

    def __init__(
        self, rows, cols, size: int, schur: int, log: WorkLog, block: str, compact: bool = False
    ):
        if schur <= 0:
            raise ValueError(f"schur must be positive, got {schur}")
        icntl, cntl = _user_controls()  # before MUMPS allocates anything
        self.log, self.block, self.size, self.schur = log, block, size, schur
        self.nnz = _stored_entries(rows, cols, size)
        self.entries = 0.0
        upper = rows <= cols  # MUMPS sums a_ij and a_ji: one triangle only
        self._upper = None if upper.all() else upper  # a mask (1 byte an entry) if needed
        if self._upper is not None:
            rows, cols = rows[upper], cols[upper]
        self._irn = (rows + 1).astype(np.int32)
        self._jcn = (cols + 1).astype(np.int32)
        self._a: np.ndarray | None  # values
        self._a = np.zeros(len(self._irn)) if self._upper is not None else None
        self._listvar = np.arange(size - schur + 1, size + 1, dtype=np.int32)
        self._redrhs = np.zeros(schur)
        self._rhs = np.zeros(size)
        #: MUMPS holds the forward sweep of the last reduced b (an expansion releases it)
        self.reduced = False
        self._reduced_columns = 0  # of that b
        #: the arrays MUMPS points at for several columns, during a call (:meth:`_point`)
        self._held: tuple[np.ndarray, np.ndarray] | None = None
        self._released = False  # the matrix let go (release_matrix): no re-factorisation
        self.statistics: SparseStatistics | None = None  # of the analysis, once done
        self._analysis_seconds: float | None = None  # not logged yet
        self._memory = ctypes.create_string_buffer(ctypes.sizeof(_DmumpsStruc) + SLACK_BYTES)
        self._id = _DmumpsStruc.from_buffer(self._memory)
        self._id.sym, self._id.par, self._id.job = SYM_SPD, HOST_WORKS, JOB_INIT
        self._id.comm_fortran = MPI.COMM_SELF.py2f()
        self._call("initialisation")
        version = self._id.version_number.decode().strip()
        if not version.startswith(MUMPS_LAYOUT_VERSION):
            self.destroy()
            raise MumpsLayoutError(
                f"PETSc links MUMPS {version}, the C layout here is MUMPS "
                f"{MUMPS_LAYOUT_VERSION}x's: use condensation='multi-rhs'"
            )
        self._compact_once = ICNTL_COMPACT not in icntl  # the user's option holds throughout
        for k, value in {ICNTL_COMPACT: int(compact), **PACKAGE_ICNTL, **icntl}.items():
            self._id.icntl[k - 1] = value
        for k, real in cntl.items():
            self._id.cntl[k - 1] = real
        self._id.n, self._id.nnz = size, len(self._irn)
        self._id.irn, self._id.jcn = _pointer(self._irn, _INT), _pointer(self._jcn, _INT)
        self._id.size_schur, self._id.schur_lld = schur, schur
        self._id.listvar_schur = _pointer(self._listvar, _INT)
        self._id.redrhs, self._id.lredrhs = _pointer(self._redrhs, _REAL), schur
        self._id.rhs, self._id.nrhs, self._id.lrhs = _pointer(self._rhs, _REAL), 1, size

    @property
    def handle(self) -> int:
        """Address of the MUMPS instance, 0 once destroyed (as a petsc4py object's handle)."""
        return 0 if self._id is None else ctypes.addressof(self._id)

    def icntl(self, k: int) -> int:
        """MUMPS's ICNTL(k) as set on this factorisation."""
        return int(self._id.icntl[k - 1])

    def _set_values(self, values: np.ndarray) -> None:
        """Point MUMPS at ``values`` (in place if they are the upper triangle's, as given)."""
        if self._upper is not None:
            assert self._a is not None  # made with the mask
            self._a[:] = values[self._upper]
        elif values.dtype == np.float64 and values.flags.c_contiguous:
            self._a = values  # MUMPS reads the caller's array: no copy
        else:
            self._a = np.ascontiguousarray(values, dtype=np.float64)
        self._id.a = _pointer(self._a, _REAL)

    def analyse(self, values: np.ndarray) -> SparseStatistics:
        """MUMPS's symbolic analysis (once): the factorisation's flops and factor entries.

        The next :meth:`factorise` is numeric only; its log record carries the analysis's
        seconds and matrix entries, as if both had run together.
        """
        if self.statistics is None:
            self._set_values(values)
            start = time.perf_counter()
            self._id.job = JOB_ANALYSE
            self._call("analysis")
            self._analysis_seconds = time.perf_counter() - start
            self.statistics = SparseStatistics(
                self.size - self.schur,
                self.nnz,
                float(self._id.rinfog[RINFOG_FLOPS_ESTIMATED - 1]),
                float(_mumps_count(self._id.infog[INFOG_FACTOR_ENTRIES_ESTIMATED - 1])),
                self.schur,
            )
        return self.statistics

    def factorise(self, values: np.ndarray) -> np.ndarray:
        """(Re-)factorise with these values of the COO given at construction.

        Returns the Schur complement ``S`` (m x m, symmetric; a new array, not kept here).
        """
        if self._released:
            raise RuntimeError(
                f"block {self.block!r}: its matrix was released; it cannot re-factorise"
            )
        self.analyse(values)
        self._set_values(values)
        self.reduced = False
        m = self.schur
        S = np.empty((m, m))  # MUMPS writes the lower triangle by rows
        self._id.schur = _pointer(S, _REAL)
        start = time.perf_counter()
        self._id.job = JOB_FACTORISE
        try:
            self._call("factorisation")
        finally:
            self._id.schur = _PREAL()  # the array is the caller's from now on
        null_pivots = self._id.infog[INFOG_NULL_PIVOTS - 1]
        if null_pivots > 0:
            raise SingularMatrixError(
                f"block {self.block!r} is singular ({null_pivots} null pivots): "
                "part of the model can move freely; check its supports, ties and contacts"
            )
        self.entries = float(_mumps_count(self._id.infog[INFOG_FACTOR_ENTRIES - 1]))
        if self._compact_once:  # a re-factorisation is not compacted (ICNTL_COMPACT)
            self._id.icntl[ICNTL_COMPACT - 1] = 0
        analysis, self._analysis_seconds = self._analysis_seconds, None
        self.log.add(
            self.block,
            "sparse_factor",
            self.size - m,
            0,
            time.perf_counter() - start + (analysis or 0.0),
            self._id.rinfog[RINFOG_FLOPS - 1],
            f"with a Schur complement of {m}",
            self.entries,
            0 if analysis is None else self.nnz,
        )
        start = time.perf_counter()
        _mirror_lower(S)
        self.log.add(self.block, "schur", m, 0, time.perf_counter() - start)
        return S

    def reduce(
        self, b: np.ndarray, what: str = "u_hat", into: np.ndarray | None = None
    ) -> np.ndarray:
        """``-C^T K^-1 b``: MUMPS's reduction phase, one forward sweep (kept for :meth:`expand`).

        ``b``: one right-hand side, or n x k of them (one sweep of the factor for all).
        ``into``: a :meth:`workspace` for k columns to use (b may be its first n rows: then
        it is not copied).
        """
        n = self.size - self.schur
        rhs, redrhs = self._point(b, into)
        if not _is_top_of(b, rhs):  # (a new rhs never is)
            rhs[:n] = b
        rhs[n:] = 0.0
        start = time.perf_counter()
        self._solve(SCHUR_REDUCTION, "reduction")
        self._log_sweep("sparse_forward", time.perf_counter() - start, what, b)
        self.reduced, self._reduced_columns = True, _columns(b)
        self._held = None  # MUMPS keeps the forward sweep itself: the arrays are the caller's
        return redrhs.copy() if b.ndim == 1 else redrhs

    def workspace(self, k: int) -> np.ndarray:
        """A right-hand-side array for k columns, to be passed as ``into`` call after call.

        glibc maps an array beyond 32 MB afresh each time, and the first touch of its pages
        costs the kernel (335k rows x 32 at 4 KB pages: 55 ms, against 6 to write it again):
        a loop of several columns a call reuses one instead.
        """
        return np.empty((self.size, k), order="F")

    def expand(self, xs: np.ndarray, what: str = "u") -> np.ndarray:
        """``K^-1 (b - C xs)`` for the last reduced b: MUMPS's expansion, one backward sweep.

        ``xs`` has as many columns as that b.
        """
        start = time.perf_counter()
        x = self._expand(xs)
        self._log_sweep("sparse_backward", time.perf_counter() - start, what, xs)
        return x

    def response(self, xs: np.ndarray, what: str, into: np.ndarray | None = None) -> np.ndarray:
        """``K^-1 C xs`` (xs: m values, or m x k): one backward sweep, no forward one.

        MUMPS expands only a reduced right-hand side: the zero one is reduced first, given
        as sparse (ICNTL(20) = 1) with one explicit zero per column on a Schur row, so that
        its forward sweep visits the Schur block alone (85k interior dofs: 9.0 ms a column
        of 64, against 16.5 for a whole substitution). Logged as one backward sweep. ``into``:
        a :meth:`workspace` for k columns, whose first n rows are then the answer.
        """
        k = _columns(xs)
        zeros = np.zeros(k)
        rows = (self.size - self.schur + 1 + np.arange(k) % self.schur).astype(np.int32)
        starts = np.arange(1, k + 2, dtype=np.int32)
        start = time.perf_counter()
        self._point(xs, into)
        self._id.icntl[ICNTL_RHS_FORMAT - 1] = SPARSE_RHS
        self._id.nz_rhs, self._id.rhs_sparse = k, _pointer(zeros, _REAL)
        self._id.irhs_sparse, self._id.irhs_ptr = _pointer(rows, _INT), _pointer(starts, _INT)
        try:
            self._solve(SCHUR_REDUCTION, "reduction")
        finally:  # dense again, and no pointers left to the arrays that go now
            self._id.icntl[ICNTL_RHS_FORMAT - 1] = PACKAGE_ICNTL[ICNTL_RHS_FORMAT]
            self._id.nz_rhs, self._id.rhs_sparse = 0, _PREAL()
            self._id.irhs_sparse, self._id.irhs_ptr = _PINT(), _PINT()
        self.reduced, self._reduced_columns = True, k
        x = self._expand(-xs, into)
        self._log_sweep("sparse_backward", time.perf_counter() - start, what, xs)
        return x

    def _expand(self, xs: np.ndarray, into: np.ndarray | None = None) -> np.ndarray:
        if not self.reduced or _columns(xs) != self._reduced_columns:
            raise RuntimeError(
                f"block {self.block!r}: expand() needs a reduce() of as many columns first"
            )
        rhs, redrhs = self._point(xs, into)
        redrhs[:] = xs
        self._solve(SCHUR_EXPANSION, "expansion")
        self.reduced, self._held = False, None  # MUMPS releases the forward sweep now
        n = self.size - self.schur
        return rhs[:n].copy() if xs.ndim == 1 else rhs[:n]

    def solve_interior(self, b: np.ndarray, what: str | None) -> np.ndarray:
        """``K^-1 b`` (b: n values, or n x k): both sweeps, the Schur block left out.

        ``what`` ``None``: not logged (a caller that logs its solves together).
        """
        n = self.size - self.schur
        rhs, _ = self._point(b)
        rhs[:n], rhs[n:] = b, 0.0
        start = time.perf_counter()
        self._solve(SCHUR_SOLVE_INTERNAL, "solution")
        self.reduced, self._held = False, None
        if what is not None:
            self._log_sweep("sparse_solve", time.perf_counter() - start, what, b, sweeps=2)
        return rhs[:n].copy() if b.ndim == 1 else rhs[:n]

    def _point(
        self, b: np.ndarray, into: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """MUMPS's right-hand side and reduced one for b's columns.

        This instance's for one column; for several, ``into`` (a :meth:`workspace`) or new
        arrays (Fortran-ordered, as MUMPS reads them).
        """
        if b.ndim == 1:
            self._id.rhs, self._id.nrhs = _pointer(self._rhs, _REAL), 1
            self._id.redrhs = _pointer(self._redrhs, _REAL)
            return self._rhs, self._redrhs
        k = b.shape[1]
        if into is not None and (into.shape != (self.size, k) or not into.flags.f_contiguous):
            raise ValueError(f"into: a workspace of {k} columns is needed, got {into.shape}")
        # new each time unless given: a result handed out is the caller's, not written over
        rhs = np.zeros((self.size, k), order="F") if into is None else into
        redrhs = np.zeros((self.schur, k), order="F")
        self._held = (rhs, redrhs)  # held while MUMPS points at them
        self._id.rhs, self._id.nrhs = _pointer(rhs, _REAL), k
        self._id.redrhs = _pointer(redrhs, _REAL)
        return rhs, redrhs

    def release_matrix(self) -> None:
        """Let the matrix's indices and values go (solves go on; no re-factorisation).

        Kept when the user's options ask MUMPS for iterative refinement or error analysis
        (ICNTL(10), ICNTL(11)): then its solves read the matrix.
        """
        if not any(self.icntl(k) for k in MATRIX_READERS):
            self._irn = self._jcn = np.zeros(0, np.int32)
            self._a = None
            self._id.irn, self._id.jcn, self._id.a = _PINT(), _PINT(), _PREAL()
            self._released = True

    def _solve(self, phase: int, name: str) -> None:
        self._id.icntl[ICNTL_SCHUR_SOLUTION - 1] = phase
        self._id.job = JOB_SOLVE
        self._call(name)

    def _log_sweep(self, kind: str, seconds: float, what: str, b, sweeps: int = 1) -> None:
        # one sweep: one multiply-add per factor entry (a full substitution is two sweeps)
        n = self.size - self.schur
        flops = 2.0 * sweeps * self.entries * _columns(b)
        self.log.add(self.block, kind, n, _columns(b), seconds, flops, what, self.entries)

    def _call(self, phase: str) -> None:
        _dmumps_c()(ctypes.byref(self._id))
        status = self._id.infog[INFOG_STATUS - 1]
        if status < 0:
            raise SingularMatrixError(
                f"MUMPS {phase} of block {self.block!r} failed (INFOG(1) = {status}, "
                f"INFOG(2) = {self._id.infog[1]}); the matrix is singular or not positive "
                "definite, or MUMPS ran out of memory (raise "
                f"-{options_prefix()}mat_mumps_icntl_14)"
            )

    def destroy(self) -> None:
        """Free MUMPS's memory (idempotent)."""
        if getattr(self, "_id", None) is not None and not MPI.Is_finalized():
            self._id.job = JOB_END
            _dmumps_c()(ctypes.byref(self._id))
        # None only once destroyed, when nothing but handle and destroy read it: typed as
        # the live struct for the methods' sake
        self._id = None  # type: ignore[assignment]

    def __del__(self) -> None:
        # as petsc4py objects: freed when collected if nobody called destroy()
        self.destroy()


def bordered(
    K: tuple[np.ndarray, np.ndarray, np.ndarray], C, mirrored: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """COO of ``[[K, C], [C^T, 0]]`` from K's COO (n x n) and the coupling C (n x m).

    The last m rows are the Schur block: its zero diagonal gives MUMPS its pattern. With
    ``mirrored`` C^T is there too (K given by both triangles), else C only (one triangle).
    """
    rows, cols, values = K
    C = C.tocoo()
    n, m = C.shape
    schur = np.arange(n, n + m, dtype=rows.dtype)  # K's index type: no wider copy
    mirror = [(C.col + n, C.row, C.data)] if mirrored else []
    parts = [(rows, cols, values), (C.row, C.col + n, C.data), *mirror, (schur, schur, np.zeros(m))]
    return tuple(np.concatenate(p) for p in zip(*parts, strict=True))  # type: ignore[return-value]


def _stored_entries(rows: np.ndarray, cols: np.ndarray, size: int) -> int:
    """Distinct entries of a symmetric pattern given by one or both triangles (both counted)."""
    low, high = np.minimum(rows, cols).astype(np.int64), np.maximum(rows, cols)
    # sorted, not np.unique: its hash table took 1.5 s on a stiffness pattern's 1.65M keys
    # (a third of a 49k-dof set-up), the sort 14 ms
    keys = np.sort(low * size + high)
    upper = keys[np.r_[True, keys[1:] != keys[:-1]]] if len(keys) else keys
    diagonal = np.count_nonzero(upper % (size + 1) == 0)  # i * size + i
    return int(2 * len(upper) - diagonal)


def _mirror_lower(S: np.ndarray, rows: int = 256) -> None:
    """Copy the lower triangle of a square array onto its upper one, in place.

    By blocks of rows: no temporary of the array's size.
    """
    m = S.shape[0]
    for r0 in range(0, m, rows):
        r1 = min(r0 + rows, m)
        D = S[r0:r1, r0:r1]
        D[...] = np.tril(D) + np.tril(D, -1).T
        S[r0:r1, r1:] = S[r1:, r0:r1].T


def _is_top_of(b: np.ndarray, rhs: np.ndarray) -> bool:
    """Whether b is rhs's first rows (the same memory, as laid out): nothing to copy."""
    return (
        b.ndim == 2
        and b.shape[1] == rhs.shape[1]
        and b.ctypes.data == rhs.ctypes.data
        and b.strides == rhs.strides
    )


def _columns(b: np.ndarray) -> int:
    """Right-hand sides in b: its columns, or one."""
    return 1 if b.ndim == 1 else b.shape[1]


def _pointer(array: np.ndarray, ctype):
    return array.ctypes.data_as(ctypes.POINTER(ctype))
