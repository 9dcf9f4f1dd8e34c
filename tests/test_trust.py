"""No silent wrong answer: every solve checks its residual; touching starts; penalty range."""

from __future__ import annotations

import warnings

from mpi4py import MPI

import dolfinx.fem as fem
import numpy as np
import pytest
import ufl

import dd_contact as dd
from dd_contact import assembly, meshes
from dd_contact.solvers.residual import FREE_ROW_TOLERANCE, ResidualCheck, exact_residual

STEEL = dd.Material(E=210e9, nu=0.3)


def _on(axis, value):
    return lambda x: np.isclose(x[axis], value)


def _plate_on_wall(clearance: float, kind: str = "interface", z0: float = 0.0):
    """A plate pulled onto a rigid wall, held in the pull direction by contact only."""
    plate = dd.Subdomain(
        meshes.box(MPI.COMM_SELF, [0, 0, z0], [0.1, 0.05, z0 + 0.01], [8, 4, 2]), STEEL, "plate"
    )
    plate.fix(_on(1, 0.0), components=[1]).fix(_on(2, z0), components=[2])
    plate.add_traction(_on(0, 0.1), (-2500 / (0.05 * 0.01), 0, 0))  # 2.5 kN towards the wall
    wall = dd.Plane([-clearance, 0, 0], [1, 0, 0])
    if kind == "interface":
        zone = dd.ContactInterface.from_boundary(plate, _on(0, 0.0), wall)
    else:
        zone = dd.ContactBoundary(plate, _on(0, 0.0), wall)
    return dd.Scene(MPI.COMM_SELF, [plate], contacts=[zone])


def _exact_residual(problem) -> tuple[float, float]:
    """|b - A x| / |b| of the last solve, over all rows and over the free rows."""
    rhs, contact = problem.iteration.solved_system(problem.tie_solver)
    exact = exact_residual(problem.solver.system, rhs, problem.solver.finish(), contact)
    return exact.whole, exact.free


@pytest.mark.parametrize("algorithm", ["FULL", "w-u"])
def test_the_estimated_residual_is_the_residual(algorithm):
    scene = _plate_on_wall(0.0)
    problem = dd.StaticProblem(scene, algorithm=algorithm)
    problem.solve()
    whole, free = _exact_residual(problem)
    estimate = problem.iteration.residual
    # A sound solve: round-off only. Three Gaussian probes: within a factor 10 (chi-square).
    assert estimate.whole < 1e-6 and estimate.free < 1e-12
    assert 0.1 < estimate.whole / whole < 10 and 0.1 < estimate.free / free < 10
    assert problem.contact_forces()["contact"][0] == pytest.approx(2500.0, rel=1e-6)


@pytest.mark.parametrize("algorithm", ["FULL", "w-u"])
def test_a_body_held_only_by_contact_with_a_clearance_is_refused(algorithm):
    # Before: FULL returned a contact force of 0 for 2.5 kN applied, with no error, and
    # the orders either failed in a dense Cholesky or, by luck of round-off, converged.
    problem = dd.TransientProblem(_plate_on_wall(1e-5), 1.0, algorithm=algorithm, inertia=False)
    with pytest.raises(dd.SingularMatrixError, match="held only by contact") as caught:
        problem.run(1, progress=False, summary=False)
    assert "1 free rigid motion: translation x" in str(caught.value)
    assert "0 active contact point(s) resist only 0" in str(caught.value)
    assert problem.work.count("sparse_factor") == 0  # refused before any solve


def test_the_check_sees_a_wrong_solution():
    problem = dd.StaticProblem(_plate_on_wall(0.0), algorithm="FULL")
    problem.solve()
    rhs, contact = problem.iteration.solved_system(problem.tie_solver)
    x = {b: v.copy() for b, v in problem.solver.finish().items()}
    x["u:plate"] += 1e-6 * np.random.default_rng(1).standard_normal(len(x["u:plate"]))
    estimate = problem.iteration.check.estimate(rhs, x, contact)
    exact = exact_residual(problem.solver.system, rhs, x, contact)
    assert estimate.free > 1e3 * FREE_ROW_TOLERANCE and estimate.whole > 1.0
    assert 0.1 < estimate.free / exact.free < 10 and 0.1 < estimate.whole / exact.whole < 10


