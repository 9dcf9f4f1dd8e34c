"""Coulomb friction between two bodies (ContactPair(..., friction=mu)): the sliding pair.

Block B pressed on block A (non-matching surfaces, A's base held) and pushed along by its
top, in every algorithm that fits; mu = 0, the inputs, the history, the energy, the output.
"""

from __future__ import annotations

import warnings

from mpi4py import MPI

import numpy as np
import pytest
from friction_checks import assert_resumed_is_whole, assert_sticks_below_half

from dd_contact.errors import EnergyGrowthWarning, InputError
from dd_contact.friction import DIRECTION_TOLERANCE, SLIP, STICK
from dd_contact.paper.verify.pair_friction import (
    PAIR_SCENES,
    PUSH,
    pair_balance,
    pair_scene,
    pressed_pair,
    sliding_pair,
)
from dd_contact.problem import StaticProblem, TransientProblem
from dd_contact.scene import ContactInterface, ContactPair

MU, STEPS, POINTS = 0.3, 20, 16  # side a (B's bottom, 3x3 cells) has 16 nodes
RUNS = [(kind, algorithm) for kind, algorithms in PAIR_SCENES.items() for algorithm in algorithms]


@pytest.fixture(scope="module")
def runs():
    """Each scene and algorithm, run once for the tests below."""
    return {(k, a): sliding_pair(k, a, MU, STEPS) for k, a in RUNS}


@pytest.mark.parametrize(("kind", "algorithm"), RUNS)
def test_sliding_reaction_is_mu_n(runs, kind, algorithm):
    """Once the whole face slides, A's tangential force on B is mu N to 1e-6."""
    run = runs[(kind, algorithm)]
    assert run["slipping"][-1] == POINTS
    T, N = np.array(run["T"]), np.array(run["N"])
    assert N[-1] == pytest.approx(1.0, rel=1e-9)  # the pressure on the unit face
    assert abs(-T[-1] / (MU * N[-1]) - 1.0) < 1e-6  # against the push along +x


@pytest.mark.parametrize(("kind", "algorithm"), RUNS)
def test_no_slip_below_half_mu_n(runs, kind, algorithm):
    """While T < mu N / 2 nothing slips, and T grows linearly with the push."""
    assert_sticks_below_half(runs[(kind, algorithm)], MU)


@pytest.mark.parametrize("kind", list(PAIR_SCENES))
def test_orders_agree_with_full(runs, kind):
    """Every order follows FULL's stick/slip path and its displacements to 1e-8."""
    full = runs[(kind, "FULL")]
    assert full["changes"] >= 2  # stuck, the edges slip, then the whole face
    for algorithm in PAIR_SCENES[kind][1:]:
        run = runs[(kind, algorithm)]
        assert run["changes"] == full["changes"]
        for field in ("u", "w"):
            error = np.linalg.norm(run[field] - full[field]) / np.linalg.norm(full[field])
            assert error < 1e-8


@pytest.mark.parametrize(("kind", "algorithm"), RUNS)
def test_dissipation_is_mu_n_times_the_slip(runs, kind, algorithm):
    """Each step dissipates >= 0; sliding steadily, mu N times B's push per step."""
    dissipated = runs[(kind, algorithm)]["dissipated"]
    assert min(dissipated) >= 0.0 and dissipated[0] == 0.0
    assert dissipated[-1] == pytest.approx(MU * 1.0 * PUSH, rel=1e-6)


@pytest.mark.parametrize("algorithm", ["FULL", "w-u"])
def test_mu_zero_is_the_frictionless_pair(algorithm):
    """friction=0 is the frictionless pair (no friction object, symmetric); mu -> 0 tends to it."""
    plain = sliding_pair("single", algorithm, 0.0, 2)
    tiny = sliding_pair("single", algorithm, 1e-10, 2)
    assert plain["changes"] == 0 and plain["slip"] == [0.0, 0.0]
    assert np.linalg.norm(tiny["u"] - plain["u"]) <= 1e-8 * np.linalg.norm(plain["u"])
    with StaticProblem(pair_scene("single", 0.0), algorithm=algorithm) as problem:
        zone = problem.analysis.zones[0]
        assert zone.operator.friction is None
        assert zone.region.symmetric and not zone.region.history
    with StaticProblem(pair_scene("single", MU), algorithm=algorithm) as problem:
        region = problem.analysis.zones[0].region
        assert not region.symmetric and region.history


def _pressed(
    kind: str, algorithm: str, push: float, mu: float = MU
) -> tuple[list, int, np.ndarray]:
    """Each step's contact iterations, the changes and the displacements of a pressed pair."""
    with StaticProblem(pressed_pair(kind, mu, 6, 10, push), algorithm=algorithm) as problem:
        iterations = []
        for step in range(1, 11):
            problem.solve(float(step))
            iterations.append(problem.iterations)
        friction = problem.analysis.zones[0].operator.friction
        assert mu == 0 or (friction.state == STICK).any()
        u = np.concatenate([sub.u.x.array for sub in problem.scene.subdomains])
        return iterations, problem.changes["gamma"], u


@pytest.mark.parametrize(("kind", "orders"), [("single", ["w-u"]), ("interface", ["v-w-u"])])
@pytest.mark.parametrize("push", [0.0, 2e-5])
def test_a_pair_closing_with_friction_settles_and_follows_full(kind, orders, push):
    """B pressed on A with a tilt, its points closing row by row while they slide along
    (nu = 0.3; and pushed along x): every step settles, the orders follow FULL's path.

    Without turning a point whose slip direction reversed into a sticking one
    (``Friction.decide``), the directions of the slipping points reversed at every
    iteration and the iteration did not settle (w-u: at step 7 pressed, at step 8 pressed
    and pushed; on 8x8 cells at step 8 both).
    """
    iterations, changes, full = _pressed(kind, "FULL", push)
    frictionless = _pressed(kind, "FULL", push, 0.0)[1]
    assert max(iterations) < 20 and changes > frictionless  # stick and slip changed too
    for algorithm in orders:
        mine, theirs, u = _pressed(kind, algorithm, push)
        assert (mine, theirs) == (iterations, changes)
        assert np.linalg.norm(u - full) <= 1e-8 * np.linalg.norm(full)


