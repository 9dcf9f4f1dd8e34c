"""Reduced subdomains (Subdomain.reduce): Craig-Bampton bases, exactness and refusals."""

from __future__ import annotations

import warnings

from mpi4py import MPI

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp

import dd_contact as dd
from dd_contact import meshes
from dd_contact.assembly import assemble
from dd_contact.errors import InputError
from dd_contact.paper.examples import parallelepiped
from dd_contact.solvers.linalg import SparseCholesky
from dd_contact.solvers.reduced import ReducedBasis, _petsc, fixed_interface_modes
from dd_contact.solvers.subdomains import coupling_layout
from dd_contact.solvers.worklog import WorkLog

STEEL = dd.Material(2.0e11, 0.3, 7800.0)
L, W = 1.0, 0.1


def _at(axis, value):
    return lambda x: np.isclose(x[axis], value)


def _cantilever(nx=10, parts=1):
    """A steel beam fixed at x = 0, in ``parts`` tied pieces, its tip on a contact interface.

    A shear traction on its top pushes the tip onto a plane 1 um beyond it.
    """
    edges = np.linspace(0.0, L, parts + 1)
    subs = []
    for k in range(parts):
        mesh = meshes.box(MPI.COMM_SELF, [edges[k], 0, 0], [edges[k + 1], W, W], [nx, 2, 2])
        subs.append(dd.Subdomain(mesh, STEEL, f"part{k}"))
    subs[0].fix(_at(0, 0.0))
    subs[-1].add_traction(_at(2, W), lambda t: [2.0e6 * t, 0.0, 0.0])
    tip = meshes.surface_from_boundary(subs[-1].mesh, _at(0, L))
    wall = dd.Plane([L + 1e-6, 0, 0], [-1.0, 0, 0])
    contact = dd.ContactInterface(tip, subs[-1], wall, kappa=1e3, contact_kappa=1e3, name="tip")
    interface = None
    if parts > 1:
        cut = meshes.surface_from_boundary(subs[0].mesh, _at(0, edges[1]))
        interface = dd.Interface(cut, subs, kappa=1e3)
    return dd.Scene(MPI.COMM_WORLD, subs, interface=interface, contacts=[contact])


def _basis(scene, modes, sub=0, patterns=()):
    model = assemble(scene)
    block = scene.subdomains[sub].block
    A = sp.csr_array(model.system.block(block, block))
    _, C = coupling_layout(block, model.system)
    dofs = model.dirichlet[block][0]
    M = model.mass[block]
    basis = ReducedBasis(A, M, np.unique(C.tocoo().row), dofs, patterns, modes, WorkLog(), "b")
    return basis, A, M, dofs


def test_static_response_is_exact_with_load_modes():
    scene = _cantilever(nx=8)
    rng = np.random.default_rng(1)
    n = scene.subdomains[0].num_dofs
    pattern = rng.standard_normal(n)
    basis, A, _, dofs = _basis(scene, 3, patterns=[pattern])
    free = np.setdiff1d(np.arange(n), dofs)
    f = 0.3 * pattern
    f[basis.b] += rng.standard_normal(basis.b.size)  # boundary forces: the constraint modes
    f[dofs] = 0.0
    u = np.zeros(n)
    u[free] = sp.linalg.spsolve(sp.csc_array(A[free][:, free]), f[free])
    q = np.linalg.solve(basis.A_r, basis.project_load(f))
    assert np.linalg.norm(basis.expand(q) - u) <= 1e-10 * np.linalg.norm(u)
    # the coordinates of a field in the span are recovered exactly
    assert np.linalg.norm(basis.coordinates(u) - q) <= 1e-9 * np.linalg.norm(q)
    basis.destroy()


