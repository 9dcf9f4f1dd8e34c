"""What the static and transient problems share: the scene assembled, the solver, the iteration.

:class:`Analysis` assembles the scene once, eliminates the Dirichlet conditions, hands the
block system to a solver (the elimination order) and solves with the contact iteration;
results land in the scene's dolfinx Functions (``Subdomain.u``, ``Interface.v``,
``ContactInterface.w`` and ``.pressure``). It owns the solver's PETSc objects and frees
them in ``close()`` (or on leaving a ``with`` block). The user-facing problems built on it,
and time stepping, are in :mod:`dd_contact.problem`.

This module only orchestrates: the contact term and the geometric checks are in
:mod:`dd_contact.contact`, the contact iteration in :mod:`dd_contact.iteration` and the
agreed results in :mod:`dd_contact.post`.
"""

from __future__ import annotations

import logging
import warnings
from typing import Self

import dolfinx.fem as fem
import numpy as np

from dd_contact import forms, timing
from dd_contact.assembly import Model, assemble
from dd_contact.contact import check_contact_geometry
from dd_contact.errors import InputError, SingularMatrixError
from dd_contact.impact import massless_walls
from dd_contact.iteration import ContactIteration, ContactSettings
from dd_contact.parallel import allgather_blocks, collective, gathered
from dd_contact.post import Results
from dd_contact.scene import KAPPA_VERIFIED, ContactBoundary, Scene
from dd_contact.solvers import MonolithicSolver, WorkLog
from dd_contact.solvers.engine import BlockEliminationSolver
from dd_contact.solvers.linalg import petsc_options, release_freed_memory
from dd_contact.solvers.mumps_schur import layout_known, mumps_version
from dd_contact.solvers.residual import ResidualCheck
from dd_contact.solvers.schedule import ALGORITHMS, fitting_algorithms
from dd_contact.solvers.stiff_ties import AugmentedTies

__all__ = ["Analysis"]

logger = logging.getLogger(__name__)

#: Solves after which ``algorithm="auto"`` compares its prediction with the clock.
CHECK_SOLVES = 3


