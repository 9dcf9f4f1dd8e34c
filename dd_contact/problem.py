"""User-facing problems: static and transient analyses of a scene, with contact.

Both are :class:`dd_contact.analysis.Analysis` (assembly, solver, contact iteration,
results); this module adds the static solve and time stepping: the initial state, Newmark
steps, the run loop with its output, checkpoints and resume. The side solves of a transient
start are in :mod:`dd_contact.solvers.auxiliary` and the energy in :mod:`dd_contact.post`.
"""

from __future__ import annotations

import logging
import sys
import warnings
from collections.abc import Callable
from pathlib import Path

from mpi4py import MPI

import dolfinx.fem as fem
import numpy as np
from tqdm import tqdm

from dd_contact import timing
from dd_contact.analysis import Analysis
from dd_contact.errors import CoarseTimeStepWarning, EnergyGrowthWarning, InputError
from dd_contact.forms import MASS_KINDS
from dd_contact.impact import BlockProducts, StartForces, block_product
from dd_contact.io import RunOutput
from dd_contact.iteration import ContactSettings
from dd_contact.parallel import collective, gathered
from dd_contact.post import energy
from dd_contact.scene import Scene
from dd_contact.solvers.auxiliary import solve_mass, surfaces_in_equilibrium
from dd_contact.solvers.linalg import petsc_options
from dd_contact.timestepping import time_scheme

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


#: A step whose energy grows by more than this fraction beyond the loads' work warns
#: (EnergyGrowthWarning). Round-off is far below it: 7e-12 a step at the default tie penalty
#: (docs/contact.md, free vibration); a contact release of the classic rule gains 1-10 %.
ENERGY_GROWTH_TOLERANCE = 1e-6

#: A contact episode (a region touching from the step its first point enters to the step its
#: last one leaves) closed in fewer steps than this warns (CoarseTimeStepWarning): the bar
#: impact's rebound was 2-4 % slow at 53 steps, 8-16 % at 10-20, within 2.7 % from 80
#: (docs/contact.md, "A time step too coarse for the impact").
MIN_CONTACT_STEPS = 60


class StaticProblem(Analysis):
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
        x, self.iterations, _ = self._solve(t, self._rhs(t, loads), f"t = {t}")
        self._publish(x)
        record = {"t": t, "iterations": self.iterations, **self._agree(x, loads, {})}
        self._results.latest = record
        return self._functions()


