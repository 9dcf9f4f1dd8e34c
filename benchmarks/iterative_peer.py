"""The iterative peer: FULL solved by preconditioned CG instead of a factor (issue 28 goal 3).

What a dolfinx user without the decomposition would reach for to step the contact problem:
the same monolithic matrix FULL assembles (K + c M + the contact penalty of the active
points), solved by PETSc's CG with Jacobi or with GAMG (smoothed aggregation, the rigid body
modes as its near null space, as dolfinx's elasticity demo sets them), each solve warm-started
from the last solution (the previous step's, or the previous contact iteration's). A contact
change changes the matrix: Jacobi reads its new diagonal, GAMG re-builds its smoothers on the
kept aggregation (``PCGAMGSetReuseInterpolation``, the cheap re-setup PETSc offers).

It is a yardstick of the benchmarks, not a feature of the package: :class:`IterativeFull` is
:class:`dd_contact.solvers.full.MonolithicSolver` whose substitution (``_apply``) is the
Krylov solve, installed for one problem by :func:`peer` (``"CG+Jacobi"``, ``"CG+GAMG"``).
The tolerance is relative to the right-hand side. :data:`RTOL` is the loosest at which the
displacements match the direct FULL's as closely as the direct solve is itself accurate:
``reduced_speed.py --part peer-accuracy`` (benchmarks/results/peer_accuracy.json; 20 steps
of the 40 x 8 x 4 bar pressed on its wall, 5 contact changes) found the direct solve 2e-13
from the converged CG iterate, and CG within 2.2e-13 of it at 1e-14 with Jacobi and at
1e-13 with GAMG (at 1e-10: 4e-9 and 1e-10; at 1e-8 the residual check refused Jacobi's
answer). docs/benchmarks.md, "The iterative peer".
"""

from __future__ import annotations

import contextlib
import time
from typing import ClassVar

from petsc4py import PETSc

import numpy as np

from dd_contact.parallel import any_rank
from dd_contact.solvers.full import MonolithicSolver

#: The peers: label -> PETSc preconditioner type.
PEERS = {"CG+Jacobi": "jacobi", "CG+GAMG": "gamg"}
#: CG's relative tolerance on the residual (|b - A x| <= RTOL |b|) per peer: the direct
#: solve's accuracy (the module doc).
RTOL = {"CG+Jacobi": 1e-14, "CG+GAMG": 1e-13}
#: GAMG's settings: dolfinx's elasticity demo's (Chebyshev-Jacobi smoothing), and the
#: aggregation kept over contact changes.
GAMG_OPTIONS = {
    "mg_levels_ksp_type": "chebyshev",
    "mg_levels_pc_type": "jacobi",
    "pc_gamg_reuse_interpolation": "true",
}
#: Iterations after which a solve is a failure (it would be a wrong answer).
MAX_ITERATIONS = 200_000


