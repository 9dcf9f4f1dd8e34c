"""Cattaneo-Mindlin: a Hertz ball pulled along its rigid plane, at a coarse mesh.

The closed forms and the measured converged numbers are in docs/validation.md; here the
half ball at h = 0.03 (5.6k dofs, ~10 s): the stuck radius within 10 % and the compliance
within 5 % (measured: 0.952-0.973 and 1.031-1.041 of theirs), the slip's share of the
compliance within 25 % at Q = 0.9 mu P (measured 1.18: the slip annulus is one or two
elements wide). A bonded contact (no slip) or a doubled Coulomb limit would fail all three
at Q = 0.9 mu P (the closed forms: c a or 0.82 a instead of 0.46 a, delta 24 or 16 % low).
"""

from __future__ import annotations

import itertools

import pytest

from dd_contact.paper.verify.cattaneo import cattaneo_mindlin

H = 0.03


@pytest.fixture(scope="module")
def run():
    return cattaneo_mindlin(H, levels=(0.3, 0.6, 0.9))


@pytest.mark.parametrize("level", [0.3, 0.6, 0.9])
def test_stuck_radius_and_compliance(run, level):
    step = next(s for s in run["steps"] if abs(s["x"] - level) < 0.05)
    assert step["c"] == pytest.approx(step["c_ref"], rel=0.10)
    assert step["delta"] == pytest.approx(step["delta_ref"], rel=0.05)
    if level == 0.9:
        assert step["slip"] == pytest.approx(step["slip_ref"], rel=0.25)


def test_stick_zone_shrinks_and_contact_stays(run):
    """Fewer points stick at each level; the contact radius is Hertz's (to 3 %) throughout."""
    sticking = [s["sticking"] for s in run["steps"]]
    assert all(b < a for a, b in itertools.pairwise(sticking))
    for s in run["steps"]:
        assert s["a_measured"] == pytest.approx(s["a"], rel=0.03)
