"""The timing model (dd_contact.timing) and algorithm="auto"."""

from __future__ import annotations

import json
from collections import Counter

from mpi4py import MPI

import numpy as np
import pytest

import dd_contact as dd
from dd_contact import calibration, timing
from dd_contact.paper import verify
from dd_contact.paper.examples import parallelepiped, row_of_blocks
from dd_contact.solvers import analysed
from dd_contact.solvers.worklog import WorkLog, WorkRecord


@pytest.fixture(scope="module")
def rates(tmp_path_factory) -> timing.MachineRates:
    """This machine's rates from the quick calibration (cached in a temporary directory)."""
    path = tmp_path_factory.mktemp("cache") / "machine_rates.json"
    return timing.machine_rates(path, quick=True)


def _flat(rate: float) -> list[list[float]]:
    return [[1.0, 1.0 / rate], [1e12, 1e12 / rate]]


#: Rates of a 2-core machine (the medians of a full calibration of this one, 2026-11-22,
#: per unit of each kind): the auto choices below are decisions of the model under fixed
#: rates, not of a calibration that the machine's load moves (they flipped under load).
TWO_CORES = timing.MachineRates(
    {
        "sparse_factor": _flat(7.7e9),
        "sparse_analysis": _flat(2.9e7),
        "sparse_solve": _flat(5.0e8),
        "sparse_solve_block": _flat(3.4e9),
        "dense_factor": _flat(6.5e9),
        "dense_solve": _flat(3.7e8),
        "dense_solve_block": _flat(1.4e10),
        "call": _flat(1.0 / 14e-6),  # the engine's Python around an operation: 14 us
    }
)


def test_pricing_divides_the_work_by_the_rate_of_its_kind():
    rates = timing.MachineRates(
        {k: _flat(10.0 ** (i + 6)) for i, k in enumerate(timing.RATE_KINDS)}
    )
    r = rates.seconds
    factor = WorkRecord("u", "sparse_factor", 100, 0, 0.0, 3e9, "", 5e6, 40_000)
    assert timing.record_seconds(factor, rates) == pytest.approx(3e9 / 1e6 + 40_000 / 1e7)
    assert timing.record_seconds(
        WorkRecord("u", "sparse_solve", 100, 1, 0.0, None, "", 5e6), rates
    ) == pytest.approx(r("sparse_solve", 5e6))
    assert timing.record_seconds(
        WorkRecord("u", "sparse_solve", 100, 64, 0.0, None, "", 5e6), rates
    ) == pytest.approx(64 * 5e6 / 1e9)
    for sweep in ("sparse_forward", "sparse_backward"):  # MUMPS's Schur phases: half a solve
        assert timing.record_seconds(
            WorkRecord("u", sweep, 100, 1, 0.0, None, "", 5e6), rates
        ) == pytest.approx(0.5 * r("sparse_solve", 5e6))
    assert timing.record_seconds(
        WorkRecord("w", "dense_factor", 300, 0, 0.0), rates
    ) == pytest.approx(300**3 / 3 / 1e10)
    assert timing.record_seconds(
        WorkRecord("w", "dense_solve", 300, 1, 0.0), rates
    ) == pytest.approx(2 * 300**2 / 1e11)
    assert timing.record_seconds(
        WorkRecord("w", "dense_solve", 300, 7, 0.0, 300 * 300 * 7.0), rates
    ) == pytest.approx(300 * 300 * 7 / 1e12)


def test_rates_interpolate_between_the_measured_sizes_and_stay_flat_beyond():
    rates = timing.MachineRates({"dense_factor": [[1e6, 1e-3], [1e8, 1e-2]]})
    assert rates.seconds("dense_factor", 1e6) == pytest.approx(1e-3)  # measured points back
    assert rates.seconds("dense_factor", 1e8) == pytest.approx(1e-2)
    assert rates.rate("dense_factor", 1e7) == pytest.approx(np.sqrt(1e9 * 1e10))  # log-log
    assert rates.rate("dense_factor", 1e12) == pytest.approx(1e10)
    # below the smallest size a call costs what the smallest did: its overhead
    assert rates.seconds("dense_factor", 10.0) == pytest.approx(1e-3)
    assert rates.seconds("dense_factor", 0.0) == 0.0


