"""One mesh's fields over time (XDMF 3 and HDF5), written so that no interruption damages them.

The files of the mesh whose output stem is ``<stem>`` (``u_block``, ``w_contact``):

* ``<stem>/mesh.h5``: ``/geometry`` (nodes x 3, float64) and ``/topology`` (cells x nodes
  per cell, int64, in VTK's node order);
* ``<stem>/<step>.h5`` (``<stem>/000012.h5``), one per written step: a dataset per field,
  named as the field, with what the index shows: the values at the mesh nodes
  (``Center="Node"``) or per cell (``"Cell"``), components last (a 3x3 tensor in 9
  columns); where those are not the Function's own values (a degree-2 field on a degree-1
  mesh, shown by its values at the nodes) also ``/dofs/<field>``, the Function's array;
  attributes ``step`` and ``t``;
* ``<stem>.xdmf``: the index, one temporal collection with a grid per written step (its
  time, the mesh and every field), which ParaView, pyvista and meshio open.

A step's file is made in memory (:func:`hdf5_image`) and written under a temporary name,
renamed once complete, before the step enters the index, which is replaced the same way
(:func:`dd_contact.writing.replace_atomically`): killed at any moment, the index lists only
complete steps; a write that fails removes what it started.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from io import BytesIO
from pathlib import Path
from xml.etree import ElementTree as ET
from xml.sax.saxutils import escape, quoteattr

import dolfinx.fem as fem
import dolfinx.plot
import h5py
import numpy as np

from dd_contact.post import MeshFields
from dd_contact.writing import failure, logger, remove_temporary, replace_atomically, set_aside

__all__ = [
    "FieldLayout",
    "SeriesWriter",
    "hdf5_image",
    "read_index",
    "read_step",
    "step_file",
    "step_files",
]

#: The mesh file of a series, in its folder.
MESH_FILE = "mesh.h5"
_STEP_FILE = re.compile(r"^(\d+)\.h5$")
_GRID_NAME = re.compile(r"^step (\d+)$")

#: XDMF's topology type by dolfinx cell type and nodes per cell.
_TOPOLOGY = {
    ("triangle", 3): "Triangle",
    ("triangle", 6): "Triangle_6",
    ("quadrilateral", 4): "Quadrilateral",
    ("quadrilateral", 9): "Quadrilateral_9",
    ("tetrahedron", 4): "Tetrahedron",
    ("tetrahedron", 10): "Tetrahedron_10",
    ("hexahedron", 8): "Hexahedron",
    ("hexahedron", 27): "Hexahedron_27",
}
_ATTRIBUTE = {(): "Scalar", (3,): "Vector", (3, 3): "Tensor"}


def step_file(step: int) -> str:
    """The name of a step's file in its series' folder."""
    return f"{step:06d}.h5"


def step_files(folder: Path) -> dict[int, Path]:
    """The step files in a series' folder, by step."""
    if not folder.is_dir():
        return {}
    found = {}
    for path in folder.iterdir():
        match = _STEP_FILE.match(path.name)
        if match:
            found[int(match.group(1))] = path
    return dict(sorted(found.items()))


class FieldLayout:
    """How one Function is stored: at the mesh nodes, per cell, or shown by its interpolant.

    A continuous field of the mesh's own degree is stored at the nodes and a cell-wise
    constant one per cell: both are the Function's values, rearranged. Any other is shown
    by its interpolant at the nodes and kept as its array too (``dofs/<name>``).

    Args:
        f: The Function (writing) or a Function on the same space (reading).
    """

    def __init__(self, f: fem.Function):
        space = f.function_space
        mesh = space.mesh
        element = space.element.basix_element
        self.name = f.name
        self.shape = tuple(space.value_shape)
        self.size = int(np.prod(self.shape, dtype=int))
        cellwise = element.discontinuous and element.degree == 0
        degree = mesh.geometry.cmaps[0].degree
        self.center = "Cell" if cellwise else "Node"
        #: Whether the stored values are the Function's own (else its array is kept too).
        self.exact = cellwise or (not element.discontinuous and element.degree == degree)
        self._shown = f
        if not self.exact:
            nodal = fem.functionspace(mesh, ("Lagrange", degree, self.shape))
            self._shown = fem.Function(nodal, name=f.name)
        self._dofs = self._shown.function_space.dofmap.list
        self._nodes = mesh.geometry.dofmaps[0]
        self._num_nodes = mesh.geometry.x.shape[0]

    @property
    def attribute(self) -> str:
        """The XDMF attribute type."""
        return _ATTRIBUTE.get(self.shape, "Matrix")

    def values(self, f: fem.Function) -> np.ndarray:
        """What the file stores of ``f``: rows per node or per cell, components last."""
        if self._shown is not f:
            self._shown.interpolate(f)
        x = self._shown.x.array.reshape(-1, self.size)
        if self.center == "Cell":
            out = x[self._dofs[:, 0]]
        else:
            out = np.empty((self._num_nodes, self.size))
            out[self._nodes.ravel()] = x[self._dofs.ravel()]
        return out[:, 0].copy() if self.shape == () else out

    def fill(self, f: fem.Function, data: h5py.File | dict) -> None:
        """Put a step's stored values of this field into ``f`` (a Function on its space)."""
        if not self.exact:
            f.x.array[:] = data[f"dofs/{self.name}"][()]
            return
        values = np.asarray(data[self.name][()]).reshape(-1, self.size)
        x = f.x.array.reshape(-1, self.size)
        if self.center == "Cell":
            x[self._dofs[:, 0]] = values
        else:
            x[self._dofs.ravel()] = values[self._nodes.ravel()]


