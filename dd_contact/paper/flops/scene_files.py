"""The JSON scene format of the operation-count model (schema: :func:`scene_from_dict`).

:func:`scene_to_dict` writes a :class:`~dd_contact.paper.flops.model.SceneSizes` as a
JSON-ready dict, :func:`scene_from_dict` validates one and :func:`load_scene` reads a file;
errors name the offending entry. ``docs/cost.md`` has an annotated example.
"""

from __future__ import annotations

import dataclasses
import json
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from dd_contact.paper.flops.model import (
    ContactCounts,
    MeshCounts,
    SceneSizes,
    SubdomainCounts,
    is_int,
)

__all__ = ["load_scene", "scene_from_dict", "scene_to_dict"]

_SCENE_KEYS = {
    "name",
    "n_steps",
    "gamma",
    "interface",
    "subdomains",
    "contacts",
    "whole",
    "substitutions_per_step",
}
_SUBDOMAIN_KEYS = {"name", "dofs", "half_bandwidth", "interface_dofs"}
_CONTACT_KEYS = {"name", "dofs", "subdomain", "alpha"}
_INTERFACE_KEYS = {"name", "dofs"}
_WHOLE_KEYS = {"name", "dofs", "half_bandwidth"}


def scene_to_dict(sizes: SceneSizes, name: str | None = None) -> dict[str, Any]:
    """JSON-serialisable scene description, the inverse of :func:`scene_from_dict`.

    Args:
        sizes: The scene.
        name: Optional title stored under ``"name"``.

    Returns:
        A dict following the schema of :func:`scene_from_dict` (contacts refer to subdomains by
        name).
    """
    out: dict[str, Any] = {} if name is None else {"name": name}
    out["n_steps"] = sizes.n_steps
    out["gamma"] = sizes.gamma
    out["interface"] = (
        None
        if sizes.interface_dofs is None
        else {"name": sizes.interface_name, "dofs": sizes.interface_dofs}
    )
    subs = []
    for sd in sizes.subdomains:
        d: dict[str, Any] = {"name": sd.name, "dofs": sd.dofs, "half_bandwidth": sd.half_bandwidth}
        if sd.interface_dofs is not None:
            d["interface_dofs"] = sd.interface_dofs
        subs.append(d)
    out["subdomains"] = subs
    out["contacts"] = [
        {
            "name": c.name,
            "dofs": c.dofs,
            "subdomain": sizes.subdomains[c.subdomain].name,
            "alpha": c.alpha,
        }
        for c in sizes.contacts
    ]
    out["whole"] = dataclasses.asdict(sizes.whole)
    if sizes.substitutions_per_step != 1:
        out["substitutions_per_step"] = sizes.substitutions_per_step
    return out


def _fields(obj: Any, where: str, allowed: set[str], required: Sequence[str]) -> dict[str, Any]:
    if not isinstance(obj, dict):
        raise ValueError(f"{where}: expected a JSON object, got {type(obj).__name__}")
    unknown = sorted(set(obj) - allowed)
    if unknown:
        raise ValueError(
            f"{where}: unknown key {unknown[0]!r} (allowed: {', '.join(sorted(allowed))})"
        )
    for key in required:
        if key not in obj:
            raise ValueError(f"{where}: missing key {key!r}")
    return obj


def _int_field(obj: Mapping[str, Any], key: str, where: str, minimum: int) -> int:
    value = obj[key]
    if not is_int(value) or value < minimum:
        kind = "a positive" if minimum == 1 else "a non-negative"
        raise ValueError(f"{where}.{key} must be {kind} integer, got {value!r}")
    return int(value)


def _name_field(obj: Mapping[str, Any], where: str, default: str) -> str:
    name = obj.get("name", default)
    if not isinstance(name, str) or not name:
        raise ValueError(f"{where}.name must be a non-empty string, got {name!r}")
    return name


