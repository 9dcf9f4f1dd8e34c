"""Output: result files for ParaView, the history of a run (JSON and CSV), checkpoints.

Every mesh lives on one rank (see :class:`dd_contact.scene.Scene`): each rank writes the
meshes it owns, so no file is written by two ranks; the lists of paths returned are
gathered from every rank. Every writer first checks, on rank 0, that its directory can be
written (:func:`check_writable`), so a bad path is an :class:`InputError` on every rank,
never an abort inside the file library. Nothing written is damaged by an interruption
(:mod:`dd_contact.writing`; docs/output.md says what survives what); a write that fails
raises one :class:`~dd_contact.errors.OutputError` on every rank.
"""

from __future__ import annotations

import csv
import json
import tempfile
from collections.abc import Callable
from io import StringIO
from pathlib import Path

from mpi4py import MPI

import dolfinx.io
import numpy as np

from dd_contact.checkpointing import Checkpoint
from dd_contact.errors import InputError, OutputError
from dd_contact.parallel import ROOT, allgathered, any_rank, bcast_from_root
from dd_contact.post import output_fields
from dd_contact.scene import Scene
from dd_contact.series import SeriesWriter
from dd_contact.writing import (
    append_or_undo,
    logger,
    make_durable,
    remove_temporary,
    replace_atomically,
)

__all__ = [
    "Checkpoint",
    "History",
    "ResultWriter",
    "RunOutput",
    "check_writable",
    "flat_record",
    "write_vtx",
]


def _unwritable(directory: Path) -> str | None:
    """Why ``directory`` cannot hold output (creating it if missing), or ``None``."""
    if directory.exists() and not directory.is_dir():
        return "is an existing file, not a directory; give a directory path"
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        return f"cannot be created ({error.strerror}); give a directory you can write to"
    try:
        with tempfile.TemporaryFile(dir=directory):
            pass
    except OSError as error:
        return f"is not writable ({error.strerror}); give a directory you can write to"
    return None


def check_writable(comm: MPI.Comm, directory: str | Path, argument: str = "output") -> Path:
    """Collective: create ``directory`` if missing and check it can be written.

    Checked on rank 0 (the ranks share the file system) and broadcast, so every rank raises
    the same :class:`InputError`, naming ``argument``, the path and the fix.
    """
    directory = Path(directory)
    problem = _unwritable(directory) if comm.rank == ROOT else None
    problem = bcast_from_root(comm, problem)
    if problem is not None:
        raise InputError(f"{argument}: the directory {str(directory)!r} {problem}")
    return directory


def _gathered_paths(comm: MPI.Comm, paths: list[Path]) -> list[Path]:
    """Collective: the paths written by every rank, in rank order, on every rank."""
    parts = allgathered(comm, paths)
    return [p for part in parts for p in part]


class ResultWriter:
    """Writes the fields of every owned mesh as a series (``<stem>.xdmf`` and ``<stem>/``).

    Per subdomain: displacement, velocity and acceleration (``dynamic``), the cell stress
    tensor and von Mises stress (DG0); the interface: v; per contact region: w, pressure,
    gap and active nodes. Each written step is a file of its own, listed in the series'
    index once complete (:mod:`dd_contact.series`, docs/output.md): an interruption never
    damages what was written before.

    With ``keep`` (a resumed run at its checkpoint's step) the series continue: steps
    written after ``keep`` are removed (the resumed run writes them again, bit for bit), a
    damaged index or step file is repaired or set aside, with a line saying so.

    Collective: every rank sets up the series of the meshes it owns.

    Args:
        scene: The scene.
        directory: Output directory (created if missing).
        dynamic: Also write velocity and acceleration.
        keep: ``None``: new series; a step: continue the series after it.
    """

    def __init__(
        self, scene: Scene, directory: str | Path, dynamic: bool = False, keep: int | None = None
    ):
        self.directory = check_writable(scene.comm, directory)
        self.fields = output_fields(scene, scene.comm.rank, dynamic)
        self.series = [SeriesWriter(self.directory, f, keep) for f in self.fields]
        paths = [self.directory / f"{f.stem}.xdmf" for f in self.fields]
        #: Every series' index, by every rank (the same list on every rank).
        self.paths = _gathered_paths(scene.comm, paths)

    def write(self, step: int, t: float) -> None:
        """Write the current values as step ``step`` at time ``t`` (rank-local: own meshes).

        Raises :class:`~dd_contact.errors.OutputError` if a file cannot be written.
        """
        for series in self.series:
            series.write(step, t)

    def close(self) -> None:
        """Nothing stays open between writes: kept for symmetry with other writers."""
        self.series = []


