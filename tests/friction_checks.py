"""Checks the friction tests share: sticking below mu N / 2, a resumed run bit for bit."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np


def assert_resumed_is_whole(problem: Callable, tmp_path, steps: int = 18) -> None:
    """``problem()`` run whole, and run to half-way (checkpoints every 3 steps) then resumed:
    bit for bit the same displacements, forces and friction history.

    Its contact state changes in both halves (the history written and read matters). The
    whole run checkpoints alike (a checkpoint must not change the numbers it goes on with).
    """
    whole, killed = problem(), Path(tmp_path) / "killed"
    whole.run(
        steps, output=Path(tmp_path) / "whole", checkpoint_every=3, summary=False, progress=False
    )
    half = steps // 2
    problem().run(half, output=killed, checkpoint_every=3, summary=False, progress=False)
    resumed = problem()
    resumed.run(steps, output=killed, resume=True, summary=False, progress=False)
    changes = [r["changes"] for r in whole.history]
    assert sum(changes[:half]) >= 1 and sum(changes[half:]) >= 1  # slip before and after
    for mine, theirs in zip(resumed.scene.subdomains, whole.scene.subdomains, strict=True):
        np.testing.assert_array_equal(mine.u.x.array, theirs.u.x.array)
    assert [r["force"] for r in resumed.history] == [r["force"] for r in whole.history]
    friction = resumed.analysis.zones[0].operator.friction
    for name, value in whole.analysis.zones[0].operator.friction.arrays().items():
        np.testing.assert_array_equal(friction.arrays()[name], value)
    resumed.close(), whole.close()


def assert_sticks_below_half(run: dict, mu: float) -> None:
    """While the tangential force T < mu N / 2 nothing slips and T grows linearly with the
    load steps (elastic and penalty compliance); at least 3 such steps."""
    T, N = np.abs(run["T"]), np.abs(run["N"])
    below = T < 0.5 * mu * N
    assert below.sum() >= 3
    assert np.all(np.array(run["slip"])[below] == 0.0)
    assert np.all(np.array(run["slipping"])[below] == 0)
    steps = np.flatnonzero(below) + 1
    assert np.allclose(T[below] / steps, T[0], rtol=1e-9)
