"""Output and results: fields, history files, resume into the same files, reactions, paths."""

from __future__ import annotations

import csv
import json
import os
import shutil
import subprocess
import sys
import textwrap
import xml.etree.ElementTree as ET
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest

import dd_contact as dd
from dd_contact import io, meshes
from dd_contact.paper import verify
from dd_contact.post import output_fields


def _on(axis, value):
    return lambda x: np.isclose(x[axis], value)


def _shared_tmp(tmp_path) -> Path:
    comm = MPI.COMM_WORLD
    return Path(comm.bcast(str(tmp_path) if comm.rank == 0 else None))


def _pressed_block(points="nodes"):
    """A unit block pressed 0.01 onto a wall (nu = 0): sigma_zz = -10 everywhere."""
    box = meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [3, 3, 3])
    block = dd.Subdomain(box, dd.Material(1000.0, 0.0), "block")
    block.fix(_on(2, 1.0), components=[2], value=[0, 0, -0.01])
    block.fix(_on(0, 0.0), components=[0]).fix(_on(1, 0.0), components=[1])
    zone = dd.ContactBoundary(block, _on(2, 0.0), dd.Plane([0, 0, 0], [0, 0, 1]), points=points)
    return block, zone, dd.Scene(MPI.COMM_WORLD, [block], contacts=[zone])


def _series(path: Path) -> dict[str, list[float]]:
    """Times of every field in a series' XDMF index."""
    out: dict[str, list[float]] = {}
    for grid in ET.parse(path).getroot().iter("Grid"):
        if grid.get("GridType") == "Uniform":
            for attribute in grid.iter("Attribute"):
                out.setdefault(attribute.get("Name"), []).append(
                    float(grid.find("Time").get("Value"))
                )
    return out


# -- results --------------------------------------------------------------------------------
@pytest.mark.mpi
@pytest.mark.parametrize("points", ["nodes", "quadrature"])
def test_static_results_area_force_and_reaction(points):
    _, _, scene = _pressed_block(points)
    problem = dd.StaticProblem(scene)
    problem.solve()
    results = problem.results
    # The whole unit face touches; the wall carries E delta / L, the supports the opposite.
    assert results["contact_area"]["contact"] == pytest.approx(1.0, rel=1e-12)
    assert results["active"]["contact"] == (16 if points == "nodes" else 9 * 4)
    force, reaction = problem.contact_forces()["contact"], problem.reactions["block"]
    assert force == pytest.approx([0.0, 0.0, 10.0], rel=5e-6, abs=1e-10)
    # Equilibrium holds to round-off, whatever the penalty.
    assert np.abs(force + reaction).max() < 1e-9 * 10.0
    assert problem.changes == {"gamma": 0, "contact": 0}


@pytest.mark.mpi
def test_reaction_of_the_tied_cantilever_balances_the_load():
    steel = dd.Material(210e9, 0.3)
    left = dd.Subdomain(meshes.box(MPI.COMM_SELF, [0, 0, 0], [5, 1, 1], [10, 2, 2]), steel, "left")
    tip = meshes.box(MPI.COMM_SELF, [5, 0, 0], [10, 1, 1], [7, 3, 3])
    right = dd.Subdomain(tip, steel, "right")
    left.fix(_on(0, 0.0))
    right.add_traction(_on(0, 10.0), (0.0, 0.0, -1e5))
    interface = dd.Interface.from_boundary(left, _on(0, 5.0), [left, right], resolution=(5, 5))
    problem = dd.StaticProblem(dd.Scene(MPI.COMM_WORLD, [left, right], interface), "v-u")
    problem.solve()
    reactions = problem.reactions  # rank-local: every rank has both
    # 1e5 N/m^2 on the 1 m^2 tip face; ties included, the support carries all of it.
    assert reactions["left"] == pytest.approx([0.0, 0.0, 1e5], abs=1e-6 * 1e5)
    assert np.array_equal(reactions["right"], np.zeros(3))  # no supports


def test_output_fields_of_the_pressed_block():
    _, _, scene = _pressed_block()
    problem = dd.StaticProblem(scene)
    problem.solve()
    fields = {f.stem: f for f in output_fields(scene, MPI.COMM_WORLD.rank, dynamic=True)}
    if MPI.COMM_WORLD.rank != 0:
        assert fields == {}
        return
    body, contact = fields["u_block"], fields["w_contact"]
    body.refresh(0.0)
    contact.refresh(0.0)
    names = [f.name for f in body.functions]
    motion = ["velocity_block", "acceleration_block"]
    assert names == ["u_block", *motion, "stress_block", "von_mises_block"]
    stress = body.functions[3].x.array.reshape(-1, 3, 3)
    expected = np.zeros((3, 3))
    expected[2, 2] = -10.0
    assert np.abs(stress - expected).max() < 5e-6 * 10.0
    assert body.functions[4].x.array == pytest.approx(10.0, rel=5e-6)
    pressure, gap, active = (f.x.array for f in contact.functions[1:])
    assert [f.name for f in contact.functions] == [
        "w_contact",
        "pressure_contact",
        "gap_contact",
        "active_contact",
    ]
    eps = problem.penalties[("block", "contact:contact")]
    assert gap == pytest.approx(-pressure * eps, rel=1e-9)  # pressure = penetration / eps
    assert np.array_equal(active, np.ones_like(active))