def write_vtx(scene: Scene, directory: str | Path, time: float = 0.0) -> list[Path]:
    """Collective: write the current fields of every mesh once as VTX (ADIOS2 ``.bp``).

    The same fields as :class:`ResultWriter` without velocity and acceleration, one
    ``<stem>.bp`` per mesh, written by its owner. Returns the paths written by every rank.
    """
    directory = check_writable(scene.comm, directory, "write_vtx directory")
    paths = []
    for fields in output_fields(scene, scene.comm.rank, dynamic=False):
        fields.refresh(time)
        path = directory / f"{fields.stem}.bp"
        writer = dolfinx.io.VTXWriter(MPI.COMM_SELF, path, fields.functions, engine="BP4")
        writer.write(time)
        writer.close()
        paths.append(path)
    return _gathered_paths(scene.comm, paths)


def flat_record(record: dict, prefix: str = "") -> dict[str, float | int | str]:
    """A history record as flat columns: nested keys joined by ``.``, vectors by x, y, z."""
    out: dict[str, float | int | str] = {}
    for key, value in record.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(flat_record(value, f"{name}."))
        elif isinstance(value, list | tuple | np.ndarray):
            labels = "xyz" if len(value) == 3 else [str(i) for i in range(len(value))]
            out.update({f"{name}.{c}": v for c, v in zip(labels, value, strict=True)})
        else:
            out[name] = value
    return out


def _csv_rows(records: list[dict], columns: list[str] | None, header: bool) -> bytes:
    """CSV text of ``records`` (the columns of the first one unless given)."""
    rows = [flat_record(r) for r in records]
    columns = columns if columns is not None else list(rows[0])
    text = StringIO(newline="")
    writer = csv.writer(text)
    if header:
        writer.writerow(columns)
    writer.writerows([row.get(c, "") for c in columns] for row in rows)
    return text.getvalue().encode()


class History:
    """The history of a run in ``history.json`` and ``history.csv`` (written by rank 0).

    The CSV grows by one row per step, written at once (a failed write is undone); the JSON
    is replaced atomically when asked, at checkpoints and at the end of a run. After a
    resume both start again from the history restored with the checkpoint.

    Args:
        directory: Output directory.
        comm: Communicator of the run.
    """

    def __init__(self, directory: str | Path, comm: MPI.Comm):
        self.directory = Path(directory)
        self.comm = comm
        self.json_path = self.directory / "history.json"
        self.csv_path = self.directory / "history.csv"
        self._columns: list[str] | None = None

    def restart(self, history: list[dict]) -> None:
        """Start both files from ``history`` (rank 0 writes; rank-local)."""
        if self.comm.rank != ROOT:
            return
        for path in (self.csv_path, self.json_path):
            remove_temporary(path)
        self._columns = list(flat_record(history[0])) if history else None
        try:
            if self.json_path.exists():
                json.loads(self.json_path.read_text())
        except ValueError as error:
            logger.warning("%s: it cannot be read (%s); rewritten", self.json_path, error)
        if self.csv_path.exists() and not self.csv_path.read_bytes().endswith(b"\n"):
            logger.warning("%s: its last row was cut short; rewritten", self.csv_path)
        if history:
            rows = _csv_rows(history, self._columns, header=True)
            replace_atomically(self.csv_path, lambda f: f.write(rows), "history.csv")
        else:
            self.csv_path.unlink(missing_ok=True)
        self.save(history)

    def append(self, record: dict) -> None:
        """Add one step's row to the CSV (rank 0 writes; rank-local)."""
        if self.comm.rank != ROOT:
            return
        header = self._columns is None
        if header:
            self._columns = list(flat_record(record))
        row = _csv_rows([record], self._columns, header)
        append_or_undo(self.csv_path, row, f"history.csv (step {record.get('step')})")

    def save(self, history: list[dict]) -> None:
        """Replace ``history.json`` atomically (rank 0 writes; rank-local)."""
        if self.comm.rank != ROOT:
            return
        text = json.dumps(history).encode()
        replace_atomically(self.json_path, lambda f: f.write(text), "history.json")

    def load(self) -> list[dict]:
        """Collective: the history in ``history.json`` on every rank (empty if none).

        Raises :class:`InputError` if the file is damaged.
        """
        history: list[dict] | str | None = None
        if self.comm.rank == ROOT:
            try:
                history = json.loads(self.json_path.read_text()) if self.json_path.exists() else []
            except ValueError as error:
                history = f"{self.json_path} cannot be read ({error})"
        history = bcast_from_root(self.comm, history)
        if isinstance(history, str):
            raise InputError(
                f"resume: {history} and the checkpoint (of an earlier version) holds no "
                "history; start a new output directory"
            )
        assert history is not None  # the root's
        return history


