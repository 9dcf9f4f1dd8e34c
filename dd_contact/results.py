"""A run's results read back: its history, and its fields at any written step.

:func:`load_results` reads an output directory of :meth:`TransientProblem.run
<dd_contact.TransientProblem.run>` (the layout: :mod:`dd_contact.series`, docs/output.md)::

    results = dd_contact.load_results("out")
    results.history                        # the records, as problem.history had them
    results.column("energy.total")         # one value per step (numpy)
    results.steps()                        # the written steps
    results.arrays(12, "u_block")          # the stored values at step 12 (numpy)
    results.functions(12, block)           # dolfinx Functions on block's spaces

The Functions are the run's to the last bit: a field stored at the nodes or per cell is put
back dof by dof, one stored by its interpolant also as its array. Reading is rank-local (no
collective call) and changes nothing in the directory.
"""

from __future__ import annotations

import json
from pathlib import Path

import dolfinx.fem as fem
import h5py
import numpy as np

from dd_contact.errors import InputError
from dd_contact.io import flat_record
from dd_contact.post import part_fields
from dd_contact.scene import ContactBoundary, ContactInterface, Interface, Scene
from dd_contact.series import MESH_FILE, FieldLayout, read_index, read_step, step_file, step_files
from dd_contact.subdomains import Subdomain

__all__ = ["SavedResults", "load_results"]

Part = Subdomain | Interface | ContactInterface | ContactBoundary


def _parts(parts: tuple) -> list[Part]:
    """The parts named: a Scene stands for its subdomains, interface and contact regions."""
    out: list[Part] = []
    for part in parts:
        if isinstance(part, Scene):
            out += [*part.subdomains, *([part.interface] if part.interface else []), *part.contacts]
        elif isinstance(part, Subdomain | Interface | ContactInterface | ContactBoundary):
            out.append(part)
        else:
            raise InputError(
                f"functions: {part!r} is not a Subdomain, Interface, ContactInterface, "
                "ContactBoundary or Scene; give the parts whose fields to read"
            )
    return out


