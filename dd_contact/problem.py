"""User-facing problems: static and transient analyses of a scene, with contact.

Both share :class:`_Analysis`: assemble the scene once, eliminate the Dirichlet conditions,
hand the block system to a solver (the elimination order), and solve with the contact
iteration. Results land in the scene's dolfinx Functions (``Subdomain.u``, ``Interface.v``,
``ContactInterface.w`` and ``.pressure``). A problem owns its solver's PETSc objects and
frees them in ``close()`` (or on leaving a ``with`` block).

This module only orchestrates: the contact term and the geometric checks are in
:mod:`dd_contact.contact`, the contact iteration in :mod:`dd_contact.iteration`, the side
solves of a transient start in :mod:`dd_contact.solvers.auxiliary` and the energy in
:mod:`dd_contact.post`.
"""

from __future__ import annotations

import logging
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Self

import dolfinx.fem as fem
import numpy as np
from tqdm import tqdm

from dd_contact import forms, timing
from dd_contact.assembly import Model, assemble
from dd_contact.contact import check_contact_geometry
from dd_contact.errors import InputError, SingularMatrixError
from dd_contact.impact import StartForces, massless_walls
from dd_contact.io import RunOutput
from dd_contact.iteration import ContactIteration, ContactSettings
from dd_contact.parallel import collective, gathered
from dd_contact.post import Results, energy
from dd_contact.scene import KAPPA_VERIFIED, ContactBoundary, Scene
from dd_contact.solvers import MonolithicSolver, WorkLog
from dd_contact.solvers.auxiliary import solve_mass, surfaces_in_equilibrium
from dd_contact.solvers.engine import BlockEliminationSolver
from dd_contact.solvers.linalg import petsc_options
from dd_contact.solvers.residual import ResidualCheck
from dd_contact.solvers.schedule import ALGORITHMS, fitting_algorithms
from dd_contact.solvers.stiff_ties import AugmentedTies
from dd_contact.timestepping import Newmark

__all__ = ["StaticProblem", "TransientProblem"]

logger = logging.getLogger(__name__)


def _check_count(argument: str, value) -> None:
    """Refuse a step count that is not a whole number >= 1."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
        raise InputError(f"run: {argument} must be a whole number >= 1, got {value!r}")


def _print_report(comm, text: str) -> None:
    """Print a report the user asked for (``run(summary=True)``) on stdout, on rank 0."""
    if comm.rank == 0:
        print(text)


class _Analysis:
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

    def _build(self, scene, algorithm, mass_coefficient, contact, condensation, expected, rates):
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
        if mass_coefficient and self._energy_safe:  # massless contact walls (dd_contact.impact)
            for z in self.model.zones:
                block = z.contact.subdomain.block
                self.model.mass[block] = massless_walls(self.model.mass[block], z.wall)
        system = self.model.effective(mass_coefficient)
        self.lifting, system.rhs = system.rhs, {}
        self.zones = self.model.zones
        self.settings = contact or ContactSettings()
        collective(self.comm, self._check_contact_geometry)
        contacts = [z.region for z in self.zones]
        #: The prediction behind ``algorithm="auto"`` (``None`` for a named algorithm).
        self.choice: timing.Choice | None = None
        if algorithm == "auto":
            structure = timing.scene_structure(
                self.comm, system, contacts, condensation, orders=len(valid) > 1
            )
            rates = rates if rates is not None else timing.machine_rates(comm=self.comm)
            self.choice = timing.choose(structure, rates, valid, steps, changes)
            algorithm = self.choice.algorithm
        self.algorithm, self.condensation = algorithm, condensation
        if algorithm == "FULL":
            self.solver = MonolithicSolver(self.comm, system, contacts, self.work)
        else:
            self.solver = BlockEliminationSolver(
                self.comm, system, contacts, self.work, algorithm, condensation
            )
        #: The solver the contact iteration drives: ``solver``, or around it the iteration
        #: that carries ties stiffer than KAPPA_SPLIT.
        self.tie_solver = self.solver
        if self.comm.allreduce(len(system.stiff_ties)):
            free = {tie.u: self.model.free(tie.u) for tie in system.stiff_ties}
            self.tie_solver = AugmentedTies(self.comm, self.solver, system.stiff_ties, free)
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
        self._load_forms = {block: forms.load_forms(sub) for _, sub, block in self._owned}
        self._constant_loads: dict[str, np.ndarray] = {}
        self._results = Results(self.comm, scene, self.model, self.iteration.alpha)

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
        """Owned load vectors r_D(t) (cached when they do not depend on time)."""
        loads = {}
        for _, sub, block in self._owned:
            if block in self._constant_loads:
                loads[block] = self._constant_loads[block]
                continue
            sub.set_time(t)
            vector = forms.assemble_load(sub, self._load_forms[block])
            if not np.all(np.isfinite(vector)):
                raise InputError(
                    f"subdomain {sub.name!r}: the load at t = {t} contains NaN or inf; check "
                    "the traction and body-force data"
                )
            if not sub.time_dependent_loads:
                self._constant_loads[block] = vector
            loads[block] = vector
        return loads

    def _rhs(self, extra: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Lifting of the Dirichlet conditions plus free-dof loads."""
        rhs = {name: vector.copy() for name, vector in self.lifting.items()}
        for block, vector in extra.items():
            free = self.model.free(block) * vector
            rhs[block] = rhs[block] + free if block in rhs else free
        return rhs

    def _solve(self, t: float, rhs: dict[str, np.ndarray], where: str, correction=None):
        if self._closed:
            raise RuntimeError(
                f"this {type(self).__name__} was closed (its factorisations are freed); "
                "create a new problem to solve again"
            )
        try:
            with petsc_options(self._options):
                return self.iteration.solve(self.tie_solver, rhs, t, where, correction)
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
        """Copy the solution into the scene's Functions (contact results on their owners)."""
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


