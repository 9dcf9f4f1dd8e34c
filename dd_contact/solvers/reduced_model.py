"""A scene's model with reduced subdomains, and their state over a run.

:func:`reduce_model` replaces each owned reduced subdomain's pieces of the assembled model
by its reduced ones (:class:`~dd_contact.solvers.reduced.ReducedBasis`); the rest of the
package then solves and steps the subdomain in its reduced coordinates, and its full fields
are expanded only when read (:func:`expansion`, :func:`defer_rates`). docs/solvers.md,
"Reduced subdomains".
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from mpi4py import MPI

import numpy as np
import scipy.sparse as sp

from dd_contact import forms
from dd_contact.blocks import Block
from dd_contact.parallel import allgathered, collective
from dd_contact.scene import KAPPA_SPLIT
from dd_contact.solvers.dense import DenseBacked
from dd_contact.solvers.linalg import sparse_statistics
from dd_contact.solvers.reduced import ReducedBasis, _pattern_span, _petsc
from dd_contact.solvers.subdomains import coupling_layout
from dd_contact.solvers.worklog import WorkLog

__all__ = [
    "REDUCED_ORDERS",
    "WallInertia",
    "defer_fields",
    "defer_rates",
    "expansion",
    "reduce_model",
    "reduced_states",
    "reduction_pays",
    "refuse_reduced",
    "start_states",
    "tied_dofs",
    "wall_inertia",
]

#: The orders that solve reduced subdomains (a small dense block through the subdomain seam).
REDUCED_ORDERS = ("w-u", "w-v-u", "v-w-u")


logger = logging.getLogger(__name__)


def reduce_model(
    comm: MPI.Comm, model, subdomains: Sequence, log: WorkLog
) -> dict[Block, ReducedBasis]:
    """Collective: each owned subdomain with a reduction replaced in ``model`` by its reduced one.

    ``model`` (an :class:`~dd_contact.assembly.Model` with its mass as the scheme uses it)
    then holds ``T^T A T`` and ``T^T M T`` for the block, its couplings on the boundary rows,
    no prescribed dofs of its own, and the block's size is the reduced one on every rank
    (``model.massless_reduced``: every reduced block's massless coordinates, every rank).
    Returns the bases of this rank's reduced subdomains.
    """
    system = model.system
    bases = collective(comm, lambda: _reduce_owned(model, subdomains, log))
    mine = {b: (basis.size, basis.massless) for b, basis in bases.items()}
    for part in allgathered(comm, mine):
        for block, (size, massless) in part.items():
            system.sizes[block] = size
            system.reduced.add(block)
            model.massless_reduced[block] = massless
    return bases


def _reduce_owned(model, subdomains: Sequence, log: WorkLog) -> dict[Block, ReducedBasis]:
    """This rank's reduced subdomains replaced in ``model`` (:func:`reduce_model`)."""
    system = model.system
    bases: dict[Block, ReducedBasis] = {}
    for sub in subdomains:
        if sub.reduction is None:
            continue
        block = sub.block
        dofs, values = model.dirichlet[block]
        if np.any(values):
            raise NotImplementedError(
                f"subdomain {sub.name!r}: a reduced subdomain with non-zero prescribed "
                "displacement is not built yet; prescribe zero there, or do not reduce it"
            )
        if any(t.u == block for t in system.stiff_ties):
            raise NotImplementedError(
                f"subdomain {sub.name!r}: a reduced subdomain's ties must have kappa at most "
                f"{KAPPA_SPLIT:g} (stiffer ties are carried by an iteration on the whole field, "
                "not built for a reduced one); give its ties kappa <= "
                f"{KAPPA_SPLIT:g}, or do not reduce it"
            )
        boundary = tied_dofs(coupling_layout(block, system)[1])
        if np.intersect1d(boundary, dofs).size:
            raise NotImplementedError(
                f"subdomain {sub.name!r}: a reduced subdomain's tied dofs must be free (some "
                "are prescribed); do not reduce it"
            )
        patterns = forms.SubdomainLoad(sub).patterns()
        if sub.reduction.if_cheaper and not reduction_pays(
            system.block(block, block), boundary, dofs, sub.reduction.modes, patterns
        ):
            logger.info("subdomain %r kept whole: reducing it would not pay", sub.name)
            continue
        mass = model.mass.get(block)
        diagonal = None if mass is None else sp.csr_array(mass).diagonal()
        del mass
        # taken out of the model, so the reduction lets them go before it factorises
        basis = ReducedBasis(
            system.matrices.pop((block, block)),
            model.mass.pop(block, None),
            boundary,
            dofs,
            patterns,
            sub.reduction.modes,
            log,
            sub.name,
            sub.reduction.tolerance,
            sub.reduction.eigensolver,
            sub.reduction.out_of_core,
        )
        # the massless (wall) dofs among the boundary ones: their reported rates are the
        # step's mean, as a whole subdomain's (dd_contact.kinematics)
        basis.massless = (
            np.zeros(0, np.int64) if diagonal is None else np.flatnonzero(diagonal[basis.b] == 0)
        )
        _replace(model, block, basis)
        bases[block] = model.reduced[block] = basis
    _walls_in_reduced(model.zones, bases)
    return bases


def reduction_pays(A, boundary: np.ndarray, fixed: np.ndarray, modes: int, patterns) -> bool:
    """Whether a reduced block's dense substitution is priced below the whole block's sparse one.

    The reduced block has ``n_b + min(m, n_i) + loads`` coordinates, a dense Cholesky factor
    whose substitution pair reads ``2 r^2``; the whole block's MUMPS factor (its entries by
    the symbolic analysis) is read once per substitution. Each is priced with this machine's
    cached rates (``dense_solve``, ``sparse_solve``, :mod:`dd_contact.calibration`); without
    them, by those counts. A step substitutes either twice, so the ratio is the step's.
    """
    from dd_contact.calibration import cached_rates  # its rates, not its measurements

    n = A.shape[0]
    free = np.setdiff1d(np.arange(n), fixed)
    b = np.intersect1d(boundary, free)
    loads = _pattern_span(patterns, n, np.asarray(fixed, np.int64)).shape[1]
    r = b.size + min(modes, free.size - b.size) + loads
    whole = _petsc(sp.csr_array(A)[free][:, free])
    try:
        entries = sparse_statistics(whole).entries
    finally:
        whole.destroy()
    rates = cached_rates()
    if rates is None:
        return 2.0 * r * r < 2.0 * entries
    return rates.seconds("dense_solve", 2.0 * r * r) < rates.seconds("sparse_solve", entries)


def tied_dofs(C: sp.sparray) -> np.ndarray:
    """The rows of coupling columns C with a non-zero entry: the boundary dofs b.

    Every one is kept: the reduced model is then the unreduced one in its basis. The ties'
    round-off entries are left out where they are made (:data:`~dd_contact.coupling.TIE_FLOOR`).
    """
    C = sp.coo_array(C)
    return np.unique(C.row[C.data != 0.0])


def _walls_in_reduced(zones: Sequence, bases: dict[Block, ReducedBasis]) -> None:
    """A reduced subdomain's contact walls, in its coordinates, with the moves that settle them.

    A whole subdomain's wall dofs are massless (energy-safe contact), so a release settles
    them with the rest held (:meth:`dd_contact.impact.StartForces.at_end`). A wall
    coordinate of a reduced one moves its constraint mode, which carries the mass of the
    interior behind it: settled alone, it threw that mass (the bar's energy grew
    10^25-fold), and left unsettled the force history drifted (the pin joint: 5.3 % of its
    peak with m = 1000). Each wall is settled instead along
    :meth:`~dd_contact.solvers.reduced.ReducedBasis.wall_directions` (``zone.directions``):
    the interior held through the modes, exactly with every mode.
    """
    for z in zones:
        parts = z.wall_parts
        if not any(block in bases for block, _ in parts):
            continue
        walls, directions = [], {}
        for block, wall in parts:
            if block in bases:
                wall, directions[block] = bases[block].wall_directions(np.asarray(wall))
            walls.append(wall)
        if hasattr(z, "walls"):  # a pair: a wall per side
            z.walls = walls
        else:
            z.wall = walls[0]
        z.directions = directions


def _replace(model, block: Block, basis: ReducedBasis) -> None:
    """The block's pieces of ``model`` in reduced coordinates (``T^T A T``, ``T^T A_us``)."""
    system, extra = model.system, basis.size - basis.b.size
    system.matrices[(block, block)] = DenseBacked(dense=basis.A_r)
    for (row, col), A in list(system.matrices.items()):
        if row == block and col == block:
            continue
        if row == block:
            rows = sp.csr_array(A)[basis.b]
            system.matrices[(row, col)] = sp.csr_array(
                sp.vstack([rows, sp.csr_array((extra, A.shape[1]))])
            )
        elif col == block:
            columns = sp.csc_array(A)[:, basis.b]
            system.matrices[(row, col)] = sp.csr_array(
                sp.hstack([columns, sp.csr_array((A.shape[0], extra))])
            )
    if basis.M_r is not None:
        model.mass[block] = DenseBacked(dense=basis.M_r)
    model.dirichlet[block] = (np.zeros(0, dtype=np.int32), np.zeros(0))


def reduced_states(system) -> dict[Block, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Zero ``(q, q', q'')`` of every reduced block of ``system`` (a ``BlockSystem``)."""
    return {
        b: (np.zeros(n), np.zeros(n), np.zeros(n))
        for b, n in system.sizes.items()
        if b in system.reduced
    }


def refuse_reduced(subdomains: Sequence, algorithm: str) -> None:
    """Reduced subdomains are solved by w-u, w-v-u and v-w-u (FULL and v-u refuse them)."""
    reduced = [s.name for s in subdomains if s.reduction is not None]
    if not reduced:
        return
    if algorithm not in REDUCED_ORDERS:
        raise NotImplementedError(
            f"subdomain(s) {reduced} are reduced (Subdomain.reduce): algorithm {algorithm!r} "
            f"does not solve reduced subdomains yet; use {', '.join(REDUCED_ORDERS)}"
        )


def expansion(basis: ReducedBasis | None, q: np.ndarray, at=None, values=None) -> Callable:
    """What writes a reduced subdomain's full field from its coordinates q, when it is read.

    ``basis`` ``None``: another rank's subdomain, whose owner expands it (nothing here).
    ``values`` replace the expansion at boundary coordinates ``at`` (the walls' rates).
    """

    def expand(field) -> None:
        if basis is not None:
            field.x.array[: basis.n] = basis.expand(q)
            if at is not None and len(at):
                field.x.array[basis.b[at]] = values

    return expand


def start_states(bases: dict[Block, ReducedBasis], owned: Sequence, states: dict) -> None:
    """The owned reduced subdomains' coordinates of their initial u and velocity.

    ``states``: block -> (q, q', q'') arrays, written in place.
    """
    for sub in owned:
        if sub.block in bases:
            basis, (q, v, _) = bases[sub.block], states[sub.block]
            q[:] = basis.coordinates(sub.u.x.array)
            v[:] = basis.coordinates(sub.velocity.x.array)


def defer_rates(subdomains: Sequence, bases: dict[Block, ReducedBasis], kinematics) -> None:
    """The reduced subdomains' velocity and acceleration expanded when next read.

    Their massless walls report the step's mean rates, as a whole subdomain's
    (``kinematics.walls``).
    """
    for sub in subdomains:
        if sub.block in kinematics.reduced:
            _, v, a = kinematics.reduced[sub.block]
            basis = bases.get(sub.block)
            at, (wv, wa) = kinematics.walls[sub.block]
            sub.defer(expansion(basis, v.copy(), at, wv.copy()), "velocity")
            sub.defer(expansion(basis, a.copy(), at, wa.copy()), "acceleration")


def defer_fields(subdomains: Sequence, bases: dict[Block, ReducedBasis], kinematics) -> None:
    """The reduced subdomains' u and rates expanded when next read (a restored state)."""
    for sub in subdomains:
        if sub.block in kinematics.reduced:
            q = kinematics.reduced[sub.block][0]
            sub.defer(expansion(bases.get(sub.block), q.copy()))
    defer_rates(subdomains, bases, kinematics)


@dataclass(frozen=True)
class WallInertia:
    """A reduced block's inertia at a release's settle (:func:`wall_inertia`).

    ``acceleration(q)``: the scheme's end acceleration, ``slope`` its derivative;
    ``velocity(q)``: the end velocity, ``velocity_slope`` its derivative.
    """

    mass: sp.sparray
    slope: float
    acceleration: Callable[[np.ndarray], np.ndarray]
    velocity_slope: float
    velocity: Callable[[np.ndarray], np.ndarray]


def wall_inertia(model, bases: dict[Block, ReducedBasis], owned: Sequence, kinematics, scheme):
    """What a release's settle of reduced walls needs of their inertia, this step.

    Per owned reduced block, a :class:`WallInertia`: the end
    acceleration (``scheme.end_acceleration``) and velocity the scheme gives q, from the
    state at t_n (copied now). With fewer modes than the interior's, a wall's move P carries
    a little mass (what the modes cannot take back), and the step's end balances it with its
    inertia, ``P^T (r - K q - M_r a(q)) = 0``: the settle keeps that balance
    (:func:`dd_contact.impact.StartForces.at_end`), as far as it adds no energy. With every
    mode ``M_r P = 0``.
    """
    velocity_slope = float(scheme.update(np.ones(1), np.zeros(1), np.zeros(1), np.zeros(1))[0][0])
    out = {}
    for sub in owned:
        if sub.block in bases:
            q, v, a = (array.copy() for array in kinematics.now(sub))
            end = kinematics.ends[sub.block].copy()

            def acceleration(x, q=q, v=v, end=end):
                return scheme.end_acceleration(x, q, v, end)

            def velocity(x, q=q, v=v, a=a):
                return scheme.update(x, q, v, a)[0]

            out[sub.block] = WallInertia(
                model.mass[sub.block], scheme.end_slope, acceleration, velocity_slope, velocity
            )
    return out
