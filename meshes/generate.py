"""Regenerate the small meshes shipped in this folder (docs/models.md).

    python meshes/generate.py [FOLDER]      # default: this folder

``parallelepiped_small.xdmf``: the bar of ``dd_contact.paper.models.parallelepiped("small")``:
subdomains ``Omega1``, ``Omega2`` (facet tags ``<name>_facets``, values
``dd_contact.paper.models.FACE_TAGS``), the interface ``interface`` and the contact interface
``end``. ``pin_joint_small.xdmf``: every mesh of
``dd_contact.paper.models.pin_joint_meshes("small")``: the 12 plate blocks with their facet
tags, the interface ``cuts`` and the hole walls ``wall_<subdomain>``. Read them with
:func:`read`; ``tests/test_models.py`` checks that the shipped files equal what this script
makes.
"""

from __future__ import annotations

import sys
from pathlib import Path

from mpi4py import MPI

import dolfinx.io
import dolfinx.mesh

from dd_contact.paper import models

HERE = Path(__file__).resolve().parent
FILES = ("parallelepiped_small", "pin_joint_small")


def model_meshes() -> dict[str, dict[str, tuple[dolfinx.mesh.Mesh, dolfinx.mesh.MeshTags | None]]]:
    """``{file stem: {mesh name: (mesh, facet tags or None)}}`` of the shipped models."""
    bar = models.parallelepiped("small", comm=MPI.COMM_SELF)
    length = models.BAR_SIZE[0]
    cut = bar.subdomains[0].mesh.geometry.x[:, 0].max()
    boxes = {"Omega1": (0.0, cut), "Omega2": (cut, length)}
    bar_meshes = {}
    for part in bar.subdomains:
        x0, x1 = boxes[part.name]
        tags = models.block_tags(part.mesh, (x0, 0.0, 0.0), (x1, *models.BAR_SIZE[1:]))
        bar_meshes[part.name] = (part.mesh, tags)
    bar_meshes["interface"] = (bar.interface.mesh, None)
    bar_meshes["end"] = (bar.contacts[0].mesh, None)

    joint = models.pin_joint_meshes("small")
    joint_meshes = dict(joint.subdomains)
    joint_meshes["cuts"] = (joint.interface, None)
    joint_meshes |= {f"wall_{name}": (wall, None) for name, wall in joint.walls.items()}
    return {"parallelepiped_small": bar_meshes, "pin_joint_small": joint_meshes}


def write(folder: Path = HERE) -> list[Path]:
    """Write the shipped meshes into ``folder``; returns the XDMF files."""
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for stem, items in model_meshes().items():
        path = folder / f"{stem}.xdmf"
        with dolfinx.io.XDMFFile(MPI.COMM_SELF, path, "w") as file:
            for name, (mesh, tags) in items.items():
                mesh.name = name
                file.write_mesh(mesh)
                if tags is not None:
                    tags.name = f"{name}_facets"
                    file.write_meshtags(
                        tags, mesh.geometry, f"/Xdmf/Domain/Grid[@Name='{name}']/Geometry"
                    )
        written.append(path)
    return written


def read(
    path: Path, names: list[str]
) -> dict[str, tuple[dolfinx.mesh.Mesh, dolfinx.mesh.MeshTags | None]]:
    """The meshes ``names`` of a shipped file, with their facet tags where they have them."""
    out = {}
    with dolfinx.io.XDMFFile(MPI.COMM_SELF, path, "r") as file:
        for name in names:
            mesh = file.read_mesh(name=name)
            tags = None
            if mesh.topology.dim == 3:
                mesh.topology.create_connectivity(2, 3)
                tags = file.read_meshtags(mesh, name=f"{name}_facets")
            out[name] = (mesh, tags)
    return out


if __name__ == "__main__":
    for path in write(Path(sys.argv[1]) if len(sys.argv) > 1 else HERE):
        print(f"wrote {path}")
