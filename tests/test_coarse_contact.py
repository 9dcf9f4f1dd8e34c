"""A contact carried by too few points is not silent (CoarseContactWarning)."""

from __future__ import annotations

import warnings

from mpi4py import MPI

import dolfinx.mesh
import numpy as np
import pytest

import dd_contact as dd
from dd_contact import meshes
from dd_contact.monitors import MIN_CONTACT_POINTS, ContactResolution

APPROACH = 0.03  # the Hertz press of docs/contact.md: a = sqrt(R approach) = 0.173 R


def _press(h: float, comm=MPI.COMM_SELF, points: str = "nodes") -> dd.StaticProblem:
    """A quarter hemisphere (R = 1) pressed by APPROACH on a plane, mesh size h at its pole."""
    mesh, tags = meshes.hemisphere(MPI.COMM_SELF, 1.0, max(0.2, h), h, max(0.2, h))
    ball = dd.Subdomain(mesh, dd.Material(1.0, 0.3), "ball")
    ball.fix((tags, meshes.HEMISPHERE_TOP), components=[2], value=[0, 0, -APPROACH])
    ball.fix((tags, meshes.HEMISPHERE_SYMMETRY_X), components=[0])
    ball.fix((tags, meshes.HEMISPHERE_SYMMETRY_Y), components=[1])
    cap = ball.locate_facets((tags, meshes.HEMISPHERE_CURVED))
    mid = mesh.geometry.x[dolfinx.mesh.entities_to_geometry(mesh, 2, cap)].mean(axis=1)
    near = cap[mid[:, 2] < 0.1 + 2 * h]
    plane = dd.Plane([0, 0, 0], [0, 0, 1])
    zone = dd.ContactBoundary(ball, near, plane, points=points, name="cap")
    return dd.StaticProblem(dd.Scene(comm, [ball], contacts=[zone]))


@pytest.mark.mpi
def test_a_press_on_one_node_warns_on_every_rank_and_names_the_fix():
    # a / h = 0.75: the pole node alone carries the press (the force 25 % off the converged
    # press's, the contact radius 31 %: benchmarks/results/coarse_contact.json)
    problem = _press(0.23, MPI.COMM_WORLD)
    with pytest.warns(dd.CoarseContactWarning, match=r"carried by 1\.0 nodes' worth") as caught:
        problem.solve()
    assert problem.results["active"]["cap"] == 1
    message = str(caught[0].message)
    assert "'cap'" in message and "refine the body's mesh and the contact surface" in message
    assert caught[0].filename == __file__  # the user's line
    with warnings.catch_warnings():  # once per region
        warnings.simplefilter("error", dd.CoarseContactWarning)
        problem.solve()
    problem.close()


def test_a_press_resolved_by_a_third_of_its_radius_is_quiet():
    # a / h = 3: 15 nodes carry it (11.5 nodes' worth), force and radius within 3 %
    with warnings.catch_warnings():
        warnings.simplefilter("error", dd.CoarseContactWarning)
        problem = _press(0.173 / 3)
        problem.solve()
    assert problem.results["active"]["cap"] == 15
    problem.close()


def _step(monitor, step, force, active, carrying, whole=False):
    record = {
        "step": step,
        "t": 1e-3 * step,
        "force": {"c": [0, 0, force]},
        "active": {"c": active},
    }
    monitor.observe(record, {"c": (carrying, whole)})


def test_an_episode_is_judged_at_its_peak_when_it_closes():
    monitor = ContactResolution()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        # an impact landing on one point, its peak carried by 20 nodes' worth: quiet
        for step, (force, points) in enumerate([(1.0, 1), (50.0, 6), (400.0, 20), (90.0, 7)]):
            _step(monitor, step + 1, force, points, float(points))
        _step(monitor, 5, 0.0, 0, 0.0)
        # a flat face pressed whole on 4 nodes: nothing for the mesh to resolve
        _step(monitor, 6, 300.0, 4, 4.0, whole=True)
        _step(monitor, 7, 0.0, 0, 0.0)
    _step(monitor, 8, 10.0, 1, 1.0)
    _step(monitor, 9, 70.0, 3, MIN_CONTACT_POINTS - 0.5)  # grew 7x on a few points
    with pytest.warns(dd.CoarseContactWarning, match=r"70 N at step 9 .* 7\.5 nodes' worth"):
        _step(monitor, 10, 0.0, 0, 0.0)
    assert monitor.warned == {"c"}
    with warnings.catch_warnings():  # once per region
        warnings.simplefilter("error")
        _step(monitor, 11, 70.0, 1, 1.0)
        _step(monitor, 12, 0.0, 0, 0.0)