def test_calibration_is_measured_once_and_cached(tmp_path, monkeypatch, rates):
    path = tmp_path / "rates.json"
    calls = []
    monkeypatch.setattr(
        calibration, "calibrate", lambda quick, progress=None: calls.append(quick) or rates
    )
    first = timing.machine_rates(path, quick=True)
    second = timing.machine_rates(path, quick=True)
    assert calls == [True]  # the second call read the cache
    assert second.points == first.points == rates.points
    assert json.loads(path.read_text())  # one record, keyed by the machine's fingerprint
    timing.machine_rates(path, quick=True, recalibrate=True)
    assert calls == [True, True]


def test_implausible_cached_rates_are_measured_again_and_not_cached(tmp_path, monkeypatch, rates):
    """The cached record of this machine once held an analysis of 5.5e6 entries in 1e-6 s
    (a difference of two noisy times): such a record is measured again, not used."""
    path = tmp_path / "rates.json"
    bogus = timing.MachineRates(
        {**rates.points, "sparse_analysis": [[61731.0, 1.5e-3], [5527125.0, 1e-6]]}
    )
    assert bogus.implausible() == ["sparse_analysis: 5.53e+12/s at 5.53e+06"]
    assert rates.implausible() == []
    calls = []
    monkeypatch.setattr(
        calibration, "calibrate", lambda quick, progress=None: calls.append(quick) or bogus
    )
    first = timing.machine_rates(path, quick=True, progress=lambda d, t: None)
    assert calls == [True] and not path.exists()  # measured, implausible: not cached
    assert first is bogus
    monkeypatch.setattr(
        calibration, "calibrate", lambda quick, progress=None: calls.append(quick) or rates
    )
    timing.machine_rates(path, quick=True)  # measured again, plausible now: cached
    assert calls == [True, True] and path.exists()
    key = next(iter(json.loads(path.read_text())))
    path.write_text(json.dumps({key: bogus.to_dict()}))  # a bogus record in the cache
    again = timing.machine_rates(path, quick=True)
    assert calls == [True, True, True] and again.points == rates.points
    assert json.loads(path.read_text())[key]["points"] == rates.points


def test_calibration_measures_an_implausible_size_again(monkeypatch):
    timings = iter([1e-9, 1e-9, 1e-3])  # two hiccups, then a plausible factorisation
    monkeypatch.setattr(calibration, "CALIBRATION_SIZES", {"quick": ([], [100]), "full": None})
    real = calibration._dense_points

    def measured(n, rng):
        point = real(n, rng)
        point["dense_factor"][1] = next(timings)
        return point

    monkeypatch.setattr(calibration, "_dense_points", measured)
    shown = []
    rates = calibration.calibrate(quick=True, progress=lambda d, t: shown.append((d, t)))
    assert rates.points["dense_factor"] == [[100**3 / 3.0, 1e-3]]
    assert shown == [(1, 2), (2, 2)]  # the dense size, then the engine's calls


def test_auto_calibration_shows_a_message_and_a_progress_bar(tmp_path, monkeypatch, capsys, rates):
    def measured(quick, progress):
        for done in (1, 2):
            progress(done, 2)
        return rates

    monkeypatch.setattr(calibration, "calibrate", measured)
    timing.machine_rates(tmp_path / "rates.json", quick=True)
    err = capsys.readouterr().err
    assert err.count("measuring this machine's rates for algorithm='auto'") == 1
    assert "calibrate: 100%" in err and "2/2" in err


