"""What a problem solves with: the scene assembled, its solver and its contact iteration.

:class:`Analysis` assembles the scene once, eliminates the Dirichlet conditions, hands the
block system to a solver (the elimination order) and solves with the contact iteration;
results land in the scene's dolfinx Functions (``Subdomain.u``, ``Interface.v``,
``ContactInterface.w`` and ``.pressure``). It owns the solver's PETSc objects and frees
them in ``close()``. The user-facing problems (:mod:`dd_contact.problem`) each hold one,
built from explicit arguments: the mass term and its kind, and whether contact walls are
massless (energy-safe contact).

This module only orchestrates: the contact term and the geometric checks are in
:mod:`dd_contact.contact`, the contact iteration in :mod:`dd_contact.iteration` and the
agreed results in :mod:`dd_contact.post`.
"""

from __future__ import annotations

import logging
import time

import dolfinx.fem as fem
import numpy as np

from dd_contact import forms, timing
from dd_contact.assembly import Model, PairZone, assemble
from dd_contact.blocks import Block
from dd_contact.contact import check_contact_geometry
from dd_contact.errors import InputError, SingularMatrixError, warn
from dd_contact.impact import massless_walls
from dd_contact.iteration import ContactIteration, ContactSettings
from dd_contact.pairs import PairOperator, check_pair_geometry
from dd_contact.parallel import (
    Traffic,
    allgather_blocks,
    allgathered,
    collective,
    counted,
    gathered,
    sum_over_ranks,
)
from dd_contact.post import Results, friction_unfit
from dd_contact.scene import KAPPA_VERIFIED, ContactBoundary, Scene
from dd_contact.solvers import MonolithicSolver, WorkLog
from dd_contact.solvers.analysed import Candidates, scene_structure
from dd_contact.solvers.engine import BlockEliminationSolver
from dd_contact.solvers.linalg import release_freed_memory
from dd_contact.solvers.memory import small_pages
from dd_contact.solvers.mumps_schur import layout_known, mumps_version
from dd_contact.solvers.petsc_options import OPTIONS_PREFIX, check_options_prefix, petsc_options
from dd_contact.solvers.reduced_model import (
    expansion,
    reduce_model,
    reduced_states,
    refuse_reduced,
)
from dd_contact.solvers.residual import ResidualCheck
from dd_contact.solvers.schedule import ALGORITHMS, fitting_algorithms
from dd_contact.solvers.stiff_ties import AugmentedTies
from dd_contact.subdomains import Subdomain

__all__ = ["Analysis"]
logger = logging.getLogger(__name__)

#: Solves after which ``algorithm="auto"`` compares its prediction with the clock.
CHECK_SOLVES = 3


def _clocks() -> tuple[float, float]:
    """The wall clock and this process's CPU time [s]."""
    return time.perf_counter(), time.process_time()


def available_condensation(condensation: str) -> str:
    """``condensation``, or ``"multi-rhs"`` (with a warning) where MUMPS's Schur route is not."""
    if condensation != "schur" or layout_known():
        return condensation
    warn(
        f"the MUMPS inside PETSc is {mumps_version() or 'unknown'}, not the 5.8.x "
        "whose reduction and expansion phases dd_contact drives: condensation "
        "'multi-rhs' is used instead (two substitutions a step, not one)",
        RuntimeWarning,
    )
    return "multi-rhs"


def check_algorithm(scene: Scene, algorithm: str, expected: tuple[float, float]) -> tuple:
    """The algorithms that fit ``scene``; refuse ``algorithm`` if it is not one of them.

    ``expected`` (steps, contact state changes) must be usable by ``"auto"``'s prediction.
    """
    has_interface = scene.interface is not None
    has_w = any(not isinstance(c, ContactBoundary) for c in scene.contacts)
    unfit = friction_unfit(scene)  # v-u, where friction would make a subdomain unsymmetric
    valid = tuple(a for a in fitting_algorithms(has_interface, has_w) if a not in unfit)
    if algorithm != "auto" and algorithm not in valid:
        parts = ["an interface" if has_interface else "no interface"]
        parts.append("contact interfaces" if has_w else "no contact interfaces")
        what = (
            f"unknown algorithm {algorithm!r} (the algorithms: auto, {', '.join(ALGORITHMS)})"
            if algorithm not in ALGORITHMS
            else f"algorithm {algorithm!r} does not fit this scene"
        )
        raise InputError(
            f"{what}; this scene has {' and '.join(parts)}; valid for it: "
            f"{', '.join(valid)} or auto (v needs an interface, w contact interfaces)"
        )
    steps, changes = expected
    if algorithm == "auto" and not (steps >= 1 and 0 <= changes < np.inf):
        raise InputError(
            f"algorithm='auto': expected steps must be >= 1 and expected changes >= 0 and "
            f"finite; got {steps} steps and {changes} changes"
        )
    return valid


