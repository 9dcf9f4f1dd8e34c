"""The pages numpy's large temporary arrays are given while a solver is built."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np

__all__ = ["small_pages"]


@contextmanager
def small_pages() -> Iterator[None]:
    """New numpy arrays in ordinary (4 KB) pages while it lasts, then as before.

    numpy asks Linux for transparent huge pages on its large arrays; where the kernel then
    compacts memory on the first touch (``defrag`` = ``madvise``, the usual setting), every
    fresh array pays for it in kernel time. glibc maps an array beyond 32 MB afresh each
    time, and a set-up makes several (the matrices of a 47k-dof part): the bar of
    ``benchmarks/decompose_vs_hand.py`` cut 1:40 spent 0.45-0.76 s in the kernel with huge
    pages, 0.27-0.28 s without (cut 5:5, whose arrays stay below 32 MB: 0.24-0.36 s both).
    """
    switch = getattr(getattr(np, "_core", None), "multiarray", None)
    switch = getattr(switch, "_set_madvise_hugepage", None)  # numpy's own switch, if any
    previous = switch(False) if switch is not None else None
    try:
        yield
    finally:
        if switch is not None:
            switch(previous)
