"""Reduced subdomains (Subdomain.reduce): Craig-Bampton bases, exactness and refusals."""

from __future__ import annotations

import warnings
from pathlib import Path

from petsc4py import PETSc

import numpy as np
import pytest
import scipy.sparse as sp

import dd_contact as dd
from dd_contact.assembly import assemble
from dd_contact.errors import InputError
from dd_contact.paper import verify
from dd_contact.paper.examples import parallelepiped
from dd_contact.paper.verify.reduced import cantilever, cantilever_basis, full_frequencies_ratio
from dd_contact.solvers import interior
from dd_contact.solvers.reduced_model import tied_dofs
from dd_contact.solvers.subdomains import coupling_layout


def _cantilever(nx=10, parts=1):
    return cantilever(nx, parts)


def _basis(scene, modes, sub=0, patterns=()):
    return cantilever_basis(scene, modes, sub, patterns)


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


def test_the_boundarys_schur_block_gives_the_basis_whole_solves_give(monkeypatch):
    """The reduction by MUMPS's Schur sweeps (SchurInterior) against whole substitutions
    (PlainInterior, taken where those sweeps cannot be driven): the same reduced model."""
    from dd_contact.solvers import interior, reduced

    scene = _cantilever(nx=8)
    n = scene.subdomains[0].num_dofs
    pattern = np.random.default_rng(2).standard_normal(n)
    made = []
    factory = reduced.interior_factor
    monkeypatch.setattr(reduced, "interior_factor", lambda *a: made.append(factory(*a)) or made[-1])
    schur, *_ = _basis(scene, 6, patterns=[pattern])
    monkeypatch.setattr(interior, "layout_known", lambda: False)
    plain, *_ = _basis(scene, 6, patterns=[pattern])
    try:
        assert [type(f).__name__ for f in made] == ["SchurInterior", "PlainInterior"]
        # the modes' basis of a repeated frequency (the square section's bending pairs) is
        # the eigensolver's pick: compared are what does not depend on it
        nb = schur.b.size
        q = np.zeros(schur.size)
        q[:nb] = np.random.default_rng(3).standard_normal(nb)
        v = np.random.default_rng(4).standard_normal(n)
        b = slice(0, nb)
        pairs = [
            (schur.A_r[b, b], plain.A_r[b, b]), (schur.M_r[b, b], plain.M_r[b, b]),
            (schur.G @ schur.G.T, plain.G @ plain.G.T), (schur.omega2, plain.omega2),
            (schur.reaction_rows[:, b], plain.reaction_rows[:, b]),
            (schur.expand(q), plain.expand(q)), (schur.project(v)[b], plain.project(v)[b]),
            (schur.expand(schur.coordinates(v)), plain.expand(plain.coordinates(v))),
        ]  # fmt: skip
        for got, want in pairs:
            assert np.abs(got - want).max() <= 1e-10 * np.abs(want).max()
    finally:
        schur.destroy(), plain.destroy()


def test_the_walls_directions_taken_from_the_reduced_mass_equal_the_solved_ones():
    """``wall_directions`` reads M_r's modes rows; the interior solve gives the same."""
    scene = _cantilever(nx=8)
    pattern = np.random.default_rng(2).standard_normal(scene.subdomains[0].num_dofs)
    basis = _basis(scene, 6, patterns=[pattern])[0]
    wall = basis.b[::3]
    at, read = basis.wall_directions(wall)
    basis._constraints_in_modes = None  # the solve each wall column took before
    at_solved, solved = basis.wall_directions(wall)
    np.testing.assert_array_equal(at, at_solved)
    assert solved[basis.b.size :].any()
    assert np.abs(read - solved).max() <= 1e-12 * np.abs(solved).max()
    basis.destroy()


