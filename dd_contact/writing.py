"""Files an interruption cannot damage: atomic replacement, appends undone, files set aside.

A process killed (SIGKILL, the OOM killer) or a disk that fills can stop a write half way.
The output of a run is written so that this damages nothing written before:

* a file rewritten as a whole (the history, a checkpoint, a field series' index) is written
  beside under a temporary name (``<name>.tmp``) and renamed over the old one: a reader, or a
  resumed run, finds the old file or the new one, never a part;
* a file that grows (``history.csv``) grows by one write, undone if it fails;
* a write that fails raises :class:`~dd_contact.errors.OutputError` naming the directory and
  what was being written, with nothing of it left behind (no temporary file, no half row).

A crash of the machine (power loss) loses what the operating system had not yet put on
the disk. A checkpoint is therefore a barrier (:func:`make_durable`): every file written
since the last one is synced to the disk before the checkpoint that says those steps are
done, and the checkpoint itself before it replaces the previous one.

What a resumed run finds damaged anyway (a file cut by a crash of the machine, a temporary
file of a killed process) it repairs or sets aside (:func:`set_aside`) and says so, one line
per file, through the ``dd_contact.io`` logger (shown on stderr unless configured).
"""

from __future__ import annotations

import ctypes
import errno as errnos
import logging
import os
from collections.abc import Callable
from pathlib import Path
from typing import IO

from dd_contact.errors import OutputError

__all__ = [
    "TEMPORARY",
    "append_or_undo",
    "failure",
    "logger",
    "make_durable",
    "remove_temporary",
    "replace_atomically",
    "set_aside",
]

#: The suffix of a file being written, renamed to its own name once complete.
TEMPORARY = ".tmp"

#: What repairs say they did (one line each); a handler of the user's may take them.
logger = logging.getLogger("dd_contact.io")


#: Files written since the last :func:`make_durable` (this process's).
_unsynced: set[Path] = set()


def make_durable(*paths: Path, what: str = "the output") -> None:
    """Sync every file written since the last call, and ``paths``, to the disk.

    Their directories too (their renames): a barrier before a checkpoint. One ``syncfs``
    per file system where the C library has it (Linux: a sync of each file costs a
    journal commit each, 5-40 ms), each file's ``fsync`` elsewhere.

    Raises :class:`OutputError` if the disk refuses (it reports late write errors here).
    """
    files = sorted(_unsynced | set(paths))
    _unsynced.clear()
    if not files:
        return
    try:
        if _syncfs is None:
            for path in files + sorted({p.parent for p in files}):
                _on_descriptor(path, os.fsync)
            return
        devices: dict[int, Path] = {}
        for path in files:
            devices.setdefault(os.stat(path.parent).st_dev, path.parent)
        for directory in devices.values():
            _on_descriptor(directory, _syncfs_or_raise)
    except OSError as error:
        raise failure(error, what, files[0].parent) from error


def _on_descriptor(path: Path, call: Callable[[int], object]) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        call(fd)
    finally:
        os.close(fd)


def _find_syncfs() -> Callable[[int], int] | None:
    try:
        return ctypes.CDLL(None, use_errno=True).syncfs
    except (OSError, AttributeError):
        return None


_syncfs = _find_syncfs()


def _syncfs_or_raise(fd: int) -> None:
    assert _syncfs is not None
    if _syncfs(fd) != 0:
        code = ctypes.get_errno()
        raise OSError(code, os.strerror(code))


def failure(error: BaseException, what: str, directory: Path) -> OutputError:
    """The :class:`OutputError` of ``error`` raised while writing ``what`` in ``directory``."""
    code = getattr(error, "errno", None)
    reason = os.strerror(code) if isinstance(code, int) and code else str(error)
    out = OutputError(f"could not write {what} in {str(directory)!r}: {reason}")
    out.errno = code if isinstance(code, int) else errnos.EIO
    return out


def replace_atomically(
    path: Path, write: Callable[[IO[bytes]], object], what: str, directory: Path | None = None
) -> None:
    """Write ``path`` as a whole by ``write(file)``: the old file or the new, never a part.

    Raises :class:`OutputError` (naming ``what`` and ``directory``, by default the file's)
    if it cannot be written; the temporary file is removed whatever stops the write (an
    error, Ctrl-C).
    """
    tmp = path.with_name(path.name + TEMPORARY)
    try:
        with open(tmp, "wb") as f:
            write(f)
        os.replace(tmp, path)
        _unsynced.add(path)
    except BaseException as error:
        tmp.unlink(missing_ok=True)
        if isinstance(error, OSError):
            raise failure(error, what, directory or path.parent) from error
        raise


def append_or_undo(path: Path, data: bytes, what: str) -> None:
    """Append ``data`` to ``path`` in one write; if it fails, cut the file back as it was."""
    fd = None
    size = 0
    try:
        fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o666)
        size = os.fstat(fd).st_size
        if os.write(fd, data) != len(data):  # a short write: the disk is full
            raise OSError(errnos.ENOSPC, os.strerror(errnos.ENOSPC))
        _unsynced.add(path)
    except BaseException as error:
        if fd is not None:
            os.ftruncate(fd, size)
        if isinstance(error, OSError):
            raise failure(error, what, path.parent) from error
        raise
    finally:
        if fd is not None:
            os.close(fd)


def set_aside(path: Path, why: str, done: str = "") -> Path:
    """Rename the damaged ``path`` to ``<name>.damaged`` (``-2``, ... if taken); say so.

    The message: ``<path>: <why>; set aside as <name>.damaged[; <done>]``.
    """
    target = path.with_name(path.name + ".damaged")
    k = 1
    while target.exists():
        k += 1
        target = path.with_name(f"{path.name}.damaged-{k}")
    os.replace(path, target)
    logger.warning("%s: %s; set aside as %s%s", path, why, target.name, f"; {done}" if done else "")
    return target


def remove_temporary(path: Path) -> None:
    """Remove the unfinished ``<path>.tmp`` a killed process left, if any; say so."""
    tmp = path.with_name(path.name + TEMPORARY)
    if tmp.is_file():
        tmp.unlink()
        logger.warning("%s: removed (a file the interrupted run had not finished)", tmp)
