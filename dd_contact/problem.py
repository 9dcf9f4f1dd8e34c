"""User-facing problems: static and transient analyses of a scene, with contact.

Each problem holds an :class:`~dd_contact.analysis.Analysis` (assembly, solver, contact
iteration, results) built from its own arguments; this module adds the static solve and
time stepping: the initial state, Newmark steps and the run loop with its output files.
What a run watches is in :mod:`dd_contact.monitors`, what it checkpoints in
:mod:`dd_contact.checkpointing`, the side solves of a transient start in
:mod:`dd_contact.solvers.auxiliary` and the energy in :mod:`dd_contact.post`.
"""

from __future__ import annotations

import logging
import sys
from collections.abc import Callable
from pathlib import Path

import dolfinx.fem as fem
import numpy as np
from tqdm import tqdm

from dd_contact import timing
from dd_contact.accuracy import check_accuracy, transient_preset
from dd_contact.analysis import Analysis
from dd_contact.arguments import positive_int
from dd_contact.checkpointing import RunState
from dd_contact.errors import InputError
from dd_contact.impact import BlockProducts, Settles, StartForces
from dd_contact.io import RunOutput
from dd_contact.iteration import ContactSettings
from dd_contact.kinematics import Kinematics
from dd_contact.monitors import (
    ENERGY_GROWTH_TOLERANCE,
    MIN_CONTACT_STEPS,
    ContactEpisodes,
    ContactResolution,
    EnergyBalance,
)
from dd_contact.parallel import (
    any_rank,
    collective,
    counted,
    gathered,
    sum_over_ranks,
)
from dd_contact.post import energy, frictional
from dd_contact.readout import AnalysisReadout
from dd_contact.scene import Scene
from dd_contact.solvers.auxiliary import solve_mass, surfaces_in_equilibrium
from dd_contact.solvers.petsc_options import OPTIONS_PREFIX
from dd_contact.solvers.reduced_model import (
    defer_fields,
    defer_rates,
    start_states,
    wall_inertia,
)
from dd_contact.stopping import StopRequests, raise_stopped
from dd_contact.timestepping import time_scheme

__all__ = ["ENERGY_GROWTH_TOLERANCE", "MIN_CONTACT_STEPS", "StaticProblem", "TransientProblem"]

logger = logging.getLogger(__name__)


class StaticProblem(AnalysisReadout):
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
            ``LinearProblem``: ``{"mat_mumps_icntl_14": 50}`` (read under
            ``petsc_options_prefix`` while this problem builds and uses its factorisations;
            docs/solvers.md).
        petsc_options_prefix: The PETSc options prefix of this problem's factorisations
            (default ``dd_contact_``): give two problems of one script their own to tune
            them apart, e.g. ``-bracket_mat_mumps_icntl_14 50`` on the command line.
        accuracy: ``"fast"``, ``"balanced"`` (default) or ``"reference"``: sets nothing
            here (:mod:`dd_contact.accuracy`).

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
        petsc_options_prefix: str = OPTIONS_PREFIX,
        accuracy: str = "balanced",
    ):
        scene.check_static_supports()
        self.accuracy = check_accuracy(accuracy, "StaticProblem")
        #: The scene assembled, its solver and contact iteration.
        self.analysis = Analysis(
            scene,
            algorithm,
            contact=contact,
            condensation=condensation,
            expected=(1, expected_changes),
            rates=rates,
            options=petsc_options,
            options_prefix=petsc_options_prefix,
        )
        #: Contact iterations of the last solve.
        self.iterations = 0
        #: How each solve's contacts are carried: a warning if by too few points.
        self.resolution = ContactResolution()

    def solve(self, t: float = 0.0) -> list[fem.Function]:
        """Collective: solve at load time ``t``.

        Returns the subdomain, interface and contact displacements (the scene's Functions);
        :attr:`results`, :meth:`contact_forces`, :attr:`reactions` and :attr:`changes`
        then hold this solve's results on every rank.
        """
        with counted(self.traffic):
            return self._solve_at(t)

    def _solve_at(self, t: float) -> list[fem.Function]:
        self._check_open()
        analysis = self.analysis
        self.iteration.start(t)
        loads, supports = analysis.loads(t)
        x, self.iterations, _ = analysis.solve(t, analysis.rhs(t, loads), f"t = {t}")
        analysis.publish(x)
        record = {"t": t, "iterations": self.iterations}
        record.update(analysis.agree(x, loads, {}, supports))
        self.resolution.solved(record, analysis.agreed.carrying)
        analysis.agreed.latest = record
        return analysis.functions()