@pytest.mark.parametrize("bad", [-0.1, float("nan"), float("inf"), "0.3", True])
def test_bad_pair_friction(bad):
    """A negative, non-finite or non-numeric coefficient on a pair is refused, naming it."""
    scene = pair_scene("single", 0.0)
    a, b = scene.pairs[0].sides
    with pytest.raises(InputError, match="ContactPair 'p': friction must be a finite number"):
        ContactPair(a, b, friction=bad, name="p")


@pytest.mark.parametrize("options", [{"unbiased": True}, {"points": "quadrature"}])
def test_friction_on_points_it_is_not_built_for_is_refused(options):
    """Unbiased or quadrature points with friction: refused, saying what works."""
    with pytest.raises(InputError, match="use the default points='nodes', unbiased=False"):
        pair_scene("single", MU, **options)
    assert pair_scene("single", 0.0, **options).pairs[0].friction == 0.0  # frictionless: as before


def test_friction_on_a_pair_side_says_to_give_it_to_the_pair():
    """A side has no friction of its own: the message says where it goes."""
    upper = pair_scene("single", 0.0).pairs[0].a.subdomain
    with pytest.raises(InputError, match=r"ContactPair\(a, b, friction=mu\)"):
        ContactInterface.from_boundary(upper, lambda x: np.isclose(x[2], 0.25), None, friction=0.2)


@pytest.mark.parametrize("algorithm", ["FULL", "v-w-u"])
def test_resumed_sliding_pair_is_the_uninterrupted_one(algorithm, tmp_path):
    """The pair's friction history is checkpointed: a resumed quasi-static run is bit for bit."""

    def problem():
        return TransientProblem(
            pair_scene("interface", MU, MPI.COMM_SELF), 1.0, algorithm=algorithm, inertia=False
        )

    assert_resumed_is_whole(problem, tmp_path)


@pytest.mark.parametrize(("kind", "algorithm"), [("single", "w-u"), ("interface", "FULL")])
def test_energy_balance_of_a_sliding_pair(kind, algorithm):
    """With inertia (B thrown along A): dissipation >= 0 every step, no EnergyGrowthWarning,
    and energy now = before + loads' work - dissipation in the steps without a change."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", EnergyGrowthWarning)
        steps = pair_balance(kind, algorithm, MU, 30)
    dissipated = np.array([s["dissipated"] for s in steps])
    assert dissipated.min() >= 0.0 and dissipated.max() > 1e-5
    settled = [s for s in steps if s["changes"] == 0 and s["dissipated"] > 0]
    assert len(settled) >= 20
    for s in steps:
        assert s["residual"] <= 1e-6 * s["total"]  # ENERGY_GROWTH_TOLERANCE: none created
    for s in settled:
        assert abs(s["residual"]) <= 1e-8 * s["total"] < 1e-3 * s["dissipated"]
    assert all(s["obstacle"] == 0.0 for s in steps)  # relative slip: no obstacle's work


def test_both_sides_write_their_slip_and_traction(tmp_path):
    """Each side's output has its slip, tangential traction and stick/slip map: sliding, B
    feels mu p against the push, A mu p along it; B slid along +x relative to A."""
    from dd_contact.results import load_results

    scene = pair_scene("single", MU, MPI.COMM_SELF)
    problem = TransientProblem(scene, 1.0, algorithm="w-u", inertia=False)
    problem.run(STEPS, output=tmp_path, summary=False, progress=False)
    stored = load_results(tmp_path)
    for side, sign in (("bottom", -1.0), ("top", 1.0)):
        fields = stored.arrays(STEPS, f"w_{side}")
        assert f"gap_{side}" not in fields  # the gap is the pair's (it failed here before)
        assert np.allclose(fields[f"stick_{side}"], SLIP, rtol=1e-12)  # the whole face slides
        traction = fields[f"traction_{side}"].reshape(-1, 3)
        pressure = fields[f"pressure_{side}"]
        assert pressure.min() > 0.5  # the couple of the push tilts it (1 on average)
        np.testing.assert_allclose(traction[:, 0], sign * MU * pressure, rtol=1e-9)
        # across the push: what a direction settled to DIRECTION_TOLERANCE leaves
        assert np.abs(traction[:, 1:]).max() < DIRECTION_TOLERANCE * MU
        slip = fields[f"slip_{side}"].reshape(-1, 3)[:, 0]
        assert np.all(-sign * slip > 0)
    problem.close()


@pytest.mark.mpi
@pytest.mark.parametrize("algorithm", ["FULL", "v-w-u", "w-v-u"])
def test_sliding_pair_on_the_ranks_of_the_communicator(algorithm):
    """On any number of ranks: T = mu N once sliding, and the serial run's displacements."""
    run = sliding_pair("interface", algorithm, MU, STEPS, MPI.COMM_WORLD)
    serial = sliding_pair("interface", algorithm, MU, STEPS, MPI.COMM_SELF)
    assert abs(-run["T"][-1] / (MU * run["N"][-1]) - 1.0) < 1e-6
    assert run["changes"] == serial["changes"]
    error = np.linalg.norm(run["u"] - serial["u"]) / np.linalg.norm(serial["u"])
    assert error < 1e-9