def test_cantilever_eigenfrequencies_match_slepc_on_the_full_matrices():
    scene = _cantilever(nx=10)
    basis, A, M, dofs = _basis(scene, 160)
    free = np.setdiff1d(np.arange(A.shape[0]), dofs)
    log = WorkLog()
    Mf = _petsc(sp.csr_array(M[free][:, free]))
    full = SparseCholesky(_petsc(sp.csr_array(A[free][:, free])), log, "full")
    omega2, _ = fixed_interface_modes(full, Mf, 20, 1e-13, "full")
    # the reduced model's 20 lowest, from its inverse pencil (accurate at the low end)
    mu = sla.eigh(basis.M_r, basis.A_r, eigvals_only=True)[::-1][:20]
    error = np.abs(np.sqrt(omega2 * mu) - 1.0)
    assert error.max() < 1e-6
    # and a few modes carry the first ones only coarsely: the trade the modes buy
    few, *_ = _basis(scene, 40)
    mu_few = sla.eigh(few.M_r, few.A_r, eigvals_only=True)[::-1][:20]
    assert 1e-5 < np.abs(np.sqrt(omega2 * mu_few) - 1.0).max() < 1e-2
    for thing in (full, basis, few):
        thing.destroy()
    Mf.destroy()


def _static(parts, algorithm, reduce):
    scene = _cantilever(nx=6, parts=parts)
    for sub, modes in zip(scene.subdomains, reduce, strict=False):
        if modes is not None:
            sub.reduce(modes=modes)
    with dd.StaticProblem(scene, algorithm) as problem:
        problem.solve(1.0)
        u = np.concatenate([s.u.x.array.copy() for s in scene.subdomains])
        force = np.array(problem.results["force"]["tip"])
        work = problem.analysis.work
    return u, force, work


@pytest.mark.parametrize(
    ("parts", "algorithm", "reduce"),
    [(1, "w-u", [0]), (1, "w-u", [6]), (2, "w-v-u", [None, 4]), (2, "w-v-u", [3, 0])],
)
def test_quasi_static_reduced_equals_unreduced(parts, algorithm, reduce):
    u, force, _ = _static(parts, algorithm, [None] * parts)
    u_r, force_r, work = _static(parts, algorithm, reduce)
    assert np.linalg.norm(force) > 0  # the tip is pressed on the wall
    assert np.linalg.norm(u_r - u) <= 1e-8 * np.linalg.norm(u)
    assert np.linalg.norm(force_r - force) <= 1e-8 * np.linalg.norm(force)
    # the reduced subdomain is expanded once, when u was read
    expansions = [r for r in work.records if r.what == "expansion"]
    assert len(expansions) == sum(m is not None for m in reduce)


def test_expansion_waits_for_a_read():
    scene = _cantilever(nx=6)
    scene.subdomains[0].reduce(modes=2)
    problem = dd.TransientProblem(scene, 0.25, "w-u", inertia=False)
    try:
        history = problem.run(4, progress=False, summary=False)
        work = problem.analysis.work
        # four quasi-static steps, no full field: nothing expanded
        assert sum(r.what == "expansion" for r in work.records) == 0
        u = scene.subdomains[0].u.x.array.copy()
        scene.subdomains[0].u.x.array.copy()
        assert sum(r.what == "expansion" for r in work.records) == 1
    finally:
        problem.close()
    # the same steps unreduced: the same contact forces and end field
    scene = _cantilever(nx=6)
    whole = dd.TransientProblem(scene, 0.25, "w-u", inertia=False)
    try:
        expected = whole.run(4, progress=False, summary=False)
    finally:
        whole.close()
    for got, want in zip(history, expected, strict=True):
        f, g = np.array(got["force"]["tip"]), np.array(want["force"]["tip"])
        assert np.linalg.norm(f - g) <= 1e-8 * np.linalg.norm(g)
    ref = scene.subdomains[0].u.x.array
    assert np.linalg.norm(u - ref) <= 1e-8 * np.linalg.norm(ref)


