"""The decomposition orders: agreement with FULL, the paper's work counts, valid orders, MPI."""

from __future__ import annotations

import dataclasses

from mpi4py import MPI

import numpy as np
import pytest

import dd_contact as dd
from dd_contact.paper import flops, verify
from dd_contact.solvers import analysed
from dd_contact.solvers.worklog import WorkLog


@pytest.fixture(scope="module")
def agreement():
    return {kappa: verify.orders_agreement(kappa) for kappa in (1e4, 1e6)}


# Stiffer ties cost digits in every float64 solve, FULL's included (measured against an
# extended-precision reference: FULL 5.9e-10, v-w-u 2.7e-10 at kappa 1e6, static), so the
# orders agree with FULL to 1e-9 at kappa 1e4 and to a few 1e-9 at the default 1e6.
@pytest.mark.parametrize(("kappa", "tolerance"), [(1e4, 1e-9), (1e6, 1e-8)])
def test_every_order_reproduces_full(agreement, kappa, tolerance):
    results = agreement[kappa]
    expected = {(k, o) for k, orders in verify.ORDER_SCENES.items() for o in orders}
    assert {(r["scene"], r["order"]) for r in results} == expected
    for r in results:
        assert r["difference"] < tolerance, r
        assert r["same_path"], r
        assert r["changes"] >= 1, r  # the contact state really changed


def _sizes(problem, n_steps: int) -> flops.SceneSizes:
    """The paper's model of a run of :func:`verify.order_scene`, read off its Scene."""
    return flops.sizes_from_scene(problem.scene, n_steps, problem.changes)


# Coupling columns of each subdomain (D_V^(k) + D_W^(k)): the interface and the contact
# interface have 4 x 4 nodes, 48 dofs each, and both blocks touch the whole interface.
_COLUMNS = {
    "interface": {"u:A": 96, "u:B": 48},
    "boundary": {"u:A": 48, "u:B": 48},
    "single": {"u:A": 48},
}


@pytest.mark.parametrize("condensation", ["multi-rhs", "schur"])
@pytest.mark.parametrize(
    ("kind", "order"),
    [
        ("interface", "v-w-u"),
        ("interface", "w-v-u"),
        ("boundary", "v-u"),
        ("single", "w-u"),
        ("interface", "FULL"),
    ],
)
def test_work_counts_equal_the_papers(kind, order, condensation):
    n_steps = 25
    scene = verify.order_scene(kind, True, 1e4)
    problem = dd.TransientProblem(scene, 0.01, algorithm=order, condensation=condensation)
    problem.run(n_steps, progress=False, summary=False)
    assert problem.changes["gamma"] >= 2
    # The paper's model has no energy-safe release solves (the same contact state solved
    # again): their work is the schedule's release plan, added to the paper's counts.
    schedule = analysed.scene_structure(
        problem.comm,
        problem.solver.system,
        [z.region for z in problem.zones],
        condensation,
        full=order == "FULL",
        orders=order != "FULL",
    ).schedule(order)
    releases = problem.iteration.releases
    assert problem.iteration.release_solves == sum(releases.values()) >= 10
    released = WorkLog.planned(
        [op for region, n in releases.items() for op in n * schedule.release(region)]
    ).per_block()
    # Schur: one substitution per step, split in MUMPS's reduction (forward sweep) and
    # expansion (backward sweep), as the paper's Tables 2 and 3 count; multi-RHS: u_hat
    # and u each a full substitution, as its Table 1 lists.
    per_step = 1 if condensation == "schur" else 2
    sizes = dataclasses.replace(_sizes(problem, n_steps), substitutions_per_step=per_step)
    model = {m.name: m for m in flops.operation_counts(sizes, order).meshes}
    if kind == "boundary":
        # v-u: the contact lives on A's own boundary; the model has no contact mesh.
        model = {name: m for name, m in model.items() if not name.startswith("w:")}
    done = problem.work_summary()
    assert set(done) == set(model)
    for name, m in model.items():
        substitutions, schur = m.substitutions, 0
        if condensation == "schur" and order != "FULL" and name.startswith("u:"):
            # Each factorisation brings its Schur complement instead of one substitution
            # per coupling column; every other count is the paper's.
            substitutions -= m.decompositions * _COLUMNS[kind][name]
            schur = m.decompositions
        extra = released.get(name, {"decompositions": 0, "substitutions": 0})
        assert extra["decompositions"] == 0, name
        assert done[name]["decompositions"] == m.decompositions, name
        assert done[name]["substitutions"] == substitutions + extra["substitutions"], name
        assert done[name]["schur"] == schur, name


def test_summary_table_is_printed_and_returned(capsys):
    problem = dd.TransientProblem(verify.order_scene("single", True, 1e4), 0.01, algorithm="w-u")
    problem.run(3, progress=False)
    table = capsys.readouterr().out
    summary = problem.work_summary()
    assert summary["u:A"]["decompositions"] == 1 and summary["u:A"]["matrix"] == "sparse"
    assert summary["w:end"]["matrix"] == "dense"
    # The Schur complement condenses; then one substitution in each of the 3 steps: a
    # forward sweep (the surface right-hand side) and a backward sweep (u).
    assert summary["u:A"]["schur"] == 1 and summary["u:A"]["substitutions"] == 3
    sweeps = [r.kind for r in problem.work.records if r.block == "u:A" and r.nrhs]
    assert sweeps == ["sparse_forward", "sparse_backward"] * 3
    assert "u:A" in table and "w:end" in table and "decompositions" in table