def test_a_press_still_growing_at_the_end_of_the_run_is_judged_then():
    monitor = ContactResolution()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for step in range(1, 5):
            _step(monitor, step, 10.0 * step, 2, 2.0)  # open: not judged yet
    with pytest.warns(dd.CoarseContactWarning, match=r"40 N at step 4"):
        monitor.finish()


def test_the_carrying_count_is_the_nodes_count_for_both_contact_schemes():
    # a / h = 3 on one mesh: 15 nodes, or 49 Gauss points, carry the press; counted in the
    # nodes' lumped areas both come to about a dozen nodes' worth
    counts = {}
    for points in ("nodes", "quadrature"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            problem = _press(0.173 / 3, points=points)
            problem.solve()
        counts[points] = problem.analysis.agreed.carrying["cap"][0]
        problem.close()
    assert counts["nodes"] == pytest.approx(11.5, abs=0.5)
    assert counts["quadrature"] == pytest.approx(counts["nodes"], rel=0.3)
    assert np.all(np.array(list(counts.values())) >= MIN_CONTACT_POINTS)


def test_a_graze_between_hits_is_not_judged():
    # the pin joint's plates graze a pin between hits with 0.2-1.3 % of a hit's impulse
    monitor = ContactResolution()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for step in range(1, 61):  # a hit: 60 steps of 100 N on 12 nodes' worth
            _step(monitor, step, 100.0, 12, 12.0)
        _step(monitor, 61, 0.0, 0, 0.0)
        for step in range(70, 75):  # a graze: 5 steps of 100 N (8 % of the hit's impulse)
            _step(monitor, step, 100.0, 3, 2.6)
        _step(monitor, 75, 0.0, 0, 0.0)
    assert monitor.warned == set()
    for step in range(80, 88):  # 8 steps of 100 N: 13 % of the hit's, on 2.6 nodes
        _step(monitor, step, 100.0, 3, 2.6)
    with pytest.warns(dd.CoarseContactWarning, match=r"at step 80 "):
        _step(monitor, 88, 0.0, 0, 0.0)


def _drop_problem() -> dd.TransientProblem:
    """The hemisphere drop at 20 steps a Hertz time, h = 0.05 R at its pole: its impact lands
    on 4 nodes (3.6 nodes' worth) and peaks on 19 (15.6 nodes' worth) at step 12."""
    pytest.importorskip("gmsh")
    from dd_contact.paper.verify.drops import DROP, hemisphere_drop_scene

    mass = DROP["rho"] * 2.0 / 3.0 * np.pi
    e_star = DROP["E"] / (1 - DROP["nu"] ** 2)
    dt = 2.87 * (mass**2 / (e_star**2 * DROP["v0"])) ** 0.2 / 20
    scene = hemisphere_drop_scene(0.05, gap=3 * DROP["v0"] * dt, comm=MPI.COMM_SELF)
    return dd.TransientProblem(scene, dt, "FULL")


def test_a_run_continued_call_by_call_judges_an_impact_at_its_peak():
    problem = _drop_problem()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", dd.CoarseTimeStepWarning)  # 18 steps in contact
        warnings.simplefilter("error", dd.CoarseContactWarning)
        for k in range(1, 25):  # the impact's first calls end on a few points
            problem.run(k, progress=False, summary=False, final=False)
    episode = [r["active"]["cap"] for r in problem.history if r["active"]["cap"]]
    assert episode[0] <= 4 and max(episode) >= 15 and problem.history[-1]["active"]["cap"] == 0
    problem.close()
    # a run that ends there (final, the default) is judged then, and says it was still open
    first = _drop_problem()
    with pytest.warns(dd.CoarseContactWarning, match=r"still in contact when run\(\) returned"):
        first.run(4, progress=False, summary=False)
    first.close()
