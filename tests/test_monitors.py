"""The parts of a transient run, alone: its energy balance, contact episodes and run state."""

import warnings
from types import SimpleNamespace

from mpi4py import MPI

import numpy as np
import pytest

from dd_contact.checkpointing import RunState
from dd_contact.errors import CoarseTimeStepWarning, EnergyGrowthWarning, InputError
from dd_contact.monitors import (
    ENERGY_GROWTH_TOLERANCE,
    MIN_CONTACT_STEPS,
    MINOR_EPISODE,
    ContactEpisodes,
    EnergyBalance,
)


def _record(step, total, contact=0.0, **extra):
    energy = {"total": total, "contact": contact}
    return {"step": step, "t": 0.1 * step, "changes": 1, "energy": energy, **extra}


def _no_work():
    return 0.0, False


def test_the_energy_balance_warns_once_when_a_step_creates_energy():
    balance = EnergyBalance(MPI.COMM_SELF, conserves_energy=True, energy_safe=True)
    balance.start({"total": 100.0, "contact": 0.0})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        balance.check(_record(1, 100.0 + 0.5 * ENERGY_GROWTH_TOLERANCE * 100.0), _no_work)
    with pytest.warns(
        EnergyGrowthWarning, match=r"step 2 .* grew by 0\.0999 J .*please report"
    ) as caught:
        balance.check(_record(2, 100.1), _no_work)
    assert caught[0].filename == __file__  # the user's line, not the package's
    assert balance.warned and balance.before == 100.1
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        balance.check(_record(3, 200.0), _no_work)  # once a run


def test_the_energy_balance_counts_the_loads_work_and_skips_moving_supports():
    balance = EnergyBalance(MPI.COMM_SELF, conserves_energy=True, energy_safe=False)
    free = {"u:a": np.array([1.0, 1.0, 0.0])}
    before = {"u:a": np.zeros(3)}
    after = {"u:a": np.array([0.1, 0.2, 0.0])}
    loads = {"u:a": np.array([10.0, 20.0, 99.0])}
    work, moved = balance.loads_work(before, after, loads, loads, free.__getitem__)
    assert work == pytest.approx(0.1 * 10.0 + 0.2 * 20.0) and not moved
    balance.start({"total": 1.0, "contact": 0.0})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        balance.check(_record(1, 1.0 + work), lambda: (work, moved))  # the loads' work only
        balance.check(_record(2, 50.0), lambda: (0.0, True))  # supports moved: not judged
    with pytest.warns(EnergyGrowthWarning, match="energy_safe_contact=True"):
        balance.check(_record(3, 60.0), _no_work)


def test_a_damped_scheme_is_held_to_the_start_plus_the_loads_work():
    balance = EnergyBalance(MPI.COMM_SELF, conserves_energy=False, energy_safe=True)
    balance.start({"total": 10.0, "contact": 0.0})
    balance.check(_record(1, 9.0), lambda: (1.0, False))
    assert balance.before == 11.0  # the bound, not the (damped) energy of the step


def _energy(kinetic, elastic):
    return {"kinetic": kinetic, "elastic": elastic}


def _episode(monitor, steps, energy_before, first_step=1, force=1.0):
    """``steps`` steps in contact; ``energy_before``: the energy of the step before."""
    for k in range(steps):
        record = {"step": first_step + k, "t": 0.0, "active": {"end": 4}, "force": {"end": force}}
        monitor.observe(record, energy_before if k == 0 else None)
    closing = {"step": first_step + steps, "t": 0.0, "active": {"end": 0}, "force": {"end": 0.0}}
    monitor.observe(closing, None)


def test_a_short_impact_warns_once_and_names_the_time_step():
    episodes = ContactEpisodes(dt=1e-6)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _episode(episodes, MIN_CONTACT_STEPS, _energy(1.0, 0.0))  # long enough
        _episode(episodes, 5, _energy(0.1, 1.0), first_step=200, force=2.0)  # a load
        # a graze: 5 steps, 0.9 MINOR_EPISODE of the long episode's impulse
        _episode(episodes, 5, _energy(1.0, 0.5), first_step=300, force=0.9 * MINOR_EPISODE * 60 / 5)
    with pytest.warns(CoarseTimeStepWarning, match=r"after only 5 time step\(s\)"):
        _episode(episodes, 5, _energy(1.0, 0.5), first_step=400, force=1.1 * MINOR_EPISODE * 60 / 5)
    assert episodes.warned


