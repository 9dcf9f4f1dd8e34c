"""Runs that end badly lose nothing: SIGKILL, a full disk, damaged files; results read back."""

import errno
import importlib.util
import json
import logging
import random
import signal
from pathlib import Path
from xml.etree import ElementTree as ET

from mpi4py import MPI

import numpy as np
import pytest

import dd_contact as dd
import dd_contact.series
from dd_contact.paper import verify
from dd_contact.writing import replace_atomically

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def _fault_injection():
    spec = importlib.util.spec_from_file_location(
        "fault_injection", BENCHMARKS / "fault_injection.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _shared_tmp(tmp_path) -> Path:
    comm = MPI.COMM_WORLD
    return Path(comm.bcast(str(tmp_path) if comm.rank == 0 else None))


def _leftovers(directory: Path) -> list[str]:
    return sorted(p.name for p in directory.rglob("*") if p.name.endswith(".tmp"))


def _run(problem, out, steps=12, **options):
    kwargs = {"checkpoint_every": 4, "progress": False, "summary": False, **options}
    return problem.run(steps, output=out, **kwargs)


# -- what "the same run" means --------------------------------------------------------------------
def test_resumed_runs_are_judged_bit_for_bit_except_full_on_several_ranks_to_round_off():
    fi = _fault_injection()
    assert [fi.reproducible(c, r) for c, r in [("flying:FULL", 1), ("flying:w-v-u", 2)]] == [
        True,
        True,
    ]
    assert fi.reproducible("flying:FULL", 2) is False
    u = np.array([1.0, -2.0, 3.0])
    nudged = u + np.array([0.0, 3e-13, 0.0])  # what two launches of FULL on 2 ranks differ by
    assert fi._agree(nudged, u, exact=True) is False
    assert fi._agree(nudged, u, exact=False) is True
    assert fi._agree(u + np.array([0.0, 1e-7, 0.0]), u, exact=False) is False
    record = {"step": 3, "changes": 1, "force": {"end": [33.0, -0.0]}, "energy": {"total": 1.0}}
    near = {"step": 3, "changes": 1, "force": {"end": [33.0, 1e-15]}, "energy": {"total": 1.0}}
    assert fi._records_agree([near], [record], exact=False) is True
    assert fi._records_agree([near], [record], exact=True) is False
    assert fi._records_agree([{**near, "changes": 2}], [record], exact=False) is False
    assert fi._records_agree([near], [record, record], exact=False) is False


# -- a hard kill -----------------------------------------------------------------------------------
@pytest.mark.parametrize(("case", "ranks"), [("pressed:w-u", 1), ("flying:w-v-u", 2)])
def test_a_run_killed_by_sigkill_resumes_bit_for_bit(tmp_path, case, ranks):
    fi = _fault_injection()
    if ranks > 1 and not fi.MPIEXEC.exists():
        pytest.skip("no mpiexec beside this Python")
    reference = tmp_path / "reference"
    assert fi._run(fi._command(case, reference, ranks, resume=False)).returncode == 0
    out = tmp_path / "killed"
    rc, _, stderr = fi._interrupted(case, out, ranks, signal.SIGKILL, random.Random(5))
    assert rc in (-signal.SIGKILL, 128 + signal.SIGKILL), stderr[-2000:]
    killed = json.loads((out / "history.json").read_text())
    assert [r["step"] for r in killed] == list(range(1, len(killed) + 1))  # complete, in order
    for index in out.glob("*.xdmf"):
        ET.parse(index)  # the indexes of the killed run open as they are
    again = fi._run(fi._command(case, out, ranks, resume=True))
    assert again.returncode == 0, again.stderr[-2000:]
    assert fi.check(out, tmp_path / "killed.final.npz", reference) is None


# -- a full disk -----------------------------------------------------------------------------------
def _full_after(monkeypatch, count: int):
    """The ``count``-th step file written fails half way through as on a full disk."""
    calls = [0]

    def replaced(path, write, what, directory=None):
        calls[0] += 1
        if calls[0] != count:
            return replace_atomically(path, write, what, directory)

        def half(f):
            f.write(b"\0" * 100)
            raise OSError(errno.ENOSPC, "No space left on device")

        return replace_atomically(path, half, what, directory)

    monkeypatch.setattr(dd_contact.series, "replace_atomically", replaced)


def test_a_full_disk_is_one_error_and_the_run_resumes_when_there_is_room(
    tmp_path, falling_bar, monkeypatch
):
    reference = _run(falling_bar()[1], tmp_path / "whole")
    out = tmp_path / "full"
    _full_after(monkeypatch, 4 + 4 * 9 + 1)  # 2 series: a mesh and an index, 2 files a step
    with pytest.raises(dd.OutputError) as raised:
        _run(falling_bar()[1], out)
    message = str(raised.value)
    assert message.startswith("run(output=...): could not write the fields of step 9 (u_bar/")
    assert f"in '{out}': No space left on device; the checkpoint at step 8 is intact" in message
    assert "run again with resume=True" in message and raised.value.errno == errno.ENOSPC
    assert not getattr(raised.value, "__notes__", [])  # raised once: not again while closing
    assert _leftovers(out) == []
    steps = dd.load_results(out).steps()
    assert steps == list(range(9))  # what was written before stays readable
    monkeypatch.undo()  # room again
    resumed = _run(falling_bar()[1], out, resume=True)
    assert resumed == reference
    assert (out / "history.csv").read_text() == (tmp_path / "whole" / "history.csv").read_text()
    assert dd.load_results(out).steps() == list(range(13))


def test_a_full_disk_while_checkpointing_keeps_the_last_checkpoint(tmp_path, falling_bar):
    import dd_contact.checkpointing as checkpointing

    class Full:
        def __init__(self, *args):
            raise OSError(errno.ENOSPC, "No space left on device")

    out = tmp_path / "full"
    problem = falling_bar()[1]

    def fill_the_disk(record):
        if record["step"] == 6:
            checkpointing.open = Full

    try:
        with pytest.raises(
            dd.OutputError, match=r"the checkpoint of step 8 .* at step 4 is intact"
        ):
            _run(problem, out, callback=fill_the_disk)
    finally:
        del checkpointing.open
    assert _leftovers(out) == []
    with np.load(out / "checkpoint.rank0.npz") as data:
        assert int(data["step"]) == 4


# -- damaged files on resume -----------------------------------------------------------------------
def test_resume_repairs_or_sets_aside_what_it_finds_damaged(tmp_path, falling_bar, caplog):
    reference = _run(falling_bar()[1], tmp_path / "whole")

    class Interrupt(Exception):
        pass

    def stop_at_10(record):
        if record["step"] == 10:
            raise Interrupt

    out = tmp_path / "damaged"
    with pytest.raises(Interrupt):
        _run(falling_bar()[1], out, callback=stop_at_10)
    # What a crash of the machine or a careless copy may leave:
    index = out / "u_bar.xdmf"
    index.write_bytes(index.read_bytes()[:-200])  # cut short
    step_3 = out / "u_bar" / "000003.h5"
    step_3.write_bytes(step_3.read_bytes()[:500])  # a step before the checkpoint, cut short
    (out / "history.json").write_text("[{")  # unreadable
    (out / "history.csv").write_bytes((out / "history.csv").read_bytes()[:-7])
    (out / "w_contact.xdmf.tmp").write_text("<Xdm")  # a temporary file of a killed write
    with caplog.at_level(logging.WARNING, logger="dd_contact.io"):
        resumed = _run(falling_bar()[1], out, resume=True)
    assert resumed == reference  # the checkpoint holds the history
    said = "\n".join(caplog.messages)
    assert "u_bar.xdmf: it cannot be read" in said and "set aside as u_bar.xdmf.damaged" in said
    assert "000003.h5: it cannot be read" in said and "step 3 is left out of u_bar.xdmf" in said
    assert "history.csv: its last row was cut short; rewritten" in said
    assert "w_contact.xdmf.tmp: removed" in said
    assert "history.json: it cannot be read" in said
    assert len(caplog.messages) == 5 and len(said.splitlines()) == 5  # one line each
    assert sorted(p.name for p in out.rglob("*.damaged")) == [
        "000003.h5.damaged",
        "u_bar.xdmf.damaged",
    ]
    results = dd.load_results(out)
    assert results.steps("u_bar") == [s for s in range(13) if s != 3]  # each once
    assert results.steps("w_contact") == list(range(13))
    assert results.history == reference
    whole = dd.load_results(tmp_path / "whole")
    for step in (9, 12):  # written again after the checkpoint at 8, as the first time
        for name, value in whole.arrays(step, "u_bar").items():
            np.testing.assert_array_equal(results.arrays(step, "u_bar")[name], value)


# -- reading results back --------------------------------------------------------------------------
@pytest.mark.mpi
def test_load_results_gives_back_every_field_bit_for_bit(tmp_path):
    out = _shared_tmp(tmp_path) / "run"
    scene = verify.order_scene("interface", True, 1e4)
    problem = dd.TransientProblem(scene, 0.01, algorithm="v-w-u")
    seen = {}

    def keep(record):
        if record["step"] % 2 == 0:
            seen[record["step"]] = {
                "u": {s.name: s.u.x.array.copy() for s in scene.subdomains},
                "v": scene.interface.v.x.array.copy(),
                "velocity_A": scene.subdomains[0].velocity.x.array.copy(),
            }

    _run(problem, out, steps=6, output_every=2, callback=keep)
    MPI.COMM_WORLD.Barrier()
    results = dd.load_results(out)  # rank-local: every rank reads every file
    assert results.meshes == ["u_A", "u_B", "v_interface", "w_end"]
    assert results.steps() == [0, 2, 4, 6] and results.time(4) == pytest.approx(0.04)
    np.testing.assert_array_equal(results.column("t"), [r["t"] for r in problem.history])
    assert results.column("force.end").shape == (6, 3)
    for step, values in seen.items():
        fields = results.functions(step, scene)
        for name, u in values["u"].items():
            assert np.array_equal(fields[f"u_{name}"].x.array, u)
        assert np.array_equal(fields["v_interface"].x.array, values["v"])
        assert np.array_equal(fields["velocity_A"].x.array, values["velocity_A"])
        assert {"stress_A", "von_mises_B", "pressure_end", "gap_end", "active_end"} <= set(fields)
    last = results.functions(6, scene.subdomains[1])
    assert np.array_equal(last["u_B"].x.array, scene.subdomains[1].u.x.array)
    points, cells = results.mesh("u_A")
    assert points.shape == (5 * 4 * 4, 3) and cells.shape == (4 * 3 * 3, 8)
    with pytest.raises(dd.InputError, match=r"step 3 of 'u_A' was not written; written: \[0, 2"):
        results.functions(3, scene)


def test_a_degree_2_field_is_shown_at_the_nodes_and_read_back_exactly(tmp_path):
    from dd_contact import meshes

    box = meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [2, 2, 2])
    block = dd.Subdomain(box, dd.Material(1000.0, 0.3, 1.0), "block", degree=2)
    block.fix(lambda x: np.isclose(x[2], 0.0))
    block.fix(lambda x: np.isclose(x[2], 1.0), value=lambda x, t: (0.01 * t, 0.0, -0.01 * t))
    scene = dd.Scene(MPI.COMM_WORLD, [block])
    problem = dd.TransientProblem(scene, 0.5, inertia=False)
    problem.run(2, output=tmp_path, progress=False, summary=False)
    results = dd.load_results(tmp_path)
    stored = results.arrays(2, "u_block")
    assert stored["u_block"].shape == (27, 3)  # the interpolant at the mesh's 27 nodes
    assert np.array_equal(stored["dofs/u_block"], block.u.x.array)
    assert np.array_equal(results.functions(2, block)["u_block"].x.array, block.u.x.array)


