import pytest


def pytest_configure(config):
    config.addinivalue_line("markers", "mpi: also run under mpiexec -n 2")


@pytest.fixture(autouse=True)
def _offscreen(monkeypatch):
    monkeypatch.setenv("PYVISTA_OFF_SCREEN", "true")
