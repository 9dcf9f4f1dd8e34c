"""SIGTERM and SIGUSR1 stop a run at the next step boundary, checkpointed and resumable."""

import json
import signal
import subprocess
import sys
import textwrap
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

RUN = textwrap.dedent(
    """
    import os, signal, sys
    import numpy as np
    from mpi4py import MPI
    import dd_contact as dd
    from dd_contact import meshes

    out, stop_at, signum, resume = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
    bar = dd.Subdomain(
        meshes.box(MPI.COMM_SELF, [0.002, 0, 0], [1.002, 0.1, 0.1], [10, 1, 1]),
        dd.Material(1.0, 0.0, 1.0),
        "bar",
    )
    bar.velocity.interpolate(lambda x: np.vstack([np.full(x.shape[1], -0.01), 0 * x[0], 0 * x[0]]))
    end = dd.ContactBoundary(
        bar, lambda x: np.isclose(x[0], 0.002), dd.Plane([0, 0, 0], [1, 0, 0]), contact_kappa=1.0
    )
    problem = dd.TransientProblem(dd.Scene(MPI.COMM_WORLD, [bar], contacts=[end]), dt=0.1)

    def kill(record):
        if record["step"] == stop_at and MPI.COMM_WORLD.rank == 0:
            os.kill(os.getpid(), signum)

    problem.run(
        30, output=out, checkpoint_every=5, resume=resume == "resume", callback=kill,
        progress=False, summary=False,
    )
    np.save(os.path.join(out, f"u_final_{MPI.COMM_WORLD.rank}.npy"), bar.u.x.array)
    """
)


MPIEXEC = Path(sys.executable).with_name("mpiexec")


def _run(script, out, stop_at, signum, resume, ranks=1):
    command = [sys.executable, str(script), str(out), str(stop_at), str(int(signum)), resume]
    if ranks > 1:
        command = [str(MPIEXEC), "-n", str(ranks), *command]
    return subprocess.run(command, capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize(
    ("signum", "stop_at", "ranks"),
    [(signal.SIGTERM, 12, 1), (signal.SIGUSR1, 7, 1), (signal.SIGTERM, 9, 2)],
)
def test_a_signal_stops_the_run_at_the_step_boundary_and_it_resumes_bit_for_bit(
    tmp_path, signum, stop_at, ranks
):
    """The signal reaches rank 0 only: every rank stops at the same step."""
    if ranks > 1 and not MPIEXEC.exists():
        pytest.skip("no mpiexec beside this Python")
    script = tmp_path / "run.py"
    script.write_text(RUN)
    whole, stopped = tmp_path / "whole", tmp_path / "stopped"
    assert _run(script, whole, 0, signum, "new", ranks).returncode == 0
    done = _run(script, stopped, stop_at, signum, "new", ranks)
    assert done.returncode == 128 + signum, done.stderr[-2000:]  # mpiexec passes it on
    name = signal.Signals(signum).name
    assert f"run stopped by {name} at step {stop_at}" in done.stderr
    assert "run again with resume=True to continue" in done.stderr
    assert "Traceback" not in done.stderr and "PETSC ERROR" not in done.stderr
    history = json.loads((stopped / "history.json").read_text())
    assert [r["step"] for r in history] == list(range(1, stop_at + 1))  # each step once
    ET.parse(stopped / "u_bar.xdmf")  # the field file was closed: it parses
    again = _run(script, stopped, 0, signum, "resume", ranks)
    assert again.returncode == 0, again.stderr[-2000:]
    np.testing.assert_array_equal(
        np.load(stopped / "u_final_0.npy"), np.load(whole / "u_final_0.npy")
    )
    resumed = json.loads((stopped / "history.json").read_text())
    assert resumed == json.loads((whole / "history.json").read_text())