def test_calibrate_command_measures_caches_and_shows(tmp_path, monkeypatch, capsys):
    from dd_contact.cli import main

    monkeypatch.setenv("DD_CONTACT_CACHE", str(tmp_path))
    assert main(["calibrate", "--quick"]) == 0
    shown = capsys.readouterr().out
    assert all(kind in shown for kind in timing.RATE_KINDS)
    cached = (tmp_path / "machine_rates.json").read_text()
    assert main(["calibrate", "--quick", "--show"]) == 0  # reads the cache: file unchanged
    assert (tmp_path / "machine_rates.json").read_text() == cached
    assert capsys.readouterr().out == shown


def test_quick_calibration_measures_every_kind(rates):
    assert set(rates.points) == set(timing.RATE_KINDS)
    for kind, points in rates.points.items():
        assert len(points) >= (1 if kind == "call" else 2), kind  # one "call": per operation
        assert all(work > 0 and seconds > 0 for work, seconds in points), kind
    assert rates.machine["quick"] is True
    # A MUMPS factorisation of a million flops is at least 1 Mflop/s and at most 1 Tflop/s.
    assert 1e6 < rates.rate("sparse_factor", 1e9) < 1e12


def test_analysis_predicts_the_factorisation_exactly():
    scene = parallelepiped("w-u", (12, 4, 3), comm=MPI.COMM_SELF)
    problem = dd.TransientProblem(scene, 1e-6, algorithm="w-u")
    sub = next(iter(problem.solver.subdomains.values()))
    stats = sub.analyse()  # the factorisation's own analysis, done ahead
    problem.run(1, progress=False, summary=False)
    (record,) = [r for r in problem.work.records if r.kind == "sparse_factor"]
    assert (stats.flops, stats.entries, stats.size) == (record.flops, record.entries, record.size)
    assert stats.schur == sub.schur > 0 and record.nnz == stats.nnz > 0


_SCENES = [
    ("interface", "FULL"),
    ("interface", "v-w-u"),
    ("interface", "w-v-u"),
    ("boundary", "FULL"),
    ("boundary", "v-u"),
    ("single", "w-u"),
]


@pytest.mark.parametrize("condensation", ["schur", "multi-rhs"])
@pytest.mark.parametrize(("kind", "algorithm"), _SCENES)
def test_the_plan_is_what_the_solver_does(kind, algorithm, condensation):
    """Set-up + steps + a change plan per change + a release plan per release solve: every
    factorisation and solve, exactly (default energy-safe contact)."""
    n_steps = 25
    problem = dd.TransientProblem(
        verify.order_scene(kind, True, 1e4), 0.01, algorithm=algorithm, condensation=condensation
    )
    full = algorithm == "FULL"
    structure = analysed.scene_structure(
        problem.comm,
        problem.solver.system,
        [z.region for z in problem.zones],
        condensation,
        full=full,
        orders=not full,
    )
    plan = timing.plan(structure, algorithm)
    problem.run(n_steps, progress=False, summary=False)
    assert problem.changes["gamma"] >= 2 and problem.iteration.cycles_resolved == 0
    planned = plan.setup + n_steps * plan.step
    for region, alpha in problem.iteration.alpha.items():
        planned += alpha * plan.changes[region]
    # A release solve re-substitutes the same contact state: no factorisation in it.
    releases = problem.iteration.releases
    assert sum(releases.values()) == problem.iteration.release_solves >= 10
    schedule = structure.schedule(algorithm)
    for region, count in releases.items():
        planned += count * WorkLog.planned(schedule.release(region)).records
    done = Counter((r.block, r.kind, r.what, r.size, r.nrhs) for r in problem.work.records)
    assert Counter((r.block, r.kind, r.what, r.size, r.nrhs) for r in planned) == done


def test_prediction_adds_up_its_parts(rates):
    problem = dd.TransientProblem(verify.order_scene("interface", True, 1e4), 0.01, "v-w-u")
    p = problem.predict(100, 30, rates)
    assert p.algorithm == "v-w-u" and p.setup > 0 and p.step > 0 and p.change > 0
    # energy-safe contact (the default) releases about RELEASES_PER_CHANGE times a change
    assert p.release > 0 and p.releases == timing.RELEASES_PER_CHANGE * 30 and p.tie_solves == 1
    assert p.total == pytest.approx(p.setup + 100 * p.step + 30 * p.change + 15 * p.release)