@pytest.mark.parametrize("modes, tolerance", [(6, 1e-6), (12, 0.5), (0, 1e-6)])
def test_the_modes_krylov_relation_gives_the_mass_products_give(monkeypatch, modes, tolerance):
    """M_r's coupling of modes to constraint modes from the block eigensolver's Krylov
    relation (no product with G per block) equals the products' (SLEPc's modes take them),
    converged modes or not (0.5: Ritz vectors far from converged), and with no modes."""
    from dd_contact.solvers import reduced

    scene = _cantilever(nx=8)
    pattern = np.random.default_rng(2).standard_normal(scene.subdomains[0].num_dofs)

    def basis():
        return cantilever_basis(scene, modes, patterns=[pattern], tolerance=tolerance)[0]

    related = basis()
    modes_of = reduced.ReducedBasis._modes
    monkeypatch.setattr(reduced.ReducedBasis, "_modes", lambda *a: (*modes_of(*a)[:2], None))
    multiplied = basis()
    try:
        assert related.G.shape[1] == modes + 1  # the load mode too
        np.testing.assert_array_equal(related.G, multiplied.G)  # the same basis
        scale = np.abs(multiplied.M_r).max()
        assert np.abs(related.M_r - multiplied.M_r).max() <= 1e-12 * scale
        assert np.abs(related.A_r - multiplied.A_r).max() == 0.0
        assert related._constraints_in_modes is not None
        assert multiplied._constraints_in_modes is not None
        diff = related._constraints_in_modes - multiplied._constraints_in_modes
        assert np.abs(diff).max() <= 1e-12 * np.abs(multiplied._constraints_in_modes).max()
    finally:
        related.destroy(), multiplied.destroy()


def test_a_load_in_the_patterns_span_up_to_its_assemblys_round_off_needs_no_substitution():
    """A re-assembled load differs from its patterns' combination by round-off that grows
    with the mesh (above 1e-12 of it at 342k dofs, where each step then paid a substitution
    of the interior factor): up to LOAD_SPAN_FLOOR it is projected through the patterns."""
    from dd_contact.solvers.reduced import LOAD_SPAN_FLOOR

    scene = _cantilever(nx=8)
    rng = np.random.default_rng(2)
    n = scene.subdomains[0].num_dofs
    pattern = rng.standard_normal(n)
    basis, _, _, dofs = _basis(scene, 3, patterns=[pattern])
    try:
        noise = rng.standard_normal(n)
        noise[dofs] = 0.0
        for fraction, substitutions in ((0.1 * LOAD_SPAN_FLOOR, 0), (10 * LOAD_SPAN_FLOOR, 1)):
            f = 0.7 * pattern
            f += fraction * np.linalg.norm(f) / np.linalg.norm(noise) * noise
            before = len(basis.log.records)
            projected = basis.project_load(f)
            done = [r for r in basis.log.records[before:] if r.what == "projection"]
            assert len(done) == substitutions
            exact = basis.project(f)
            assert np.linalg.norm(projected - exact) <= 2 * fraction * np.linalg.norm(exact)
    finally:
        basis.destroy()


def test_cantilever_eigenfrequencies_match_slepc_on_the_full_matrices():
    # the 20 lowest of the reduced cantilever (m = 20) against SLEPc's on the full matrices
    assert np.abs(full_frequencies_ratio(20)).max() < 1e-6
    # with fewer modes than frequencies asked the rest are missing: far off
    assert np.abs(full_frequencies_ratio(15)).max() > 1.0


def test_verify_cases_of_reduced_subdomains_pass():
    records = verify.run_cases(["reduced-static", "reduced-modes"])
    assert len(records) == 5
    assert all(r["passed"] for r in records), records


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
    [
        (1, "w-u", [0]),
        (1, "w-u", [6]),
        (2, "w-v-u", [None, 4]),
        (2, "w-v-u", [3, 0]),
        (2, "v-w-u", [3, 0]),
    ],
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


def test_quasi_static_reduced_at_the_default_penalty_is_the_unreduced_model():
    """At kappa 1e6 the ties' round-off entries off the tied faces, left out of a reduced
    subdomain's boundary, made it another model: 7.3e-7 of u from the unreduced one (the
    conditioning amplifies 1e-15 of the largest entry). Dropped where the ties are made,
    both solve one model: 1.4e-7, the penalised system's round-off (w-v-u and FULL, both
    unreduced, differ by 2.6e-8 here)."""
    du, df = verify.reduced.static_difference(2, "w-v-u", [3, 0], kappa=1e6)
    assert du <= 3e-7 and df <= 2e-8


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