@pytest.mark.parametrize("kind", ["interface", "boundary"])
def test_a_touching_start_holds_the_body_from_the_first_solve(kind):
    # The face lies a round-off distance (1e-15 m) off the wall: a touching start, so the
    # body is held from the first solve (before: no point started active).
    scene = _plate_on_wall(-1e-15, kind)
    problem = dd.StaticProblem(scene, algorithm="FULL")
    problem.solve()
    assert problem.contact_forces()["contact"][0] == pytest.approx(2500.0, rel=1e-6)
    assert problem.iteration.residual.free < FREE_ROW_TOLERANCE


def test_the_touching_tolerance_is_a_setting():
    settings = dd.ContactSettings(touching_tolerance=0.0)  # the sign of the gap decides
    problem = dd.StaticProblem(_plate_on_wall(1e-9), algorithm="FULL", contact=settings)
    with pytest.raises(dd.SingularMatrixError, match="held only by contact"):
        problem.solve()  # 1 nm apart: no point touches
    relaxed = dd.ContactSettings(touching_tolerance=1e-8)
    problem = dd.StaticProblem(_plate_on_wall(1e-9), algorithm="FULL", contact=relaxed)
    problem.solve()
    assert problem.contact_forces()["contact"][0] == pytest.approx(2500.0, rel=1e-6)


@pytest.mark.parametrize("name", ["touching_tolerance", "residual_tolerance"])
def test_tolerances_must_not_be_negative(name):
    with pytest.raises(ValueError, match=name):
        dd.ContactSettings(**{name: -1.0})


def _tied_bar(kappa: float) -> dd.Scene:
    left = dd.Subdomain(meshes.box(MPI.COMM_SELF, [0, 0, 0], [5, 1, 1], [10, 2, 2]), STEEL, "left")
    right = dd.Subdomain(
        meshes.box(MPI.COMM_SELF, [5, 0, 0], [10, 1, 1], [7, 3, 3]), STEEL, "right"
    )
    left.fix(_on(0, 0.0))
    right.add_traction(_on(0, 10.0), (0.0, 0.0, -1e5))
    interface = dd.Interface.from_boundary(
        left, _on(0, 5.0), [left, right], resolution=(5, 5), cell_type="triangle", kappa=kappa
    )
    return dd.Scene(MPI.COMM_SELF, [left, right], interface)


def test_round_off_of_a_too_stiff_penalty_is_an_error_not_a_wrong_answer(monkeypatch):
    # Without the split of stiff ties (KAPPA_SPLIT out of reach), kappa 1e14 loses the
    # answer to round-off: before, the tip deflection came out 4x too small with no error.
    monkeypatch.setattr(assembly, "KAPPA_SPLIT", np.inf)
    problem = dd.StaticProblem(_tied_bar(1e14))
    with pytest.raises(dd.InaccurateSolutionError, match="too stiff for double precision"):
        problem.solve()
    assert problem.iteration.residual.whole > 1.0


def test_a_penalty_above_the_verified_range_warns():
    with pytest.warns(dd.PenaltyRangeWarning, match="outside the verified range"):
        dd.StaticProblem(_tied_bar(10 * dd.KAPPA_VERIFIED[1]))


def test_a_penalty_in_the_verified_range_neither_warns_nor_fails():
    with warnings.catch_warnings():
        warnings.simplefilter("error", dd.PenaltyRangeWarning)
        problem = dd.StaticProblem(_tied_bar(dd.DEFAULT_KAPPA))
    problem.solve()
    whole, _ = _exact_residual(problem)
    assert problem.iteration.residual.whole < 1e-5 and whole < 1e-5


def test_the_check_can_be_switched_off(monkeypatch):
    monkeypatch.setattr(assembly, "KAPPA_SPLIT", np.inf)
    settings = dd.ContactSettings(residual_tolerance=None)
    problem = dd.StaticProblem(_tied_bar(1e14), contact=settings)
    problem.solve()  # the user's choice: no check, no error
    assert problem.iteration.residual is None


@pytest.mark.mpi
def test_the_probes_are_the_same_on_every_rank():
    comm = MPI.COMM_WORLD
    problem = dd.StaticProblem(_tied_bar(1e4))
    check = ResidualCheck(comm, problem.solver.system)
    for block in problem.solver.system.sizes:
        probe = check.probe(block)
        assert probe.shape == (problem.solver.system.sizes[block], 3)
        assert all(np.array_equal(probe, other) for other in comm.allgather(probe))