def hdf5_image(arrays: dict[str, np.ndarray], attributes: dict | None = None) -> bytes:
    """An HDF5 file of ``arrays`` (and root ``attributes``), made in memory.

    The file system sees only plain writes of the finished image: a full disk is an
    ``OSError`` of Python's, never a failure inside the HDF5 library (which raised from its
    close and even crashed).
    """
    buffer = BytesIO()
    with h5py.File(buffer, "w") as data:
        data.attrs.update(attributes or {})
        for name, array in arrays.items():
            data[name] = array
    return buffer.getvalue()


def _item(dims: Sequence[int], source: str, number: str = "Float") -> str:
    shape = " ".join(str(n) for n in dims)
    return (
        f'<DataItem Dimensions="{shape}" NumberType="{number}" Precision="8" '
        f'Format="HDF">{escape(source)}</DataItem>'
    )


def read_index(path: Path) -> dict[int, float]:
    """The steps an index lists, with their times; raises ``ValueError`` if it is damaged."""
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as error:
        raise ValueError(f"it cannot be read ({error})") from error
    steps = {}
    for grid in root.iter("Grid"):
        if grid.get("GridType") != "Uniform":
            continue
        match = _GRID_NAME.match(grid.get("Name", ""))
        time = grid.find("Time")
        if match is None or time is None:
            raise ValueError("it is not a series of this version of dd_contact")
        steps[int(match.group(1))] = float(time.get("Value", "nan"))
    return steps


def read_step(path: Path, shapes: dict[str, tuple[int, ...]] | None = None) -> tuple[int, float]:
    """A step file's ``(step, t)``; ``ValueError`` if it is damaged or its fields differ.

    Args:
        path: The step file.
        shapes: The datasets it must hold, with their shapes.
    """
    try:
        with h5py.File(path, "r") as data:
            for name, shape in (shapes or {}).items():
                if data[name].shape != shape:
                    raise ValueError(f"its {name} has shape {data[name].shape}, not {shape}")
            return int(data.attrs["step"]), float(data.attrs["t"])
    except (OSError, KeyError) as error:
        raise ValueError(f"it cannot be read ({error})") from error