class StaticProblem(_Analysis):
    """Static linear elasticity of a scene with contact (the static form of system (14)).

    Args:
        scene: What is modelled.
        algorithm: Elimination order; ``"FULL"`` solves the block system as one matrix;
            ``"auto"`` picks the one with the least predicted time (see :attr:`choice`).
        contact: Contact iteration settings.
        condensation: How the decomposition orders condense a subdomain: ``"schur"``
            (MUMPS's Schur complement, the default) or ``"multi-rhs"``.
        expected_changes: For ``"auto"``: contact state changes expected per solve
            (default 3: a contact iteration typically settles in a few changes).
        rates: For ``"auto"``: machine rates (default: this machine's, measured once
            and cached; see :func:`dd_contact.timing.machine_rates`).
        petsc_options: PETSc options for the MUMPS factorisations, as dolfinx's
            ``LinearProblem``: ``{"mat_mumps_icntl_14": 50}`` (read under the prefix
            ``dd_contact_`` while this problem builds its factorisations; docs/solvers.md).

    Example:
        >>> with StaticProblem(scene) as problem:
        ...     u_left, u_right, v = problem.solve()
    """

    def __init__(
        self,
        scene: Scene,
        algorithm: str = "FULL",
        contact: ContactSettings | None = None,
        condensation: str = "schur",
        expected_changes: float = 3.0,
        rates: timing.MachineRates | None = None,
        petsc_options: dict | None = None,
    ):
        scene.check_static_supports()
        expected = (1, expected_changes)
        super().__init__(
            scene, algorithm, 0.0, contact, condensation, expected, rates, petsc_options
        )
        self.iterations = 0

    def solve(self, t: float = 0.0) -> list[fem.Function]:
        """Collective: solve at load time ``t``.

        Returns the subdomain, interface and contact displacements (the scene's Functions);
        :attr:`results`, :meth:`contact_forces`, :attr:`reactions` and :attr:`changes`
        then hold this solve's results on every rank.
        """
        self.iteration.start(t)
        loads = collective(self.comm, lambda: self._loads(t))
        x, self.iterations, _ = self._solve(t, self._rhs(loads), f"t = {t}")
        self._publish(x)
        record = {"t": t, "iterations": self.iterations, **self._agree(x, loads, {})}
        self._results.latest = record
        return self._functions()