def _interface(top: Mapping[str, Any], source: str) -> tuple[int | None, str]:
    """The interface's dofs (None: no interface) and name."""
    if top.get("interface") is None:
        return None, "Gamma_I"
    where = f"{source}: interface"
    iface = _fields(top["interface"], where, _INTERFACE_KEYS, ("dofs",))
    return _int_field(iface, "dofs", where, 1), _name_field(iface, where, "Gamma_I")


def _subdomains(
    top: Mapping[str, Any], source: str, interface_dofs: int | None
) -> list[SubdomainCounts]:
    """The subdomains, checked against the interface and for unique names."""
    raw_subs = top["subdomains"]
    if not isinstance(raw_subs, list) or not raw_subs:
        raise ValueError(f"{source}: subdomains must be a non-empty list")
    subdomains = [
        _subdomain(raw, f"{source}: subdomains[{k}]", f"Omega{k + 1}", interface_dofs)
        for k, raw in enumerate(raw_subs)
    ]
    names = [sd.name for sd in subdomains]
    if len(set(names)) != len(names):
        raise ValueError(f"{source}: subdomain names are not unique: {names}")
    return subdomains


def _subdomain(
    raw: Any, where: str, default_name: str, interface_dofs: int | None
) -> SubdomainCounts:
    """One subdomain; ``interface_dofs`` is the scene's interface (None: it has none)."""
    sd = _fields(raw, where, _SUBDOMAIN_KEYS, ("dofs", "half_bandwidth"))
    name = _name_field(sd, where, default_name)
    dofs = _int_field(sd, "dofs", where, 1)
    band = _int_field(sd, "half_bandwidth", where, 1)
    if band > dofs:
        raise ValueError(f"{where}: half_bandwidth {band} > dofs {dofs}")
    tied = None
    if sd.get("interface_dofs") is not None:
        tied = _int_field(sd, "interface_dofs", where, 0)
        if tied and interface_dofs is None:
            raise ValueError(f"{where}: interface_dofs given but the scene has no interface")
        if interface_dofs is not None and tied > interface_dofs:
            raise ValueError(f"{where}: interface_dofs {tied} > interface dofs {interface_dofs}")
    return SubdomainCounts(name, dofs, band, tied)


def _contacts(top: Mapping[str, Any], source: str, names: list[str]) -> list[ContactCounts]:
    """The contact interfaces, each with the index of its subdomain among ``names``."""
    raw_contacts = top["contacts"]
    if not isinstance(raw_contacts, list) or not raw_contacts:
        raise ValueError(f"{source}: contacts must be a non-empty list")
    contacts = []
    for k, raw in enumerate(raw_contacts):
        where = f"{source}: contacts[{k}]"
        c = _fields(raw, where, _CONTACT_KEYS, ("dofs", "subdomain", "alpha"))
        index = _owner_index(c["subdomain"], where, names)
        contacts.append(
            ContactCounts(
                _name_field(c, where, f"Gamma_C{k + 1}"),
                _int_field(c, "dofs", where, 1),
                index,
                _int_field(c, "alpha", where, 0),
            )
        )
    return contacts


def _owner_index(owner: Any, where: str, names: list[str]) -> int:
    """The index of a contact interface's subdomain, given by name or by 0-based index."""
    if isinstance(owner, str):
        if owner not in names:
            raise ValueError(
                f"{where}.subdomain {owner!r} is not a subdomain (known: {', '.join(names)})"
            )
        return names.index(owner)
    if is_int(owner):
        if not 0 <= owner < len(names):
            raise ValueError(
                f"{where}.subdomain index {owner} is not a subdomain "
                f"(0..{len(names) - 1}: {', '.join(names)})"
            )
        return int(owner)
    raise ValueError(f"{where}.subdomain must be a name or an index, got {owner!r}")


