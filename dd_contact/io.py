"""Output: result files for ParaView, the history of a run (JSON and CSV), checkpoints.

Every mesh lives on one rank (see :class:`dd_contact.scene.Scene`): each rank writes the
meshes it owns, so no file is written by two ranks; the lists of paths returned are
gathered from every rank. Every writer first checks, on rank 0, that its directory can be
written (:func:`check_writable`), so a bad path is an :class:`InputError` on every rank,
never an abort inside the file library.
"""

from __future__ import annotations

import csv
import json
import os
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

from mpi4py import MPI

import dolfinx.fem as fem
import dolfinx.io
import numpy as np

from dd_contact.errors import InputError
from dd_contact.parallel import ROOT, allgathered, barrier, bcast_from_root, every_rank
from dd_contact.post import MeshFields, output_fields
from dd_contact.scene import Scene

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


def _written_times(path: Path) -> list[float]:
    """The times already stored in an XDMF file (empty if it does not exist)."""
    if not path.exists():
        return []
    return [float(e.attrib["Value"]) for e in ET.parse(path).getroot().iter("Time")]


class ResultWriter:
    """Streams the fields of every owned mesh to XDMF files (``<stem>.xdmf`` + ``.h5``).

    Per subdomain: displacement, velocity and acceleration (``dynamic``), the cell stress
    tensor and von Mises stress (DG0); the interface: v; per contact region: w, pressure,
    gap and active nodes. Fields of a higher degree than their mesh are written as
    interpolants on the mesh's nodes (XDMF's rule).

    With ``append=True`` (a resumed run) writing continues in the same files: ParaView
    sees one series. Times already in a file are skipped: a resumed run recomputes the
    steps after its checkpoint bit for bit, so those are already there.

    Collective: every rank creates (and closes) the writers of the meshes it owns.

    Args:
        scene: The scene.
        directory: Output directory (created if missing).
        dynamic: Also write velocity and acceleration.
        append: Continue existing files instead of starting new ones.
    """

    def __init__(
        self, scene: Scene, directory: str | Path, dynamic: bool = False, append: bool = False
    ):
        self.directory = check_writable(scene.comm, directory)
        self.fields = output_fields(scene, scene.comm.rank, dynamic)
        self.files: list[tuple[dolfinx.io.XDMFFile, MeshFields, list, float | None]] = []
        paths = []
        for fields in self.fields:
            path = self.directory / f"{fields.stem}.xdmf"
            times = _written_times(path) if append else []
            mode = "a" if times else "w"
            file = dolfinx.io.XDMFFile(MPI.COMM_SELF, path, mode)
            mesh = fields.functions[0].function_space.mesh
            if mode == "w":
                file.write_mesh(mesh)
            written = [_on_mesh_nodes(f) for f in fields.functions]
            self.files.append((file, fields, written, max(times) if times else None))
            paths += [path, path.with_suffix(".h5")]
        #: Every file written, by every rank (the same list on every rank).
        self.paths = _gathered_paths(scene.comm, paths)

    def write(self, t: float) -> None:
        """Write the current values at time ``t`` (rank-local: each rank its own files)."""
        for file, fields, written, last in self.files:
            if last is not None and t - last <= 1e-9 * max(abs(t), abs(last), 1e-300):
                continue
            fields.refresh(t)
            for source, target in zip(fields.functions, written, strict=True):
                if target is not source:
                    target.interpolate(source)
                file.write_function(target, t)

    def close(self) -> None:
        """Close the files (rank-local)."""
        for file, *_ in self.files:
            file.close()
        self.files = []


def _on_mesh_nodes(f: fem.Function) -> fem.Function:
    """``f`` itself, or a Function of the mesh's own degree to interpolate it into."""
    mesh = f.function_space.mesh
    element = f.function_space.element.basix_element
    degree = mesh.geometry.cmaps[0].degree
    if element.discontinuous or element.degree == degree:
        return f
    shape = f.function_space.value_shape
    space = fem.functionspace(mesh, ("Lagrange", degree, shape))
    return fem.Function(space, name=f.name)


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


