"""The PETSc options of the package's factorisations: a prefix per problem, and the user's.

MUMPS can be tuned through the PETSc options database under a problem's options prefix
(:data:`OPTIONS_PREFIX`, ``dd_contact_``, unless the problem names its own), e.g.
``-dd_contact_mat_mumps_icntl_14 50``; :func:`petsc_options` puts a problem's options in
the database while its factorisations are built or solved, and makes its prefix the one
they read (:func:`options_prefix`). The settings the package relies on
(:data:`REQUIRED_ICNTL`) cannot be changed that way.
"""

from __future__ import annotations

import contextlib
import contextvars
import re
from collections.abc import Iterator, Mapping

from petsc4py import PETSc

from dd_contact.errors import InputError

__all__ = [
    "OPTIONS_PREFIX",
    "REQUIRED_ICNTL",
    "check_options_prefix",
    "options_prefix",
    "petsc_options",
]

#: The default PETSc options prefix of the package's MUMPS factorisations (the KSP, its PC
#: and the factor matrix): ``-dd_contact_mat_mumps_icntl_14 50`` on the command line, or
#: ``PETSc.Options()["dd_contact_mat_mumps_icntl_14"] = 50`` before the solver is built. A
#: problem given ``petsc_options_prefix`` reads its own instead.
OPTIONS_PREFIX = "dd_contact_"

# The prefix of the problem whose factorisations are being built or solved (petsc_options).
_ACTIVE_PREFIX = contextvars.ContextVar("dd_contact_options_prefix", default=OPTIONS_PREFIX)

# MUMPS control parameters (MUMPS 5.8 Users' guide, section 6.1 "Integer control
# parameters"; ICNTL(k) is ``id.ICNTL(k)``).
ICNTL_NULL_PIVOT_DETECTION = 24  # ICNTL(24): detection of null pivot rows (0: off, 1: on)
NULL_PIVOTS_DETECTED = 1  # ... on: null pivot rows are detected and counted in INFOG(28)

#: The MUMPS settings the package relies on, ICNTL index -> value: null pivots detected, so
#: a singular block fails with :class:`SingularMatrixError` (INFOG(28) > 0). An option under
#: :data:`OPTIONS_PREFIX` that changes one of them is refused.
REQUIRED_ICNTL = {ICNTL_NULL_PIVOT_DETECTION: NULL_PIVOTS_DETECTED}


def options_prefix() -> str:
    """The options prefix the factorisations built now read (:func:`petsc_options`)."""
    return _ACTIVE_PREFIX.get()


def check_options_prefix(prefix: object) -> str:
    """``prefix`` if it can be a PETSc options prefix, else an :class:`InputError`."""
    if not isinstance(prefix, str) or not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", prefix):
        raise InputError(
            f"petsc_options_prefix: {prefix!r} is not a PETSc options prefix; give letters, "
            "digits and underscores starting with a letter, ending in '_' by convention "
            "(e.g. 'bracket_')"
        )
    return prefix


@contextlib.contextmanager
def petsc_options(
    options: Mapping[str, object] | None, prefix: str = OPTIONS_PREFIX
) -> Iterator[None]:
    """Put ``options`` under ``prefix`` in the PETSc database, then restore it.

    As dolfinx's ``LinearProblem(petsc_options=..., petsc_options_prefix=...)``: keys without
    the prefix or dash (``{"mat_mumps_icntl_14": 50}``), values a number, string, bool or
    ``None`` (a flag). The factorisations built or solved inside read options under
    ``prefix`` (:func:`options_prefix`); what was in the database before is put back after.
    """
    token = _ACTIVE_PREFIX.set(prefix)
    try:
        if not options:
            yield
            return
        with _options_under(prefix, options):
            yield
    finally:
        _ACTIVE_PREFIX.reset(token)


@contextlib.contextmanager
def _options_under(prefix: str, options: Mapping[str, object]) -> Iterator[None]:
    database = PETSc.Options(prefix)
    for key, value in options.items():
        if not isinstance(key, str) or key.startswith("-") or key.startswith(prefix):
            raise InputError(
                f"petsc_options: key {key!r} must be an option name without the dash and the "
                f"prefix, e.g. 'mat_mumps_icntl_14' (it is read as -{prefix}<key>)"
            )
        if value is not None and not isinstance(value, str | int | float | bool):
            raise InputError(
                f"petsc_options[{key!r}]: give a number, string, bool or None, got "
                f"{type(value).__name__}"
            )
    saved = {k: database.getString(k) if database.hasName(k) else None for k in options}
    present = {k for k in options if database.hasName(k)}
    try:
        for key, value in options.items():
            # petsc4py's stub lacks Options.__setitem__ (it exists; None sets a bare flag)
            database[key] = value  # type: ignore[index]
        yield
    finally:
        for key in options:
            if key in present:
                database[key] = saved[key]  # type: ignore[index]  # as above
            else:
                database.delValue(key)


def _check_required_options() -> None:
    """Refuse options under the active prefix that change :data:`REQUIRED_ICNTL`."""
    prefix = options_prefix()
    options = PETSc.Options(prefix)
    for icntl, value in REQUIRED_ICNTL.items():
        name = f"mat_mumps_icntl_{icntl}"
        if options.getInt(name, value) != value:
            raise InputError(
                f"-{prefix}{name} must be {value} (MUMPS ICNTL({icntl})): dd_contact "
                "relies on it to report singular blocks; remove the option"
            )