def _with_mass(model: Model, scene: Scene, mass_kind: str, massless: bool) -> None:
    """Make the assembled mass matrices of ``model`` the ones the time scheme uses.

    Massless contact walls first (:func:`dd_contact.impact.massless_walls`), then the
    lumped or averaged kind, so that the walls' mass is spread like the rest.
    """
    if massless:
        for z in model.zones:
            for block, wall in z.wall_parts:
                if block in model.mass:  # owned here (a pair's other side may not be)
                    model.mass[block] = massless_walls(model.mass[block], wall)
    if mass_kind == "consistent":
        return
    for sub in scene.subdomains:
        if sub.block in model.mass:  # owned here
            degree = sub.V.element.basix_element.degree
            model.mass[sub.block] = forms.mass_of_kind(model.mass[sub.block], degree, mass_kind)


def _refuse_split_pairs(scene: Scene) -> None:
    """Energy-safe releases of a pair need both its walls on its rank: refuse the others."""
    for pair in scene.pairs:
        owners = {scene.owner(scene.index(side.subdomain)) for side in pair.sides}
        if len(owners) > 1:
            raise NotImplementedError(
                f"contact pair {pair.name!r}: its subdomains are owned by ranks "
                f"{sorted(owners)}; the energy-safe release of a pair needs both on one rank "
                "(not built yet): run on fewer ranks, order the subdomains so that both land "
                "on one rank (subdomain k is owned by rank k % size), or pass "
                "energy_safe_contact=False"
            )


def _contact_dofs(zones) -> dict[Block, np.ndarray]:
    """Block -> dofs any contact term of ``zones`` may act on."""
    out: dict[Block, np.ndarray] = {}
    for z in zones:
        for block, dofs in z.parts:
            out[block] = np.union1d(out[block], dofs) if block in out else dofs
    return out


