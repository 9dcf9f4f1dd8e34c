"""Output for ParaView: VTX (ADIOS2) files of every mesh's displacement."""

from __future__ import annotations

from pathlib import Path

from mpi4py import MPI

import dolfinx.io

from dd_contact.scene import Scene

__all__ = ["write_vtx"]


def write_vtx(scene: Scene, directory: str | Path, time: float = 0.0) -> list[Path]:
    """Write ``u_<subdomain>.bp`` and ``v_<interface>.bp`` into ``directory``.

    Meshes are held by every rank, so only rank 0 writes.

    Returns:
        The paths written (on rank 0; empty on other ranks).
    """
    if scene.comm.rank != 0:
        return []
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    functions = [s.u for s in scene.subdomains]
    if scene.interface is not None:
        functions.append(scene.interface.v)
    paths = []
    for f in functions:
        path = directory / f"{f.name}.bp"
        with dolfinx.io.VTXWriter(MPI.COMM_SELF, path, [f], engine="BP4") as writer:
            writer.write(time)
        paths.append(path)
    return paths