def test_a_reduced_block_is_held_for_blas_products_and_without_petsc_copies():
    """Its stiffness and mass multiply by BLAS on the basis's arrays (symmetric: one
    triangle), as their CSR would;
    the interior's PETSc copies are gone once the modes are out (the block eigensolver)."""
    from dd_contact.solvers.dense import DenseBacked

    scene = _cantilever(nx=6)
    scene.subdomains[0].reduce(modes=4)
    problem = dd.TransientProblem(scene, 1e-3, "w-u")
    try:
        block = scene.subdomains[0].block
        basis = problem.model.reduced[block]
        stiffness = problem.model.system.matrices[(block, block)]
        mass = problem.model.mass[block]
        x = np.random.default_rng(5).standard_normal(basis.size)
        for matrix, dense in ((stiffness, basis.A_r), (mass, basis.M_r)):
            assert isinstance(matrix, DenseBacked) and matrix._dense is dense
            csr = sp.csr_array(matrix)  # a plain copy: scipy's product
            assert not isinstance(csr, DenseBacked)
            ref = csr @ x
            assert np.abs(matrix @ x - ref).max() <= 1e-13 * np.abs(ref).max()
            assert np.abs(x @ matrix - x @ csr).max() <= 1e-13 * np.abs(ref).max()
            assert matrix._symmetric  # exactly symmetric: dsymv, one triangle read
            for columns in (2, DenseBacked.SYMV_COLUMNS + 2):  # one by one, and by gemm
                X = np.random.default_rng(columns).standard_normal((basis.size, columns))
                want = csr @ X
                assert np.abs(matrix @ X - want).max() <= 1e-13 * np.abs(want).max()
            rows = matrix[[0, 2]]  # a slice is plain CSR: no stale dense array
            assert getattr(rows, "_dense", None) is None
            assert np.abs(rows @ x - ref[[0, 2]]).max() <= 1e-13 * np.abs(ref).max()
        assert basis._M_ii._mat is None and basis.factor._factor._a is None
        problem.advance()
    finally:
        problem.close()


def test_an_interior_factor_out_of_core_gives_the_in_core_run(tmp_path, monkeypatch):
    """reduce(out_of_core=True): MUMPS keeps the interior's factor on disk (ICNTL(22) = 1),
    for that factor alone, and the model, the steps and the expanded field are the same.

    Out of core the constraint modes go a pass's columns at a time (ICNTL(27)), here 5 of
    the boundary's, in core all at once, and the modes' Krylov blocks are 32 columns, not 8:
    omega^2 the same to 1e-12 (measured 9.7e-13), not to round-off. Three modes: the square
    section's bending pair and the next (a fourth would split the next pair, whose basis is
    the eigensolver's pick)."""
    monkeypatch.setenv("MUMPS_OOC_TMPDIR", str(tmp_path))
    monkeypatch.setattr(interior, "OUT_OF_CORE_COLUMNS", 5)
    runs = {}
    for out_of_core in (False, True):
        scene = _cantilever(nx=6)
        scene.subdomains[0].reduce(modes=3, out_of_core=out_of_core)
        problem = dd.TransientProblem(scene, 1e-3, "w-u")
        try:
            basis = problem.model.reduced[scene.subdomains[0].block]
            assert basis.factor._factor.icntl(22) == int(out_of_core)
            passes = (5, 5) if out_of_core else (-32, None)  # MUMPS's default bound, ours
            assert (basis.factor._factor.icntl(27), basis.factor.pass_columns) == passes
            assert basis.b.size > 3 * 5  # several passes out of core
            for _ in range(3):
                problem.advance()
            nb = basis.b.size
            u = scene.subdomains[0].u.x.array.copy()  # expanded: read back from the factor
            runs[out_of_core] = (basis.A_r[:nb, :nb], basis.M_r[:nb, :nb], basis.omega2, u)
        finally:
            problem.close()
    for got, want, tol in zip(runs[True], runs[False], (1e-14, 1e-14, 1e-11, 1e-9), strict=True):
        assert np.abs(got - want).max() <= tol * np.abs(want).max()  # measured 5e-11 for u
    assert not PETSc.Options().hasName("dd_contact_mat_mumps_icntl_22")  # put back
    assert not PETSc.Options().hasName("dd_contact_mat_mumps_icntl_27")
    with pytest.raises(InputError, match=r"out_of_core=\.\.\.\) takes True or False"):
        _cantilever(nx=4).subdomains[0].reduce(modes=2, out_of_core="yes")