# -- algorithm="auto" on scenes whose answer is known -------------------------------------
def test_one_contact_interface_on_a_large_subdomain_chooses_w_v_u_or_w_u():
    rates = TWO_CORES
    """Each contact change re-factorises only the small w block (FULL: everything)."""
    split = dd.TransientProblem(parallelepiped("v-w-u", (48, 10, 6)), 1e-6, "auto", rates=rates)
    assert split.algorithm == "w-v-u", split.choice.table()
    whole = dd.TransientProblem(parallelepiped("w-u", (48, 10, 6)), 1e-6, "auto", rates=rates)
    assert whole.algorithm == "w-u", whole.choice.table()
    # 1000 changes: FULL re-factorising the whole bar cannot win, so it is not analysed
    assert set(whole.choice.predictions) == {"w-u"} and set(whole.choice.skipped) == {"FULL"}
    assert whole.choice.skipped["FULL"] > whole.choice.predictions["w-u"].total
    assert "FULL     not analysed: cannot win" in whole.choice.table()


def test_many_active_contact_interfaces_choose_v_w_u():
    rates = TWO_CORES
    """w-v-u would re-factorise all contact interfaces together on every change."""
    problem = dd.TransientProblem(row_of_blocks(5), 2e-4, algorithm="auto", rates=rates)
    assert problem.algorithm == "v-w-u", problem.choice.table()
    p = problem.choice.predictions
    assert set(p) | set(problem.choice.skipped) == {"FULL", "v-w-u", "w-v-u"}
    assert p["w-v-u"].change > 3 * p["v-w-u"].change


def test_without_contact_interfaces_auto_chooses_among_the_orders_without_w():
    rates = TWO_CORES
    scene = parallelepiped("v-u", (48, 10, 6))
    changing = dd.TransientProblem(scene, 1e-6, algorithm="auto", rates=rates)
    assert set(changing.choice.predictions) | set(changing.choice.skipped) == {"FULL", "v-u"}
    # v-u re-factorises the contact subdomain only, FULL the whole bar ...
    assert changing.algorithm == "v-u", changing.choice.table()
    # ... but without changes FULL's one substitution per step beats v-u's two per subdomain.
    still = dd.TransientProblem(scene, 1e-6, "auto", expected_changes=0, rates=rates)
    assert still.algorithm == "FULL", still.choice.table()
    assert set(still.choice.predictions) == {"FULL", "v-u"} and not still.choice.skipped


def test_auto_solves_like_the_named_algorithm(rates):
    auto = dd.StaticProblem(verify.order_scene("interface", False), "auto", rates=rates)
    named = dd.StaticProblem(verify.order_scene("interface", False), auto.algorithm)
    u_auto = np.concatenate([f.x.array for f in auto.solve()])
    u_named = np.concatenate([f.x.array for f in named.solve()])
    assert auto.choice.algorithm == auto.algorithm in auto.choice.table()
    np.testing.assert_allclose(u_auto, u_named, rtol=0, atol=1e-12 * np.abs(u_named).max())


@pytest.mark.parametrize(("steps", "changes"), [(0, 1), (10, -1), (10, float("nan"))])
def test_auto_refuses_impossible_expectations(steps, changes, rates):
    with pytest.raises(dd.InputError, match="expected steps must be >= 1"):
        dd.TransientProblem(
            verify.order_scene("single", True),
            0.01,
            "auto",
            expected_steps=steps,
            expected_changes=changes,
            rates=rates,
        )