def test_reduced_subdomains_refuse_what_is_not_built():
    with pytest.raises(NotImplementedError, match="w-u or w-v-u"):
        scene = _cantilever(nx=4)
        scene.subdomains[0].reduce(modes=2)
        dd.StaticProblem(scene, "FULL")
    scene = _cantilever(nx=4)
    scene.subdomains[0].reduce(modes=2)
    problem = dd.TransientProblem(scene, 1e-5, "w-u")
    with pytest.raises(NotImplementedError, match="checkpoints"):
        problem.run(2, output="unused", checkpoint_every=1, progress=False)
    problem.close()
    for bad in (-1, 2.5, True):
        with pytest.raises(InputError, match="modes"):
            _cantilever(nx=4).subdomains[0].reduce(modes=bad)
    with pytest.raises(InputError, match="interior dofs"):
        _basis(_cantilever(nx=2), 10_000)


def _interior(scene) -> list[int]:
    """Interior dofs of each subdomain (free, not tied): a complete basis has this many."""
    model = assemble(scene)
    out = []
    for sub in scene.subdomains:
        _, C = coupling_layout(sub.block, model.system)
        tied = np.unique(C.tocoo().row)
        out.append(sub.num_dofs - len(np.union1d(tied, model.dirichlet[sub.block][0])))
    return out


def _impact(algorithm, modes, steps=30, scheme="trapezoidal"):
    """The bar of the benchmarks striking its wall (no load), reduced or not.

    ``modes``: per subdomain (``None``: unreduced).
    """
    scene = parallelepiped(algorithm, (12, 3, 3), pressure=0.0, contact_kappa=1.0)
    if modes is not None:
        for sub, m in zip(scene.subdomains, modes(scene), strict=True):
            sub.reduce(modes=m)
    problem = dd.TransientProblem(scene, 4e-7, algorithm, scheme=scheme)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", dd.CoarseTimeStepWarning)
            history = problem.run(steps, progress=False, summary=False)
        u = np.concatenate([s.u.x.array.copy() for s in scene.subdomains])
        v = np.concatenate([s.velocity.x.array.copy() for s in scene.subdomains])
    finally:
        problem.close()
    force = np.array([r["force"]["end"][0] for r in history])
    energy = np.array([r["energy"]["total"] for r in history])
    return force, energy, u, v


@pytest.mark.parametrize("algorithm", ["w-u", "w-v-u"])
def test_impact_in_reduced_coordinates_converges_to_the_unreduced_run(algorithm):
    force, _, u, v = _impact(algorithm, None)
    assert force.max() > 0  # the bar strikes the wall
    errors = []
    for modes in (
        lambda scene: [10] * len(scene.subdomains),
        lambda scene: [n - 1 for n in _interior(scene)],
    ):
        f, e, u_r, v_r = _impact(algorithm, modes)
        errors.append(np.abs(f - force).max() / np.abs(force).max())
        # energy-safe contact: the energy never grows (no load), reduced or not
        assert e.max() <= e[0] * (1 + 1e-9)
    assert 1e-4 < errors[0] < 0.5  # ten modes: the wave is carried coarsely
    assert errors[1] < 1e-5  # every mode but one, and the load modes: the unreduced run
    assert np.linalg.norm(u_r - u) <= 1e-5 * np.linalg.norm(u)
    # velocity = 2 (u_n+1 - u_n) / dt - u'_n carries the displacements' round-off amplified
    assert np.linalg.norm(v_r - v) <= 1e-4 * np.linalg.norm(v)


def test_generalized_alpha_in_reduced_coordinates():
    force, energy, u, _ = _impact("w-u", None, 20, "generalized-alpha")
    f, e, u_r, _ = _impact("w-u", lambda s: [n - 1 for n in _interior(s)], 20, "generalized-alpha")
    assert np.abs(f - force).max() <= 1e-5 * np.abs(force).max()
    assert np.linalg.norm(u_r - u) <= 1e-5 * np.linalg.norm(u)
    assert np.abs(e - energy).max() <= 1e-6 * energy[0]