def test_reduced_subdomains_refuse_what_is_not_built():
    with pytest.raises(NotImplementedError, match="w-u, w-v-u, v-w-u"):
        scene = _cantilever(nx=4)
        scene.subdomains[0].reduce(modes=2)
        dd.StaticProblem(scene, "FULL")
    for bad in (-1, 2.5, True):
        with pytest.raises(InputError, match="modes"):
            _cantilever(nx=4).subdomains[0].reduce(modes=bad)
    # a tie stiffer than KAPPA_SPLIT: refused with the limit and the way out
    scene = cantilever(4, 1, kappa=1e9)
    scene.subdomains[0].reduce(modes=2)
    with pytest.raises(NotImplementedError, match=r"kappa at most 1e\+06.*do not reduce it"):
        dd.StaticProblem(scene, "w-u")


def _interior(scene) -> list[int]:
    """Interior dofs of each subdomain (free, not tied): a complete basis has this many."""
    model = assemble(scene)
    out = []
    for sub in scene.subdomains:
        _, C = coupling_layout(sub.block, model.system)
        tied = np.unique(C.tocoo().row)
        out.append(sub.num_dofs - len(np.union1d(tied, model.dirichlet[sub.block][0])))
    return out


def _impact(algorithm, modes, steps=30, scheme="trapezoidal", safe=True):
    """The bar of the benchmarks striking its wall (no load), reduced or not.

    ``modes``: per subdomain (``None``: unreduced).
    """
    scene = parallelepiped(algorithm, (12, 3, 3), pressure=0.0, contact_kappa=1.0)
    if modes is not None:
        for sub, m in zip(scene.subdomains, modes(scene), strict=True):
            sub.reduce(modes=m)
    problem = dd.TransientProblem(scene, 4e-7, algorithm, scheme=scheme, energy_safe_contact=safe)
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


def _complete(scene):
    return [n - 1 for n in _interior(scene)]


@pytest.mark.parametrize("algorithm", ["w-u", "w-v-u", "v-w-u"])
def test_impact_in_reduced_coordinates_converges_to_the_unreduced_run(algorithm):
    """The classic trapezoidal contact (energy_safe_contact=False): the same equations."""
    force, _, u, _ = _impact(algorithm, None, safe=False)
    assert force.max() > 0  # the bar strikes the wall
    f, _, _, _ = _impact(algorithm, lambda scene: [10] * len(scene.subdomains), safe=False)
    assert 1e-4 < np.abs(f - force).max() / np.abs(force).max() < 0.5  # ten modes: coarse
    f, _, u_r, _ = _impact(algorithm, _complete, safe=False)
    # every mode but the highest, and the load modes: the unreduced run but for that mode,
    # which an impact excites (measured 3e-5 of the peak force in w-u, 1.1e-3 in w-v-u)
    assert np.abs(f - force).max() <= 3e-3 * np.abs(force).max()
    assert np.linalg.norm(u_r - u) <= 1e-3 * np.linalg.norm(u)
    # (the velocity is not compared: the one mode left out, the highest, rings in it)


@pytest.mark.parametrize("algorithm", ["w-u", "w-v-u", "v-w-u"])
def test_energy_safe_contact_of_reduced_subdomains(algorithm):
    """Energy never grows; a complete basis is the unreduced run but for its missing mode.

    A reduced subdomain's walls are settled at a release along moves that hold its interior
    through the modes; with ten modes those carry much mass, and the settle balances their
    inertia as far as that adds no energy (without that limit: +0.3 % of the energy at a
    release in w-v-u, an EnergyGrowthWarning). Complete basis: 1.7e-6 of the peak force in
    w-u, 1.4e-3 in w-v-u, where the missing mode rings as in classic contact.
    """
    force, _, _, _ = _impact(algorithm, None)
    for modes, tolerance in ((lambda scene: [10] * len(scene.subdomains), 0.5), (_complete, 2e-3)):
        with warnings.catch_warnings():
            warnings.simplefilter("error", dd.EnergyGrowthWarning)
            f, e, _, _ = _impact(algorithm, modes)
        assert e.max() <= e[0] * (1 + 1e-9)
        assert np.abs(f - force).max() <= tolerance * np.abs(force).max()