def _hemisphere_on_plane(gap: float):
    """A 50 mm steel ball held along z only by the plane, pressed by 1 MPa on its flat face."""
    R = 0.05
    mesh, tags = meshes.hemisphere(MPI.COMM_SELF, R, 0.2 * R, 0.05 * R, 0.2 * R)
    ball = dd.Subdomain(mesh, STEEL, "ball")
    ball.fix((tags, meshes.HEMISPHERE_SYMMETRY_X), components=[0])
    ball.fix((tags, meshes.HEMISPHERE_SYMMETRY_Y), components=[1])
    ball.add_traction((tags, meshes.HEMISPHERE_TOP), (0.0, 0.0, -1.0e6))
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=tags)
    force = 1.0e6 * fem.assemble_scalar(fem.form(1.0 * ds(meshes.HEMISPHERE_TOP)))
    plane = dd.Plane([0, 0, -gap], [0, 0, 1])  # the pole is a node at the origin
    cap = dd.ContactBoundary(ball, (tags, meshes.HEMISPHERE_CURVED), plane)
    return dd.Scene(MPI.COMM_SELF, [ball], contacts=[cap]), force


@pytest.mark.parametrize("gap", [0.0, 1e-15])
def test_a_hemisphere_whose_pole_touches_carries_a_prescribed_force(gap):
    # Before: with the pole's computed gap at +6e-22 no point started active, the first solve
    # was singular and returned u_z = +7.6e10 m and a contact force of 0, with no error.
    scene, force = _hemisphere_on_plane(gap)
    problem = dd.StaticProblem(scene)
    problem.solve()
    assert problem.contact_forces()["contact"][2] == pytest.approx(force, rel=1e-6)
    assert problem.iteration.residual.free < FREE_ROW_TOLERANCE
    if gap > 0:  # the sign test alone leaves the ball free: now an error, not F = 0
        scene, _ = _hemisphere_on_plane(gap)
        signed = dd.ContactSettings(touching_tolerance=0.0)
        with pytest.raises(dd.SingularMatrixError, match="held only by contact"):
            dd.StaticProblem(scene, contact=signed).solve()


def _block_on_pin(resolution):
    """A block pressed onto a rigid pin through a contact interface on its bottom face."""
    block = dd.Subdomain(
        meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 0.25, 0.5], [24, 6, 12]),
        dd.Material(1.0, 0.3),
        "block",
    )
    block.fix(_on(2, 0.5), value=[0, 0, -2e-3])
    block.fix(_on(1, 0.0), components=[1]).fix(_on(1, 0.25), components=[1])
    pin = dd.Cylinder([0.5, 0, -2.0], [0, 1, 0], 2.0)
    zone = dd.ContactInterface.from_boundary(block, _on(2, 0.0), pin, resolution=resolution)
    problem = dd.StaticProblem(dd.Scene(MPI.COMM_SELF, [block], contacts=[zone]))
    problem.solve()
    force = problem.contact_forces()["contact"][2]
    problem.close()
    return force


def test_a_contact_interface_that_is_not_a_facet_copy_carries_the_facet_copy_force():
    # Before: the penalty tie locked the wall to what the contact mesh can represent, and
    # these meshes carried 2.9-3.6x the force of the facet copy; the projected tie
    # (P1 = P2 P4^-1 P2^T) measured +1.5 % and -3.0 %: the discretisation of the contact.
    reference = _block_on_pin(None)
    assert _block_on_pin((24, 3)) == pytest.approx(reference, rel=1e-12)  # a facet copy too
    with warnings.catch_warnings():
        warnings.simplefilter("error", dd.SurfaceResolutionWarning)
        for resolution in ((37, 5), (17, 3)):
            assert _block_on_pin(resolution) == pytest.approx(reference, rel=0.05), resolution
    # 48 cells along the pin's curvature on the wall's 24: the surface over-constrains the
    # wall (force +5.6 %, nodal peak +45 %), and that is reported.
    with pytest.warns(dd.SurfaceResolutionWarning, match="'contact'"):
        assert _block_on_pin((48, 6)) == pytest.approx(reference, rel=0.1)