# -- run(): arguments and semantics ---------------------------------------------------------
def test_run_counts_steps_from_t0_and_refuses_nothing_to_do(falling_bar):
    problem = falling_bar()[1]
    assert len(problem.run(3, progress=False, summary=False)) == 3
    with pytest.raises(dd.InputError, match=r"already at step 3; .* call run\(6\) for 3 more"):
        problem.run(3, progress=False, summary=False)
    assert len(problem.run(6, progress=False, summary=False)) == 6 and problem.step == 6


@pytest.mark.parametrize(
    ("argument", "kwargs"),
    [
        ("n_steps", {"n_steps": -5}),
        ("n_steps", {"n_steps": 2.5}),
        ("output_every", {"n_steps": 2, "output_every": 0}),
        ("checkpoint_every", {"n_steps": 2, "checkpoint_every": 0}),
    ],
)
def test_bad_run_arguments_are_refused(argument, kwargs, falling_bar):
    problem = falling_bar()[1]
    with pytest.raises(dd.InputError, match=f"run: {argument} must be a positive integer"):
        problem.run(progress=False, **kwargs)
    assert problem.step == 0


def test_unknown_algorithm_lists_auto():
    _, _, scene = _pressed_block()
    unknown = r"unknown algorithm 'wvu' \(the algorithms: auto, FULL"
    with pytest.raises(dd.InputError, match=unknown):
        dd.StaticProblem(scene, algorithm="wvu")
    with pytest.raises(dd.InputError, match=r"no contact interfaces; valid for it: FULL or auto"):
        dd.StaticProblem(scene, algorithm="w-u")


# -- bad output paths -----------------------------------------------------------------------
@pytest.mark.mpi
def test_output_path_that_is_a_file_is_refused_before_solving(tmp_path, falling_bar):
    target = _shared_tmp(tmp_path) / "results"
    if MPI.COMM_WORLD.rank == 0:
        target.write_text("not a directory")
    MPI.COMM_WORLD.Barrier()
    problem = falling_bar()[1]
    message = rf"run\(output=...\): the directory '{target}' is an existing file, not a directory"
    with pytest.raises(dd.InputError, match=message):
        problem.run(5, output=target, progress=False)
    assert problem.step == 0 and problem.work.count("sparse_factor", "FULL") == 0  # no solve
    with pytest.raises(dd.InputError, match=r"write_vtx directory: the directory .* existing file"):
        io.write_vtx(problem.scene, target)


_READ_ONLY_SCRIPT = """
from mpi4py import MPI
import sys
import numpy as np
import dd_contact as dd
from dd_contact import io, meshes
box = meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [1, 1, 1])
scene = dd.Scene(MPI.COMM_WORLD, [dd.Subdomain(box, dd.Material(1.0, 0.0), "b")])
for target in sys.argv[1:]:
    try:
        io.write_vtx(scene, target)
    except dd.InputError as error:
        print("InputError:", error)
"""


def test_unwritable_output_is_an_input_error_not_an_abort(tmp_path):
    # A read-only directory and one below it: ADIOS2 used to abort the process (rc 134).
    base = tmp_path
    locked = base / "locked"
    locked.mkdir()
    locked.chmod(0o555)
    script = base / "script.py"
    script.write_text(textwrap.dedent(_READ_ONLY_SCRIPT))
    env = dict(os.environ, PYTHONPATH=str(Path(dd.__file__).parents[1]))
    command = [sys.executable, str(script), str(locked), str(locked / "sub")]
    if os.geteuid() == 0:  # root writes anywhere: drop the capability that lets it
        if shutil.which("setpriv") is None:
            pytest.skip("running as root without setpriv: cannot make a directory read-only")
        command = ["setpriv", "--bounding-set", "-dac_override,-dac_read_search", *command]
    done = subprocess.run(
        command, env=env, capture_output=True, text=True, timeout=120, check=False
    )
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines == [
        f"InputError: write_vtx directory: the directory '{locked}' is not writable "
        "(Permission denied); give a directory you can write to",
        f"InputError: write_vtx directory: the directory '{locked / 'sub'}' cannot be created "
        "(Permission denied); give a directory you can write to",
    ]


# -- files ----------------------------------------------------------------------------------
@pytest.mark.mpi
def test_write_vtx_lists_the_files_of_every_rank(tmp_path):
    out = _shared_tmp(tmp_path)
    scene = verify.order_scene("interface", False, 1e4)
    dd.StaticProblem(scene, "v-w-u").solve()
    paths = io.write_vtx(scene, out)
    MPI.COMM_WORLD.Barrier()
    names = sorted(p.name for p in paths)
    assert names == ["u_A.bp", "u_B.bp", "v_interface.bp", "w_end.bp"]
    assert all(p.is_dir() for p in paths)  # BP4 writes a directory per file