def test_a_second_back_substitution_for_the_same_rhs_sweeps_forward_again():
    """MUMPS releases the forward sweep after an expansion (v-u: a subdomain read again)."""
    problem = dd.StaticProblem(verify.order_scene("interface", False, 1e4), "v-w-u")
    problem.solve()
    sub = problem.solver.subdomains["u:A"]
    x = problem.solver.finish()
    u = x["u:A"].copy()
    before = len(problem.work.records)
    sub.u = None  # as after a new surface solution for the same right-hand side
    np.testing.assert_allclose(sub.back_substitute(x), u, rtol=0, atol=1e-12 * abs(u).max())
    redo = [(r.kind, r.what) for r in problem.work.records[before:]]
    assert redo == [("sparse_forward", "u"), ("sparse_backward", "u")]


@pytest.mark.parametrize(
    ("kind", "order", "valid"),
    [
        ("interface", "w-u", "FULL, v-w-u, w-v-u"),
        ("interface", "v-u", "FULL, v-w-u, w-v-u"),
        ("boundary", "v-w-u", "FULL, v-u"),
        ("single", "w-v-u", "FULL, w-u"),
    ],
)
def test_an_order_the_scene_cannot_use_is_refused(kind, order, valid):
    with pytest.raises(dd.InputError, match=f"'{order}' does not fit.*valid for it: {valid} "):
        dd.StaticProblem(verify.order_scene(kind, False, 1e4), algorithm=order)


@pytest.mark.mpi
@pytest.mark.parametrize(("kind", "order"), [("interface", "v-w-u"), ("boundary", "v-u")])
def test_ranks_own_whole_subdomains_and_match_serial(kind, order):
    comm = MPI.COMM_WORLD
    results = {}
    for name, c in (("parallel", comm), ("serial", MPI.COMM_SELF)):
        scene = verify.order_scene(kind, True, 1e4, c)
        problem = dd.TransientProblem(scene, 0.01, algorithm=order)
        problem.run(15, progress=False, summary=False)
        results[name] = (verify.displacements(scene), problem.changes["gamma"])
        owned = {b for b in problem.solver.subdomains}
        # Subdomain k lives on rank k % size, and nowhere else.
        expected = {f"u:{s.name}" for k, s in enumerate(scene.subdomains) if k % c.size == c.rank}
        assert owned == expected
    (xp, gp), (xs, gs) = results["parallel"], results["serial"]
    assert gp == gs >= 1
    assert np.linalg.norm(xp - xs) / np.linalg.norm(xs) < 1e-9


@pytest.mark.parametrize("algorithm", ["FULL", "v-w-u", "w-v-u", "w-u", "v-u"])
def test_parallelepiped_scene_for_every_algorithm(algorithm):
    from dd_contact.paper.examples import parallelepiped

    nx, ny, nz = 12, 4, 2
    scene = parallelepiped(algorithm, (nx, ny, nz), comm=MPI.COMM_SELF)
    problem = dd.TransientProblem(scene, 1e-6, algorithm=algorithm, track_energy=False)
    history = problem.run(4, progress=False, summary=False)
    face = 3 * (ny + 1) * (nz + 1)  # dofs of an end face, the interface, a contact interface
    split = algorithm in ("v-w-u", "w-v-u", "v-u")
    volume = 3 * (nx + 2 if split else nx + 1) * (ny + 1) * (nz + 1)
    surfaces = face * (split + algorithm.startswith(("v-w", "w-")))
    assert sum(problem.solver.system.sizes.values()) == volume + surfaces
    # The tilted wall: two node rows (of ny + 1) touch in the first step; the contact wall
    # is massless (dd_contact.impact), so the rest of the end face follows in the second
    # (with mass on it, two rows a step: [6, 12, 15, 15]). No point leaves: no release.
    active = [r["active"]["end"] for r in history]
    assert active == [2 * (nz + 1)] + 3 * [(ny + 1) * (nz + 1)]
    assert problem.changes["gamma"] == 2 and problem.iteration.release_solves == 0


@pytest.mark.parametrize("kind", ["interface", "boundary", "single"])
def test_sizes_from_scene_read_the_coupling_columns(kind):
    """The bridge finds each subdomain's tied interface dofs and its contact-interface dofs."""
    sizes = flops.sizes_from_scene(verify.order_scene(kind, False, 1e4))
    for k, sd in enumerate(sizes.subdomains):
        contact = sizes.contact_of(k)
        own_w = contact.dofs if contact is not None and kind != "boundary" else 0
        assert sizes.tied_dofs(k) + own_w == _COLUMNS[kind][sd.name], sd.name
    # FULL's matrix: every block (v and w have 48 dofs each); one subdomain is its own whole.
    surfaces = {"interface": 96, "boundary": 48, "single": 0}[kind]
    assert sizes.whole.dofs == sum(sd.dofs for sd in sizes.subdomains) + surfaces
