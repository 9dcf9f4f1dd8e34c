"""Output for ParaView (VTX/ADIOS2 files of every mesh) and checkpoints of long runs.

Every mesh lives on one rank (see :class:`dd_contact.scene.Scene`): each rank writes the
meshes it owns, so no file is written by two ranks.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from mpi4py import MPI

import dolfinx.io
import numpy as np

from dd_contact.scene import Scene

__all__ = ["Checkpoint", "ResultWriter", "write_vtx"]


def _owned_functions(scene: Scene) -> list[list]:
    """Function groups (one group per mesh) owned by this rank."""
    rank = scene.comm.rank
    groups = [[s.u] for k, s in enumerate(scene.subdomains) if scene.owner(k) == rank]
    if scene.interface is not None and rank == 0:
        groups.append([scene.interface.v])
    for c in scene.contacts:
        if scene.contact_owner(c) == rank:
            groups.append([c.w, c.pressure])
    return groups


class ResultWriter:
    """Streams displacements (and contact pressure) of every owned mesh to VTX files.

    One ``<name>.bp`` per mesh; a resumed run starts new files ``<name>.from<step>.bp`` so
    that what was written before the interruption is kept as it is.

    Args:
        scene: The scene.
        directory: Output directory.
        first_step: Step the run starts from (0 for a fresh run).
    """

    def __init__(self, scene: Scene, directory: str | Path, first_step: int = 0):
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        suffix = "" if first_step == 0 else f".from{first_step:06d}"
        self.writers = []
        self.paths = []
        for group in _owned_functions(scene):
            path = self.directory / f"{group[0].name}{suffix}.bp"
            self.writers.append(dolfinx.io.VTXWriter(MPI.COMM_SELF, path, group, engine="BP4"))
            self.paths.append(path)

    def write(self, t: float) -> None:
        """Write the current values at time ``t``."""
        for writer in self.writers:
            writer.write(t)

    def close(self) -> None:
        """Close the files."""
        for writer in self.writers:
            writer.close()
        self.writers = []


def write_vtx(scene: Scene, directory: str | Path, time: float = 0.0) -> list[Path]:
    """Write the current fields of every owned mesh once; returns the paths written."""
    writer = ResultWriter(scene, directory)
    writer.write(time)
    writer.close()
    return writer.paths


class Checkpoint:
    """The state of a run, one ``.npz`` file per rank plus the shared history (JSON).

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
        self.history_path = self.directory / "history.json"

    def exists(self) -> bool:
        """Whether every rank finds its checkpoint file."""
        return self.comm.allreduce(self.path.exists(), op=MPI.LAND)

    def save(self, arrays: dict[str, np.ndarray], history: list[dict]) -> None:
        """Write this rank's arrays (and, on rank 0, the history)."""
        self.directory.mkdir(parents=True, exist_ok=True)
        tmp = self.path.with_name(self.path.name + ".tmp.npz")
        np.savez(tmp, **arrays)
        os.replace(tmp, self.path)
        if self.comm.rank == 0:
            tmp = self.history_path.with_suffix(".json.tmp")
            tmp.write_text(json.dumps(history))
            os.replace(tmp, self.history_path)
        self.comm.Barrier()

    def load(self) -> tuple[dict[str, np.ndarray], list[dict]]:
        """This rank's arrays and the history."""
        with np.load(self.path) as data:
            arrays = {k: data[k] for k in data.files}
        history = None
        if self.comm.rank == 0:
            history = json.loads(self.history_path.read_text())
        return arrays, self.comm.bcast(history)