class SavedResults:
    """The results in a run's output directory (see :func:`load_results`).

    Attributes:
        directory: The output directory.
        history: The step records in ``history.json`` (as ``problem.history`` had them: at
            the end of a run, a stop or an error, and at each checkpoint).
        meshes: The stems of the field series (``u_block``, ``w_contact``, ...).
    """

    def __init__(self, directory: str | Path):
        self.directory = Path(directory)
        if not self.directory.is_dir():
            raise InputError(
                f"load_results: {str(self.directory)!r} is not a directory; give the output "
                "directory of a run (run(output=...))"
            )
        path = self.directory / "history.json"
        try:
            self.history: list[dict] = json.loads(path.read_text()) if path.exists() else []
        except ValueError as error:
            raise InputError(
                f"load_results: {path} cannot be read ({error}); resuming the run rewrites it"
            ) from error
        self._times: dict[str, dict[int, float]] = {}
        for index in sorted(self.directory.glob("*.xdmf")):
            folder = self.directory / index.stem
            if not (folder / MESH_FILE).exists():
                continue  # not a series of this layout
            try:
                self._times[index.stem] = read_index(index)
            except ValueError:  # damaged: the step files that can be read
                self._times[index.stem] = {s: read_step(p)[1] for s, p in self._sound(folder)}
        self.meshes = list(self._times)

    @staticmethod
    def _sound(folder: Path):
        for step, path in step_files(folder).items():
            try:
                read_step(path)
            except ValueError:
                continue
            yield step, path

    # -- history ----------------------------------------------------------------------------
    def column(self, key: str) -> np.ndarray:
        """One entry of every record as an array: ``"t"``, ``"energy.total"``, ``"force.end"``.

        A vector entry (``force.<region>``, ``reaction.<subdomain>``) gives one row per step.
        """
        rows = [flat_record(r) for r in self.history]
        if rows and key in rows[0]:
            return np.array([row[key] for row in rows])
        parts = [f"{key}.{c}" for c in "xyz"]
        if rows and all(p in rows[0] for p in parts):
            return np.array([[row[p] for p in parts] for row in rows])
        known = ", ".join(rows[0]) if rows else "none: the history is empty"
        raise InputError(f"column: no {key!r} in the history; its columns: {known}")

    # -- fields -----------------------------------------------------------------------------
    def steps(self, stem: str | None = None) -> list[int]:
        """The written steps of one series, or (``None``) those every series has."""
        if stem is not None:
            return sorted(self._series(stem))
        every = [set(times) for times in self._times.values()]
        return sorted(set.intersection(*every)) if every else []

    def time(self, step: int, stem: str | None = None) -> float:
        """The time of a written step."""
        stem = stem if stem is not None else self.meshes[0]
        return self._series(stem)[self._step(step, stem)]

    def _series(self, stem: str) -> dict[int, float]:
        if stem not in self._times:
            raise InputError(
                f"no field series {stem!r} in {str(self.directory)!r}; it has: "
                f"{', '.join(self.meshes) or 'none'}"
            )
        return self._times[stem]

    def _step(self, step: int, stem: str) -> int:
        if step not in self._series(stem):
            steps = sorted(self._series(stem))
            raise InputError(
                f"step {step} of {stem!r} was not written; written: "
                f"{steps[:5]}{' ...' if len(steps) > 5 else ''} (output_every sets which)"
            )
        return step

    def mesh(self, stem: str) -> tuple[np.ndarray, np.ndarray]:
        """A series' mesh: node coordinates (nodes x 3) and cells (VTK's node order)."""
        self._series(stem)
        with h5py.File(self.directory / stem / MESH_FILE, "r") as data:
            return data["geometry"][()], data["topology"][()]

    def arrays(self, step: int, stem: str) -> dict[str, np.ndarray]:
        """The stored values of every field of ``stem`` at ``step`` (numpy).

        Per node (rows in the order of :meth:`mesh`'s nodes) or per cell, components last
        (a stress tensor as 9 columns, xx xy xz yx ...); ``dofs/<name>``: a Function's array
        where it is stored too.
        """
        path = self.directory / stem / step_file(self._step(step, stem))
        out: dict[str, np.ndarray] = {}
        with h5py.File(path, "r") as data:
            data.visititems(
                lambda name, item: (
                    out.__setitem__(name, item[()]) if isinstance(item, h5py.Dataset) else None
                )
            )
        return out

    def functions(self, step: int, *parts) -> dict[str, fem.Function]:
        """The fields of ``parts`` at ``step`` as new Functions on the parts' spaces.

        Args:
            step: A written step.
            parts: Subdomains, the interface, contact regions, or a Scene (all its parts):
                the run's, or built again by the same script (the meshes are checked).

        Returns:
            By field name (``u_block``, ``velocity_block``, ``stress_block``, ``w_end``,
            ``pressure_end``, ...): the value at ``step``, equal to the run's bit for bit.
        """
        out = {}
        for part in _parts(parts):
            fields = part_fields(part, dynamic=True)
            stem = fields.stem
            self._check_mesh(stem, fields.functions[0].function_space.mesh)
            path = self.directory / stem / step_file(self._step(step, stem))
            with h5py.File(path, "r") as data:
                for f in fields.functions:
                    if f.name in data:
                        loaded = fem.Function(f.function_space, name=f.name)
                        FieldLayout(loaded).fill(loaded, data)
                        out[f.name] = loaded
        return out

    def _check_mesh(self, stem: str, mesh) -> None:
        geometry, _ = self.mesh(stem)
        x = mesh.geometry.x
        scale = max(float(np.abs(x).max(initial=0.0)), 1e-300)
        if geometry.shape != x.shape or np.abs(geometry - x).max(initial=0.0) > 1e-12 * scale:
            raise InputError(
                f"functions: the mesh of {stem!r} is not the one in {str(self.directory)!r} "
                f"({x.shape[0]} nodes here, {geometry.shape[0]} there, or moved); build the "
                "scene as the run did"
            )


def load_results(directory: str | Path) -> SavedResults:
    """Read a run's output directory back (rank-local): history and fields at written steps.

    Example:
        >>> results = dd_contact.load_results("out")
        >>> u = results.functions(results.steps()[-1], block)["u_block"]
    """
    return SavedResults(directory)
