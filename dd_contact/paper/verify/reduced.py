"""Verification of reduced subdomains (``Subdomain.reduce``): statics exact, modes converged.

``reduced-static``: a steel cantilever, in one piece (w-u) or two tied pieces (w-v-u), its
tip pressed on a wall by a shear traction, solved whole and with subdomains reduced; the
load modes make the reduced answer the unreduced one (to round-off). ``reduced-modes``: the
first 20 eigenfrequencies of the cantilever reduced with m fixed-interface modes against
SLEPc's on its full matrices.
"""

from __future__ import annotations

from mpi4py import MPI

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

import dd_contact as dd
from dd_contact import meshes
from dd_contact.assembly import assemble
from dd_contact.paper.verify.models import Record, locator, record
from dd_contact.parallel import sum_over_ranks
from dd_contact.solvers.interior import InteriorMatrix, PlainInterior
from dd_contact.solvers.reduced import ReducedBasis, _petsc, fixed_interface_modes
from dd_contact.solvers.reduced_model import tied_dofs
from dd_contact.solvers.subdomains import coupling_layout
from dd_contact.solvers.worklog import WorkLog
from dd_contact.subdomains import MODES_TOLERANCE

__all__ = ["cantilever", "cantilever_basis", "case_reduced_modes", "case_reduced_static"]

STEEL = dd.Material(2.0e11, 0.3, 7800.0)
LENGTH, WIDTH = 1.0, 0.1


def cantilever(nx: int = 10, parts: int = 1, kappa: float = 1e3) -> dd.Scene:
    """A steel beam fixed at x = 0, in ``parts`` tied pieces, its tip on a contact interface.

    A shear traction on its top pushes the tip onto a plane 1 um beyond it; ``kappa``: the
    tie and contact penalties.
    """
    edges = np.linspace(0.0, LENGTH, parts + 1)
    subs = []
    for k in range(parts):
        box = [edges[k], 0, 0], [edges[k + 1], WIDTH, WIDTH]
        mesh = meshes.box(MPI.COMM_SELF, *box, [nx, 2, 2])
        subs.append(dd.Subdomain(mesh, STEEL, f"part{k}"))
    subs[0].fix(locator(0, 0.0))
    subs[-1].add_traction(locator(2, WIDTH), lambda t: [2.0e6 * t, 0.0, 0.0])
    tip = meshes.surface_from_boundary(subs[-1].mesh, locator(0, LENGTH))
    wall = dd.Plane([LENGTH + 1e-6, 0, 0], [-1.0, 0, 0])
    contact = dd.ContactInterface(tip, subs[-1], wall, kappa=kappa, contact_kappa=kappa, name="tip")
    interface = None
    if parts > 1:
        cut = meshes.surface_from_boundary(subs[0].mesh, locator(0, edges[1]))
        interface = dd.Interface(cut, subs, kappa=kappa)
    return dd.Scene(MPI.COMM_WORLD, subs, interface=interface, contacts=[contact])


def cantilever_basis(
    scene: dd.Scene, modes: int, sub: int = 0, patterns=(), tolerance: float = MODES_TOLERANCE
) -> tuple:
    """A subdomain's basis with its assembled A, M and prescribed dofs (modes to ``tolerance``)."""
    model = assemble(scene)
    block = scene.subdomains[sub].block
    A = sp.csr_array(model.system.block(block, block))
    _, C = coupling_layout(block, model.system)
    dofs = model.dirichlet[block][0]
    M = model.mass[block]
    tied = tied_dofs(C)
    basis = ReducedBasis(A, M, tied, dofs, patterns, modes, WorkLog(), "cantilever", tolerance)
    return basis, A, M, dofs


def full_frequencies_ratio(modes: int, count: int = 20, nx: int = 10) -> np.ndarray:
    """``omega_reduced / omega_full - 1`` of the ``count`` lowest modes (SLEPc on the full)."""
    basis, A, M, dofs = cantilever_basis(cantilever(nx), modes)
    free = np.setdiff1d(np.arange(A.shape[0]), dofs)
    Mf = _petsc(M[free][:, free])
    Af = InteriorMatrix(A[free][:, free])
    full = PlainInterior(Af, sp.csr_array((free.size, 0)), WorkLog(), "full")
    try:
        omega2, _ = fixed_interface_modes(Af.mat, full, Mf, count, 1e-13, "full")
        # the reduced model's lowest from its inverse pencil (accurate at the low end)
        mu = sla.eigh(basis.M_r, basis.A_r, eigvals_only=True)[::-1][:count]
    finally:
        Af.release()
        full.destroy()
        Mf.destroy()
        basis.destroy()
    return 1.0 / np.sqrt(omega2 * mu) - 1.0


def static_difference(
    parts: int, algorithm: str, modes: list, kappa: float = 1e3
) -> tuple[float, float]:
    """Relative difference of u and of the contact force, reduced against unreduced."""

    def solve(reduce):
        scene = cantilever(6, parts, kappa)
        for sub, m in zip(scene.subdomains, reduce, strict=True):
            if m is not None:
                sub.reduce(modes=m)
        with dd.StaticProblem(scene, algorithm) as problem:
            problem.solve(1.0)
            # a reduced subdomain's full u is expanded on its owner: compare there
            rank = scene.comm.rank
            owned = [s for k, s in enumerate(scene.subdomains) if scene.owner(k) == rank]
            u = np.concatenate([s.u.x.array.copy() for s in owned] or [np.zeros(0)])
            return u, np.array(problem.results["force"]["tip"])

    u, force = solve([None] * parts)
    u_r, force_r = solve(modes)
    squares = sum_over_ranks(MPI.COMM_WORLD, np.array([np.sum((u_r - u) ** 2), np.sum(u**2)]))
    du = np.sqrt(squares[0] / squares[1])
    return float(du), float(np.linalg.norm(force_r - force) / np.linalg.norm(force))


def case_reduced_static() -> list[Record]:
    """Quasi-static response of reduced subdomains equals the unreduced one (load modes)."""
    out = []
    for parts, algorithm, modes in ((1, "w-u", [6]), (2, "w-v-u", [3, 0])):
        du, df = static_difference(parts, algorithm, modes)
        what = f"{algorithm}, modes {modes}"
        out.append(record("reduced-static", f"1 + |u_r - u| / |u|, {what}", 1 + du, 1.0, 1e-8))
        out.append(record("reduced-static", f"1 + |f_r - f| / |f|, {what}", 1 + df, 1.0, 1e-8))
    return out


def case_reduced_modes() -> list[Record]:
    """The first 20 eigenfrequencies of the reduced cantilever (m = 20) against SLEPc's."""
    error = float(np.abs(full_frequencies_ratio(20)).max())
    quantity = "1 + max |omega_r / omega - 1|, 20 lowest, m = 20"
    return [record("reduced-modes", quantity, 1 + error, 1.0, 1e-6)]