@pytest.mark.mpi
def test_auto_under_mpi_predicts_the_orders_as_in_serial():
    """Subdomains analysed on their owner ranks; every rank gets the same choice."""
    rates = timing.MachineRates({k: _flat(1e9) for k in timing.RATE_KINDS})
    comm = MPI.COMM_WORLD
    shared = dd.TransientProblem(
        parallelepiped("v-w-u", (24, 6, 4), comm=comm), 1e-6, "auto", rates=rates
    )
    alone = dd.TransientProblem(
        parallelepiped("v-w-u", (24, 6, 4), comm=MPI.COMM_SELF), 1e-6, "auto", rates=rates
    )
    assert comm.allgather(shared.algorithm) == [alone.algorithm] * comm.size
    for order in ("v-w-u", "w-v-u"):
        assert shared.choice.predictions[order].total == pytest.approx(
            alone.choice.predictions[order].total, rel=1e-12
        )


def test_auto_reuses_the_analysis_and_factorises_as_the_named_algorithm(rates):
    """auto analyses the candidates once; the chosen solver factorises as if named."""
    runs = {}
    for algorithm in ("auto", "w-v-u"):
        problem = dd.TransientProblem(
            parallelepiped("v-w-u", (24, 6, 4)), 1e-6, algorithm, rates=TWO_CORES
        )
        problem.run(4, progress=False, summary=False)
        runs[algorithm] = problem
    assert runs["auto"].algorithm == "w-v-u", runs["auto"].choice.table()

    def factorisations(problem):
        return Counter(
            (r.block, r.kind, r.size, r.nnz > 0)  # nnz > 0: this one ran the analysis
            for r in problem.work.records
            if r.kind in ("sparse_factor", "dense_factor")
        )

    assert factorisations(runs["auto"]) == factorisations(runs["w-v-u"])
    analysed = [r.block for r in runs["auto"].work.records if r.nnz > 0]
    assert len(analysed) == len(set(analysed)) == 2  # each subdomain analysed once


def test_auto_chooses_again_when_the_first_solves_miss_by_more_than_2x(rates, caplog):
    """Sparse rates 1e4 x too fast make FULL look cheapest (the orders' dense work is priced
    right); its first three solves take far longer than predicted: auto re-plans, switches."""
    optimistic = rates.scaled({k: 1e-4 for k in timing.RATE_KINDS if k.startswith("sparse")})
    scene = parallelepiped("v-w-u", (48, 10, 6))
    problem = dd.TransientProblem(
        scene, 1e-6, "auto", rates=optimistic, expected_steps=100, expected_changes=100
    )
    assert problem.algorithm == "FULL" and not problem.choice.replanned
    with caplog.at_level("WARNING", logger="dd_contact.analysis"):
        problem.run(5, progress=False, summary=False)
    assert problem.choice.replanned and problem.algorithm != "FULL", problem.choice.table()
    assert problem.choice.misses["sparse_factor"] > 100 * timing.MISS
    assert "chose again for the rest of the run" in caplog.text
    named = dd.TransientProblem(parallelepiped("v-w-u", (48, 10, 6)), 1e-6, "FULL")
    named.run(5, progress=False, summary=False)
    u, expected = scene.subdomains[0].u.x.array, named.scene.subdomains[0].u.x.array
    np.testing.assert_allclose(u, expected, rtol=0, atol=1e-7 * np.abs(expected).max())


def test_a_replan_switches_only_for_a_clear_gain():
    structure = analysed.SceneStructure({}, {}, {}, {}, set(), None)

    def priced(totals):  # the rest of the run of each (one "step" of that many seconds)
        def predict(plan, rates, steps, changes, releases, tie_solves):
            return timing.Prediction(plan, 0.0, totals[plan], 0.0, steps, changes)

        return predict

    choice = timing.Choice("A", {"A": None, "B": None})
    for totals, expected in (({"A": 10.0, "B": 9.0}, "A"), ({"A": 10.0, "B": 7.0}, "B")):
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(timing, "plan", lambda structure, algorithm: algorithm)
            mp.setattr(timing, "predict", priced(totals))
            rest = timing.Expected(1, 0)
            again = timing.replan(choice, structure, TWO_CORES, {"sparse_factor": 3.0}, rest)
        assert again.algorithm == expected and again.replanned
        assert again.misses == {"sparse_factor": 3.0}