class History:
    """The history of a run in ``history.json`` and ``history.csv`` (written by rank 0).

    The CSV grows by one row per step; the JSON is rewritten (atomically) when asked, at
    checkpoints and at the end of a run. After a resume both start again from the
    history restored with the checkpoint.

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
        """Start both files from ``history`` (rank 0 writes)."""
        self._columns = None
        if self.comm.rank == ROOT:
            self.csv_path.unlink(missing_ok=True)
            for record in history:
                self.append(record)
        self.save(history)

    def append(self, record: dict) -> None:
        """Add one step's row to the CSV (rank 0 writes; rank-local)."""
        if self.comm.rank != ROOT:
            return
        row = flat_record(record)
        if self._columns is None:
            self._columns = list(row)
            with self.csv_path.open("w", newline="") as f:
                csv.writer(f).writerow(self._columns)
        with self.csv_path.open("a", newline="") as f:
            csv.writer(f).writerow([row.get(c, "") for c in self._columns])

    def save(self, history: list[dict]) -> None:
        """Rewrite ``history.json`` atomically (rank 0 writes; rank-local)."""
        if self.comm.rank != ROOT:
            return
        tmp = self.json_path.with_suffix(".json.tmp")
        tmp.write_text(json.dumps(history))
        os.replace(tmp, self.json_path)

    def load(self) -> list[dict]:
        """Collective: the history in ``history.json`` on every rank (empty if none)."""
        history: list[dict] | None = None
        if self.comm.rank == ROOT:
            history = json.loads(self.json_path.read_text()) if self.json_path.exists() else []
        history = bcast_from_root(self.comm, history)
        assert history is not None  # the root's
        return history


class Checkpoint:
    """The state of a run, one ``.npz`` file per rank (the history is :class:`History`'s).

    Files are written to a temporary name and renamed, so an interruption while writing
    leaves the previous checkpoint intact.

    Args:
        directory: Where the checkpoint lives.
        comm: Communicator of the run.
    """

    def __init__(self, directory: str | Path, comm: MPI.Comm):
        self.directory = Path(directory)
        self.comm = comm
        self.path = self.directory / f"checkpoint.rank{comm.rank}.npz"

    def exists(self) -> bool:
        """Collective: whether every rank finds its checkpoint file."""
        return every_rank(self.comm, self.path.exists())

    def save(self, arrays: dict[str, np.ndarray]) -> None:
        """Collective: write this rank's arrays."""
        self.directory.mkdir(parents=True, exist_ok=True)
        tmp = self.path.with_name(self.path.name + ".tmp.npz")
        # numpy's stub: a key of **arrays might be its keyword allow_pickle (a bool); none is
        np.savez(tmp, **arrays)  # type: ignore[arg-type]
        os.replace(tmp, self.path)
        barrier(self.comm)

    def load(self) -> dict[str, np.ndarray]:
        """This rank's arrays (rank-local)."""
        with np.load(self.path) as data:
            return {k: data[k] for k in data.files}


class RunOutput:
    """What a run writes to its output directory: fields, history and checkpoints.

    Creating it checks the directory (collective, before any solve).

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

    def open(self, step: int, history: list[dict]) -> None:
        """Collective: start (``step`` 0) or continue the field and history files."""
        self.history.restart(history)
        self.fields = ResultWriter(self.scene, self.directory, self.dynamic, append=step > 0)

    def record(self, record: dict, write_fields: bool) -> None:
        """One step: its history row and, if asked, its fields (rank-local)."""
        self.history.append(record)
        if write_fields and self.fields is not None:
            self.fields.write(record["t"])

    def save(self, state: dict[str, np.ndarray], history: list[dict]) -> None:
        """Collective: a checkpoint (the history first, so it always covers the state)."""
        self.history.save(history)
        self.checkpoint.save(state)

    def close(self, history: list[dict]) -> None:
        """Rank-local: the final history and closed field files (also after an error)."""
        self.history.save(history)
        if self.fields is not None:
            self.fields.close()
            self.fields = None
