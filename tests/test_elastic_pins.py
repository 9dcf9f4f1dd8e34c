"""The multi-pin joint with elastic pins (models.pin_joint(pins="elastic"), issue 27).

The pin mesh puts its surface nodes at the hole wall's angles, the scene has a subdomain
per pin and a contact pair per hole wall, and as the pins' Young's modulus grows the joint
tends to the rigid-pin one (coarse mesh; benchmarks/elastic_pin_limit.py has finer ones).
"""

import dataclasses

from mpi4py import MPI

import numpy as np
import pytest

import dd_contact as dc
from dd_contact.paper import models
from dd_contact.paper.models.elastic_pins import pin_mesh, towards_rigid

COARSE = (3, 2, 1, 4)  # cells per quarter hole, radial, layers, grip: as the demo tests


def _layout():
    names = list(models.PIN_JOINT_SCALES["small"])
    return dataclasses.replace(models.pin_joint_layout("small"), **dict(zip(names, COARSE)))


def test_the_pins_surface_nodes_lie_on_its_circle_at_the_hole_walls_angles():
    n, layers, radius = 3, 2, 0.01
    mesh = pin_mesh(MPI.COMM_SELF, (0.1, 0.2), radius, 0.02, n, layers)
    x = mesh.geometry.x
    r = np.hypot(x[:, 0] - 0.1, x[:, 1] - 0.2)
    rim = np.isclose(r, radius, rtol=1e-9)
    assert rim.sum() == 4 * n * (layers + 1)
    angles = np.arctan2(x[rim, 1] - 0.2, x[rim, 0] - 0.1) / (2 * np.pi / (4 * n)) - 0.5
    # at the wall's phase (half a cell), to gmsh's arc parametrisation (6e-9 of a cell)
    assert np.abs(angles - np.round(angles)).max() < 1e-7
    assert mesh.topology.index_map(3).size_local == (n * n + 4 * n * n) * layers


def test_the_elastic_pin_joint_has_a_pin_subdomain_and_a_pair_per_hole_wall():
    scene = models.pin_joint(_layout(), clearance=0.0, pins="elastic", comm=MPI.COMM_SELF)
    names = [s.name for s in scene.subdomains]
    assert names[-5:] == [f"pin{k}" for k in range(5)] and len(names) == 17
    assert len(scene.pairs) == 10
    assert all(
        p.a.name.startswith("hole_") and p.b.subdomain.name.startswith("pin") for p in scene.pairs
    )
    with pytest.raises(dc.InputError, match="pins='soft' is not one of"):
        models.pin_joint(_layout(), pins="soft")


def test_stiffer_elastic_pins_tend_to_the_rigid_pins():
    r = towards_rigid(_layout(), comm=MPI.COMM_SELF)
    u = [row["u_difference"] for row in r["rows"]]  # E_pin x1, x10, x100: +1.28, -0.60, -0.79 %
    # the elastic joint converges as 1 / E_pin: each tenfold step closes ~10x less
    assert abs(u[2] - u[1]) < 0.15 * abs(u[1] - u[0])
    # what is left is two contact discretisations' difference on this coarse mesh
    assert abs(u[2]) < 0.01
    assert max(row["force_difference"] for row in r["rows"]) < 0.006  # 0.19-0.48 %
    assert sum(r["rigid_forces"]) == pytest.approx(20e3, rel=1e-3)  # the load at its peak