class IterativeFull(MonolithicSolver):
    """FULL whose solves are CG with ``pc`` (``"jacobi"`` or ``"gamg"``), warm-started.

    ``coordinates``: block name -> (n, 3) dof coordinates of the blocks with nodes (the
    subdomains): GAMG's rigid body modes; other blocks get the translations only.
    Attributes ``iterations`` and ``solves`` count CG's work, ``setup_seconds`` the
    preconditioner set-ups (at the start and at each contact change).
    """

    pc_type = "jacobi"
    rtol = 1e-13
    coordinates: ClassVar[dict[str, np.ndarray]] = {}

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.ksp: PETSc.KSP | None = None
        self._x: PETSc.Vec | None = None
        self.iterations: list[int] = []
        self.setup_seconds = 0.0

    def _refactorise(self) -> None:
        """Push new values; the preconditioner is set up again on the changed matrix."""
        if self.ksp is not None and not any_rank(self.comm, self.matrix.dirty):
            return
        self.matrix.push()
        A = self.matrix.A
        assert A is not None
        start = time.perf_counter()
        if self.ksp is None:
            A.setOption(PETSc.Mat.Option.SPD, True)  # type: ignore[arg-type]
            self.ksp = PETSc.KSP().create(self.comm)
            self.ksp.setType(PETSc.KSP.Type.CG)
            self.ksp.setTolerances(rtol=self.rtol, atol=0.0, max_it=MAX_ITERATIONS)
            self.ksp.setInitialGuessNonzero(True)
            self.ksp.setNormType(PETSc.KSP.NormType.UNPRECONDITIONED)
            self.ksp.getPC().setType(self.pc_type)
            if self.pc_type == "gamg":  # as dolfinx's elasticity demo sets it up
                if all(n % 3 == 0 for n in self.system.sizes.values()):
                    A.setBlockSize(3)  # aggregates of nodes, not of dofs
                A.setNearNullSpace(self._rigid_modes(A))
                options = PETSc.Options()
                for key, value in GAMG_OPTIONS.items():
                    options.setValue(f"dd_peer_{key}", value)
                self.ksp.setOptionsPrefix("dd_peer_")
                self.ksp.setFromOptions()
                for key in GAMG_OPTIONS:
                    options.delValue(f"dd_peer_{key}")
            self._x = A.createVecRight()
            self._x.zeroEntries()
        self.ksp.setOperators(A)
        self.ksp.setUp()
        self.setup_seconds += time.perf_counter() - start

    def _rigid_modes(self, A: PETSc.Mat) -> PETSc.NullSpace:
        """Three translations and three rotations over every dof with coordinates."""
        n = A.getSize()[0]
        modes = np.zeros((6, n))
        for name, off in self.offsets.items():
            size = self.system.sizes[name]
            for k in range(3):
                modes[k, off + k : off + size : 3] = 1.0
            xyz = self.coordinates.get(str(name))
            if xyz is None or len(xyz) * 3 != size:
                continue
            x, y, z = (xyz[:, j] - xyz[:, j].mean() for j in range(3))
            for k, (a, b, ca, cb) in enumerate(((0, 1, -y, x), (1, 2, -z, y), (2, 0, -x, z))):
                modes[3 + k, off + a : off + size : 3] = ca
                modes[3 + k, off + b : off + size : 3] = cb
        vectors = []
        for row in modes:
            if not np.any(row):
                continue
            v = A.createVecRight()
            v.getArray()[:] = row
            vectors.append(v)
        # GAMG wants them orthonormal
        Q, _ = np.linalg.qr(np.array([v.getArray() for v in vectors]).T)
        for v, q in zip(vectors, Q.T, strict=True):
            v.getArray()[:] = q
        return PETSc.NullSpace().create(vectors=vectors, comm=A.comm)

    def _apply(self, b: PETSc.Vec) -> PETSc.Vec:
        """CG from the last solution."""
        assert self.ksp is not None and self._x is not None
        self.ksp.solve(b, self._x)
        reason = self.ksp.getConvergedReason()
        if reason <= 0:
            raise RuntimeError(f"CG ({self.pc_type}) did not converge: reason {reason}")
        self.iterations.append(self.ksp.getIterationNumber())
        return self._x.copy()

    def destroy(self) -> None:
        """Free the KSP and the kept solution, then the matrix."""
        if self.ksp is not None:
            self.ksp.destroy()
        if self._x is not None:
            self._x.destroy()
        super().destroy()


def dof_coordinates(scene) -> dict[str, np.ndarray]:
    """Block name -> (n, 3) coordinates of each subdomain's dofs (one row per node)."""
    return {
        str(sub.block): sub.V.tabulate_dof_coordinates()
        for sub in scene.subdomains
        if sub.V.dofmap.index_map_bs == 3
    }


@contextlib.contextmanager
def peer(label: str, scene, rtol: float | None = None):
    """Problems built inside with ``algorithm="FULL"`` solve by the peer ``label``.

    ``rtol``: CG's tolerance (default the peer's :data:`RTOL`).
    """
    import dd_contact.analysis as analysis

    settings = {"pc_type": PEERS[label], "rtol": rtol or RTOL[label]}
    solver = type("Peer", (IterativeFull,), {**settings, "coordinates": dof_coordinates(scene)})
    before = analysis.MonolithicSolver
    analysis.MonolithicSolver = solver
    try:
        yield solver
    finally:
        analysis.MonolithicSolver = before