def test_misses_are_measured_over_predicted_seconds_per_kind():
    rates = timing.MachineRates({k: _flat(1e9) for k in timing.RATE_KINDS})
    records = [
        WorkRecord("d", "dense_factor", 3000, 0, 3 * 9e9 / 1e9, 9e9),  # 3 x its 9 s
        WorkRecord("u", "sparse_forward", 10, 1, 0.2, 2e8, "u_hat", 1e8),  # 4 x 0.05 s
        WorkRecord("w", "dense_solve", 10, 1, 0.01, 200.0),  # too little time to judge
    ]
    assert timing.misses(records, rates) == pytest.approx(
        {"dense_factor": 3.0, "sparse_solve": 4.0}
    )


# -- what the solvers spend around their operations (issue 30) -------------------------
@pytest.mark.parametrize("algorithm", ["v-w-u", "w-v-u", "FULL"])
def test_a_step_records_the_operations_its_plan_prices(algorithm):
    """A step without a contact change: the solver records exactly the plan's operations
    (substitutions, surface solves, coupling products), and its time around them in
    calls of its solve and finish."""
    problem = dd.TransientProblem(verify.order_scene("interface", True, 1e4), 0.01, algorithm)
    structure = analysed.scene_structure(
        problem.comm,
        problem.solver.system,
        [z.region for z in problem.zones],
        full=algorithm == "FULL",
        orders=algorithm != "FULL",
    )
    plan = timing.plan(structure, algorithm)
    problem.run(2, progress=False, summary=False)
    for _ in range(30):
        first, calls = len(problem.work.records), len(problem.work.calls)
        released = problem.iteration.release_solves
        record = problem.advance()
        if not record["changes"] and problem.iteration.release_solves == released:
            break
    else:
        pytest.skip("every step changed the contact state")
    done = problem.work.records[first:]
    key = lambda r: (r.block, r.kind, r.what, r.size, r.nrhs)  # noqa: E731
    assert Counter(map(key, done)) == Counter(map(key, plan.step))
    # the eliminated group's coupling: B^T y forward, B x in the back-substitution
    products = [r.what for r in done if r.kind == "dense_product"]
    assert sorted(products) == ([] if algorithm == "FULL" else ["x", "y"])
    # one solve and one finish, whose operations are the step's
    assert sum(n for n, _ in problem.work.calls[calls:]) == len(plan.step)
    assert all(seconds >= 0 for _, seconds in problem.work.calls[calls:])


def test_an_operation_is_priced_with_the_time_around_it():
    rates = timing.MachineRates({k: _flat(1e9) for k in timing.RATE_KINDS})
    rates.points["call"] = _flat(1.0 / 2e-5)  # 20 us around each operation
    records = [
        WorkRecord("w", "dense_solve", 100, 1, 0.0),
        WorkRecord("w", "dense_product", 100, 40, 0.0, what="y"),
        WorkRecord("w", "dense_product", 100, 40, 0.0, what="condense"),
    ]
    plan = timing.Plan("v-w-u", [], records, {})
    # a solve 2 n^2, a product with a vector 2 n m, W^T W n m^2 (flops at 1e9/s each)
    work = 2 * 100**2 + 2 * 100 * 40 + 100 * 40**2
    assert plan.seconds(plan.step, rates) == pytest.approx(work / 1e9 + 3 * 2e-5)
    assert [timing.rate_kind(r) for r in records] == [
        "dense_solve",
        "dense_solve",
        "dense_solve_block",
    ]


def test_releases_and_stiff_tie_solves_add_to_the_total():
    p = timing.Prediction("A", 1.0, 0.1, 0.5, 100, 20, release=0.05, releases=10, tie_solves=3)
    solves = 100 + 20 + 10
    assert p.total == pytest.approx(1.0 + 100 * 0.1 + 20 * 0.5 + 10 * 0.05 + 2 * solves * 0.1)
    assert timing.Prediction("A", 1.0, 0.1, 0.5, 100, 20).total == pytest.approx(21.0)