def agreed_error(comm: MPI.Comm, error: OutputError | None) -> OutputError | None:
    """Collective: the first rank's error (by rank) if any rank has one, on every rank."""
    if not any_rank(comm, error is not None):
        return None
    found = [e for e in allgathered(comm, None if error is None else (str(error), error.errno))]
    message, code = next(e for e in found if e is not None)
    out = OutputError(message)
    out.errno = code
    return out


class RunOutput:
    """What a run writes to its output directory: fields, history and checkpoints.

    Creating it checks the directory (collective, before any solve). A write that fails on
    any rank raises one :class:`OutputError` on every rank, which says how to go on; after
    it nothing more is written (closing included).

    Args:
        scene: The scene.
        directory: Output directory.
        dynamic: Also write velocity and acceleration.
    """

    def __init__(self, scene: Scene, directory: str | Path, dynamic: bool):
        self.scene, self.dynamic = scene, dynamic
        self.directory = check_writable(scene.comm, directory, "run(output=...)")
        self.checkpoint = Checkpoint(self.directory, scene.comm)
        self.history = History(self.directory, scene.comm)
        self.fields: ResultWriter | None = None
        #: The step of the last checkpoint written or restored (``None``: none).
        self.checkpointed: int | None = None
        self._failed = False

    def _attempt(self, action: Callable[[], None]) -> None:
        """Collective: run ``action``; if it fails to write on some rank, raise everywhere."""
        local = None
        try:
            action()
        except OutputError as failed:
            local = failed
        error = agreed_error(self.scene.comm, local)
        if error is not None:
            self._failed = True
            if self.checkpointed is None:
                then = "no checkpoint was written (checkpoint_every=...): run again from the start"
            else:
                then = (
                    f"the checkpoint at step {self.checkpointed} is intact: make room (or move "
                    "the directory to a disk with room) and run again with resume=True"
                )
            raised = OutputError(f"run(output=...): {error}; {then}")
            raised.errno = error.errno
            raise raised from local

    def restore(self) -> tuple[dict[str, np.ndarray], list[dict]]:
        """Collective: the checkpoint's state and history (found by ``checkpoint.exists()``)."""
        state, history = self.checkpoint.load()
        self.checkpointed = int(state["step"])
        return state, history if history is not None else self.history.load()

    def open(self, step: int, t: float, history: list[dict]) -> None:
        """Collective: start (``step`` 0: its fields written) or continue the files."""

        def start():
            self.history.restart(history)
            self.fields = ResultWriter(
                self.scene, self.directory, self.dynamic, step if step > 0 else None
            )
            if step == 0:
                self.fields.write(0, t)

        self._attempt(start)

    def record(
        self,
        record: dict,
        history: list[dict],
        state: Callable[[], dict[str, np.ndarray]],
        output_every: int,
        checkpoint_every: int | None,
    ) -> None:
        """Collective: one step's history row, its fields and checkpoint if their turn."""
        step = record["step"]

        def write():
            self.history.append(record)
            if step % output_every == 0 and self.fields is not None:
                self.fields.write(step, record["t"])

        self._attempt(write)
        if checkpoint_every and step % checkpoint_every == 0:
            self.save(state(), history)
            logger.info("checkpoint at step %d (t = %.6g)", step, record["t"])

    def save(self, state: dict[str, np.ndarray], history: list[dict]) -> None:
        """Collective: a checkpoint (with the history) and ``history.json``."""
        try:
            self._attempt(lambda: self.checkpoint.write(state, history))
        except OutputError:
            self.checkpoint.discard()  # the ranks whose write went through: theirs too
            raise
        self.checkpoint.commit()
        self.checkpointed = int(state["step"])
        self._attempt(lambda: self.history.save(history))

    def _save_durably(self, history: list[dict]) -> None:
        """The final history, and the whole run on the disk when it returns."""
        self.history.save(history)
        make_durable()

    def close(self, history: list[dict], error: BaseException | None = None) -> None:
        """The final ``history.json`` (unless a write failed); closed field files.

        Collective after a run that ended well (a failed write raises
        :class:`OutputError` on every rank); rank-local after ``error``, whose propagation
        a failed write does not replace (it is noted on ``error``).
        """
        if self.fields is not None:
            self.fields.close()
            self.fields = None
        if self._failed:
            return
        if error is None:
            self._attempt(lambda: self._save_durably(history))
            return
        try:
            self.history.save(history)
        except OutputError as failed:
            error.add_note(f"dd_contact: {failed}")