def test_a_reduced_release_follows_the_unreduced_bar():
    """The paper's bar (25 x 6 x 5) shaken on and off its wall, w-u: with 100 modes the
    contact-force history through the releases is the unreduced one to 1.5 % of its peak
    (measured 0.83 %). The walls' settle along P must balance the inertia P carries at the
    step's end: balancing only the static residual gave 3.4 % (2.3 % with m = 320 on
    50 x 12 x 10, 6.3 % at a quarter of the paper's cells)."""
    from mpi4py import MPI

    from dd_contact.paper import models

    def force(modes):
        scene = models.parallelepiped((25, 6, 5), algorithm="w-u", comm=MPI.COMM_SELF)
        for sub in scene.subdomains if modes else ():
            sub.reduce(modes=modes)
        problem = dd.TransientProblem(scene, 1e-4, "w-u", track_energy=False)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", dd.CoarseTimeStepWarning)
            history = problem.run(25, progress=False, summary=False)
        problem.close()
        assert sum(r["changes"] for r in history) >= 10  # on, off and on again
        return np.array([r["force"]["end"][0] for r in history])

    reference = force(None)
    assert (reference == 0).any() and reference.max() > 1e3  # it does leave the wall
    assert np.abs(force(100) - reference).max() <= 0.015 * reference.max()


def test_generalized_alpha_in_reduced_coordinates():
    force, energy, u, _ = _impact("w-u", None, 20, "generalized-alpha", safe=False)
    f, e, u_r, _ = _impact("w-u", _complete, 20, "generalized-alpha", safe=False)
    assert np.abs(f - force).max() <= 1e-4 * np.abs(force).max()
    assert np.linalg.norm(u_r - u) <= 1e-4 * np.linalg.norm(u)
    assert np.abs(e - energy).max() <= 1e-5 * energy[0]


@pytest.mark.mpi
@pytest.mark.parametrize("algorithm", ["w-v-u", "v-w-u"])
def test_reduced_subdomains_on_every_rank_count(algorithm):
    """Both pieces reduced: each rank owns one on two ranks; same answers."""
    du, df = verify.reduced.static_difference(2, algorithm, [3, 0])
    assert du <= 1e-8 and df <= 1e-8
    force, _, _, _ = _impact(algorithm, None, steps=10)
    f, e, _, _ = _impact(algorithm, lambda s: [10] * len(s.subdomains), steps=10)
    assert 0 < np.abs(f - force).max() <= 0.5 * np.abs(force).max()
    assert e.max() <= e[0] * (1 + 1e-9)


@pytest.mark.mpi
def test_a_refusal_during_reduction_on_one_rank_is_raised_on_every_rank():
    """A reduced piece with a non-zero prescribed displacement is refused by its owner only
    (rank 0 on two ranks); the other rank raises it too instead of waiting in the next
    collective (faulthandler ends a hang after 60 s)."""
    import faulthandler

    from mpi4py import MPI

    from dd_contact.paper.verify.reduced import cantilever

    scene = cantilever(nx=6, parts=2)
    left = scene.subdomains[0]
    left.fix(lambda x: np.isclose(x[0], 0.0), value=[1e-9, 0.0, 0.0]).reduce(modes=2)
    faulthandler.dump_traceback_later(60, exit=True)
    try:
        with pytest.raises(NotImplementedError, match="non-zero prescribed displacement"):
            dd.TransientProblem(scene, 1e-3, "w-v-u")
        MPI.COMM_WORLD.Barrier()  # every rank got here
    finally:
        faulthandler.cancel_dump_traceback_later()


def test_a_reduced_subdomains_support_reaction_is_its_step_s_from_the_first_step():
    """The supports' reaction reads the load at t_n+1, also on the first step (it once read
    the load at t_n there: 2.9 % off, the top's traction ramping on the clamped edge)."""
    from dd_contact.paper.verify.reduced import cantilever

    def reactions(modes):
        scene = cantilever(nx=6)
        if modes is not None:
            scene.subdomains[0].reduce(modes=modes)
        problem = dd.TransientProblem(scene, 1e-3, "w-u")
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", dd.CoarseContactWarning)
                history = problem.run(3, progress=False, summary=False)
        finally:
            problem.close()
        return np.array([r["reaction"]["part0"] for r in history])

    unreduced, reduced = reactions(None), reactions(70)
    assert np.abs(unreduced[0, 0]) > 100.0  # the clamp holds the traction's first step
    gap = np.abs(reduced - unreduced).max(axis=1) / np.abs(unreduced).max()
    assert gap.max() < 1e-5  # measured 6.6e-8, 3.1e-7, 2.3e-7