def _whole(top: Mapping[str, Any], source: str, subdomains: list[SubdomainCounts]) -> MeshCounts:
    """The undecomposed model: as given, or merged from the subdomains."""
    if top.get("whole") is None:
        return MeshCounts(
            "Omega (merged)",
            sum(sd.dofs for sd in subdomains),
            max(sd.half_bandwidth for sd in subdomains),
        )
    where = f"{source}: whole"
    w = _fields(top["whole"], where, _WHOLE_KEYS, ("dofs", "half_bandwidth"))
    dofs, band = _int_field(w, "dofs", where, 1), _int_field(w, "half_bandwidth", where, 1)
    if band > dofs:
        raise ValueError(f"{where}: half_bandwidth {band} > dofs {dofs}")
    return MeshCounts(_name_field(w, where, "Omega"), dofs, band)


def scene_from_dict(data: Any, source: str = "scene") -> SceneSizes:
    """Validate a scene description (parsed JSON) and build its :class:`SceneSizes`.

    Schema (``docs/cost.md`` has an annotated example)::

        {
          "name": "optional title",
          "n_steps": N_TS,                       # >= 0
          "gamma": changes in the whole model,   # max(alpha) <= gamma <= sum(alpha)
          "interface": {"name": "Gamma_I", "dofs": D_V} or null / absent (no interface),
          "subdomains": [                        # at least one
            {"name": "Omega1", "dofs": D_U, "half_bandwidth": B_U,
             "interface_dofs": D_V^(k)},         # optional: default all D_V, 0 = not tied
            ...
          ],
          "contacts": [                          # at least one, at most one per subdomain
            {"name": "Gamma_C1", "dofs": D_W,
             "subdomain": "Omega1" or 0,         # owner, by name or 0-based index
             "alpha": changes on this contact interface},
            ...
          ],
          "whole": {"name": "Omega", "dofs": D, "half_bandwidth": B},
                     # optional: the undecomposed model for FULL and w-u; default: the sum of
                     # the subdomain dofs and the largest subdomain half-bandwidth
          "substitutions_per_step": 1 or 2       # optional: subdomain substitutions per
                     # step, 1 (default, the paper's Tables 2 and 3) or 2 (its Table 1)
        }

    Args:
        data: The parsed JSON.
        source: Prefix of error messages (e.g. the file name).

    Returns:
        The scene.

    Raises:
        ValueError: On a missing or unknown key, a number that is not a (positive or
            non-negative) integer, a contact interface pointing at an unknown subdomain, or an
            inconsistent scene (e.g. ``gamma`` outside ``[max(alpha), sum(alpha)]``); the message
            names the offending entry.
    """
    top = _fields(data, source, _SCENE_KEYS, ("n_steps", "gamma", "subdomains", "contacts"))
    n_steps = _int_field(top, "n_steps", source, 0)
    gamma = _int_field(top, "gamma", source, 0)
    interface_dofs, interface_name = _interface(top, source)
    subdomains = _subdomains(top, source, interface_dofs)
    contacts = _contacts(top, source, [sd.name for sd in subdomains])
    whole = _whole(top, source, subdomains)
    try:
        return SceneSizes(
            subdomains=tuple(subdomains),
            contacts=tuple(contacts),
            interface_dofs=interface_dofs,
            n_steps=n_steps,
            gamma=gamma,
            whole=whole,
            interface_name=interface_name,
            substitutions_per_step=top.get("substitutions_per_step", 1),
        )
    except ValueError as err:
        raise ValueError(f"{source}: {err}") from None


def load_scene(path: str | os.PathLike[str]) -> SceneSizes:
    """Read a scene JSON file (schema: :func:`scene_from_dict`).

    Args:
        path: The file.

    Returns:
        The scene.

    Raises:
        ValueError: If the file is not valid JSON or not a valid scene (message names the file,
            and the line and column of a JSON syntax error).
        OSError: If the file cannot be read.
    """
    text = Path(path).read_text()
    try:
        data = json.loads(text)
    except json.JSONDecodeError as err:
        raise ValueError(f"{path}: not valid JSON: {err}") from None
    return scene_from_dict(data, str(path))
