"""dd_contact.paper.compare: the agreement rule, the table, FULL against the orders over a run."""

import numpy as np
import pytest

from dd_contact.paper import compare, models


def _run(algorithm, checkpoints, active=(0, 1, 1), chosen=None):
    history = [{"active": {"end": a}} for a in active]
    return compare.Run(
        algorithm, chosen or algorithm, "model", history, np.array([0.5, 0.25, 0.25]),
        {s: np.asarray(u, float) for s, u in checkpoints.items()}, 2.0,
        {"gamma": 1, "end": 1}, 3, 7,
    )  # fmt: skip


def test_checkpoints_double_up_to_the_last_step():
    assert compare.checkpoint_steps(80) == [1, 2, 4, 8, 16, 32, 64, 80]
    assert compare.checkpoint_steps(2) == [1, 2]
    assert compare.checkpoint_steps(1) == [1]


def test_agreement_is_relative_to_the_largest_displacement_and_judged_against_roundoff():
    full = _run("FULL", {1: [1.0, 0.0], 2: [2.0, 0.0], 3: [1.0, 1.0]})
    close = _run("w-v-u", {1: [1.0, 0.0], 2: [2.0, 2e-9], 3: [1.0, 1.0 + 1e-6]})
    twin = _run("FULL, AMD", {1: [1.0, 0.0], 2: [2.0, 0.0], 3: [1.0, 1.0 + 4e-7]})
    check = compare.agreement(close, full, ["end"], twin)
    assert check.early == [0.0, 1e-9]  # 2e-9 / largest 2.0
    assert check.worst == pytest.approx(5e-7) and check.final == pytest.approx(5e-7)
    assert check.roundoff == pytest.approx(2e-7)
    assert check.limit == pytest.approx(compare.ROUNDOFF_FACTOR * 2e-7)
    assert check.ok and compare.disagreements({"w-v-u": check}) is None
    # Without a round-off reference the floor is the yardstick.
    assert compare.agreement(close, full, ["end"]).limit == pytest.approx(1e-6)


def test_a_different_history_or_a_large_difference_disagrees():
    full = _run("FULL", {1: [1.0], 2: [2.0]})
    other_history = compare.agreement(_run("v-u", {1: [1.0], 2: [2.0]}, (0, 0, 1)), full, ["end"])
    assert not other_history.same_history and not other_history.ok
    drifted = compare.agreement(_run("w-u", {1: [1.0], 2: [2.0 + 1e-5]}), full, ["end"])
    assert drifted.worst == pytest.approx(5e-6) and not drifted.ok
    message = compare.disagreements({"v-u": other_history, "w-u": drifted})
    assert "v-u" in message and "w-u" in message and "history differs" in message


def test_text_and_markdown_tables_hold_the_same_cells():
    full = _run("FULL", {1: [1.0], 2: [2.0]})
    auto = _run("auto", {1: [1.0], 2: [2.0]}, chosen="w-v-u")
    checks = {"auto": compare.agreement(auto, full, ["end"])}
    gflops = {"FULL": 1.5, "w-v-u": 0.25}
    text = compare.table([full, auto], checks, gflops).splitlines()
    markdown = compare.markdown_table([full, auto], checks, gflops).splitlines()
    assert len(text) == 4 and len(markdown) == 4
    assert text[2].split()[0] == "FULL" and "auto (w-v-u)" in text[3]
    for line, row in zip(text[2:], markdown[2:], strict=True):
        cells = [c.strip() for c in row.strip("|").split("|")]
        assert " ".join(c for c in cells if c) == " ".join(line.split())
    assert "0.25" in markdown[3] and "same" in markdown[3]


def test_orders_stay_within_roundoff_of_full_over_many_steps():
    """The tiny bar shaken on its wall for 80 steps: w-v-u matches FULL to 1e-8 in the first
    steps; later both drift apart by round-off, as far as FULL drifts from itself with
    another MUMPS ordering (docs/compare.md)."""

    def bar():
        return models.parallelepiped("tiny", body_force=21e6, period=4e-3)

    full = compare.run_algorithm(bar, "FULL", 1e-4, 80)
    orders = compare.run_algorithm(bar, "w-v-u", 1e-4, 80)
    twin = compare.roundoff_run(bar, 1e-4, 80)
    check = compare.agreement(orders, full, ["end"], twin)
    assert full.changes["end"] >= 6  # 8 (21-23 before one release was one episode)
    assert check.same_history
    assert max(check.early) < compare.EARLY_TOLERANCE
    assert check.worst <= check.limit <= 1e-5
    # The yardstick is real: FULL solved in another order is not FULL to the last bit.
    twin_check = compare.agreement(twin, full, ["end"])
    assert 1e-10 < twin_check.worst < 1e-5