def test_more_modes_than_interior_dofs_keep_the_interior_whole(monkeypatch):
    """Asked for as many modes as its interior has dofs, or more, a subdomain keeps every
    mode (a dense eigensolve): its reduced matrices are the whole ones in another basis.
    Past WHOLE_INTERIOR_LIMIT interior dofs that is refused."""
    from dd_contact.solvers import reduced

    scene = _cantilever(nx=2)
    basis, A, _, dofs = _basis(scene, 10_000)
    try:
        free = np.setdiff1d(np.arange(A.shape[0]), dofs)
        assert basis.size == free.size  # the basis is complete
        exact = np.sort(np.linalg.eigvalsh(A[free][:, free].toarray()))[:5]
        assert basis.omega2.size == basis.i.size
        T = np.column_stack([basis.expand(e) for e in np.eye(basis.size)])[free]
        got = np.sort(np.linalg.eigvals(np.linalg.solve(T.T @ T, basis.A_r)).real)[:5]
        assert np.allclose(got, exact, rtol=1e-9)  # the same operator
    finally:
        basis.destroy()
    monkeypatch.setattr(reduced, "WHOLE_INTERIOR_LIMIT", 10)
    with pytest.raises(InputError, match="interior dofs"):
        _basis(_cantilever(nx=2), 10_000)


def _pin_joint_forces(modes, steps, safe=True):
    """The small pin joint on touching pins, w-v-u, every subdomain reduced to ``modes``
    (``None``: unreduced): each hole wall's force along y, per step."""
    import dataclasses

    from dd_contact.paper import models

    cells = dict(n_circumferential=3, n_radial=2, n_layers=1, n_length=4)
    layout = dataclasses.replace(models.pin_joint_layout("small"), **cells)
    scene = models.pin_joint(layout, clearance=0.0)
    if modes is not None:
        for sub in scene.subdomains:
            sub.reduce(modes=modes)
    problem = dd.TransientProblem(scene, 1.6e-6, "w-v-u", energy_safe_contact=safe)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", dd.CoarseContactWarning)
            warnings.simplefilter("ignore", dd.CoarseTimeStepWarning)
            warnings.simplefilter("ignore", dd.EnergyGrowthWarning)  # classic contact
            history = problem.run(steps, progress=False, summary=False)
    finally:
        problem.close()
    walls = sorted(history[0]["force"])
    return np.array([[r["force"][w][1] for w in walls] for r in history])


def test_the_pin_joint_with_every_subdomain_reduced():
    """Its loads have components on guided dofs only (x and z of the grips' traction):
    zero patterns off the supports, dropped. Its hole blocks have fewer interior dofs than
    the modes asked (12 or 30): kept whole; the grips' (320) reduced."""
    force = _pin_joint_forces(None, 60, safe=False)
    assert np.abs(force).max() > 100.0  # the plates bear on the pins
    whole = _pin_joint_forces(1000, 60, safe=False)  # every mode: the same model
    assert np.abs(whole - force).max() <= 1e-5 * np.abs(force).max()  # measured 1.8e-7
    # energy-safe: the reduced walls are settled at a release along moves that hold the
    # interior through the modes: every mode is the unreduced run (measured 1.3e-9 of the
    # peak; 1.2e-3 when they were left unsettled); 60 modes in each grip: 1.5e-3, 20: 7.5e-2
    force = _pin_joint_forces(None, 60)
    whole = _pin_joint_forces(1000, 60)
    assert np.abs(whole - force).max() <= 1e-7 * np.abs(force).max()
    reduced = _pin_joint_forces(60, 60)
    assert np.abs(reduced - force).max() <= 5e-3 * np.abs(force).max()


