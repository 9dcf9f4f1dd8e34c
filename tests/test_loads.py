"""Loads assembled as seldom as their time dependence allows (forms.SubdomainLoad).

A cached or scaled load must equal the load assembled afresh at the same time (1e-14 of
its size), and a general load of Subdomain.time must still be assembled at every time.
"""

from mpi4py import MPI

import dolfinx.fem as fem
import numpy as np
import pytest
import ufl

import dd_contact as dd
from dd_contact import forms, meshes
from dd_contact.errors import InputError

TIMES = [0.0, 0.3, 1.7, 2.5]


def _block():
    return dd.Subdomain(
        meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 0.5], [4, 3, 2]),
        dd.Material(210e9, 0.3, 7850.0),
        "block",
    )


def _top(x):
    return np.isclose(x[2], 0.5)


def _side(x):
    return np.isclose(x[0], 1.0)


def _field(sub):
    x = ufl.SpatialCoordinate(sub.mesh)
    return ufl.as_vector((x[1] * x[2], 1.0 + x[0], -(x[0] ** 2)))


def _check_equal(sub, load, times=TIMES):
    """The load of ``load`` equals the one assembled afresh at every time in ``times``."""
    for t in times:
        sub.set_time(t)
        fresh = forms.assemble_load(sub)
        cached = load()
        scale = max(np.abs(fresh).max(), 1e-300)
        assert np.abs(cached - fresh).max() <= 1e-14 * scale, t


def test_constant_load_is_assembled_once_and_equals_a_fresh_one():
    sub = _block()
    sub.set_body_force(_field(sub))  # UFL, no time: assembled once
    sub.add_traction(_top, (0.0, 2e5, -1e6))  # a 3-vector: its three unit loads
    load = forms.SubdomainLoad(sub)
    assert load.assemblies == 1 + 3
    assert not load.constant  # the 3-vector is read at every call (a Constant may change)
    _check_equal(sub, load)
    assert load.assemblies == 4  # none since

    alone = _block()
    alone.set_body_force(_field(alone))
    only_ufl = forms.SubdomainLoad(alone)
    assert only_ufl.constant and only_ufl.assemblies == 1
    _check_equal(alone, only_ufl)
    assert only_ufl() is only_ufl()  # the cached array itself
    assert only_ufl.assemblies == 1


def test_separable_loads_are_assembled_once_and_scaled():
    sub = _block()
    sub.add_traction(_top, lambda t: [0.0, 1e4 * t, -1e6 * min(t, 1.0)])  # callable 3-vector
    sub.add_traction(_side, _field(sub), amplitude=lambda t: np.sin(3.0 * t))
    sub.set_body_force(sub.time * _field(sub))  # time times a field
    load = forms.SubdomainLoad(sub)
    assert load.assemblies == 3 + 1 + 1
    _check_equal(sub, load)
    assert load.assemblies == 5


def test_general_time_dependent_load_is_assembled_at_every_time():
    sub = _block()
    sub.add_traction(_top, ufl.sin(sub.time) * _field(sub))  # not a Constant times a field
    sub.set_body_force(ufl.as_vector((0.0, 0.0, -sub.time * sub.time)))
    load = forms.SubdomainLoad(sub)
    assert load.assemblies == 0
    _check_equal(sub, load)
    assert load.assemblies == 2 * len(TIMES)


def test_a_field_that_uses_time_is_not_cached_under_an_amplitude():
    sub = _block()
    x = ufl.SpatialCoordinate(sub.mesh)
    sub.add_traction(_top, ufl.as_vector((sub.time * x[0], 0.0, 1.0)), amplitude=lambda t: 2 - t)
    load = forms.SubdomainLoad(sub)
    assert load.assemblies == 0
    _check_equal(sub, load)
    assert load.assemblies == len(TIMES)


def test_problem_assembles_a_general_load_once_per_solve(monkeypatch):
    sub = _block()
    sub.fix(lambda x: np.isclose(x[2], 0.0))
    sub.add_traction(_top, ufl.as_vector((0.0, 0.0, -1e6 * ufl.cos(sub.time))))
    calls = []
    assemble = fem.assemble_vector
    monkeypatch.setattr(fem, "assemble_vector", lambda *a: calls.append(1) or assemble(*a))
    with dd.StaticProblem(dd.Scene(MPI.COMM_WORLD, [sub])) as problem:
        before = len(calls)
        for t in (0.5, 1.0, 1.5):
            problem.solve(t)
        assert len(calls) - before == 3
        sub.set_time(1.5)
        expected = forms.assemble_load(sub)
    # the solution carries the load of the last time: its reaction balances it
    assert problem.reactions["block"][2] == pytest.approx(-expected.sum(), rel=1e-9)


def test_amplitude_must_be_a_callable_of_a_number():
    sub = _block()
    with pytest.raises(InputError, match=r"'block' traction: amplitude must be a callable"):
        sub.add_traction(_top, (0.0, 0.0, 1.0), amplitude=2.0)
    with pytest.raises(InputError, match=r"'block' body force amplitude .* returned nan at t = 0"):
        sub.set_body_force((0.0, 0.0, 1.0), amplitude=lambda t: float("nan"))


def test_a_cached_load_follows_the_users_function_and_constant():
    """A load cached as time-free is assembled again when the user's data in it changes."""
    sub = _block()
    pressure = fem.Function(fem.functionspace(sub.mesh, ("Lagrange", 1)))
    pressure.x.array[:] = 1e5
    factor = fem.Constant(sub.mesh, 2.0)
    n = ufl.FacetNormal(sub.mesh)
    sub.add_traction(_top, -pressure * n)  # a time-free field: cached
    x = ufl.SpatialCoordinate(sub.mesh)
    sub.set_body_force(ufl.as_vector((0.0, factor * x[0], 0.0)), amplitude=lambda t: 1.0 + t)
    load = forms.SubdomainLoad(sub)
    assert load.assemblies == 2
    _check_equal(sub, load, [0.0, 0.5])
    assert load.assemblies == 2  # nothing changed: nothing assembled
    pressure.x.array[:] = np.linspace(0.0, 3e5, len(pressure.x.array))
    factor.value = -7.0
    _check_equal(sub, load, [0.5, 1.0])
    assert load.assemblies == 4  # each cached term once more, then cached again
