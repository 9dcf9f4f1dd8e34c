"""User-facing problems: set up from a scene, solve, results as dolfinx Functions."""

from __future__ import annotations

import dolfinx.fem as fem

from dd_contact.assembly import assemble_static
from dd_contact.scene import InputError, Scene
from dd_contact.solvers import MonolithicSystem, WorkLog

__all__ = ["ALGORITHMS", "StaticProblem"]

#: Elimination orders (method.md section 5). Only FULL is available so far.
ALGORITHMS = ("FULL",)


class StaticProblem:
    """Static linear elasticity of a decomposed scene, the static form of system (14).

    Args:
        scene: What is modelled.
        algorithm: Elimination order; ``"FULL"`` solves the block system as one matrix.

    Example:
        >>> problem = StaticProblem(scene)
        >>> u_left, u_right, v = problem.solve()
    """

    def __init__(self, scene: Scene, algorithm: str = "FULL"):
        if algorithm not in ALGORITHMS:
            raise InputError(
                f"StaticProblem: unknown algorithm {algorithm!r}; valid: {', '.join(ALGORITHMS)}"
            )
        scene.check_static_supports()
        self.scene = scene
        self.algorithm = algorithm
        self.work = WorkLog()
        self._system = assemble_static(scene)

    @property
    def penalties(self) -> dict[tuple[str, str], float]:
        """Absolute penalty eps of every tie (subdomain, surface), from all ranks."""
        merged: dict[tuple[str, str], float] = {}
        for part in self.scene.comm.allgather(self._system.penalties):
            merged.update(part)
        return merged

    def solve(self) -> list[fem.Function]:
        """Solve; returns the subdomain displacements, then the interface displacement."""
        monolithic = MonolithicSystem(self.scene.comm, self._system)
        solution = monolithic.solve(self.work)
        monolithic.destroy()
        functions = []
        for sub in self.scene.subdomains:
            sub.u.x.array[:] = solution[f"u:{sub.name}"]
            functions.append(sub.u)
        if self.scene.interface is not None:
            iface = self.scene.interface
            iface.v.x.array[:] = solution[f"v:{iface.name}"]
            functions.append(iface.v)
        return functions