class SeriesWriter:
    """Rank-local: one mesh's series, written by the mesh's owner.

    Args:
        directory: The run's output directory.
        fields: The mesh's fields.
        keep: ``None`` starts a new series (this mesh's earlier files removed); a step
            continues the series after it (a resume): steps written after it are removed,
            to be written again, and a damaged index or step file is repaired or set aside.
    """

    def __init__(self, directory: Path, fields: MeshFields, keep: int | None):
        self.directory, self.fields, self.stem = directory, fields, fields.stem
        self.folder = directory / self.stem
        self.index = directory / f"{self.stem}.xdmf"
        self.layouts = [FieldLayout(f) for f in fields.functions]
        mesh = fields.functions[0].function_space.mesh
        nodes = mesh.geometry.dofmaps[0].shape[1]  # VTK's cells: count, then the nodes
        topology = dolfinx.plot.vtk_mesh(mesh)[0].reshape(-1, nodes + 1)[:, 1:]
        cell = (mesh.topology.cell_type.name, topology.shape[1])
        mesh_file = f"{self.stem}/{MESH_FILE}"
        self._mesh_xml = (
            f'<Topology TopologyType="{_TOPOLOGY[cell]}" NumberOfElements="{topology.shape[0]}">'
            f"{_item(topology.shape, f'{mesh_file}:/topology', 'Int')}</Topology>"
            f'<Geometry GeometryType="XYZ">{_item(mesh.geometry.x.shape, f"{mesh_file}:/geometry")}'
            "</Geometry>"
        )
        self._shapes = {
            layout.name: (topology.shape[0] if layout.center == "Cell" else len(mesh.geometry.x),)
            + ((layout.size,) if layout.shape != () else ())
            for layout in self.layouts
        }
        self.entries: dict[int, str] = {}
        try:
            self.folder.mkdir(exist_ok=True)
        except OSError as error:
            raise failure(error, f"the folder {self.stem}/", directory) from error
        remove_temporary(self.index)
        remove_temporary(self.folder / MESH_FILE)
        self._write_mesh(mesh.geometry.x, topology)
        if keep is None:
            self._start()
        else:
            self._recover(keep)

    # -- writing -------------------------------------------------------------------------
    def _write_mesh(self, geometry: np.ndarray, topology: np.ndarray) -> None:
        image = hdf5_image({"geometry": geometry, "topology": topology.astype(np.int64)})
        what = f"the mesh of {self.stem} ({self.stem}/{MESH_FILE})"
        replace_atomically(self.folder / MESH_FILE, lambda f: f.write(image), what, self.directory)

    def _grid(self, step: int, t: float) -> str:
        source = f"{self.stem}/{step_file(step)}"
        attributes = "".join(
            f"<Attribute Name={quoteattr(layout.name)} AttributeType="
            f'"{layout.attribute}" Center="{layout.center}">'
            f"{_item(self._shapes[layout.name], f'{source}:/{layout.name}')}</Attribute>"
            for layout in self.layouts
        )
        return (
            f'<Grid Name="step {step}" GridType="Uniform"><Time Value="{float(t)!r}"/>'
            f"{self._mesh_xml}{attributes}</Grid>"
        )

    def _write_index(self) -> None:
        lines = [self.entries[step] for step in sorted(self.entries)]
        text = (
            '<?xml version="1.0"?>\n<Xdmf Version="3.0">\n <Domain>\n'
            f'  <Grid Name={quoteattr(self.stem)} GridType="Collection" '
            'CollectionType="Temporal">\n'
            + "".join(f"   {line}\n" for line in lines)
            + "  </Grid>\n </Domain>\n</Xdmf>\n"
        )
        replace_atomically(self.index, lambda f: f.write(text.encode()), f"{self.index.name}")

    def write(self, step: int, t: float) -> None:
        """Write the fields at ``step`` (time ``t``), then list the step in the index."""
        self.fields.refresh(t)
        arrays = {}
        for layout, f in zip(self.layouts, self.fields.functions, strict=True):
            arrays[layout.name] = layout.values(f)
            if not layout.exact:
                arrays[f"dofs/{layout.name}"] = f.x.array
        image = hdf5_image(arrays, {"step": step, "t": float(t)})
        path = self.folder / step_file(step)
        what = f"the fields of step {step} ({self.stem}/{path.name})"
        replace_atomically(path, lambda f: f.write(image), what, self.directory)
        self.entries[step] = self._grid(step, t)
        try:
            self._write_index()
        except BaseException:
            del self.entries[step]
            path.unlink(missing_ok=True)
            raise

    # -- starting and resuming --------------------------------------------------------------
    def _start(self) -> None:
        """A new series: this mesh's step files of an earlier run removed, an empty index."""
        for path in step_files(self.folder).values():
            path.unlink()
        self.directory.joinpath(f"{self.stem}.h5").unlink(missing_ok=True)  # an old format
        self._write_index()

    def _recover(self, keep: int) -> None:
        """Continue after step ``keep``: the index rebuilt from the step files that are sound."""
        listed: dict[int, float] | None = None
        if self.index.exists():
            try:
                listed = read_index(self.index)
            except ValueError as error:
                set_aside(self.index, str(error), f"rebuilt from the files in {self.stem}/")
        files = step_files(self.folder)
        for step, path in files.items():
            if step > keep:
                path.unlink()  # written after the checkpoint: written again
                continue
            try:
                found, t = read_step(path, self._shapes)
                if found != step:
                    raise ValueError(f"it holds step {found}")
            except ValueError as error:
                set_aside(path, str(error), f"step {step} is left out of {self.index.name}")
                continue
            self.entries[step] = self._grid(step, t)
        missing = sorted(s for s in listed or {} if s <= keep and s not in files)
        if missing:
            logger.warning(
                "%s: listed steps %s whose files are missing; left out of the series",
                self.index,
                missing,
            )
        self._write_index()