def _resumed_reduced_run(algorithm, out, comm):
    """The reduced parallelepiped run 6 steps at once, and 3 + 3 through a checkpoint."""

    def problem():
        scene = parallelepiped(algorithm, (12, 4, 2), comm=comm)
        for sub in scene.subdomains:
            sub.reduce(modes=10)
        return dd.TransientProblem(
            scene, 1e-6, algorithm=algorithm, track_energy=False, energy_safe_contact=True
        )

    # the same run uninterrupted, checkpointing alike (a checkpoint re-factorises what a
    # low-rank correction stands for: a resumed run's factors are made anew)
    whole = problem()
    whole.run(6, output=Path(out) / "whole", checkpoint_every=3, summary=False, progress=False)
    killed = Path(out) / "killed"
    problem().run(3, output=killed, checkpoint_every=3, summary=False, progress=False)
    resumed = problem()
    resumed.run(6, output=killed, resume=True, summary=False, progress=False)
    assert sum(r["changes"] for r in whole.history) >= 2  # contact changed on the way
    for mine, theirs in zip(resumed.scene.subdomains, whole.scene.subdomains, strict=True):
        for field in ("u", "velocity", "acceleration"):
            mine_values, their_values = getattr(mine, field), getattr(theirs, field)
            np.testing.assert_array_equal(mine_values.x.array, their_values.x.array)
    assert [r["force"] for r in resumed.history] == [r["force"] for r in whole.history]


@pytest.mark.parametrize("algorithm", ["w-u", "w-v-u"])
def test_a_resumed_reduced_run_is_the_uninterrupted_one(algorithm, tmp_path):
    """A checkpoint holds a reduced subdomain's coordinates and its walls' rates (not its
    expanded fields): the resumed run steps the same numbers, bit for bit."""
    from mpi4py import MPI

    _resumed_reduced_run(algorithm, tmp_path, MPI.COMM_SELF)
    # a checkpoint of other reductions is refused
    scene = parallelepiped(algorithm, (12, 4, 2), comm=MPI.COMM_SELF)
    other = dd.TransientProblem(scene, 1e-6, algorithm=algorithm, energy_safe_contact=True)
    with pytest.raises(InputError, match="reduced otherwise"):
        other.run(6, output=tmp_path / "killed", resume=True, summary=False, progress=False)


@pytest.mark.mpi
def test_a_resumed_reduced_run_on_two_ranks_is_the_uninterrupted_one(tmp_path):
    """w-v-u, each rank owning one reduced piece (its coordinates in its own file)."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    _resumed_reduced_run("w-v-u", comm.bcast(str(tmp_path) if comm.rank == 0 else None), comm)


@pytest.mark.parametrize("rates", ["counts", "cached"])
def test_reduction_pays_only_where_its_dense_block_is_cheaper(rates, monkeypatch):
    """A block that is mostly boundary is kept whole; one with a small boundary is reduced.

    Priced by this machine's cached rates, or without them by the counts (2 r^2 against
    the sparse factor's entries); a small block's sparse call overhead can favour the dense
    one, so the bar is long enough (837 dofs) for the counts to decide both ways.
    """
    from dd_contact import calibration
    from dd_contact.solvers import reduced_model

    if rates == "counts":
        monkeypatch.setattr(calibration, "cached_rates", lambda: None)
    scene = _cantilever(nx=60, parts=2)
    model = assemble(scene)
    block = scene.subdomains[0].block
    A = model.system.block(block, block)
    dofs = model.dirichlet[block][0]
    tied = tied_dofs(coupling_layout(block, model.system)[1])
    free = np.setdiff1d(np.arange(A.shape[0]), dofs)
    assert 0 < tied.size < 0.1 * free.size  # a cut face of a 30-cell bar
    assert reduced_model.reduction_pays(A, tied, dofs, 5, [])
    assert not reduced_model.reduction_pays(A, free, dofs, 5, [])  # all boundary: r = n
    # in a problem: asked if_cheaper with every mode (r = n), each stays whole
    for sub in scene.subdomains:
        sub.reduce(modes=10_000, if_cheaper=True)
    problem = dd.StaticProblem(scene, "w-v-u")
    try:
        assert problem.model.system.reduced == set()
        assert all(problem.model.system.sizes[s.block] == s.num_dofs for s in scene.subdomains)
    finally:
        problem.close()