class Analysis:
    """The scene assembled, with its solver and contact iteration; what a problem solves with.

    Args:
        scene: What is modelled.
        algorithm: Elimination order, ``"FULL"`` or ``"auto"``.
        mass_coefficient: The mass term's factor in the effective matrix ``K + c M``
            (0: a static or quasi-static problem).
        mass_kind: ``"consistent"``, ``"lumped"`` or ``"averaged"`` (with a mass term).
        massless_walls: Move the contact walls' mass inside the body (energy-safe contact).
        contact: Contact iteration settings.
        condensation: How the decomposition orders condense a subdomain.
        expected: For ``"auto"``: (solves, contact state changes) expected.
        rates: For ``"auto"``: machine rates (default: this machine's).
        options: PETSc options for the factorisations (read while they are built).
        options_prefix: The prefix they are read under (one per problem, to tune two
            problems of one script apart).
    """

    def __init__(
        self,
        scene: Scene,
        algorithm: str,
        *,
        mass_coefficient: float = 0.0,
        mass_kind: str = "consistent",
        massless_walls: bool = False,
        contact: ContactSettings | None = None,
        condensation: str = "schur",
        expected: tuple[float, float] = (1.0, 3.0),
        rates: timing.MachineRates | None = None,
        options: dict | None = None,
        options_prefix: str = OPTIONS_PREFIX,
    ):
        #: PETSc options of the factorisations, and the prefix they are read under.
        self.options = dict(options or {})
        self.options_prefix = check_options_prefix(options_prefix)
        condensation = available_condensation(condensation)
        valid = check_algorithm(scene, algorithm, expected)
        refuse_reduced(scene.subdomains, algorithm)
        if mass_coefficient and massless_walls:
            _refuse_split_pairs(scene)
        self.scene, self.comm = scene, scene.comm
        #: What this analysis's ranks exchanged (:mod:`dd_contact.parallel`).
        self.traffic = Traffic()
        #: Every factorisation and solve of this analysis.
        self.work = WorkLog()
        #: This rank's subdomains, in scene order.
        self.owned: list[Subdomain] = [
            s for k, s in enumerate(scene.subdomains) if scene.owner(k) == self.comm.rank
        ]
        with self.petsc_options(), counted(self.traffic), small_pages():  # no huge pages
            self.model: Model = collective(self.comm, lambda: assemble(scene))
            for z in self.model.zones:  # the pressure-swing check reads static pressure only
                z.check_resolution = not mass_coefficient
            if mass_coefficient:
                _with_mass(self.model, scene, mass_kind, massless_walls)
            #: This rank's reduced subdomains' bases (``Subdomain.reduce``).
            self.reduced = reduce_model(self.comm, self.model, self.owned, self.work)
            system = self.model.effective(mass_coefficient)
            system.rhs = {}  # built at every solve: loads and prescribed values at its time
            self._lifting = self.model.lifting(mass_coefficient)
            self._lifted: tuple[dict, dict] | None = None  # the last prescribed values, rhs
            self.zones = self.model.zones
            self.settings = contact or ContactSettings()
            collective(self.comm, self._check_contact_geometry)
            self._system, self._solves = system, 0
            self._started = _clocks()  # reset at the first solve
            self.condensation = condensation
            #: The prediction behind ``algorithm="auto"`` (``None`` for a named algorithm).
            self.choice: timing.Choice | None = None
            #: Whether the run releases contact points (energy-safe contact): priced.
            self.releasing = mass_coefficient > 0 and massless_walls
            if algorithm == "auto":
                expected_run = self._expected(expected, self.releasing)
                algorithm, reused = self._choose(valid, expected_run, rates)
                self._use(algorithm, reused)
            else:
                self._use(algorithm)
            self.iteration = ContactIteration(
                self.comm,
                self.zones,
                self.settings,
                system.sizes,
                None
                if self.settings.residual_tolerance is None
                else ResidualCheck(self.comm, system, _contact_dofs(self.zones)),
                held=[] if mass_coefficient else scene.bodies(),
            )
        self._closed = False
        #: Every reduced subdomain's (q, q', q'') in reduced coordinates (every rank).
        self.reduced_states = reduced_states(system)
        self._load = {sub.block: forms.SubdomainLoad(sub) for sub in self.owned}
        self._free: dict[str, np.ndarray] = {}  # model.free(block), kept
        with counted(self.traffic):
            #: The results of each solve, agreed on every rank (``agreed.latest``: the last).
            self.agreed = Results(self.comm, scene, self.model, self.iteration.alpha)

    # -- the solver -----------------------------------------------------------------------
    def _expected(self, expected: tuple[float, float], releases: bool) -> timing.Expected:
        """Collective: the run priced: ``(steps, changes)``, releases, the stiff ties' solves.

        Energy-safe contact (``releases``) solves again about
        :data:`timing.RELEASES_PER_CHANGE` times per change.
        """
        steps, changes = expected
        stiff = sum_over_ranks(self.comm, len(self._system.stiff_ties)) > 0
        return timing.Expected(
            steps,
            changes,
            timing.RELEASES_PER_CHANGE * changes if releases else 0.0,
            timing.TIE_SOLVES if stiff else 1.0,
        )

    def _choose(self, valid, expected: timing.Expected, rates):
        """Collective: ``algorithm="auto"``'s choice, and the analysed parts of its solver.

        The orders are analysed first (their subdomains kept for the chosen solver); FULL
        only if :func:`dd_contact.timing.full_cannot_win` does not rule it out.
        """
        rates = rates if rates is not None else timing.machine_rates(comm=self.comm)
        contacts = [z.region for z in self.zones]
        candidates = Candidates(self.comm, self._system, contacts, self.condensation, self.work)
        orders = tuple(a for a in valid if a != "FULL")
        structure = candidates.analyse_orders() if orders else None
        skipped = {}
        if structure is not None:
            least = timing.full_cannot_win(structure, rates, orders, expected)
            if least is not None:
                skipped["FULL"] = least
        if "FULL" in valid and not skipped:
            structure = candidates.analyse_full(structure)
        analysed = tuple(a for a in valid if a not in skipped)
        assert structure is not None  # the orders', or FULL's alone
        self.choice = timing.choose(structure, rates, analysed, expected)
        self.choice.skipped = skipped
        self._auto = (structure, rates, expected)  # for the check after CHECK_SOLVES
        return self.choice.algorithm, candidates.take(self.choice.algorithm)

    def _use(self, algorithm: str, reused=None) -> None:
        """Build ``algorithm``'s solver (from the parts auto analysed, if given)."""
        system, contacts = self._system, [z.region for z in self.zones]
        self.algorithm = algorithm
        if algorithm == "FULL":
            self.solver = reused or MonolithicSolver(self.comm, system, contacts, self.work)
        else:
            self.solver = BlockEliminationSolver(
                self.comm, system, contacts, self.work, algorithm, self.condensation, reused
            )
        release_freed_memory()  # the build's temporaries, before the factorisations' peak
        #: The solver the contact iteration drives: ``solver``, or around it the iteration
        #: that carries ties stiffer than KAPPA_SPLIT.
        self.tie_solver = self.solver
        if sum_over_ranks(self.comm, len(system.stiff_ties)):
            free = {tie.u: self.model.free(tie.u) for tie in system.stiff_ties}
            self.tie_solver = AugmentedTies(self.comm, self.solver, system.stiff_ties, free)

    def _check_choice(self) -> None:
        """Collective: after CHECK_SOLVES solves, compare auto's prediction with the clock.

        If a kind of work took more than MISS times (or less than 1/MISS of) its predicted
        time (a loaded machine, stale rates), choose again for the rest of the expected run
        with the rates corrected by what was measured, and switch solver if another wins.
        """
        structure, rates, expected = self._auto
        wall, cpu = (now - then for now, then in zip(_clocks(), self._started, strict=True))
        share = min(cpu / wall, 1.0) if wall > 0 and cpu > 0 else 1.0  # another job's load
        local = timing.misses(self.work.records, rates, self.work.calls, share)
        observed: dict[str, float] = {}  # the worst miss of any rank, the same on every rank
        for part in allgathered(self.comm, local):
            for kind, ratio in part.items():
                worst = observed.get(kind, 1.0)
                observed[kind] = ratio if abs(np.log(ratio)) > abs(np.log(worst)) else worst
        assert self.choice is not None  # auto chose
        self.choice.misses = observed
        if all(1.0 / timing.MISS <= r <= timing.MISS for r in observed.values()):
            return
        choice = timing.replan(self.choice, structure, rates, observed, self._rest(expected))
        logger.warning(
            "algorithm='auto': the first %d solves took %s x the predicted time; chose again "
            "for the rest of the run: %s (was %s)",
            self._solves,
            ", ".join(f"{k} {r:.2g}" for k, r in observed.items()),
            choice.algorithm,
            self.algorithm,
        )
        self.choice = choice
        if choice.algorithm != self.algorithm:
            self.solver.destroy()
            self._use(choice.algorithm)

    def _rest(self, expected: timing.Expected) -> timing.Expected:
        """The rest of the expected run, with the tie solves per solve counted so far."""
        it = self.iteration
        changes = max(expected.changes - it.gamma, 0.0)
        releases = expected.releases and timing.RELEASES_PER_CHANGE * changes
        tie_solves = expected.tie_solves
        if isinstance(self.tie_solver, AugmentedTies):
            solves = self._solves + it.gamma + it.release_solves  # of the contact iteration
            tie_solves = max(self.tie_solver.solves / max(solves, 1), 1.0)
        return timing.Expected(
            max(expected.steps - self._solves, 1.0), changes, releases, tie_solves
        )

    # -- a solve --------------------------------------------------------------------------
    def _check_contact_geometry(self, t: float = 0.0) -> None:
        """Refuse an obstacle that overlaps the body or whose normal points into it."""
        for z in self.zones:
            if isinstance(z, PairZone):
                tolerance = self.settings.penetration_tolerance
                size = 1e-3 * z.length if tolerance is None else tolerance
                assert isinstance(z.operator, PairOperator)
                check_pair_geometry(z.operator, z.contact.name, size)
                continue
            check_contact_geometry(
                z.operator,
                z.contact.mesh,
                z.contact.subdomain.mesh,
                z.contact.name,
                self.settings.penetration_tolerance,
                t,
            )

    def free(self, block: str) -> np.ndarray:
        """1 on the free dofs of an owned subdomain block, 0 on its prescribed ones (kept)."""
        if block not in self._free:
            self._free[block] = self.model.free(Block.parse(block))
        return self._free[block]

    def loads(self, t: float) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
        """Collective: owned loads r_D(t) (not to be written), reduced blocks' f_D on supports."""
        return collective(self.comm, lambda: self._loads(t))

    def _loads(self, t: float) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
        loads: dict[str, np.ndarray] = {}  # SubdomainLoad assembles as seldom as it can
        supports: dict[str, np.ndarray] = {}  # a reduced block's load on its supports
        for sub in self.owned:
            sub.set_time(t)
            basis, load = self.reduced.get(sub.block), self._load[sub.block]
            out = [load()] if basis is None else load.reduced(basis)
            loads[sub.block] = out[0]
            supports.update({sub.block: out[1]} if basis is not None else {})  # T^T r, r_D
            if not all(np.all(np.isfinite(v)) for v in out):
                raise InputError(
                    f"subdomain {sub.name!r}: the load at t = {t} contains NaN or inf; check "
                    "the traction and body-force data"
                )
        return loads, supports

    def _prescribed(self, t: float) -> dict[str, np.ndarray]:
        """The right-hand side of the prescribed values at ``t`` (recomputed when they change).

        A contact boundary on prescribed dofs gets their new values too.
        """
        values = {sub.block: sub.prescribed.values(t) for sub in self.owned}
        for block, basis in self.reduced.items():  # its prescribed dofs were removed
            values[block] = basis.prescribed(values[block], t)
        if self._lifted is not None and all(
            np.array_equal(v, values[block]) for block, v in self._lifted[0].items()
        ):
            return self._lifted[1]
        for z in self.zones:
            if z.block in values:
                g = np.zeros(self.model.system.sizes[z.block])
                g[self._lifting.dofs[z.block]] = values[z.block]
                z.prescribed[:] = g[z.dofs]
        self._lifted = (values, self._lifting(values))
        return self._lifted[1]

    def rhs(self, t: float, extra: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Collective: the prescribed values' right-hand side at ``t`` plus free-dof loads."""
        lifted = collective(self.comm, lambda: self._prescribed(t))
        rhs = dict(lifted)  # shared arrays: replaced below, never written
        for block, vector in extra.items():
            free = self.free(block) * vector
            if block in rhs:
                free += rhs[block]
            rhs[block] = free
        return rhs

    def solve(self, t: float, rhs: dict[str, np.ndarray], where: str, correction=None):
        """Collective: the contact iteration at ``t``; ``(x, iterations, changes)``."""
        if self._closed:
            raise RuntimeError(
                "this problem was closed (its factorisations are freed); create a new "
                "problem to solve again"
            )
        try:
            with self.petsc_options():
                if not self._solves:
                    self._started = _clocks()  # what auto's check compares with the clock
                out = self.iteration.solve(self.tie_solver, rhs, t, where, correction)
                self._solves += 1
                if self.choice is not None and self._solves == CHECK_SOLVES:
                    self._check_choice()
                return out
        except SingularMatrixError as error:
            raise type(error)(
                f"{error} (at {where}; {self._active_summary()}). Likely causes: a body held "
                "only by contact, which needs some points in contact from the start (close the "
                "clearance, or add Dirichlet conditions or a soft support); a penalty outside "
                f"the verified range kappa in [{KAPPA_VERIFIED[0]:g}, {KAPPA_VERIFIED[1]:g}]"
                f"{self._penalty_note()}"
            ) from None

    def _penalty_note(self) -> str:
        """The ties of this rank outside the verified penalty range, for an error message."""
        low, high = KAPPA_VERIFIED
        outside = [
            f"{surface!r} on {sub!r} has kappa = {kappa:.3g}"
            for (sub, surface), kappa in self.model.system.kappas.items()
            if not low <= kappa <= high
        ]
        return f" ({'; '.join(outside)})" if outside else ""

    def _active_summary(self) -> str:
        local = {n: int(a.sum()) for n, a in self.iteration.active.items()}
        counts = gathered(self.comm, local)
        return "active contact points: " + (
            ", ".join(f"{k}: {v}" for k, v in counts.items()) if counts else "none"
        )

    def agree(self, x, loads, accelerations, supports) -> dict:
        """Collective: this solve's results on every rank (:meth:`Results.agree`)."""
        it = self.iteration
        return self.agreed.agree(x, loads, accelerations, supports, it.active, it.alpha)

    def publish(self, x: dict[str, np.ndarray]) -> None:
        """Collective: copy the solution into the scene's Functions.

        Contact results land on their owners; every rank gets every subdomain's u here (the
        one gather of whole subdomains in a solve).
        """
        if isinstance(self.solver, BlockEliminationSolver):  # each rank holds its own u only
            sizes = self.model.system.sizes
            owners = {s.block: self.scene.owner(k) for k, s in enumerate(self.scene.subdomains)}
            x = {**x, **allgather_blocks(self.comm, x, owners, sizes)}
        for sub in self.scene.subdomains:
            if sub.block in self.reduced_states:
                self.reduced_states[sub.block][0][:] = x[sub.block]
                sub.defer(expansion(self.reduced.get(sub.block), x[sub.block].copy()))
            else:
                sub.u.x.array[:] = x[sub.block]
        self.publish_surfaces(x)
        for z in self.zones:
            z.publish(x)
        if any(not np.all(np.isfinite(v)) for v in x.values()):
            raise FloatingPointError(
                "the solution contains NaN or inf: the system is too ill-conditioned (extreme "
                "penalties?) or the data are not finite"
            )

    def owners_blocks(self, x: dict[str, np.ndarray], blocks: list[Block]) -> dict[str, np.ndarray]:
        """Collective: ``x`` with the owners' values of the ``blocks`` some rank changed.

        A rank holds copies of blocks it does not own (FULL's whole solution on every rank,
        the interface everywhere); what an owner changed after the solve (the massless walls
        put in equilibrium, :meth:`dd_contact.impact.StartForces.at_end`) reaches them here.
        """
        names = sorted({Block.parse(b) for part in allgathered(self.comm, blocks) for b in part})
        if not names:
            return x
        system = self.model.system
        owners = {b: system.owners[b] for b in names}
        return {**x, **allgather_blocks(self.comm, x, owners, system.sizes)}

    def publish_surfaces(self, x: dict[str, np.ndarray]) -> None:
        """Copy the interface's and the owned contact surfaces' displacement into Functions."""
        if self.scene.interface is not None:
            self.scene.interface.v.x.array[:] = x[self.scene.interface.block]
        for z in self.zones:
            for side, (block, dofs) in zip(z.sides, z.parts, strict=True):
                if block in x:
                    side.w.x.array[:] = x[block][dofs]

    def state_now(self) -> dict[str, np.ndarray]:
        """This rank's view of every block at the current time (subdomains, surfaces)."""
        sizes = self.model.system.sizes
        x: dict[str, np.ndarray] = {
            s.block: self.reduced_states[s.block][0]
            if s.block in self.reduced_states
            else s.u.x.array[: sizes[s.block]]
            for s in self.scene.subdomains
        }
        if self.scene.interface is not None:
            x[self.scene.interface.block] = self.scene.interface.v.x.array
        for c in self.scene.contacts:
            x.setdefault(c.block, c.w.x.array)
        return x

    def functions(self) -> list[fem.Function]:
        """The scene's displacement Functions: subdomains, interface, contact surfaces."""
        out = [s.u for s in self.scene.subdomains]
        if self.scene.interface is not None:
            out.append(self.scene.interface.v)
        return out + [c.w for c in self.scene.contacts]

    # -- what it found ----------------------------------------------------------------------
    def predict(
        self, steps: float, changes: float, rates: timing.MachineRates | None = None
    ) -> timing.Prediction:
        """Predicted solver time of this analysis's algorithm (collective).

        From MUMPS's analysis of the matrices it factorises and this machine's rates
        (:mod:`dd_contact.timing`): set-up, one step, one contact change, one release solve,
        and the total for ``steps`` steps with ``changes`` contact state changes (and the
        release and stiff-tie solves expected with them).
        """
        contacts = [z.region for z in self.zones]
        full = self.algorithm == "FULL"
        rates = rates if rates is not None else timing.machine_rates(comm=self.comm)
        with self.petsc_options(), counted(self.traffic):  # the analysis reads the options
            structure = scene_structure(
                self.comm,
                self.solver.system,
                contacts,
                self.condensation,
                full=full,
                orders=not full,
            )
        e = self._expected((steps, changes), self.releasing)
        plan = timing.plan(structure, self.algorithm)
        return timing.predict(plan, rates, e.steps, e.changes, e.releases, e.tie_solves)

    # -- resources ------------------------------------------------------------------------
    def petsc_options(self):
        """The context in which this analysis's factorisations read their PETSc options."""
        return petsc_options(self.options, self.options_prefix)

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` freed the factorisations."""
        return self._closed

    def close(self) -> None:
        """Collective, idempotent: free the solver's PETSc factorisations and matrices."""
        if self._closed:
            return
        self._closed = True
        self.solver.destroy()
        for basis in self.reduced.values():
            basis.destroy()
        logger.debug("analysis (%s): freed the solver", self.algorithm)