def _subdomain(name, n, seed):
    rng = np.random.default_rng(seed)

    def field():
        return SimpleNamespace(x=SimpleNamespace(array=rng.random(n)))

    return SimpleNamespace(name=name, u=field(), velocity=field(), acceleration=field())


def _iteration():
    return SimpleNamespace(
        gamma=7,
        release_solves=2,
        active={"end": np.array([True, False, True])},
        alpha={"end": 5},
        releases={"end": 1},
    )


def _surface(name, n, seed):
    array = np.random.default_rng(seed).random(n)
    return SimpleNamespace(name=name, x=SimpleNamespace(array=array))


def _zones(seed):
    end = SimpleNamespace(name="end", w=_surface("w", 4, seed))
    return [SimpleNamespace(contact=end, sides=[end])]


def _interface(seed):
    return SimpleNamespace(name="glue", v=_surface("v", 5, seed))


def test_the_run_state_goes_to_arrays_and_back_exactly():
    zones, interface = _zones(0), _interface(0)
    saved = RunState([_subdomain("bar", 6, 0)], zones, _iteration(), interface)
    arrays = saved.arrays(12, 1.2e-5, 1e-6, "inertia=True")
    target = _subdomain("bar", 6, 1)
    iteration = SimpleNamespace(gamma=0, release_solves=0, active={}, alpha={}, releases={})
    restored_zones, restored_interface = _zones(1), _interface(1)
    restored = RunState([target], restored_zones, iteration, restored_interface)
    assert restored.restore(arrays, 1e-6, "inertia=True") == (12, 1.2e-5)
    surfaces = [(restored_zones[0].contact.w, zones[0].contact.w)]
    surfaces.append((restored_interface.v, interface.v))  # the next start forces read them
    for mine, theirs in surfaces:
        np.testing.assert_array_equal(mine.x.array, theirs.x.array)
    for name in ("u", "velocity", "acceleration"):
        source = getattr(saved.owned[0], name).x.array
        np.testing.assert_array_equal(getattr(target, name).x.array, source)
    assert (iteration.gamma, iteration.release_solves) == (7, 2)
    assert (iteration.alpha, iteration.releases) == ({"end": 5}, {"end": 1})
    np.testing.assert_array_equal(iteration.active["end"], [True, False, True])


def test_a_run_state_of_other_settings_or_meshes_is_refused():
    zones = _zones(0)
    arrays = RunState([_subdomain("bar", 6, 0)], zones, _iteration()).arrays(3, 3.0, 1.0, "a")
    other = RunState([_subdomain("bar", 9, 1)], zones, _iteration())
    with pytest.raises(InputError, match=r"dt = 1\.0, this run has dt = 2\.0"):
        other.restore(arrays, 2.0, "a")
    with pytest.raises(InputError, match="written with a; this run has b"):
        other.restore(arrays, 1.0, "b")
    with pytest.raises(InputError, match="does not match subdomain 'bar'"):
        other.restore(arrays, 1.0, "a")


def test_a_run_state_without_the_surfaces_is_refused():
    """A checkpoint of an earlier version: resuming from it would start from wrong forces."""
    zones = _zones(0)
    arrays = RunState([_subdomain("bar", 6, 0)], zones, _iteration()).arrays(3, 3.0, 1.0, "a")
    del arrays["w/end"]
    with pytest.raises(InputError, match=r"no 'end' surface .*start a new output directory"):
        RunState([_subdomain("bar", 6, 1)], _zones(1), _iteration()).restore(arrays, 1.0, "a")