class TransientProblem(_Analysis):
    """Time stepping with contact: Newmark's trapezoidal rule, or quasi-static steps.

    The initial state is read from the scene: ``Subdomain.u`` (displacement) and
    ``Subdomain.velocity``; the initial acceleration follows from equilibrium at ``t0``.

    Args:
        scene: What is modelled.
        dt: Time step (fixed: the subdomain matrices are factorised once for it).
        algorithm: Elimination order.
        inertia: ``False`` for quasi-static load stepping (no mass terms).
        contact: Contact iteration settings.
        t0: Initial time.
        condensation: How the decomposition orders condense a subdomain (``"schur"`` or
            ``"multi-rhs"``).
        track_energy: Record the energy in every step's history record (one matrix-vector
            product per block per step; switch it off when timing).
        expected_steps: For ``algorithm="auto"``: the length of the run (default 1000).
        expected_changes: For ``"auto"``: contact state changes expected over the run
            (default: one per step, as when a contact area grows or shrinks all along).
        rates: For ``"auto"``: machine rates (default: this machine's, measured once
            and cached; see :func:`dd_contact.timing.machine_rates`).
        petsc_options: PETSc options for the MUMPS factorisations, as dolfinx's
            ``LinearProblem``: ``{"mat_mumps_icntl_14": 50}`` (read under the prefix
            ``dd_contact_`` while this problem builds its factorisations; docs/solvers.md).
        energy_safe_contact: Contact that never creates energy (:mod:`dd_contact.impact`):
            massless contact walls, and a point leaving contact lets go over its step. The
            bar impact with the default contact penalty: energy 9-12x -> 1.0, 65-137 state
            changes -> 3, contact duration within 1 % (docs/contact.md). Off by default for
            now: it changes every contact history (the default is to change with issue 13).
    """

    def __init__(
        self,
        scene: Scene,
        dt: float,
        algorithm: str = "FULL",
        inertia: bool = True,
        contact: ContactSettings | None = None,
        t0: float = 0.0,
        condensation: str = "schur",
        track_energy: bool = True,
        expected_steps: int = 1000,
        expected_changes: float | None = None,
        rates: timing.MachineRates | None = None,
        petsc_options: dict | None = None,
        energy_safe_contact: bool = False,
    ):
        self.newmark = Newmark(dt)
        self._energy_safe = bool(energy_safe_contact)
        self.inertia = inertia
        if inertia:
            massless = [s.name for s in scene.subdomains if s.material.rho <= 0]
            if massless:
                raise InputError(
                    f"TransientProblem: subdomain(s) {massless} have no density; give "
                    "Material(rho=...) or use inertia=False for quasi-static steps"
                )
        else:
            scene.check_static_supports()
        mass_coefficient = self.newmark.mass_coefficient if inertia else 0.0
        changes = expected_steps if expected_changes is None else expected_changes
        super().__init__(
            scene,
            algorithm,
            mass_coefficient,
            contact,
            condensation,
            (expected_steps, changes),
            rates,
            petsc_options,
        )
        self.track_energy = track_energy
        self.dt, self.t0 = dt, t0
        self.t, self.step = t0, 0
        self.history: list[dict] = []
        self._started = False

    # -- state ---------------------------------------------------------------------------
    def start(self) -> None:
        """Collective: set up the initial state (done by the first step if not called).

        Checks the initial data, puts the interface and contact interfaces in equilibrium
        with the initial displacement, and computes the initial acceleration.
        """
        if not self._started:
            self._start()

    def _start(self) -> None:
        def check_initial_data():
            for _, sub, _ in self._owned:
                for f in (sub.u, sub.velocity):
                    if not np.all(np.isfinite(f.x.array)):
                        raise InputError(
                            f"subdomain {sub.name!r} initial {f.name} contains NaN "
                            "or inf; check the data interpolated into it"
                        )

        collective(self.comm, check_initial_data)
        for _, sub, block in self._owned:
            fixed = self.model.free(block) == 0
            sub.velocity.x.array[fixed] = 0.0
        self.iteration.start(self.t0)
        if self.inertia:
            with petsc_options(self._options):
                self._initial_acceleration()
        self._started = True

    def _initial_acceleration(self) -> None:
        """M u''(t0) = r(t0) - K u(t0) - tie forces (massless surfaces in equilibrium)."""
        loads = collective(self.comm, lambda: self._loads(self.t0))
        u0 = {block: sub.u.x.array[: sub.num_dofs].copy() for _, sub, block in self._owned}
        moved = self.comm.allreduce(any(np.any(u != 0) for u in u0.values()))
        x0 = {s.block: s.u.x.array.copy() for s in self.scene.subdomains}
        if moved:
            x0.update(surfaces_in_equilibrium(self.comm, self.model.system, u0, self.work))
            self._publish_surfaces(x0)
        residual = {}
        for _, sub, block in self._owned:
            r = loads[block].copy()
            for (rb, cb), A in self.model.system.matrices.items():
                if rb == block and cb in x0:
                    r -= A @ x0[cb]
                elif cb == block and rb != cb and rb in x0:
                    r -= A.T @ x0[rb]
            residual[block] = r * self.model.free(block)
        for _, sub, block in self._owned:
            if not np.any(residual[block]):
                sub.acceleration.x.array[:] = 0.0
                continue
            # M with the prescribed (and massless) dofs eliminated: a = 0 there.
            mass = self.model.mass[block]
            fixed = np.flatnonzero((self.model.free(block) == 0) | (mass.diagonal() == 0))
            sub.acceleration.x.array[:] = solve_mass(
                self.model.mass[block], fixed, residual[block], self.work, sub.name
            )
            logger.debug("initial acceleration of subdomain %r from its mass matrix", sub.name)

    def _state_now(self) -> dict[str, np.ndarray]:
        """This rank's view of every block at the current time (subdomains, surfaces)."""
        sizes = self.model.system.sizes
        x = {s.block: s.u.x.array[: sizes[s.block]] for s in self.scene.subdomains}
        if self.scene.interface is not None:
            x[self.scene.interface.block] = self.scene.interface.v.x.array
        for c in self.scene.contacts:
            x.setdefault(c.block, c.w.x.array)
        return x

    def energy(self) -> dict[str, float]:
        """Collective: kinetic, elastic (with ties) and contact-penalty energy now [J]."""
        x = {s.block: s.u.x.array for s in self.scene.subdomains}
        if self.scene.interface is not None:
            x[self.scene.interface.block] = self.scene.interface.v.x.array
        for c in self.scene.contacts:
            x.setdefault(c.block, c.w.x.array)
        velocities = {block: sub.velocity.x.array for _, sub, block in self._owned}
        local = energy(self.model, x, velocities, self.zones)
        parts = np.array(
            self.comm.allreduce(np.array([local["kinetic"], local["elastic"], local["contact"]]))
        )
        return {
            "kinetic": parts[0],
            "elastic": parts[1],
            "contact": parts[2],
            "total": float(parts.sum()),
        }

    # -- stepping -----------------------------------------------------------------------
    def advance(self) -> dict:
        """Collective: one time step; returns its record (also appended to :attr:`history`).

        The record (also :attr:`results`, the same on every rank): ``step``, ``t``,
        ``iterations``, ``changes`` (contact state changes in this step), and per contact
        region ``force`` [N], ``active`` (points) and ``contact_area`` [m^2], per subdomain
        ``reaction`` [N] (its supports), and ``energy`` [J] (dynamics, ``track_energy``).
        """
        if not self._started:
            self._start()
        t_new = self.t + self.dt
        loads = collective(self.comm, lambda: self._loads(t_new))
        external = dict(loads)
        where = f"step {self.step + 1} (t = {t_new:.6g})"
        if self.inertia:  # the trapezoidal rule in equilibrium form (dd_contact.impact)
            previous = collective(self.comm, lambda: self._loads(self.t))
            start = StartForces(
                self.model.system,
                self.zones,
                self._state_now(),
                self.iteration.active,
                [block for _, _, block in self._owned],
                self.tie_solver.rhs_offset,
            )
            for _, sub, block in self._owned:
                n = sub.num_dofs
                history = self.newmark.history(sub.u.x.array[:n], sub.velocity.x.array[:n])
                loads[block] = (
                    loads[block]
                    + previous[block]
                    - start.internal[block]
                    + self.model.mass[block] @ history
                )

            def correction(active):
                return {b: v * self.model.free(b) for b, v in start.correction(active).items()}

            release = correction if self._energy_safe else None
            x, iterations, changes = self._solve(t_new, self._rhs(loads), where, release)
            for _, sub, block in self._owned:
                n = sub.num_dofs
                v, a = self.newmark.update(x[block], sub.u.x.array[:n], sub.velocity.x.array[:n])
                sub.velocity.x.array[:n] = v
                sub.acceleration.x.array[:n] = a
        else:
            x, iterations, changes = self._solve(t_new, self._rhs(loads), where)
        self._publish(x)
        self.t, self.step = t_new, self.step + 1
        accelerations = {b: s.acceleration.x.array for _, s, b in self._owned if self.inertia}
        record = {"step": self.step, "t": t_new, "iterations": iterations, "changes": changes}
        record.update(self._agree(x, external, accelerations))
        if self.inertia and self.track_energy:
            record["energy"] = self.energy()
        self._results.latest = record
        self.history.append(record)
        return record

    def run(
        self,
        n_steps: int,
        output: str | Path | None = None,
        output_every: int = 1,
        checkpoint_every: int | None = None,
        resume: bool = False,
        progress: bool | None = None,
        callback: Callable[[dict], None] | None = None,
        summary: bool = True,
    ) -> list[dict]:
        """Collective: advance up to step number ``n_steps``, writing results as it goes.

        ``n_steps`` is the step to reach, counted from t0, not a number of new steps: after
        ``run(10)``, ``run(20)`` takes 10 more, and a second ``run(10)`` raises
        :class:`InputError`. With ``resume=True`` the run continues from the checkpoint in
        ``output`` (if there is one) to the same ``n_steps``; a checkpoint already at
        ``n_steps`` leaves nothing to do and returns its history.

        Args:
            n_steps: Last step number of the run (>= 1).
            output: Directory (created if missing) for the fields (XDMF), ``history.json``,
                ``history.csv`` and checkpoints; see ``docs/output.md``.
            output_every: Write the fields every this many steps (>= 1).
            checkpoint_every: Save a checkpoint every this many steps (needs ``output``).
            resume: Continue from the checkpoint in ``output`` if there is one.
            progress: Show a progress bar (default: when stderr is a terminal, on rank 0).
            callback: Called with each step's record after the step.
            summary: Print the work per block (:meth:`work_table`) at the end, on rank 0.

        Returns:
            The history: one record per step (time, iterations, contact state changes,
            active points, contact area and force per region, support reactions, energy).
        """
        _check_count("n_steps", n_steps)
        _check_count("output_every", output_every)
        if checkpoint_every is not None:
            _check_count("checkpoint_every", checkpoint_every)
            if output is None:
                raise InputError("run: checkpoint_every needs an output directory (output=...)")
        files = RunOutput(self.scene, output, self.inertia) if output is not None else None
        restored = resume and files is not None and files.checkpoint.exists()
        if restored:
            self._restore(files.checkpoint.load(), files.history.load())
        if self.step >= n_steps and not (restored and self.step == n_steps):
            where = f"the checkpoint in {str(output)!r} is" if restored else "the problem is"
            raise InputError(
                f"run(n_steps={n_steps}): {where} already at step {self.step}; n_steps is the "
                f"step number to reach (counted from t0), not a number of new steps: call "
                f"run({self.step + n_steps}) for {n_steps} more"
            )
        if not self._started:
            self._start()
        if files is not None:
            files.open(self.step, self.history)
            if self.step == 0:
                files.fields.write(self.t)
        show = progress if progress is not None else sys.stderr.isatty()
        bar = None
        if show and self.comm.rank == 0 and self.step < n_steps:
            bar = tqdm(total=n_steps, initial=self.step, unit="step", file=sys.stderr)
        try:
            while self.step < n_steps:
                record = self.advance()
                if files is not None:
                    files.record(record, self.step % output_every == 0)
                if checkpoint_every and self.step % checkpoint_every == 0:
                    files.save(self._state(), self.history)
                    logger.info("checkpoint at step %d (t = %.6g)", self.step, self.t)
                if bar is not None:
                    bar.update(1)
                    bar.set_postfix(t=f"{self.t:.4g}", changes=self.iteration.gamma)
                if callback is not None:
                    callback(record)
        finally:
            if bar is not None:
                bar.close()
            if files is not None:
                files.close(self.history)
        if summary:
            table = self.work_table()
            report = []
            if self.choice is not None:
                report.append(f"algorithm='auto' chose {self.algorithm}:\n{self.choice.table()}")
            report.append(
                f"{self.algorithm}: {self.step} steps, {self.iteration.gamma} contact "
                f"state changes\n{table}"
            )
            _print_report(self.comm, "\n".join(report))
        return self.history

    def _state(self) -> dict[str, np.ndarray]:
        state = {
            "step": np.array(self.step),
            "t": np.array(self.t),
            "dt": np.array(self.dt),
            "gamma": np.array(self.iteration.gamma),
        }
        for _, sub, _ in self._owned:
            state[f"u/{sub.name}"] = sub.u.x.array
            state[f"velocity/{sub.name}"] = sub.velocity.x.array
            state[f"acceleration/{sub.name}"] = sub.acceleration.x.array
        for z in self.zones:
            state[f"active/{z.contact.name}"] = self.iteration.active[z.contact.name]
            state[f"alpha/{z.contact.name}"] = np.array(self.iteration.alpha[z.contact.name])
        return state

    def _restore(self, state: dict[str, np.ndarray], history: list[dict]) -> None:
        """Collective: the state of a checkpoint, and the history up to its step."""
        if float(state["dt"]) != self.dt:
            raise InputError(
                f"resume: the checkpoint was written with dt = {float(state['dt'])}, this run "
                f"has dt = {self.dt}; use the same time step or start a new output directory"
            )
        for _, sub, _ in self._owned:
            for name in ("u", "velocity", "acceleration"):
                key = f"{name}/{sub.name}"
                target = getattr(sub, name).x.array
                if key not in state or state[key].shape != target.shape:
                    raise InputError(
                        f"resume: the checkpoint does not match subdomain {sub.name!r} "
                        "(different scene or mesh); start a new output directory"
                    )
                target[:] = state[key]
        self.step, self.t = int(state["step"]), float(state["t"])
        self.iteration.gamma = int(state["gamma"])
        for z in self.zones:
            self.iteration.active[z.contact.name] = state[f"active/{z.contact.name}"]
            self.iteration.alpha[z.contact.name] = int(state[f"alpha/{z.contact.name}"])
        # v and w need no restoring: they are massless and solved afresh in every step.
        self.history = [r for r in history if r["step"] <= self.step]
        self._results.latest = self.history[-1] if self.history else {}
        self._results.alpha = gathered(self.comm, self.iteration.alpha)
        self._started = True

    def _publish_surfaces(self, surfaces: dict[str, np.ndarray]) -> None:
        if self.scene.interface is not None:
            self.scene.interface.v.x.array[:] = surfaces[self.scene.interface.block]
        for z in self.zones:
            if z.block in surfaces:
                z.contact.w.x.array[:] = surfaces[z.block][z.dofs]
