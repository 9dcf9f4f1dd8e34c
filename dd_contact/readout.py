"""What both problems answer, read from the analysis they hold.

:class:`AnalysisReadout` is the part of the public API that :class:`~dd_contact.problem.
StaticProblem` and :class:`~dd_contact.problem.TransientProblem` share: the last solve's
results, contact forces, reactions, penalties, contact state changes, the work done and the
predicted time, and ``close()``. Everything it answers is the analysis's
(:class:`dd_contact.analysis.Analysis`), agreed on every rank where it says so.
"""

from __future__ import annotations

from typing import Self

import numpy as np

from dd_contact import timing
from dd_contact.analysis import Analysis
from dd_contact.parallel import counted

__all__ = ["AnalysisReadout"]


class _FromAnalysis:
    """A problem's read-only view of an attribute of its analysis (documented there)."""

    def __set_name__(self, owner, name: str) -> None:
        self.name = name
        self.__doc__ = f"The analysis's ``{name}`` (:class:`dd_contact.analysis.Analysis`)."

    def __get__(self, problem, owner=None):
        if problem is None:
            return self
        return getattr(problem.analysis, self.name)


class AnalysisReadout:
    """The public API both problems share, read from the analysis they hold (:attr:`analysis`)."""

    analysis: Analysis
    scene = _FromAnalysis()
    comm = _FromAnalysis()
    model = _FromAnalysis()
    zones = _FromAnalysis()
    solver = _FromAnalysis()
    tie_solver = _FromAnalysis()
    iteration = _FromAnalysis()
    work = _FromAnalysis()
    algorithm = _FromAnalysis()
    condensation = _FromAnalysis()
    settings = _FromAnalysis()
    choice = _FromAnalysis()
    traffic = _FromAnalysis()

    @property
    def results(self) -> dict:
        """The last solve's results, the same on every rank (rank-local; empty before).

        ``force`` (contact force per region), ``active`` (active points), ``contact_area``
        and ``reaction`` (support reaction per subdomain); see ``docs/output.md``.
        """
        return self.analysis.agreed.latest

    def contact_forces(self) -> dict[str, np.ndarray]:
        """Total force of each obstacle on the body at the last solve [N], per region.

        A contact pair's is the force its side ``b`` exerts on its side ``a``.

        Rank-local: every rank holds every region's force (agreed at the end of each
        solve); zero before the first solve.
        """
        return self.analysis.agreed.vectors("force", [c.name for c in self.scene.regions])

    @property
    def reactions(self) -> dict[str, np.ndarray]:
        """Support reaction of each subdomain at the last solve [N] (rank-local).

        The total force its Dirichlet conditions exert on it; zero without supports or
        before the first solve.
        """
        names = [s.name for s in self.scene.subdomains]
        return self.analysis.agreed.vectors("reaction", names)

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
        return dict(self.analysis.agreed.penalties)

    @property
    def changes(self) -> dict[str, int]:
        """Contact state changes so far: ``"gamma"`` (whole model) and one count per contact.

        Rank-local: the counts are agreed at the end of each solve.
        """
        return {"gamma": self.iteration.gamma, **self.analysis.agreed.alpha}

    def predict(
        self, steps: float, changes: float, rates: timing.MachineRates | None = None
    ) -> timing.Prediction:
        """Collective: this problem's predicted linear-algebra time (``Analysis.predict``).

        Set-up, one step, one contact change, and the total for ``steps`` steps with
        ``changes`` contact state changes, in seconds on this machine.
        """
        return self.analysis.predict(steps, changes, rates)

    def work_summary(self) -> dict[str, dict]:
        """Work per block so far, from all ranks (collective).

        Matrix kind and size, decompositions, substitutions (right-hand sides, as the paper
        counts them), seconds and GFLOPs; see :meth:`dd_contact.solvers.WorkLog.per_block`.
        """
        with counted(self.traffic):
            return self.work.merged(self.comm).per_block()

    def work_table(self) -> str:
        """:meth:`work_summary` as a text table (collective)."""
        with counted(self.traffic):
            return self.work.merged(self.comm).table()

    def _check_open(self) -> None:
        """Refuse to solve after :meth:`close`."""
        if self.analysis.closed:
            raise RuntimeError(
                f"this {type(self).__name__} was closed (its factorisations are freed); "
                "create a new problem to solve again"
            )

    def close(self) -> None:
        """Free the solver's PETSc factorisations and matrices (collective; idempotent).

        The results stay in the scene's Functions, the history and the work log; the problem
        cannot solve any more. ``with StaticProblem(scene) as problem:`` closes on leaving.
        """
        self.analysis.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
