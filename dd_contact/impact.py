"""Contact forces over a time step that never create energy.

The trapezoidal rule (eqs. A10-A11) conserves the energy of a linear system exactly: over a
step the work of the forces is that of their mean ``(f_n + f_{n+1}) / 2``. A penalty contact
point is linear only while its state holds. A point that leaves contact during a step
(penetration ``g_n > 0`` at the start, ``g_{n+1} <= 0`` at the end) still pushes with half
its start force ``k g_n`` over the whole step. That work, ``k g_n (g_n - g_{n+1}) / 2``,
exceeds the energy the penalty held, ``k g_n^2 / 2``: each release creates
``k g_n |g_{n+1}| / 2``. With a stiff penalty, the point bounces off again, and the bar
impact of docs/validation.md ("Impact") gained 9-12x its energy over 30-60 such releases.

The step is therefore written in its equilibrium form: the start-of-step forces are computed
from the state at ``t_n``, not carried in the acceleration::

    (a0 M + K) u_{n+1} = M (a0 u_n + a1 u'_n) + r_n + r_{n+1} - K x_n + f_C(x_n; A')

which is the trapezoidal rule itself when ``A' = A_n`` (then ``K x_n - f_C = r_n - M u''_n``).
The start force counts only the points in contact at both ends of the step,
``A' = A_n & A_{n+1}`` (``A_{n+1}``: the contact iteration's current active set):

- in contact throughout: the mean force, exact for the quadratic penalty energy;
- entering: no start force (the point does not touch at ``t_n``); the end force removes
  ``k g_{n+1} |g_n| / 2``: at most the force times the last gap, dissipated;
- leaving: the start force scaled by ``theta = g_n / (g_n - g_{n+1})`` (the discrete gradient
  of ``k <g>+^2 / 2``, Armero and Petocz): the work is the energy the penalty held, exactly,
  instead of ``k g_n |g_{n+1}| / 2`` more. ``theta`` depends on the end state: it is updated
  from each solution until it settles (:meth:`StartForces.settled`).

So the contact never adds energy, at any penalty and any time step (``docs/contact.md``).
Generalized-alpha weights the start forces ``alpha_f / (1 - alpha_f)`` against the end ones
(1 here): :class:`StartForces` scales its corrections alike, and a releasing point keeps its
share ``theta`` of that smaller start force, so it never adds energy either.
A contact interface's surface w has no mass: its start force reaches the subdomain through
the tie, so a leaving point changes w at ``t_n``: w is put back in equilibrium with ``A'``
(a solve of the small contact-interface block) and the tie's start force uses that w.

A node on a wall that contacts still has mass, and with a stiff penalty it bounces off the
obstacle every few steps while the body stays pressed on it (the bar: 137 state changes in one
impact, none gaining energy but the contact duration lost). The wall's mass is therefore
spread over the rest of the body (:func:`massless_walls`, after Khenous, Laborde and Renard's
idea of a massless contact boundary): the contact wall is massless, like a contact
interface's w, and the bar comes off after one episode. Total mass is kept. Spread evenly
(each row scaled) rather than moved to the wall's neighbours, the layer next to the wall
keeps the mass of any other layer: a heavier one stops against the wall like a separate
body and raised the bar's peak contact force to 1.33 rho c v A (even: 1.10-1.18 lumped).

Velocities follow from the displacements, ``u'_{n+1} = 2 (u_{n+1} - u_n) / dt - u'_n``; the
acceleration reported is the step's mean ``(u'_{n+1} - u'_n) / dt`` (nothing reuses it).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager

import numpy as np
import scipy.sparse as sp

from dd_contact.assembly import ContactZone
from dd_contact.blocks import Block, BlockKeyed, BlockSystem, split_by_blocks
from dd_contact.settle import Settles, in_equilibrium
from dd_contact.solvers.reduced_model import WallInertia

__all__ = [
    "GEOMETRIC_STEPS",
    "RELEASE_FLOOR",
    "RELEASE_TOLERANCE",
    "BlockProducts",
    "StartForces",
    "massless_walls",
]

#: The kept fraction theta of a releasing point is settled when it changes by less than this
#: fraction of itself between two solves: the energy error of the release is then below this
#: fraction of the penalty energy the point held (f^2 / 2k, small for a stiff penalty).
RELEASE_TOLERANCE = 1e-3

#: ... or when that work is below this fraction of the elastic energy at t_n (this rank's):
#: the points that barely touched, whose penetration is at round-off, settle by it.
RELEASE_FLOOR = 1e-8

#: Corrections of a step that move theta to a geometric mean; after them (the iterates have
#: not settled) theta only decreases: a kept force below the discrete gradient's dissipates,
#: one above it would create energy.
GEOMETRIC_STEPS = 8


class BlockProducts:
    """Block rows of ``A x`` (``BlockSystem.row_product``), the ``kept`` ones remembered per x.

    The energy at the end of a step and the start forces of the next one both read ``K x_n``
    on every owned subdomain row, a sparse product of the subdomain's size: the second finds
    it here. A kept row is taken again when any block it reads differs from the remembered
    one (the user may change a displacement between steps). The system's matrices must not
    change.
    """

    def __init__(self, system: BlockSystem, kept: Iterable[Block]):
        self.system = system
        # a kept row -> the blocks it reads
        self._read = {row: {col for col, _ in system.block_row(row)} for row in kept}
        self._last: dict[Block, tuple[dict[Block, np.ndarray], np.ndarray]] = {}
        self.computed = 0  # products of kept rows taken (not found): a count for tests

    def row(self, row: Block, x: BlockKeyed[np.ndarray]) -> np.ndarray:
        """``(A x)_row`` as a new array (the caller may change it)."""
        if row not in self._read:
            return self.system.row_product(row, x)
        read = {c: x[c] for c in self._read[row] if c in x}
        last = self._last.get(row)
        if (
            last is None
            or last[0].keys() != read.keys()
            or not all(np.array_equal(last[0][c], v) for c, v in read.items())
        ):
            last = self._last[row] = (
                {c: v.copy() for c, v in read.items()},
                self.system.row_product(row, x),
            )
            self.computed += 1
        return last[1].copy()


class StartForces:
    """The start-of-step forces of one step on the owned subdomain rows.

    The :class:`dd_contact.iteration.StepCorrection` of the step's contact iteration.

    Args:
        system: K with the ties (no mass, no Dirichlet conditions).
        zones: This rank's contact regions.
        x: The state at ``t_n``: every block this rank holds.
        active: The active sets at ``t_n``.
        owned: The owned subdomain blocks.
        offset: Forces of stiff ties carried on the right-hand side at ``t_n``
            (:attr:`dd_contact.iteration.ContactSolver.rhs_offset`).
        free: 1 on the free dofs of a block, 0 on prescribed ones (a correction is masked).
        weight: Weight of the start forces against the end ones in the step (the scheme's
            ``start_weight``: 1 in the trapezoidal rule, ``alpha_f / (1 - alpha_f)`` in
            generalized-alpha); the corrections carry it too.
        products: Where ``K x_n`` is taken (the energy of the last step's end may have taken
            it already); by default computed here, not kept.
        end_loads: The loads ``r_n+1`` on the owned subdomain blocks (for :meth:`at_end`).
        end_offset: The stiff ties' forces of the last solve (for :meth:`at_end`).
        time: ``t_n``. A moving obstacle's operator is put at ``t_n`` for the start forces
            and their penetrations are kept: the contact iteration moves it to ``t_n+1``.
        inertia: Reduced blocks' inertia: their walls' moves carry mass
            (:func:`dd_contact.solvers.reduced_model.wall_inertia`).
        settles: What the zones' settles keep from step to step (the problem's; by default
            this step's own: each settle's fixed part is then made again).
    """

    def __init__(
        self,
        system: BlockSystem,
        zones: Sequence[ContactZone],
        x: Mapping[str, np.ndarray],
        active: Mapping[str, np.ndarray],
        owned: Sequence[Block],
        offset: Mapping[Block, np.ndarray],
        free: Callable[[Block], np.ndarray],
        weight: float = 1.0,
        products: BlockProducts | None = None,
        end_loads: Mapping[Block, np.ndarray] | None = None,
        end_offset: Callable[[], Mapping[Block, np.ndarray]] | None = None,
        time: float | None = None,
        inertia: Mapping[Block, WallInertia] | None = None,
        settles: Settles | None = None,
    ):
        self.system, self.zones, self.x, self.free = system, zones, x, free
        self.settles = settles if settles is not None else Settles()
        self._inertia = inertia or {}
        self.time = time
        #: Each contact's penetration and G at ``t_n``: every start force and theta reads
        #: them (the obstacle at ``t_n+1`` would give back a force never applied).
        self.g0: dict[str, np.ndarray] = {}
        self._G0: dict[str, sp.csr_array] = {}
        self._gap0: dict[str, np.ndarray] = {}
        self._x0: dict[str, np.ndarray] = {}  # x may be updated in place by the step
        for z in zones:
            name = z.contact.name
            with _operator_at(z, time):
                self._x0[name] = np.array(z.gather(x), dtype=float)
                self.g0[name] = z.operator.penetration(self._x0[name])
                self._G0[name], self._gap0[name] = z.operator.G, z.operator.gap
        self._end_loads = end_loads or {}
        #: The blocks the last :meth:`at_end` changed on this rank.
        self.settled_blocks: list[Block] = []
        self._end_offset = end_offset or dict
        self.weight = weight
        self.start = {name: a.copy() for name, a in active.items()}
        #: theta of each contact's releasing points, as last used (and its contacts then)
        self.kept: dict[str, np.ndarray] = {}
        self._releasing: set[str] = set()
        self._calls = 0  # corrections asked for in this step
        #: Each contact's end as solved, before :meth:`at_end` settled its massless dofs.
        self._solved_end: dict[str, np.ndarray] = {}
        #: ``K x_n - f_C(x_n; A_n)`` on each owned subdomain block (ties and stiff-tie forces in).
        self.internal = {}
        for block in owned:
            force = products.row(block, x) if products else system.row_product(block, x)
            if block in offset:
                force += offset[block]
            self.internal[block] = force
        #: ``x_n K x_n / 2`` on this rank's subdomain rows: the scale of :data:`RELEASE_FLOOR`
        self.elastic_energy = abs(sum(float(x[b] @ f) for b, f in self.internal.items())) / 2
        for z in zones:
            if z.block in self.internal:  # contact on the subdomain's own boundary
                start = self.start[z.contact.name].astype(float)
                np.add.at(self.internal[z.block], z.dofs, self._point_forces(z, start))
                if (friction := getattr(z.operator, "friction", None)) is not None:
                    np.add.at(self.internal[z.block], z.dofs, -(z.free * friction.start_force()))

    def correction(
        self, active: Mapping[str, np.ndarray], x: Mapping[Block, np.ndarray] | None
    ) -> tuple[dict[Block, np.ndarray], dict[Block, np.ndarray]]:
        """When the step ends with ``active``, points that leave let go: the change.

        A point that leaves keeps the fraction ``theta = g_n / (g_n - g_n+1)`` of its start
        force (the discrete gradient of its penalty energy, with ``g_n+1`` from the last
        solution ``x``): the work over the step is then the energy it held, exactly, and the
        force tends to the in-contact one as ``g_n+1 -> 0``.

        Returns right-hand-side additions and shifts of solved blocks (both empty unless a
        point active at ``t_n`` is not in ``active``). A contact boundary's start force is
        on its subdomain's rows and is given back there. A contact interface's reaches the
        subdomain through the tie, ``K_uw w_n``, which should be ``K_uw w'`` (w in
        equilibrium with the start forces that remain): solving for ``w - (w_n - w')``
        instead puts that change on the small w rows only, so no subdomain is re-solved
        for it (unless stiff ties carry part of the tie on the right-hand side).
        """
        rhs: dict[Block, np.ndarray] = {}
        shifts: dict[Block, np.ndarray] = {}
        self._releasing = set()
        self._calls += 1
        for z in self.zones:
            name = z.contact.name
            leaving = self.start[name] & ~active[name]
            if not leaving.any():
                continue
            kept = self.kept[name] = self._kept(z, x)
            self._releasing.add(name)
            if z.block in self.internal:  # its start force was in K x_n - f_C: give it back
                part = np.zeros(self.system.sizes[z.block])
                np.add.at(part, z.dofs, self._start_forces(z, np.where(leaving, 1 - kept, 0)))
                rhs[z.block] = rhs.get(z.block, 0.0) + part
                continue
            both = {name: self.start[name] & active[name]}
            remaining = self._start_forces(z, np.where(leaving, kept, 0))
            start = z.gather(self.x) - self._surface_at_start(z, both, remaining)
            shift = z.scatter(start, self.system.sizes)
            if self.system.stiff_ties:
                for side, (w, _) in zip(z.sides, z.parts, strict=True):
                    u = side.subdomain.block
                    tie = sp.csr_array(self.system.block(u, w))
                    rhs[u] = rhs.get(u, 0.0) + tie @ shift[w]
                continue
            matrix, _ = z.contribution(active[name])
            pieces = split_by_blocks(z.parts, matrix, self.system.sizes)
            for w, _ in z.parts:
                w_rows = self.system.block(w, w) @ shift[w]
                for c, _ in z.parts:
                    w_rows += pieces[(w, c)] @ shift[c]
                rhs[w] = rhs.get(w, 0.0) - w_rows
                shifts[w] = shift[w]
        rhs = {block: self.weight * vector * self.free(block) for block, vector in rhs.items()}
        return rhs, {block: self.weight * shift for block, shift in shifts.items()}

    def released(self, z: ContactZone) -> np.ndarray | None:
        """The share theta of its start force each point of ``z`` keeps (None: none leaves)."""
        return self.kept[z.contact.name] if z.contact.name in self._releasing else None

    def settled(self, active: Mapping[str, np.ndarray], x: Mapping[Block, np.ndarray]) -> bool:
        """Whether the kept fractions of the last :meth:`correction` hold for solution x.

        Each leaving point's theta from x is within RELEASE_TOLERANCE of the one used, or
        the work its contact's leaving points would change by, ``sum |dtheta| k g_n (g_n -
        g_n+1) / 2``, is below RELEASE_FLOOR of the elastic energy at t_n: points that
        barely touched (g_n at round-off) settle by what their force can still do, not by
        the round-off of their theta.
        """
        for z in self.zones:
            name = z.contact.name
            if name not in self._releasing:
                continue
            leaving = self.start[name] & ~active[name]
            k = z.operator.points.weight / z.operator.epsilon
            g0 = np.maximum(self.g0[name], 0.0)
            g1 = np.minimum(z.operator.penetration(z.gather(x)), 0.0)
            change = np.abs(_discrete_gradient(g0, g1) - self.kept[name])
            if not (change[leaving] > RELEASE_TOLERANCE * self.kept[name][leaving]).any():
                continue
            work = k[leaving] @ (change * g0 * (g0 - g1))[leaving]
            if work > 2 * RELEASE_FLOOR * self.elastic_energy:
                return False
        return True

    def pressed_back(self, x: Mapping[Block, np.ndarray]) -> dict[str, np.ndarray]:
        """Points in contact at t_n that are deeper in the obstacle at the end of ``x``.

        A point let go keeps at most its whole start force (theta <= 1); ending deeper than
        it started, ``g_n+1 > g_n``, its penalty stores ``k g_n+1 (g_n+1 - g_n) / 2`` more
        than that force did work for. Where that is more than RELEASE_FLOOR of the elastic
        energy, those points are back in contact (the mean force, exact).
        """
        out = {}
        for z in self.zones:
            name = z.contact.name
            g0 = np.maximum(self.g0[name], 0.0)
            g1 = z.operator.penetration(z.gather(x))
            deeper = self.start[name] & (g1 > g0)
            k = z.operator.points.weight / z.operator.epsilon
            created = k[deeper] @ (g1[deeper] * (g1[deeper] - g0[deeper]))
            too_much = created > 2 * RELEASE_FLOOR * self.elastic_energy
            out[name] = deeper if too_much else np.zeros_like(deeper)
        return out

    def needs_whole(self, active: Mapping[str, np.ndarray], x: Mapping[Block, np.ndarray]) -> bool:
        """Whether :meth:`at_end` needs more of the solution than ``x`` holds (its walls)."""
        return any(
            (self.start[z.contact.name] & ~active[z.contact.name]).any()
            and not _holds_rows(self.system, z, x)
            for z in self.zones
        )

    def at_end(
        self, active: Mapping[str, np.ndarray], x: Mapping[Block, np.ndarray]
    ) -> dict[Block, np.ndarray]:
        """``x`` with the massless dofs of each contact a point leaves in equilibrium.

        The step holds a massless dof's balance only on average over the step, and a point
        that leaves keeps just the share ``theta`` of its start force: the rest would stay on
        the wall (and a contact interface's w) as an unbalanced force. The solution then
        shows the wall overshooting into the obstacle (the point "pressed back", a second
        and third state change for one release), and the trapezoidal rule flips that force
        every later step without damping it (a bar's end face zig-zagged for good). Those
        dofs are put in equilibrium with the rest held, ``r_n+1 - K x + f_C(x; active) =
        0``: the minimum of a convex potential in them, so the energy can only drop. Zones
        no point leaves are untouched, and so are those whose rows read blocks ``x`` does
        not hold (:meth:`needs_whole`).
        """
        out = dict(x)
        offset = self._end_offset()
        self.settled_blocks, self._solved_end = [], {}
        for z in self.zones:
            name = z.contact.name
            if (self.start[name] & ~active[name]).any() and _holds_rows(self.system, z, out):
                self._solved_end[name] = z.gather(out)  # the step's own end, for the work
                state = in_equilibrium(
                    self.system, z, out, active[name], self._end_loads, offset, self.free,
                    self._inertia, self.settles,
                )  # fmt: skip
                out.update(state)
                self.settled_blocks += list(state)
        return out

    def obstacle_work(
        self, active: Mapping[str, np.ndarray], x: BlockKeyed[np.ndarray], safe: bool
    ) -> float:
        """This rank's work of the moving obstacles on the bodies over the step [J].

        Each point's mean force (start ``c0 = s k g_n``, ``s`` as the step applied it: 1 in
        contact at both ends, theta leaving (``safe``) or 1 (classic), end ``c1 = k g_n+1``)
        times the obstacle's advance at the point, ``g(y, t_n+1) - g(y, t_n)`` at fixed y,
        taken at ``x_n+1`` for c0 and ``x_n`` for c1: with the linear penetrations exactly
        what contact in and contact out of every point adds beyond the release's discrete
        gradient (for a translating plane: the mean force times the obstacle's
        displacement). With friction, its tangential work too
        (:attr:`dd_contact.friction.Friction.obstacle_work`).
        """
        work = 0.0
        for z in self.zones:
            name = z.contact.name
            motion = getattr(getattr(z.operator, "obstacle", None), "motion", None)
            if motion is None or name not in self.g0:
                continue
            op, start, end = z.operator, self.start[name], active[name]
            x1, x0 = self._solved_end.get(name, z.gather(x)), self._x0[name]
            share = np.where(start & end, 1.0, 0.0)
            leaving = start & ~end
            kept = self.kept.get(name, np.ones(op.num_points)) if safe else 1.0
            share = np.where(leaving, kept, share)
            k = op.points.weight / op.epsilon
            c0 = share * k * self.g0[name]
            c1 = np.where(end, k * op.penetration(x1), 0.0)
            advance1 = op.penetration(x1) - (self._G0[name] @ x1 - self._gap0[name])
            advance0 = op.penetration(x0) - self.g0[name]
            w = self.weight
            work += float(w * c0 @ advance1 + c1 @ advance0) / (1 + w)
            if (friction := getattr(op, "friction", None)) is not None:
                work += friction.obstacle_work  # its tangential work, as the step committed it
        return work

    def _kept(self, z: ContactZone, x: Mapping[Block, np.ndarray] | None) -> np.ndarray:
        """The theta to use next: 1 before any solution, then towards the last solution's."""
        if x is None:
            return np.ones(z.operator.num_points)
        g0 = np.maximum(self.g0[z.contact.name], 0.0)
        theta = _discrete_gradient(g0, z.operator.penetration(z.gather(x)))
        previous = self.kept.get(z.contact.name)
        if previous is not None and self._calls > GEOMETRIC_STEPS:
            return np.minimum(theta, previous)  # unsettled so far: the smaller force is safe
        if previous is not None:  # theta ~ c / theta': the mean settles it
            return np.sqrt(theta * previous)
        return theta

    def _point_forces(self, z: ContactZone, factor: np.ndarray) -> np.ndarray:
        """``factor`` times each point's penalty force at ``t_n``, on the zone's dofs."""
        op, name = z.operator, z.contact.name
        pen = self.g0[name]
        return z.free * (self._G0[name].T @ (factor * op.points.weight / op.epsilon * pen))

    def _start_forces(self, z: ContactZone, share: np.ndarray) -> np.ndarray:
        """``share`` of each point's start force on the zone's dofs, friction's too.

        A leaving point keeps the same share theta of its start friction traction as of its
        normal force: within mu times the pressure it keeps. Kept whole, it pushed the
        point along itself while the pressure let go: the massless surface then moved
        along the traction at t_n (a contact interface's w in equilibrium with it) and
        friction fed the body (the oblique impact at mu = 1 to 20 in w-u, v-w-u, w-v-u).
        """
        forces = self._point_forces(z, share)
        if (friction := getattr(z.operator, "friction", None)) is not None:
            forces -= z.free * friction.start_force(share)
        return forces

    def _surface_at_start(
        self, z: ContactZone, active: Mapping[str, np.ndarray], forces: np.ndarray
    ) -> np.ndarray:
        """The massless w of ``z`` (a pair's two) in equilibrium at t_n with ``active``, ``forces``.

        In contact matrix numbering: a contact interface's dofs are its w block's, whole.
        """
        blocks = [w for w, _ in z.parts]
        with _operator_at(z, self.time):
            matrix, vector = z.contribution(active[z.contact.name])
        rest = {k: v for k, v in self.x.items() if k not in blocks}
        b = np.concatenate([-self.system.row_product(w, rest) for w in blocks])
        return self.settles.surface_solve(self.system, z, matrix, b + vector - forces)


@contextmanager
def _operator_at(z: ContactZone, t: float | None) -> Iterator[None]:
    """``z``'s operator at time ``t`` inside (``None``: as it is), back at its time after."""
    now = z.operator.t
    if t is None or t == now:
        yield
        return
    z.operator.update(t)
    try:
        yield
    finally:
        z.operator.update(now)


def _holds_rows(system: BlockSystem, z: ContactZone, x: Mapping[Block, np.ndarray]) -> bool:
    """Whether ``x`` holds every block the rows of ``z``'s massless dofs read."""
    rows = {sub for sub, _ in z.wall_parts} | {block for block, _ in z.parts}
    return all(c in x for b in rows for c, _ in system.block_row(b))


def _discrete_gradient(g0: np.ndarray, g1: np.ndarray) -> np.ndarray:
    """``g0 / (g0 - g1)`` where a point leaves (``g0 > 0 >= g1``), else 1.

    The kept fraction whose start force ``theta k g0`` does the work of the penalty energy
    ``k g0^2 / 2`` it held.
    """
    out = np.ones_like(g0)
    leaves = (g0 > 0) & (g1 <= 0)
    np.divide(g0, g0 - g1, out=out, where=leaves)
    return out


def massless_walls(mass: sp.sparray, wall: np.ndarray) -> sp.csr_array:
    """``mass`` with no mass on the ``wall`` dofs, theirs spread evenly over the others.

    The wall rows and columns are removed; a remaining dof's coupling to the wall becomes
    its own diagonal mass (its row sum, its lumped mass, is kept); then every entry is
    scaled by total / remaining mass, so the total mass is exact and no dof next to the
    wall is heavier than its like elsewhere. All wall (nothing remains): unchanged.
    """
    M = sp.csr_array(mass)
    on_wall = np.zeros(M.shape[0], bool)
    on_wall[wall] = True
    keep = sp.diags_array((~on_wall).astype(float))
    coupling = np.asarray(M[:, on_wall].sum(axis=1)).ravel() * ~on_wall
    rest = sp.csr_array(keep @ M @ keep + sp.diags_array(coupling))
    remaining = rest.sum()
    if remaining <= 0:
        return M
    return sp.csr_array(rest * (M.sum() / remaining))
