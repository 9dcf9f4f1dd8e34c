from mpi4py import MPI

import numpy as np
import pytest

import dd_contact as dd
from dd_contact import meshes


def pytest_configure(config):
    config.addinivalue_line("markers", "mpi: also run under mpiexec -n 2")


@pytest.fixture(autouse=True)
def _offscreen(monkeypatch):
    monkeypatch.setenv("PYVISTA_OFF_SCREEN", "true")


@pytest.fixture
def falling_bar():
    """Factory of a bar flying at a wall 0.002 away (contact from about step 2 to step 22).

    ``falling_bar(**options)`` gives ``(bar, problem)``; options go to TransientProblem.
    """

    def make(**options):
        bar = dd.Subdomain(
            meshes.box(MPI.COMM_SELF, [0.002, 0, 0], [1.002, 0.1, 0.1], [10, 1, 1]),
            dd.Material(1.0, 0.0, 1.0),
            "bar",
        )
        bar.velocity.interpolate(
            lambda x: np.vstack([np.full(x.shape[1], -0.01), 0 * x[0], 0 * x[0]])
        )
        end = dd.ContactBoundary(
            bar,
            lambda x: np.isclose(x[0], 0.002),
            dd.Plane([0, 0, 0], [1, 0, 0]),
            contact_kappa=1.0,
        )
        scene = dd.Scene(MPI.COMM_WORLD, [bar], contacts=[end])
        return bar, dd.TransientProblem(scene, dt=0.1, **options)

    return make