class Analysis:
    """Assembly, solver and contact iteration shared by the static and transient problems."""

    def __init__(
        self,
        scene: Scene,
        algorithm: str,
        mass_coefficient: float,
        contact: ContactSettings | None,
        condensation: str,
        expected: tuple[float, float],
        rates: timing.MachineRates | None,
        options: dict | None,
    ):
        self._options = dict(options or {})
        with petsc_options(self._options):  # checked, and read by the factorisations built
            self._build(scene, algorithm, mass_coefficient, contact, condensation, expected, rates)
        self._free: dict[str, np.ndarray] = {}  # model.free(block), kept

    def _build(self, scene, algorithm, mass_coefficient, contact, condensation, expected, rates):
        if condensation == "schur" and not layout_known():
            warnings.warn(
                f"the MUMPS inside PETSc is {mumps_version() or 'unknown'}, not the 5.8.x "
                "whose reduction and expansion phases dd_contact drives: condensation "
                "'multi-rhs' is used instead (two substitutions a step, not one)",
                RuntimeWarning,
                stacklevel=4,
            )
            condensation = "multi-rhs"
        has_interface = scene.interface is not None
        has_w = any(not isinstance(c, ContactBoundary) for c in scene.contacts)
        valid = fitting_algorithms(has_interface, has_w)
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
        self.scene, self.comm = scene, scene.comm
        self.work = WorkLog()
        self.model: Model = collective(self.comm, lambda: assemble(scene))
        for z in self.model.zones:  # the pressure-swing check reads static pressure only
            z.check_resolution = not mass_coefficient
        if mass_coefficient and self._energy_safe:  # massless contact walls (dd_contact.impact)
            for z in self.model.zones:
                block = z.contact.subdomain.block
                self.model.mass[block] = massless_walls(self.model.mass[block], z.wall)
        if mass_coefficient and self.mass_kind != "consistent":  # after the walls: theirs spread
            for sub in scene.subdomains:
                if sub.block in self.model.mass:  # owned here
                    degree = sub.V.element.basix_element.degree
                    M = self.model.mass[sub.block]
                    self.model.mass[sub.block] = forms.mass_of_kind(M, degree, self.mass_kind)
        system = self.model.effective(mass_coefficient)
        system.rhs = {}  # built at every solve: loads and prescribed values at its time
        self._lifting = self.model.lifting(mass_coefficient)
        self._lifted: tuple[dict, dict] | None = None  # the last prescribed values, their rhs
        self.zones = self.model.zones
        self.settings = contact or ContactSettings()
        collective(self.comm, self._check_contact_geometry)
        contacts = [z.region for z in self.zones]
        #: The prediction behind ``algorithm="auto"`` (``None`` for a named algorithm).
        self.choice: timing.Choice | None = None
        reused = None  # the chosen solver's parts that auto built and analysed already
        self._system, self._solves = system, 0
        if algorithm == "auto":
            rates = rates if rates is not None else timing.machine_rates(comm=self.comm)
            self.choice, structure = timing.auto_choice(
                self.comm, system, contacts, condensation, valid, rates, steps, changes, self.work
            )
            algorithm = self.choice.algorithm
            reused = structure.parts.take(algorithm)
            structure.parts = None
            self._auto = (structure, rates, steps, changes)  # for the check after CHECK_SOLVES
        self.condensation = condensation
        self._use(algorithm, reused)
        self.iteration = ContactIteration(
            self.comm,
            self.zones,
            self.settings,
            system.sizes,
            None
            if self.settings.residual_tolerance is None
            else ResidualCheck(self.comm, system, {z.block: z.dofs for z in self.zones}),
            held=[] if mass_coefficient else scene.bodies(),
        )
        self._closed = False
        self._owned = [
            (k, s, s.block)
            for k, s in enumerate(scene.subdomains)
            if scene.owner(k) == self.comm.rank
        ]
        self._load = {block: forms.SubdomainLoad(sub) for _, sub, block in self._owned}
        self._results = Results(self.comm, scene, self.model, self.iteration.alpha)

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
        if self.comm.allreduce(len(system.stiff_ties)):
            free = {tie.u: self.model.free(tie.u) for tie in system.stiff_ties}
            self.tie_solver = AugmentedTies(self.comm, self.solver, system.stiff_ties, free)

    def _check_choice(self) -> None:
        """Collective: after CHECK_SOLVES solves, compare auto's prediction with the clock.

        If a kind of work took more than MISS times (or less than 1/MISS of) its predicted
        time (a loaded machine, stale rates), choose again for the rest of the expected run
        with the rates corrected by what was measured, and switch solver if another wins.
        """
        structure, rates, steps, changes = self._auto
        local = timing.misses(self.work.records, rates)
        observed = {}  # the worst miss of any rank, the same on every rank
        for part in self.comm.allgather(local):
            for kind, ratio in part.items():
                worst = observed.get(kind, 1.0)
                observed[kind] = ratio if abs(np.log(ratio)) > abs(np.log(worst)) else worst
        self.choice.misses = observed
        if all(1.0 / timing.MISS <= r <= timing.MISS for r in observed.values()):
            return
        left = (max(steps - self._solves, 1.0), max(changes - self.iteration.gamma, 0.0))
        choice = timing.replan(self.choice, structure, rates, observed, *left)
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

    # -- pieces ----------------------------------------------------------------------------
    def _check_contact_geometry(self, t: float = 0.0) -> None:
        """Refuse an obstacle that overlaps the body or whose normal points into it."""
        for z in self.zones:
            check_contact_geometry(
                z.operator,
                z.contact.mesh,
                z.contact.subdomain.mesh,
                z.contact.name,
                self.settings.penetration_tolerance,
                t,
            )

    def _loads(self, t: float) -> dict[str, np.ndarray]:
        """Owned load vectors r_D(t), shared arrays not to be written.

        :class:`forms.SubdomainLoad` assembles them as seldom as their time dependence allows.
        """
        loads = {}
        for _, sub, block in self._owned:
            sub.set_time(t)
            vector = loads[block] = self._load[block]()
            if not np.all(np.isfinite(vector)):
                raise InputError(
                    f"subdomain {sub.name!r}: the load at t = {t} contains NaN or inf; check "
                    "the traction and body-force data"
                )
        return loads

    def _prescribed(self, t: float) -> dict[str, np.ndarray]:
        """The right-hand side of the prescribed values at ``t`` (recomputed when they change).

        A contact boundary on prescribed dofs gets their new values too.
        """
        values = {block: sub.prescribed.values(t) for _, sub, block in self._owned}
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

    def _rhs(self, t: float, extra: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Collective: the prescribed values' right-hand side at ``t`` plus free-dof loads."""
        lifted = collective(self.comm, lambda: self._prescribed(t))
        rhs = dict(lifted)  # shared arrays: replaced below, never written
        for block, vector in extra.items():
            if block not in self._free:
                self._free[block] = self.model.free(block)
            free = self._free[block] * vector
            if block in rhs:
                free += rhs[block]
            rhs[block] = free
        return rhs

    def _solve(self, t: float, rhs: dict[str, np.ndarray], where: str, correction=None):
        if self._closed:
            raise RuntimeError(
                f"this {type(self).__name__} was closed (its factorisations are freed); "
                "create a new problem to solve again"
            )
        try:
            with petsc_options(self._options):
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

    def _agree(self, x, loads, accelerations) -> dict:
        """Collective: this solve's results on every rank (:meth:`Results.agree`)."""
        it = self.iteration
        return self._results.agree(x, loads, accelerations, it.active, it.alpha)

    @property
    def results(self) -> dict:
        """The last solve's results, the same on every rank (rank-local; empty before).

        ``force`` (contact force per region), ``active`` (active points), ``contact_area``
        and ``reaction`` (support reaction per subdomain); see ``docs/output.md``.
        """
        return self._results.latest

    def _active_summary(self) -> str:
        local = {n: int(a.sum()) for n, a in self.iteration.active.items()}
        counts = gathered(self.comm, local)
        return "active contact points: " + (
            ", ".join(f"{k}: {v}" for k, v in counts.items()) if counts else "none"
        )

    def _publish(self, x: dict[str, np.ndarray]) -> None:
        """Collective: copy the solution into the scene's Functions.

        Contact results land on their owners; every rank gets every subdomain's u here (the
        one gather of whole subdomains in a solve).
        """
        if isinstance(self.solver, BlockEliminationSolver):  # each rank holds its own u only
            sizes = self.model.system.sizes
            owners = {s.block: self.scene.owner(k) for k, s in enumerate(self.scene.subdomains)}
            x = {**x, **allgather_blocks(self.comm, x, owners, sizes)}
        for sub in self.scene.subdomains:
            sub.u.x.array[:] = x[sub.block]
        if self.scene.interface is not None:
            self.scene.interface.v.x.array[:] = x[self.scene.interface.block]
        for z in self.zones:
            w = x[z.block][z.dofs]
            z.contact.w.x.array[:] = w
            z.contact.pressure.x.array[:] = z.pressure(w)
        if any(not np.all(np.isfinite(v)) for v in x.values()):
            raise FloatingPointError(
                "the solution contains NaN or inf: the system is too ill-conditioned (extreme "
                "penalties?) or the data are not finite"
            )

    def contact_forces(self) -> dict[str, np.ndarray]:
        """Total force of each obstacle on the body at the last solve [N], per region.

        Rank-local: every rank holds every region's force (agreed at the end of each
        solve); zero before the first solve.
        """
        return self._results.vectors("force", [c.name for c in self.scene.contacts])

    @property
    def reactions(self) -> dict[str, np.ndarray]:
        """Support reaction of each subdomain at the last solve [N] (rank-local).

        The total force its Dirichlet conditions exert on it; zero without supports or
        before the first solve.
        """
        return self._results.vectors("reaction", [s.name for s in self.scene.subdomains])

    @property
    def active_sets(self) -> dict[str, np.ndarray]:
        """Active contact points of the contact regions this rank owns (rank-local).

        One boolean per contact point (the surface nodes by default); the counts of every
        region are in :attr:`results`.
        """
        return {name: active.copy() for name, active in self.iteration.active.items()}

    @property
    def penalties(self) -> dict[tuple[str, str], float]:
        """Absolute penalty eps of every tie and contact, from all ranks (rank-local)."""
        return dict(self._results.penalties)

    def predict(
        self, steps: float, changes: float, rates: timing.MachineRates | None = None
    ) -> timing.Prediction:
        """Predicted linear-algebra time of this problem's algorithm (collective).

        From MUMPS's analysis of the matrices it factorises and this machine's rates
        (:mod:`dd_contact.timing`): set-up, one step, one contact change, and the total for
        ``steps`` steps with ``changes`` contact state changes.
        """
        contacts = [z.region for z in self.zones]
        full = self.algorithm == "FULL"
        rates = rates if rates is not None else timing.machine_rates(comm=self.comm)
        with petsc_options(self._options):  # the analysis reads the factorisations' options
            structure = timing.scene_structure(
                self.comm,
                self.solver.system,
                contacts,
                self.condensation,
                full=full,
                orders=not full,
            )
        return timing.predict(timing.plan(structure, self.algorithm), rates, steps, changes)

    def work_summary(self) -> dict[str, dict]:
        """Work per block so far, from all ranks (collective).

        Matrix kind and size, decompositions, substitutions (right-hand sides, as the paper
        counts them), seconds and GFLOPs; see :meth:`dd_contact.solvers.WorkLog.per_block`.
        """
        return self.work.merged(self.comm).per_block()

    def work_table(self) -> str:
        """:meth:`work_summary` as a text table (collective)."""
        return self.work.merged(self.comm).table()

    @property
    def changes(self) -> dict[str, int]:
        """Contact state changes so far: ``"gamma"`` (whole model) and one count per contact.

        Rank-local: the counts are agreed at the end of each solve.
        """
        return {"gamma": self.iteration.gamma, **self._results.alpha}

    def _functions(self) -> list[fem.Function]:
        out = [s.u for s in self.scene.subdomains]
        if self.scene.interface is not None:
            out.append(self.scene.interface.v)
        return out + [c.w for c in self.scene.contacts]

    # -- resources -------------------------------------------------------------------------
    def close(self) -> None:
        """Free the solver's PETSc factorisations and matrices (collective; idempotent).

        The results stay in the scene's Functions, the history and the work log; the problem
        cannot solve any more. ``with StaticProblem(scene) as problem:`` closes on leaving.
        """
        if self._closed:
            return
        self._closed = True
        self.solver.destroy()
        logger.debug("%s (%s): freed the solver", type(self).__name__, self.algorithm)

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