class TransientProblem(Analysis):
    """Time stepping with contact: the trapezoidal rule, generalized-alpha, or quasi-static.

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
        energy_safe_contact: Contact that never creates energy (:mod:`dd_contact.impact`,
            the default): massless contact walls, and a point leaving contact keeps the
            discrete-gradient share of its start force. The bar impact with the default
            contact penalty: energy 9-12x -> 1, 59-137 state changes -> 1, contact duration
            within 1.3 % (docs/contact.md). ``False``: the classic trapezoidal contact (the
            paper's; it creates energy when points leave contact, which is reported).
        mass: ``"consistent"`` (the default), ``"lumped"`` (row sums for degree 1, the
            diagonal scaled to the exact total mass for degree 2) or ``"averaged"`` (half
            each: an impact's peak force overshoots least; docs/contact.md).
        scheme: ``"trapezoidal"`` (the default: no numerical damping, energy conserved) or
            ``"generalized-alpha"`` (damps the modes short against dt; second order).
        rho_infinity: generalized-alpha's spectral radius for dt / period -> infinity, in
            [0, 1] (default 0.8; 1 is the trapezoidal rule, 0 damps the most).
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
        energy_safe_contact: bool = True,
        mass: str = "consistent",
        scheme: str = "trapezoidal",
        rho_infinity: float | None = None,
    ):
        if mass not in MASS_KINDS:
            raise InputError(
                f"TransientProblem: unknown mass {mass!r}; valid: "
                f"{', '.join(map(repr, MASS_KINDS))} (lumped: a diagonal mass matrix; "
                "averaged: half consistent, half lumped)"
            )
        self.mass_kind = mass
        #: The time-integration scheme (coefficients and updates).
        self.time_scheme = time_scheme(scheme, dt, rho_infinity)
        self.scheme = scheme
        self._energy_safe = bool(energy_safe_contact)
        self._energy_before: float | None = None  # the last step's total energy (its bound)
        self._previous_loads: tuple[float | None, dict] = (None, {})  # (t, r(t)) of a step
        self._energy_warned = False
        self._contact_steps: dict[str, int] = {}  # steps of each region's open episode
        self._impact: dict[str, bool] = {}  # whether motion, not load, opened that episode
        self._coarse_warned = False
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
        mass_coefficient = self.time_scheme.mass_coefficient if inertia else 0.0
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
        #: ``K x`` by block rows, shared by the energy and the next step's start forces (it
        #: keeps a copy of x: without the energy there is nothing to share)
        owned = [block for _, _, block in self._owned]
        self._products = BlockProducts(self.model.system, owned) if track_energy else None
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
        if self.inertia and self.track_energy:
            self._energy_before = self.energy()["total"]
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
            r = loads[block] - block_product(self.model.system, block, x0)
            residual[block] = r * self.model.free(block)
        for _, sub, block in self._owned:
            if not np.any(residual[block]):
                sub.acceleration.x.array[:] = 0.0
                continue
            # M with the prescribed dofs eliminated, as in the effective matrix.
            mass = self.model.mass[block]  # a = 0 on prescribed and massless dofs
            fixed = np.flatnonzero((self.model.free(block) == 0) | (mass.diagonal() == 0))
            sub.acceleration.x.array[:] = solve_mass(
                self.model.mass[block], fixed, residual[block], self.work, sub.name
            )
            logger.debug("initial acceleration of subdomain %r from its mass matrix", sub.name)

    def _check_energy(self, record, before, previous, external, x) -> None:
        """Collective: warn once if the step's energy grew by more than the loads' work.

        The trapezoidal rule conserves energy exactly but for contact points that change
        state; a gain beyond round-off is energy the contact created (dd_contact.impact).
        Generalized-alpha's energy may swing up within a step while it decays overall (its
        velocity overshoot): it is held to the energy at the start plus the loads' work.
        Skipped while prescribed displacements move (their reactions' work is not counted).
        """
        energy_before = self._energy_before
        energy_after = record["energy"]["total"]
        self._energy_before = energy_after
        if energy_before is None or self._energy_warned:
            return
        work, moved = 0.0, False
        for _, _, block in self._owned:
            free = self.model.free(block)
            du = x[block] - before[block]
            moved = moved or bool(np.any(du[free == 0]))
            work += 0.5 * float((free * (previous[block] + external[block])) @ du)
        work = self.comm.allreduce(work)
        if self.comm.allreduce(moved, op=MPI.LOR):
            return
        if not self.time_scheme.conserves_energy:
            self._energy_before = energy_before + work
        gain = energy_after - energy_before - work
        if gain > ENERGY_GROWTH_TOLERANCE * max(abs(energy_before), abs(energy_after)):
            self._energy_warned = True
            fix = (
                "this should not happen with energy_safe_contact=True: please report it"
                if self._energy_safe
                else "use TransientProblem(..., energy_safe_contact=True), or a softer "
                "contact penalty (contact_kappa)"
            )
            warnings.warn(
                f"step {record['step']} (t = {record['t']:.6g}): the energy grew by "
                f"{gain:.3g} J ({gain / max(abs(energy_before), 1e-300):.2%}) more than the "
                f"loads' work, with {record['changes']} contact state change(s): the contact "
                f"created energy; {fix}",
                EnergyGrowthWarning,
                stacklevel=3,
            )

    def _check_episodes(self, record: dict) -> None:
        """Warn once if an impact's contact episode closed within MIN_CONTACT_STEPS steps.

        An episode is an impact when kinetic energy was at least half of the kinetic and
        elastic energy at the step before it opened (unknown without ``track_energy``: then
        every episode counts); a load that presses and lets go slowly is followed by any dt.
        ``record["active"]`` and the energy are agreed on every rank: every rank warns alike.
        """
        before = self.history[-1].get("energy") if self.history else None
        for name, points in record["active"].items():
            steps = self._contact_steps.get(name, 0)
            if points:
                if not steps:
                    self._impact[name] = before is None or (
                        before["kinetic"] >= 0.5 * (before["kinetic"] + before["elastic"])
                    )
                self._contact_steps[name] = steps + 1
                continue
            self._contact_steps[name] = 0
            if not steps or steps >= MIN_CONTACT_STEPS or self._coarse_warned:
                continue
            if not self._impact.get(name, True):
                continue
            self._coarse_warned = True
            duration = steps * self.dt
            warnings.warn(
                f"contact {name!r}: an impact's contact episode ended at step {record['step']} "
                f"(t = {record['t']:.6g}) after only {steps} time step(s), {duration:.3g} s; "
                f"with fewer than {MIN_CONTACT_STEPS} steps per contact an impact's rebound is "
                f"inaccurate (the bar impact: 15 % slow at 8 steps, 2-4 % at 53), though the "
                f"energy is kept; use a smaller time step, dt <= {duration:.3g} / "
                f"{MIN_CONTACT_STEPS} = {duration / MIN_CONTACT_STEPS:.3g} s",
                CoarseTimeStepWarning,
                stacklevel=3,
            )

    def _state_now(self) -> dict[str, np.ndarray]:
        """This rank's view of every block at the current time (subdomains, surfaces)."""
        sizes = self.model.system.sizes
        x = {s.block: s.u.x.array[: sizes[s.block]] for s in self.scene.subdomains}
        if self.scene.interface is not None:
            x[self.scene.interface.block] = self.scene.interface.v.x.array
        for c in self.scene.contacts:
            x.setdefault(c.block, c.w.x.array)
        return x

    @staticmethod
    def _kinematics(sub) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The owned displacement, velocity and acceleration of a subdomain now."""
        n = sub.num_dofs
        return sub.u.x.array[:n], sub.velocity.x.array[:n], sub.acceleration.x.array[:n]

    def energy(self) -> dict[str, float]:
        """Collective: kinetic, elastic (with ties) and contact-penalty energy now [J]."""
        velocities = {block: sub.velocity.x.array for _, sub, block in self._owned}
        local = energy(self.model, self._state_now(), velocities, self.zones, self._products)
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
        scheme = self.time_scheme
        if self.inertia:  # the scheme in equilibrium form (dd_contact.impact)
            if self._previous_loads[0] != self.t:  # the last step's loads are r(t_n)
                self._previous_loads = (self.t, collective(self.comm, lambda: self._loads(self.t)))
            previous = self._previous_loads[1]
            if self.track_energy:  # for the energy balance of the step
                before = {b: s.u.x.array[: s.num_dofs].copy() for _, s, b in self._owned}
            start = StartForces(
                self.model.system,
                self.zones,
                self._state_now(),
                self.iteration.active,
                [block for _, _, block in self._owned],
                self.tie_solver.rhs_offset,
                self.model.free,
                scheme.start_weight,
                self._products,
            )
            for _, sub, block in self._owned:
                # r_n+1 + w (r_n - K x_n) + M h, summed in this order, in one new array
                rhs = np.subtract(previous[block], start.internal[block])
                rhs *= scheme.start_weight
                rhs += loads[block]
                rhs += self.model.mass[block] @ scheme.history(*self._kinematics(sub))
                loads[block] = rhs

            release = start if self._energy_safe else None
            x, iterations, changes = self._solve(t_new, self._rhs(t_new, loads), where, release)
            for _, sub, block in self._owned:
                n = sub.num_dofs
                v, a = scheme.update(x[block], *self._kinematics(sub))
                sub.velocity.x.array[:n] = v
                sub.acceleration.x.array[:n] = a
        else:
            x, iterations, changes = self._solve(t_new, self._rhs(t_new, loads), where)
        self._publish(x)
        self.t, self.step = t_new, self.step + 1
        self._previous_loads = (t_new, external)
        accelerations = {b: s.acceleration.x.array for _, s, b in self._owned if self.inertia}
        record = {"step": self.step, "t": t_new, "iterations": iterations, "changes": changes}
        record.update(self._agree(x, external, accelerations))
        if self.inertia and self.track_energy:
            record["energy"] = self.energy()
            self._check_energy(record, before, previous, external, x)
        if self.inertia:
            self._check_episodes(record)
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
            "integration": np.array(self._integration()),
            "release_solves": np.array(self.iteration.release_solves),
        }
        for _, sub, _ in self._owned:
            state[f"u/{sub.name}"] = sub.u.x.array
            state[f"velocity/{sub.name}"] = sub.velocity.x.array
            state[f"acceleration/{sub.name}"] = sub.acceleration.x.array
        for z in self.zones:
            state[f"active/{z.contact.name}"] = self.iteration.active[z.contact.name]
            state[f"alpha/{z.contact.name}"] = np.array(self.iteration.alpha[z.contact.name])
            state[f"releases/{z.contact.name}"] = np.array(self.iteration.releases[z.contact.name])
        return state

    def _integration(self) -> str:
        """The settings a resumed run must share with its checkpoint (besides dt)."""
        rho = getattr(self.time_scheme, "rho_infinity", 1.0)
        return (
            f"inertia={self.inertia}, scheme={self.scheme!r}, rho_infinity={rho}, "
            f"mass={self.mass_kind!r}, energy_safe_contact={self._energy_safe}"
        )

    def _restore(self, state: dict[str, np.ndarray], history: list[dict]) -> None:
        """Collective: the state of a checkpoint, and the history up to its step."""
        if float(state["dt"]) != self.dt:
            raise InputError(
                f"resume: the checkpoint was written with dt = {float(state['dt'])}, this run "
                f"has dt = {self.dt}; use the same time step or start a new output directory"
            )
        written = str(state["integration"]) if "integration" in state else None
        if written is not None and written != self._integration():
            raise InputError(
                f"resume: the checkpoint was written with {written}; this run has "
                f"{self._integration()}; use the same settings or start a new output directory"
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
            key = f"releases/{z.contact.name}"  # absent in checkpoints before the count
            self.iteration.releases[z.contact.name] = int(state[key]) if key in state else 0
        self.iteration.release_solves = int(state.get("release_solves", 0))
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