def _check_scene_for(scene: Scene, inertia: bool) -> None:
    """A density for every subdomain with inertia; supports for every body without."""
    if inertia:
        massless = [s.name for s in scene.subdomains if s.material.rho <= 0]
        if massless:
            raise InputError(
                f"TransientProblem: subdomain(s) {massless} have no density; give "
                "Material(rho=...) or use inertia=False for quasi-static steps"
            )
    else:
        scene.check_static_supports()


class TransientProblem(AnalysisReadout):
    """Time stepping with contact: the trapezoidal rule, generalized-alpha, or quasi-static.

    The initial state is read from the scene: ``Subdomain.u`` (displacement) and
    ``Subdomain.velocity``; the initial acceleration follows from equilibrium at ``t0``.

    Args:
        scene: What is modelled.
        dt: Time step (fixed: the subdomain matrices are factorised once for it); ``None``
            takes the named ``accuracy`` preset's.
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
            ``LinearProblem``: ``{"mat_mumps_icntl_14": 50}`` (read under
            ``petsc_options_prefix`` while this problem builds and uses its factorisations;
            docs/solvers.md).
        petsc_options_prefix: The PETSc options prefix of this problem's factorisations
            (default ``dd_contact_``): give two problems of one script their own to tune
            them apart, e.g. ``-bracket_mat_mumps_icntl_14 50`` on the command line.
        energy_safe_contact: Contact that never creates energy (:mod:`dd_contact.impact`,
            the default): massless contact walls, and a point leaving contact keeps the
            discrete-gradient share of its start force (docs/validation.md measures what it
            changes). ``False``: the classic trapezoidal contact (the paper's; it creates
            energy when points leave contact, which is reported).
        mass: ``"consistent"`` (default, or the preset's), ``"lumped"`` (row sums; degree 2:
            scaled to the total mass) or ``"averaged"`` (half each: least overshoot).
        scheme: ``"trapezoidal"`` (the default: no numerical damping, energy conserved) or
            ``"generalized-alpha"`` (damps the modes short against dt; second order).
        rho_infinity: generalized-alpha's spectral radius for dt / period -> infinity, in
            [0, 1] (default 0.8; 1 is the trapezoidal rule, 0 damps the most).
        accuracy: ``"fast"``, ``"balanced"`` or ``"reference"``: sets ``dt`` (in wave times
            of the contacts) and ``mass`` where not given; ``None``: "balanced"'s mass.
    """

    def __init__(
        self,
        scene: Scene,
        dt: float | None = None,
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
        petsc_options_prefix: str = OPTIONS_PREFIX,
        energy_safe_contact: bool = True,
        mass: str | None = None,
        scheme: str = "trapezoidal",
        rho_infinity: float | None = None,
        accuracy: str | None = None,
    ):
        dt, mass = transient_preset(scene, accuracy, dt, mass, inertia)
        self.accuracy = accuracy
        #: The mass matrix's kind.
        self.mass_kind = mass
        #: The time-integration scheme (coefficients and updates).
        self.time_scheme = time_scheme(scheme, dt, rho_infinity)
        self.scheme = scheme
        self.energy_safe = bool(energy_safe_contact)
        self.inertia = inertia
        _check_scene_for(scene, inertia)
        changes = expected_steps if expected_changes is None else expected_changes
        #: The scene assembled, its solver and contact iteration.
        self.analysis = Analysis(
            scene,
            algorithm,
            mass_coefficient=self.time_scheme.mass_coefficient if inertia else 0.0,
            mass_kind=mass,
            massless_walls=self.energy_safe,
            contact=contact,
            condensation=condensation,
            expected=(expected_steps, changes),
            rates=rates,
            options=petsc_options,
            options_prefix=petsc_options_prefix,
        )
        self.track_energy = track_energy
        #: ``K x`` by block rows, shared by the energy and the next step's start forces (it
        #: keeps a copy of x: without the energy there is nothing to share)
        owned = [sub.block for sub in self.analysis.owned]
        self._products = BlockProducts(self.model.system, owned) if track_energy else None
        self._settles = Settles()  # the release settles' fixed parts, from step to step
        self.dt, self.t0 = dt, t0
        self.t, self.step = t0, 0
        self.history: list[dict] = []
        self._previous_loads: tuple[float | None, dict] = (None, {})  # (t, r(t)) of a step
        #: The energy balance each step is held to (with inertia and ``track_energy``).
        self.energy_balance = EnergyBalance(
            self.comm, self.time_scheme.conserves_energy, self.energy_safe, scene.contacts, dt
        )
        #: The contact episodes (with inertia): a warning if one is too short.
        self.episodes = ContactEpisodes(dt)
        #: How the contacts are carried at their peaks: a warning if by too few points.
        self.resolution = ContactResolution()
        self._run_state = RunState(self.analysis.owned, self.zones, self.iteration, scene.interface)
        #: Every subdomain's velocity and acceleration, stepped alike on every rank.
        self.kinematics = Kinematics(
            self.comm,
            scene.subdomains,
            {s.block: scene.owner(k) for k, s in enumerate(scene.subdomains)},
            self.model.mass if inertia else {},
            self.time_scheme,
            self.analysis.reduced_states,
            self.model.massless_reduced,
        )
        self._run_state.kinematics = self.kinematics
        self._started = False

    # -- state ---------------------------------------------------------------------------
    def start(self) -> None:
        """Collective: check the initial data, settle the surfaces, take the acceleration."""
        if not self._started:
            with counted(self.traffic):
                self._start()

    def _start(self) -> None:
        owned = self.analysis.owned

        def check_initial_data():
            for sub in owned:
                for f in (sub.u, sub.velocity):
                    if not np.all(np.isfinite(f.x.array)):
                        raise InputError(
                            f"subdomain {sub.name!r} initial {f.name} contains NaN "
                            "or inf; check the data interpolated into it"
                        )

        collective(self.comm, check_initial_data)
        for sub in owned:
            if sub.block not in self.analysis.reduced:  # a reduced one: quasi-static only
                sub.velocity.x.array[self.analysis.free(sub.block) == 0] = 0.0
        start_states(self.analysis.reduced, owned, self.analysis.reduced_states)
        self.iteration.start(self.t0)
        if self.inertia and self.track_energy:
            self.energy_balance.start(self._energy())
        if self.inertia:
            with self.analysis.petsc_options():
                self._initial_acceleration()
            self.kinematics.share(with_displacement=bool(self.analysis.reduced_states))
            self.kinematics.start_walls()
        self._started = True

    def _initial_acceleration(self) -> None:
        """M u''(t0) = r(t0) - K u(t0) - tie forces (massless surfaces in equilibrium)."""
        owned, system = self.analysis.owned, self.model.system
        loads = self.analysis.loads(self.t0)[0]
        now = self.kinematics.now
        u0 = {sub.block: now(sub)[0].copy() for sub in owned}
        moved = any_rank(self.comm, any(np.any(u != 0) for u in u0.values()))
        x0 = {s.block: now(s)[0].copy() for s in self.scene.subdomains}
        if moved:
            x0.update(surfaces_in_equilibrium(self.comm, system, u0, self.work))
            self.analysis.publish_surfaces(x0)
        residual = {}
        for sub in owned:
            r = loads[sub.block] - system.row_product(sub.block, x0)
            residual[sub.block] = r * self.analysis.free(sub.block)
        for sub in owned:
            if not np.any(residual[sub.block]):
                now(sub)[2][:] = 0.0
                continue
            # M with the prescribed dofs eliminated, as in the effective matrix.
            mass = self.model.mass[sub.block]  # a = 0 on prescribed and massless dofs
            fixed = np.flatnonzero((self.analysis.free(sub.block) == 0) | (mass.diagonal() == 0))
            now(sub)[2][:] = solve_mass(mass, fixed, residual[sub.block], self.work, sub.name)
            logger.debug("initial acceleration of subdomain %r from its mass matrix", sub.name)

    def energy(self) -> dict[str, float]:
        """Collective: kinetic, elastic (with ties) and contact-penalty energy now [J]."""
        with counted(self.traffic):
            return self._energy()

    def _energy(self) -> dict[str, float]:
        velocities = {sub.block: self.kinematics.now(sub)[1] for sub in self.analysis.owned}
        state = self.analysis.state_now()
        local = energy(self.model, state, velocities, self.zones, self._products)
        # with friction, also the step's frictional dissipation (the balance takes it out)
        names = ["kinetic", "elastic", "contact"] + ["dissipated"] * frictional(self.scene)
        parts = np.array(sum_over_ranks(self.comm, np.array([local[n] for n in names])))
        return {**dict(zip(names, parts, strict=True)), "total": float(parts[:3].sum())}

    # -- stepping -----------------------------------------------------------------------
    def _inertia_loads(self, loads: dict, previous: dict) -> StartForces:
        """Turn ``loads`` (r_n+1) into the scheme's right-hand side in equilibrium form.

        ``r_n+1 + w (r_n - K x_n) + M h`` per owned subdomain (:mod:`dd_contact.impact`);
        returns the start forces, whose release the contact iteration may ask for.
        """
        scheme, owned = self.time_scheme, self.analysis.owned
        start = StartForces(
            self.model.system,
            self.zones,
            self.analysis.state_now(),
            self.iteration.active,
            [sub.block for sub in owned],
            self.tie_solver.rhs_offset,
            self.analysis.free,
            scheme.start_weight,
            self._products,
            end_loads=dict(loads),
            end_offset=lambda: self.tie_solver.rhs_offset,
            time=self.t,
            inertia=wall_inertia(self.model, self.analysis.reduced, owned, self.kinematics, scheme),
            settles=self._settles,
        )
        for sub in owned:
            block = sub.block
            # summed in this order, in one new array
            rhs = np.subtract(previous[block], start.internal[block])
            rhs *= scheme.start_weight
            rhs += loads[block]
            rhs += self.model.mass[block] @ scheme.history(*self.kinematics.now(sub))
            loads[block] = rhs
        return start

    def advance(self) -> dict:
        """Collective: one time step; returns its record (also appended to :attr:`history`).

        The record (also :attr:`results`, the same on every rank): ``step``, ``t``,
        ``iterations``, ``changes`` (contact state changes in this step), and per contact
        region ``force`` [N], ``active`` (points) and ``contact_area`` [m^2], per subdomain
        ``reaction`` [N] (its supports), and ``energy`` [J] (dynamics, ``track_energy``).
        """
        with counted(self.traffic):
            return self._advance()

    def _advance(self) -> dict:
        self._check_open()
        if not self._started:
            self._start()
        analysis, owned = self.analysis, self.analysis.owned
        t_new = self.t + self.dt
        if self.inertia and self._previous_loads[0] != self.t:  # the last step's: r(t_n)
            self._previous_loads = (self.t, analysis.loads(self.t)[0])
        loads, supports = analysis.loads(t_new)
        external = dict(loads)
        where = f"step {self.step + 1} (t = {t_new:.6g})"
        release = None
        if self.inertia:
            previous = self._previous_loads[1]
            if self.track_energy:  # for the energy balance of the step
                before = {s.block: self.kinematics.now(s)[0].copy() for s in owned}
            start = self._inertia_loads(loads, previous)
            release = start if self.energy_safe else None
        x, iterations, changes = analysis.solve(t_new, analysis.rhs(t_new, loads), where, release)
        if release is not None and changes:  # what its owner settled, on every rank
            x = analysis.owners_blocks(x, release.settled_blocks)
        if self.inertia:
            self.kinematics.step(x)
        analysis.publish(x)
        if self.inertia:  # the others' u arrived with the publication: update them alike
            self.kinematics.follow()
            defer_rates(self.scene.subdomains, analysis.reduced, self.kinematics)
        self.t, self.step = t_new, self.step + 1
        self._previous_loads = (t_new, external)
        accelerations = {s.block: self.kinematics.now(s)[2] for s in owned if self.inertia}
        record = {"step": self.step, "t": t_new, "iterations": iterations, "changes": changes}
        record.update(analysis.agree(x, external, accelerations, supports))
        if self.inertia and self.track_energy:
            energy_before = self.history[-1].get("energy") if self.history else None
            record["energy"] = self._energy()
            free, active = analysis.free, self.iteration.active
            self.energy_balance.check(
                record,
                lambda: self.energy_balance.loads_work(before, x, previous, external, free),
                lambda: start.obstacle_work(active, analysis.state_now(), self.energy_safe),
            )
        else:
            energy_before = None
        if self.inertia:
            self.episodes.observe(record, energy_before)
        self.resolution.observe(record, analysis.agreed.carrying)
        analysis.agreed.latest = record
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
        final: bool = True,
    ) -> list[dict]:
        """Collective: advance up to step number ``n_steps``, writing results as it goes.

        ``n_steps`` is the step to reach, counted from t0, not a number of new steps: after
        ``run(10)``, ``run(20)`` takes 10 more, and a second ``run(10)`` raises
        :class:`InputError`. With ``resume=True`` the run continues from the checkpoint in
        ``output`` (if there is one) to the same ``n_steps``; a checkpoint already at
        ``n_steps`` leaves nothing to do and returns its history.

        Args:
            n_steps: Last step number of the run (>= 1).
            output: Directory (created if missing) for the fields (XDMF and HDF5, a file per
                written step), ``history.json``, ``history.csv`` and checkpoints; see
                ``docs/output.md`` (and :func:`dd_contact.load_results` to read them back).
            output_every: Write the fields every this many steps (>= 1).
            checkpoint_every: Save a checkpoint every this many steps (needs ``output``).
            resume: Continue from the checkpoint in ``output`` if there is one.
            progress: Show a progress bar (default: when stderr is a terminal, on rank 0).
            callback: Called with each step's record after the step.
            summary: Print the work per block (:meth:`work_table`) at the end, on rank 0.
            final: Whether this call ends the run: a contact still open at its end is
                judged at its largest force so far (:class:`CoarseContactWarning`). Pass
                ``False`` to a call that a later one continues (``run(k)`` in a loop): an
                impact's first steps carry it on a point or two, and its contacts are
                judged when they close.

        Returns:
            The history: one record per step (time, iterations, contact state changes,
            active points, contact area and force per region, support reactions, energy).
        """
        with counted(self.traffic):
            history = self._run(
                n_steps, output, output_every, checkpoint_every, resume, progress, callback
            )
            if final:
                self.resolution.finish()
            if summary:
                self._print_summary()
            return history

    def _run(
        self, n_steps, output, output_every, checkpoint_every, resume, progress, callback
    ) -> list[dict]:
        positive_int(n_steps, "run: n_steps")
        positive_int(output_every, "run: output_every")
        if checkpoint_every is not None:
            positive_int(checkpoint_every, "run: checkpoint_every")
            if output is None:
                raise InputError("run: checkpoint_every needs an output directory (output=...)")
        files = RunOutput(self.scene, output, self.inertia) if output is not None else None
        self._resume_or_refuse(n_steps, files if resume else None, output)
        if not self._started:
            self._start()
        if files is not None:
            files.open(self.step, self.t, self.history)
        show = progress if progress is not None else sys.stderr.isatty()
        bar = None
        if show and self.comm.rank == 0 and self.step < n_steps:
            bar = tqdm(total=n_steps, initial=self.step, unit="step", file=sys.stderr)
        stopped = None
        try:
            with StopRequests() as stop:
                while self.step < n_steps and stopped is None:
                    record = self._advance()
                    if files is not None:
                        files.record(
                            record, self.history, self._state, output_every, checkpoint_every
                        )
                    if bar is not None:
                        bar.update(1)
                        bar.set_postfix(t=f"{self.t:.4g}", changes=self.iteration.gamma)
                    if callback is not None:
                        callback(record)
                    stopped = stop.requested(self.comm)
            if stopped is not None and files is not None:
                files.save(self._state(), self.history)
        except BaseException as error:
            if files is not None:
                files.close(self.history, error)
            raise
        finally:
            if bar is not None:
                bar.close()
        if files is not None:
            files.close(self.history)
        if stopped is not None:
            raise_stopped(self.comm, stopped, self.step, self.t, output)
        return self.history

    def _resume_or_refuse(self, n_steps: int, files: RunOutput | None, output) -> None:
        """Collective: restore the checkpoint in ``files``, if any; refuse a run past n_steps."""
        restored = files is not None and files.checkpoint.exists()
        if restored:
            assert files is not None  # restored from its checkpoint
            self._restore(*files.restore())
        if self.step >= n_steps and not (restored and self.step == n_steps):
            where = f"the checkpoint in {str(output)!r} is" if restored else "the problem is"
            raise InputError(
                f"run(n_steps={n_steps}): {where} already at step {self.step}; n_steps is the "
                f"step number to reach (counted from t0), not a number of new steps: call "
                f"run({self.step + n_steps}) for {n_steps} more"
            )

    def _print_summary(self) -> None:
        """Collective: the work per block (and auto's choice) on stdout, on rank 0."""
        table = self.work_table()
        report = []
        if self.choice is not None:
            report.append(f"algorithm='auto' chose {self.algorithm}:\n{self.choice.table()}")
        report.append(
            f"{self.algorithm}: {self.step} steps, {self.iteration.gamma} contact "
            f"state changes\n{table}"
        )
        if self.comm.rank == 0:
            print("\n".join(report))

    def _state(self) -> dict[str, np.ndarray]:  # a checkpoint's
        self.analysis.solver.rebase()  # a resumed run continues from the same factors
        return self._run_state.arrays(self.step, self.t, self.dt, self._integration())

    def _integration(self) -> str:
        """The settings a resumed run must share with its checkpoint (besides dt)."""
        rho = getattr(self.time_scheme, "rho_infinity", 1.0)
        return (
            f"inertia={self.inertia}, scheme={self.scheme!r}, rho_infinity={rho}, "
            f"mass={self.mass_kind!r}, energy_safe_contact={self.energy_safe}"
        )

    def _restore(self, state: dict[str, np.ndarray], history: list[dict]) -> None:
        """Collective: the state of a checkpoint, and the history up to its step."""
        self.step, self.t = self._run_state.restore(state, self.dt, self._integration())
        self.history = [r for r in history if r["step"] <= self.step]
        agreed = self.analysis.agreed
        agreed.latest = self.history[-1] if self.history else {}
        agreed.alpha = gathered(self.comm, self.iteration.alpha)
        self.kinematics.share(with_displacement=True)
        defer_fields(self.scene.subdomains, self.analysis.reduced, self.kinematics)
        self._started = True