def test_pyvista_and_meshio_open_every_field_at_every_step(tmp_path, falling_bar):
    meshio = pytest.importorskip("meshio")
    falling_bar()[1].run(4, output=tmp_path, progress=False, summary=False)
    bar = ["acceleration_bar", "stress_bar", "u_bar", "velocity_bar", "von_mises_bar"]
    contact = ["active_contact", "gap_contact", "pressure_contact", "w_contact"]
    # pyvista in a subprocess: a crash of its reader fails the test, not pytest
    assert _fault_injection().pyvista_fields(tmp_path) == {
        "u_bar": (5, bar),
        "w_contact": (5, contact),
    }
    for stem, names in (("u_bar", bar), ("w_contact", contact)):
        with meshio.xdmf.TimeSeriesReader(tmp_path / f"{stem}.xdmf") as series:
            assert series.read_points_cells()[0].shape == ((44, 3) if stem == "u_bar" else (4, 3))
            assert series.num_steps == 5
            for k in range(5):
                t, nodal, cells = series.read_data(k)
                assert t == pytest.approx(0.1 * k) and sorted({*nodal, *cells}) == names


def test_a_checkpoint_is_synced_to_the_disk_after_every_file_of_the_steps_it_covers(
    tmp_path, falling_bar, monkeypatch
):
    """A crash of the machine keeps what a checkpoint says is done: each file written before
    the checkpoint is synced before the checkpoint itself, which is synced before it counts."""
    import os

    import dd_contact.checkpointing as checkpointing
    import dd_contact.writing as writing

    synced: list[str] = []
    real = os.fsync

    def fsync(fd):
        synced.append(os.readlink(f"/proc/self/fd/{fd}"))
        real(fd)

    monkeypatch.setattr(os, "fsync", fsync)
    monkeypatch.setattr(writing, "_syncfs", None)  # each file's fsync: what was synced is seen
    commits = []
    commit = checkpointing.Checkpoint.commit
    monkeypatch.setattr(
        checkpointing.Checkpoint, "commit", lambda self: (commits.append(len(synced)), commit(self))
    )
    out = tmp_path / "run"
    _run(falling_bar()[1], out, steps=8)  # checkpoints at steps 4 and 8
    assert len(commits) == 2
    files = [p for p in out.rglob("*") if p.is_file() and "checkpoint" not in p.name]
    first = synced[: commits[0]]
    checkpoint = str(out / "checkpoint.rank0.npz.tmp")
    assert first[-1] == checkpoint  # the checkpoint last, before it replaces the previous one
    step_4 = [p for p in files if p.suffix == ".h5" and p.stem.isdigit() and int(p.stem) <= 4]
    assert len(step_4) >= 5 and all(str(p) in first[:-1] for p in step_4)
    assert str(out / "history.csv") in first and str(out / "history.json") in first
    assert str(out) in synced  # the renames
    after = synced[commits[1] :]  # the renames, then what the run's end wrote
    assert after[:2] == [str(out), str(out.parent)] and str(out / "history.json") in after
    assert set(map(str, files)) <= set(synced)
    assert writing._unsynced == set()


def test_one_syncfs_per_file_system_makes_the_output_durable(tmp_path, monkeypatch):
    import dd_contact.writing as writing

    if writing._syncfs is None:
        pytest.skip("no syncfs in this C library: each file is synced")
    calls = []
    real = writing._syncfs
    monkeypatch.setattr(writing, "_syncfs", lambda fd: calls.append(fd) or real(fd))
    for k in range(3):
        writing.replace_atomically(tmp_path / f"{k}.h5", lambda f: f.write(b"x"), "a step")
    writing.append_or_undo(tmp_path / "history.csv", b"1,2\n", "a row")
    assert len(writing._unsynced) == 4
    writing.make_durable(tmp_path / "checkpoint.npz")
    assert len(calls) == 1 and writing._unsynced == set()
    writing.make_durable()
    assert len(calls) == 1  # nothing new: no sync
