"""Verification cases with closed-form or independent references (``dd-contact verify``).

Each case returns records ``{case, quantity, value, reference, rel_error, tolerance, passed}``.
The scene builders are public so tests, demos and benchmarks use the same models.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass

from mpi4py import MPI

import numpy as np

from dd_contact import meshes
from dd_contact.post import boundary_average, cell_stress
from dd_contact.problem import StaticProblem
from dd_contact.scene import Interface, Material, Scene, Subdomain

__all__ = ["CASES", "Record", "bent_bar", "patch_test", "run_cases"]


@dataclass
class Record:
    """One verified quantity."""

    case: str
    quantity: str
    value: float
    reference: float
    rel_error: float
    tolerance: float
    passed: bool


def _record(case: str, quantity: str, value: float, reference: float, tol: float) -> Record:
    rel = abs(value - reference) / abs(reference)
    return Record(case, quantity, float(value), float(reference), float(rel), tol, bool(rel <= tol))


def _on(axis: int, coordinate: float) -> Callable[[np.ndarray], np.ndarray]:
    return lambda x: np.isclose(x[axis], coordinate)


# -- tied patch test -----------------------------------------------------------------------
def patch_test(
    kappa: float = 1e6,
    surface_cell: str = "quadrilateral",
    volume_cell: str = "hexahedron",
    comm: MPI.Comm = MPI.COMM_WORLD,
    traction: float = 1.0e6,
) -> float:
    """Two non-matching boxes tied through a third mesh under uniaxial tension.

    Omega1 = [0,1]^3 (3x5x5 cells) and Omega2 = [1,2]x[0,1]^2 (4x7x3 cells), tied through a
    4x6 interface on x = 1; symmetry planes x=0, y=0, z=0; traction on x = 2. The exact
    stress is uniform sigma_xx = traction, all other components zero.

    Returns:
        The largest deviation of any stress component in any cell, relative to the traction.
    """
    steel = Material(E=210e9, nu=0.3)
    left = Subdomain(
        meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [3, 5, 5], volume_cell), steel, "left"
    )
    right = Subdomain(
        meshes.box(MPI.COMM_SELF, [1, 0, 0], [2, 1, 1], [4, 7, 3], volume_cell), steel, "right"
    )
    for axis in range(3):
        for sub in (left, right):
            if not (sub is right and axis == 0):
                sub.fix(_on(axis, 0.0), components=[axis])
    right.add_traction(_on(0, 2.0), (traction, 0.0, 0.0))
    interface = Interface.from_boundary(
        left, _on(0, 1.0), [left, right], resolution=(4, 6), cell_type=surface_cell, kappa=kappa
    )
    scene = Scene(comm, [left, right], interface)
    StaticProblem(scene).solve()
    exact = np.zeros((3, 3))
    exact[0, 0] = traction
    return max(float(np.abs(cell_stress(s) - exact).max()) / traction for s in (left, right))


# -- bent bar against one conforming mesh --------------------------------------------------
BAR = {"length": 10.0, "width": 1.0, "height": 1.0, "E": 1.0e3, "nu": 0.3, "force": 1.0e-2}


def _bar_subdomain(x0: float, x1: float, cells: tuple[int, int, int], name: str) -> Subdomain:
    return Subdomain(
        meshes.box(MPI.COMM_SELF, [x0, 0.0, 0.0], [x1, BAR["width"], BAR["height"]], cells),
        Material(BAR["E"], BAR["nu"]),
        name,
    )


def _load_bar(clamped: Subdomain, tip: Subdomain) -> None:
    clamped.fix(_on(0, 0.0))
    area = BAR["width"] * BAR["height"]
    tip.add_traction(_on(0, BAR["length"]), (0.0, 0.0, -BAR["force"] / area))


def bent_bar(
    refinement: int = 1,
    kappa: float = 1e6,
    matching: bool = True,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> tuple[float, float]:
    """A cantilever (10 x 1 x 1, clamped at x = 0, shear load at the tip), cut at x = 5.

    The tied model has two halves tied through an interface mesh: with ``matching`` the
    halves and the interface have the single mesh's cells (the difference is then the
    penalty's alone); otherwise the right half and the interface use other resolutions.

    Returns:
        Tip deflection (mean u_z over the tip face) of the tied model and of one conforming
        mesh with the left half's resolution.
    """
    r = refinement
    L = BAR["length"]
    single = _bar_subdomain(0.0, L, (10 * r, 2 * r, 2 * r), "bar")
    _load_bar(single, single)
    StaticProblem(Scene(comm, [single])).solve()
    reference = boundary_average(single, _on(0, L))[2]

    left = _bar_subdomain(0.0, L / 2, (5 * r, 2 * r, 2 * r), "left")
    right_cells = (5 * r, 2 * r, 2 * r) if matching else (4 * r, 3 * r, 3 * r)
    right = _bar_subdomain(L / 2, L, right_cells, "right")
    _load_bar(left, right)
    interface = Interface.from_boundary(
        left,
        _on(0, L / 2),
        [left, right],
        resolution=(2 * r, 2 * r) if matching else (3 * r, 4 * r),
        cell_type="quadrilateral" if matching else "triangle",
        kappa=kappa,
    )
    StaticProblem(Scene(comm, [left, right], interface)).solve()
    return float(boundary_average(right, _on(0, L))[2]), float(reference)


# -- cases ---------------------------------------------------------------------------------
def _case_patch(name: str, surface_cell: str, volume_cell: str) -> Callable[[], list[Record]]:
    def run() -> list[Record]:
        error = patch_test(1e6, surface_cell, volume_cell)
        # value: the worst stress relative to the traction; reference: the exact 1.
        return [_record(name, "1 + max |sigma - sigma_exact| / t", 1.0 + error, 1.0, 1e-6)]

    return run


def _case_bent_bar() -> list[Record]:
    records = []
    for kappa in (1e4, 1e6):
        tied, single = bent_bar(1, kappa, matching=True)
        # The tie adds a compliance of order 1/kappa (measured: 0.22/kappa for this bar).
        quantity = f"tip deflection, kappa={kappa:g}"
        records.append(_record("bent-bar", quantity, tied, single, 1.0 / kappa))
    tied, single = bent_bar(1, 1e6, matching=False)
    records.append(_record("bent-bar", "tip deflection, non-matching", tied, single, 0.05))
    return records


CASES: dict[str, Callable[[], list[Record]]] = {
    "patch-hex-quad": _case_patch("patch-hex-quad", "quadrilateral", "hexahedron"),
    "patch-hex-tri": _case_patch("patch-hex-tri", "triangle", "hexahedron"),
    "patch-tet-tri": _case_patch("patch-tet-tri", "triangle", "tetrahedron"),
    "bent-bar": _case_bent_bar,
}


def run_cases(names: list[str] | None = None) -> list[dict]:
    """Run the named cases (default all) and return their records as dicts."""
    names = list(CASES) if not names else names
    unknown = [n for n in names if n not in CASES]
    if unknown:
        raise ValueError(f"unknown case(s) {unknown}; valid: {', '.join(CASES)}")
    return [asdict(r) for name in names for r in CASES[name]()]