@pytest.mark.mpi
def test_history_files_are_written_without_checkpoints(tmp_path, falling_bar):
    out = _shared_tmp(tmp_path)
    problem = falling_bar()[1]
    history = problem.run(5, output=out, progress=False, summary=False)
    if MPI.COMM_WORLD.rank != 0:
        return
    assert json.loads((out / "history.json").read_text()) == history
    with (out / "history.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 5
    for row, record in zip(rows, history, strict=True):
        assert int(row["step"]) == record["step"] and float(row["t"]) == record["t"]
        assert float(row["force.contact.x"]) == record["force"]["contact"][0]
        assert float(row["energy.total"]) == record["energy"]["total"]
        assert float(row["reaction.bar.x"]) == record["reaction"]["bar"][0]
    times = _series(out / "u_bar.xdmf")["von_mises_bar"]
    assert times == pytest.approx([0.1 * k for k in range(6)])


@pytest.mark.mpi
def test_resume_continues_the_same_files(tmp_path, falling_bar):
    base = _shared_tmp(tmp_path)
    reference = falling_bar()[1].run(30, output=base / "whole", progress=False, summary=False)

    class Interrupt(Exception):
        pass

    def stop_at_12(record):
        if record["step"] == 12:
            raise Interrupt

    out = base / "resumed"
    with pytest.raises(Interrupt):
        _, problem = falling_bar()
        problem.run(30, output=out, checkpoint_every=5, callback=stop_at_12, progress=False)
    if MPI.COMM_WORLD.rank == 0:
        assert len(_series(out / "u_bar.xdmf")["u_bar"]) == 13  # steps 0 ... 12
    resumed = falling_bar()[1].run(30, output=out, resume=True, checkpoint_every=5, progress=False)
    assert resumed == reference
    if MPI.COMM_WORLD.rank != 0:
        return
    names = sorted(p.name for p in out.iterdir())
    assert not any(".from" in n for n in names)
    for stem in ("u_bar", "w_contact"):  # one series each: steps 0 ... 30, none twice
        assert _series(out / f"{stem}.xdmf") == _series(base / "whole" / f"{stem}.xdmf")
    assert _series(out / "w_contact.xdmf")["gap_contact"] == pytest.approx(
        [0.1 * k for k in range(31)]
    )
    assert json.loads((out / "history.json").read_text()) == reference
    assert (out / "history.csv").read_text() == (base / "whole" / "history.csv").read_text()


# -- PETSc options ---------------------------------------------------------------------------
def test_petsc_options_reach_mumps_and_leave_the_database_as_it_was():
    from petsc4py import PETSc

    _, _, scene = _pressed_block()
    database = PETSc.Options()
    problem = dd.StaticProblem(scene, petsc_options={"mat_mumps_icntl_14": 77})
    problem.solve()
    factor = problem.solver._factor.ksp.getPC().getFactorMatrix()
    assert factor.getMumpsIcntl(14) == 77
    assert not database.hasName("dd_contact_mat_mumps_icntl_14")
    plain = dd.StaticProblem(scene)
    plain.solve()
    # Without the option the default (5 here) comes back: nothing stayed behind.
    assert plain.solver._factor.ksp.getPC().getFactorMatrix().getMumpsIcntl(14) == 5
    with pytest.raises(dd.InputError, match="mat_mumps_icntl_24 must be 1"):
        dd.StaticProblem(scene, petsc_options={"mat_mumps_icntl_24": 0}).solve()
    assert not database.hasName("dd_contact_mat_mumps_icntl_24")
    with pytest.raises(dd.InputError, match="key '-mat_mumps_icntl_14' must be an option name"):
        dd.StaticProblem(scene, petsc_options={"-mat_mumps_icntl_14": 50})


def test_two_problems_are_tuned_apart_by_their_options_prefixes():
    from petsc4py import PETSc

    _, _, scene = _pressed_block()
    database = PETSc.Options()
    database["bracket_mat_mumps_icntl_14"] = 61
    database["lever_mat_mumps_icntl_24"] = 0  # the package relies on null-pivot detection
    try:
        bracket = dd.StaticProblem(scene, petsc_options_prefix="bracket_")
        plain = dd.StaticProblem(scene)
        bracket.solve()
        plain.solve()
        factor = bracket.solver._factor.ksp.getPC().getFactorMatrix()
        assert factor.getMumpsIcntl(14) == 61
        assert plain.solver._factor.ksp.getPC().getFactorMatrix().getMumpsIcntl(14) == 5
        assert bracket.solver._factor.ksp.getOptionsPrefix() == "bracket_"
        with pytest.raises(dd.InputError, match="-lever_mat_mumps_icntl_24 must be 1"):
            dd.StaticProblem(scene, petsc_options_prefix="lever_").solve()
        bracket.close()
        plain.close()
    finally:
        database.delValue("bracket_mat_mumps_icntl_14")
        database.delValue("lever_mat_mumps_icntl_24")
    with pytest.raises(dd.InputError, match="'-x_' is not a PETSc options prefix"):
        dd.StaticProblem(scene, petsc_options_prefix="-x_")