def test_the_plan_prices_one_release_solve_per_region():
    problem = dd.TransientProblem(verify.order_scene("interface", True, 1e4), 0.01, "v-w-u")
    structure = analysed.scene_structure(
        problem.comm, problem.solver.system, [z.region for z in problem.zones], full=False
    )
    plan = timing.plan(structure, "v-w-u")
    schedule = structure.schedule("v-w-u")
    assert set(plan.releases) == set(structure.regions)
    for region, records in plan.releases.items():
        assert [(r.block, r.kind, r.what) for r in records] == [
            (o.target, o.kind, o.what) for o in schedule.release(region)
        ]
    assert plan.release_seconds(TWO_CORES) > 0


def test_the_solvers_time_around_their_operations_is_judged_after_the_first_call():
    rates = timing.MachineRates({k: _flat(1e9) for k in timing.RATE_KINDS})
    rates.points["call"] = _flat(1.0 / 1e-5)
    # the first call builds the surface system: left out; then 3 x 10 operations in 0.6 s
    calls = [(50, 5.0), (10, 0.2), (10, 0.2), (10, 0.2)]
    assert timing.misses([], rates, calls) == pytest.approx({"call": 0.6 / 3e-4})
    assert timing.misses([], rates, calls[:1]) == {}


def test_auto_prices_the_stiff_ties_solves_and_counts_them_when_it_checks(rates):
    from dd_contact.solvers.stiff_ties import AugmentedTies

    scene = verify.pressed_scene("interface", kappa=1e12, comm=MPI.COMM_SELF)
    problem = dd.StaticProblem(scene, "auto", rates=rates)
    assert isinstance(problem.analysis.tie_solver, AugmentedTies)
    assert all(p.tie_solves == timing.TIE_SOLVES for p in problem.choice.predictions.values())
    problem.solve()
    analysis = problem.analysis
    solves = analysis.tie_solver.solves
    rest = analysis._rest(timing.Expected(10, 3, 0.0, timing.TIE_SOLVES))
    it = analysis.iteration
    assert rest.tie_solves == pytest.approx(solves / (1 + it.gamma + it.release_solves))
    assert rest.tie_solves > 1 and rest.steps == 9


def test_fulls_lower_bound_uses_the_fastest_rate_measured():
    rates = timing.MachineRates({"sparse_solve": [[1e4, 1e-3], [1e6, 2e-3], [1e8, 1.0]]})
    # 5e8 per second at 1e6 is the fastest: below and beyond, the bound is no slower
    assert rates.least_seconds("sparse_solve", 1e3) == pytest.approx(2e-6)
    assert rates.least_seconds("sparse_solve", 1e9) == pytest.approx(2.0)
    for work in (1e3, 1e5, 1e7, 1e9):
        assert rates.least_seconds("sparse_solve", work) <= rates.seconds("sparse_solve", work)


def test_a_process_with_half_a_core_is_judged_by_its_share():
    """Another job on the machine slows every kind alike: no miss."""
    rates = timing.MachineRates({k: _flat(1e9) for k in timing.RATE_KINDS})
    records = [WorkRecord("d", "dense_factor", 3000, 0, 2 * 9.0, 9e9)]  # 2 x its 9 s
    assert timing.misses(records, rates) == pytest.approx({"dense_factor": 2.0})
    assert timing.misses(records, rates, share=0.5) == pytest.approx({"dense_factor": 1.0})


def test_a_first_factorisation_is_not_judged():
    """Its analysis and fresh memory are paid once: the rest of the run repeats neither."""
    rates = timing.MachineRates({k: _flat(1e9) for k in timing.RATE_KINDS})
    first = WorkRecord("u", "sparse_factor", 100, 0, 50.0, 1e9, "", 1e6, 5000)  # 50x
    again = WorkRecord("u", "sparse_factor", 100, 0, 3.0, 1e9, "", 1e6)  # 3x
    assert timing.misses([first], rates) == {}
    assert timing.misses([first, again], rates) == pytest.approx({"sparse_factor": 3.0})