def test_round_off_of_a_run_that_came_to_rest_does_not_warn():
    """Held to the largest energy of the run: 1e-12 J is round-off after 100 J."""
    balance = EnergyBalance(MPI.COMM_SELF, conserves_energy=True, energy_safe=True)
    balance.start({"total": 100.0, "contact": 0.0})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        balance.check(_record(1, 1e-7), lambda: (-100.0, False))  # the loads took it out
        balance.check(_record(2, 1e-7 + 1.4e-12), _no_work)
    assert balance.largest == 100.0 and not balance.warned


def test_a_release_within_the_iterations_tolerance_does_not_warn():
    """A release settles its kept force within RELEASE_TOLERANCE of the penalty energy held."""
    from dd_contact.impact import RELEASE_TOLERANCE

    balance = EnergyBalance(MPI.COMM_SELF, conserves_energy=True, energy_safe=True)
    balance.start({"total": 1.0, "contact": 0.0})
    balance.check(_record(1, 1.0, contact=0.5), _no_work)  # half of it in the penalty
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        balance.check(_record(2, 1.0 + 0.9 * RELEASE_TOLERANCE * 0.5), _no_work)
    with pytest.warns(EnergyGrowthWarning):
        balance.check(_record(3, 1.01, contact=0.0), _no_work)  # no penalty energy held


def test_the_classic_contact_gets_no_release_allowance():
    """Without energy-safe contact there is no release iteration to settle within."""
    from dd_contact.impact import RELEASE_TOLERANCE

    balance = EnergyBalance(MPI.COMM_SELF, conserves_energy=True, energy_safe=False)
    balance.start({"total": 1.0, "contact": 0.0})
    balance.check(_record(1, 1.0, contact=0.5), _no_work)
    with pytest.warns(EnergyGrowthWarning, match="energy_safe_contact=True"):
        balance.check(_record(2, 1.0 + 0.9 * RELEASE_TOLERANCE * 0.5), _no_work)


def test_a_moving_obstacles_work_is_counted_in_its_steps_only():
    wall = SimpleNamespace(motion=lambda t: (0.0, 0.0, 0.01 * max(t - 0.15, 0.0)))
    contacts = [SimpleNamespace(obstacle=wall)]
    balance = EnergyBalance(MPI.COMM_SELF, True, energy_safe=True, contacts=contacts, dt=0.1)
    balance.start({"total": 1.0, "contact": 0.0})
    asked = []

    def obstacle_work():
        asked.append(1)
        return 0.5

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        balance.check(_record(1, 1.0), _no_work, obstacle_work)  # t 0 -> 0.1: at rest
        balance.check(_record(2, 1.5), _no_work, obstacle_work)  # moved: its 0.5 J counted
    assert len(asked) == 1
    with pytest.warns(EnergyGrowthWarning, match=r"step 3 .* grew by 0\.1 J"):
        balance.check(_record(3, 2.1), _no_work, obstacle_work)  # 0.6 J against 0.5 J


def test_a_moving_obstacle_with_friction_is_checked_with_its_work():
    """Its work (normal and, through friction, tangential) is counted; a gain beyond it warns."""
    wall = SimpleNamespace(motion=lambda t: (0.01 * t, 0.0, 0.0))
    contacts = [SimpleNamespace(obstacle=wall, friction=0.3)]
    balance = EnergyBalance(MPI.COMM_SELF, True, energy_safe=True, contacts=contacts, dt=0.1)
    balance.start({"total": 1.0, "contact": 0.0})
    asked = []

    def obstacle_work():
        asked.append(1)
        return 0.5

    dissipating = _record(1, 1.3)
    dissipating["energy"]["dissipated"] = 0.2  # 1.0 + 0.5 - 0.2
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        balance.check(dissipating, _no_work, obstacle_work)
    assert asked == [1] and balance.before == 1.3
    created = _record(2, 1.3 + 0.5 + 1e-3)  # 1 mJ beyond the obstacle's work
    with pytest.warns(EnergyGrowthWarning, match=r"step 2 .* grew by 0\.001 J"):
        balance.check(created, _no_work, obstacle_work)
