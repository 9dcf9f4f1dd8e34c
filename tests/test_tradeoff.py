"""The trade study: its design, the Pareto front, the budget, and a tiny real study."""

from __future__ import annotations

import json

import numpy as np
import pytest

from dd_contact.cli import main
from dd_contact.paper.tradeoff import (
    BudgetExceeded,
    Knob,
    Level,
    TradeScene,
    combined_design,
    default_verdict,
    first_design,
    is_costly,
    pareto_front,
    run_in_process,
    run_study,
    scene,
)
from dd_contact.paper.tradeoff.pin import REFERENCE as PIN_REFERENCE
from dd_contact.paper.tradeoff.pin import SPAN, WALLS
from dd_contact.paper.tradeoff.pin import WINDOW as PIN_WINDOW
from dd_contact.paper.tradeoff.scenes import bar_error, hertz_error
from dd_contact.paper.tradeoff.study import refresh
from dd_contact.paper.tradeoff.tilted import REFERENCE, WINDOW, richardson, windows
from dd_contact.paper.verify.bar import _contact_duration

KNOBS = (
    Knob("h", 0.1, (Level(0.2), Level(0.05)), "resolution"),
    Knob("mass", "c", (Level("l"),)),
    Knob("k", 1, (Level(2),)),
    Knob("tie", 1e6, (Level(1e4, {"contact": "interface"}),)),
    Knob("contact", "boundary", (Level("interface"),)),
    Knob("alg", "F", (Level("x"),), "time only"),
    Knob("deg", 1, (Level(2, {"h": 0.2}),)),
)


def test_first_design_is_the_default_then_each_level_alone_with_what_it_needs():
    runs = first_design(KNOBS)
    base = {"h": 0.1, "mass": "c", "k": 1, "tie": 1e6, "contact": "boundary", "alg": "F", "deg": 1}
    assert [r.changed for r in runs] == [
        "default",
        "h=0.2",
        "h=0.05",
        "mass=l",
        "k=2",
        "tie=10000, contact=interface",
        "contact=interface",
        "alg=x",
        "deg=2, h=0.2",
    ]
    assert runs[0].settings == base and runs[0].phase == "default"
    for run in runs[1:]:
        assert run.settings == {**base, **run.changes}
        assert run.phase == "one knob"
    kinds = ["resolution"] * 2 + ["model"] * 4 + ["time only", "resolution"]
    assert [r.kind for r in runs[1:]] == kinds  # a level that moves h too moves along h


@pytest.mark.parametrize(
    ("name", "count"),
    [("hertz", 23), ("bar-impact", 32), ("tilted-wall", 17), ("pin-joint", 25)],
)
def test_the_scenes_designs_vary_one_knob_at_a_time(name, count):
    trade = scene(name)
    runs = first_design(trade.knobs)
    assert len(runs) == count
    assert len({r.key for r in runs}) == count  # no run twice
    base = runs[0].settings
    names = {k.name for k in trade.knobs}
    for run in runs[1:]:
        moved = {k for k in names if run.settings[k] != base[k]}
        assert moved == set(run.changes)  # exactly the knob and what its level needs


def _point(changes, error, seconds, phase="one knob", kind="model"):
    base = {k.name: k.default for k in KNOBS}
    return {
        "settings": {**base, **changes},
        "changes": changes,
        "changed": ", ".join(f"{k}={v}" for k, v in changes.items()) or "default",
        "phase": phase,
        "kind": kind,
        "error": error,
        "seconds": seconds,
    }


MEASURED = [
    _point({}, 0.10, 1.0, "default", "default"),
    _point({"h": 0.2}, 0.20, 0.5, kind="resolution"),
    _point({"h": 0.05}, 0.05, 3.0, kind="resolution"),
    _point({"mass": "l"}, 0.08, 0.9),  # faster and more accurate: a win
    _point({"k": 2}, 0.105, 0.8),  # 0.8x the time, error within 1.1x: a win
    _point({"alg": "x"}, 0.10, 0.7, kind="time only"),  # time only: never a win
    _point({"contact": "interface"}, 0.10, 0.95),  # 0.95x the time: noise, not a win
    _point({"tie": 1e4, "contact": "interface"}, None, None),  # failed
]


def test_combined_design_combines_the_wins_and_the_front():
    runs = combined_design(KNOBS, MEASURED)
    assert [r.changes for r in runs] == [
        {"mass": "l", "k": 2},  # every win together
        {"mass": "l", "k": 2, "h": 0.2},  # ... with each resolution level
        {"mass": "l", "k": 2, "h": 0.05},
        {"h": 0.2, "alg": "x"},  # pairs of one-knob runs on the front
        {"h": 0.2, "mass": "l"},
        {"alg": "x", "mass": "l"},
        {"alg": "x", "h": 0.05},
        {"mass": "l", "h": 0.05},
    ]
    assert {r.phase for r in runs} == {"combined"}
    assert [r.changes for r in combined_design(KNOBS, MEASURED, limit=2)] == [
        {"mass": "l", "k": 2},
        {"mass": "l", "k": 2, "h": 0.2},
    ]
    # what was measured is not planned again
    again = [*MEASURED, _point({"mass": "l", "k": 2}, 0.1, 1.0, "combined", "combined")]
    assert {"mass": "l", "k": 2} not in [r.changes for r in combined_design(KNOBS, again)]


def test_pareto_front_on_a_hand_made_set():
    pts = {
        "A": (1.0, 0.5),
        "B": (2.0, 0.2),
        "C": (3.0, 0.2),  # beaten by B (slower, as accurate)
        "D": (0.5, 1.0),
        "E": (2.0, 0.3),  # beaten by B (as fast, less accurate)
        "F": (4.0, 0.1),
        "G": (2.0, 0.2),  # ties with B: neither beats the other
        "H": (0.4, None),  # failed
    }
    points = [{"name": k, "seconds": t, "error": e} for k, (t, e) in pts.items()]
    assert [p["name"] for p in pareto_front(points)] == ["D", "A", "B", "G", "F"]
    cpu = [{**p, "cpu_seconds": 5.0 - p["seconds"]} for p in points]
    assert [p["name"] for p in pareto_front(cpu, "cpu_seconds")] == ["F"]  # fastest, best


def test_default_verdict():
    points = [_point({}, 0.10, 1.0, "default", "default"), _point({"k": 2}, 0.2, 0.5)]
    assert default_verdict(points) == {
        "on_front": True,
        "front_seconds": 1.0,
        "time_ratio": 1.0,
        "good": True,
        "beaten_by": [],
    }
    near = [*points, _point({"mass": "l"}, 0.09, 0.95)]  # 1.05x: within 10 %
    verdict = default_verdict(near)
    assert (verdict["on_front"], verdict["good"]) == (False, True)
    assert verdict["time_ratio"] == pytest.approx(1.0 / 0.95)
    assert verdict["beaten_by"] == ["mass=l"]
    far = [*points, _point({"mass": "l"}, 0.09, 0.5)]  # 2x: off the front
    assert default_verdict(far)["good"] is False
    assert default_verdict(far)["time_ratio"] == pytest.approx(2.0)


def test_the_errors_against_the_closed_forms():
    f0, duration, dt = 1e-4, 2.0, 0.25
    t = dt * np.arange(1, 13)
    forces = np.where(t < duration, f0, 0.0)
    result = {
        "forces": forces.tolist(),
        "force_ref": f0,
        "duration_ref": duration,
        "duration": 2.0,
        "parting": 2.0,
        "plateau_force": f0,
        "peak_force": f0,
        "rebound": 1.0,
        "energy_ratio": 1.0,
        "changes": 1,
        "steps": 12,
    }
    assert bar_error(result, dt)["error"] == 0.0
    forces[3] *= 1.1  # one step 10 % high: 0.1 F0 dt over F0 2L/c
    result["forces"] = forces.tolist()
    assert bar_error(result, dt)["error"] == pytest.approx(0.1 * dt / duration)
    # the duration: the last fall through half the plateau (1), between the steps it lies
    ramp = [0.0, 1.0, 1.2, 0.4, 1.0, 1.0, 0.75, 0.25, 0.0, 0.0]  # a dip, then the release
    assert _contact_duration(ramp, 1.0, dt) == pytest.approx(dt * (7 + 0.25 / 0.5))
    assert _contact_duration([1.0, 1.0], 1.0, dt) == 2 * dt  # still pressing at the end
    r = np.linspace(0.0, 0.95 * 0.99, 20)  # Hertz's profile with a 1 % short, p0 3 % high
    profile = {"profile_r": r, "profile_p": 1.03 * np.sqrt(1.0 - (r / 0.99) ** 2)}
    hertz = {"a": 0.98, "a_ref": 1.0, "p_max": 1.05, "p0_ref": 1.0, **profile}
    out = hertz_error({**hertz, "force": 1.0, "dofs": 9, "iterations": 3})
    assert out["error"] == pytest.approx(0.03)
    assert out["parts"]["contact_radius"] == pytest.approx(-0.01)
    assert out["parts"]["peak_pressure_nodal"] == pytest.approx(0.05)  # raw, not judged


def _fake_runner(stop_after: int):
    calls = []

    def run(scene_name, settings, timeout):
        calls.append(settings)
        if len(calls) > stop_after:
            raise BudgetExceeded
        return {
            "error": 0.1 / len(calls),
            "seconds": float(len(calls)),
            "cpu_seconds": 1.0,
            "peak_mib": 100.0,
            "parts": {},
        }

    return run


def test_a_budget_stop_still_writes_valid_json_and_the_chart(tmp_path):
    out, png = tmp_path / "study.json", tmp_path / "study.png"
    lines = []
    trade = scene("bar-impact")
    run_study(trade, 1e9, out, png, runner=_fake_runner(3), say=lines.append)
    doc = json.loads(out.read_text())
    assert doc["stopped"] == "budget"
    assert [r["phase"] for r in doc["runs"]] == ["warm-up", "default", "one knob", "one knob"]
    assert doc["runs"][3]["stopped"] == "budget" and doc["runs"][3]["error"] is None
    assert doc["front"] == [1, 2] and doc["runs"][1]["default"] is True  # not the warm-up
    assert png.read_bytes()[:4] == b"\x89PNG"
    assert "stopped by the budget" in lines[-1]
    # a budget spent before the first run: no run, a valid document all the same
    run_study(trade, 1e-9, out, png, runner=_fake_runner(99), say=lines.append)
    doc = json.loads(out.read_text())
    assert (doc["runs"], doc["front"], doc["stopped"]) == ([], [], "budget")


def test_a_worker_past_the_budget_is_stopped():
    settings = first_design(scene("bar-impact").knobs)[0].settings
    with pytest.raises(BudgetExceeded):
        run_in_process("bar-impact", settings, timeout=0.05)


def test_a_tiny_real_study_against_the_closed_form(tmp_path, capsys):
    # At CFL 0.5 (the old default: averaged mass gains there, not at CFL 1).
    trade = scene("bar-impact").with_defaults(n=20, across=1, cfl=0.5).only(["mass"])
    doc = run_study(trade, 600, tmp_path / "s.json", None, combined_limit=0)
    assert [r["changed"] for r in doc["runs"]] == [
        "default, warm-up",
        "default",
        "mass=lumped",
        "mass=averaged",
        "default, repeated",
    ]
    warm, default, _, averaged, repeat = doc["runs"]
    assert repeat["error"] == default["error"] == warm["error"]  # one run: one answer
    for run in doc["runs"]:
        parts = run["parts"]
        assert abs(parts["duration"]) < 0.03  # 2L/c
        assert abs(parts["plateau_force"]) < 0.03  # rho c v0 A
        assert run["peak_mib"] >= run["baseline_mib"] > 0 and run["cpu_seconds"] > 0
    assert default["error"] == pytest.approx(0.0480, rel=0.01)
    assert averaged["error"] < default["error"]
    assert doc["reference"]["kind"] == "closed form"
    assert json.loads((tmp_path / "s.json").read_text())["front"] == doc["front"]
    assert "bar-impact: default" in capsys.readouterr().out


def test_cli_tradeoff(tmp_path, capsys):
    out, png = tmp_path / "t.json", tmp_path / "t.png"
    argv = ["tradeoff", "hertz", "--budget", "1e-9", "--json", str(out), "--plot", str(png)]
    assert main(argv) == 0
    assert json.loads(out.read_text())["scene"] == "hertz" and png.exists()
    assert "stopped by the budget" in capsys.readouterr().out
    assert main(["tradeoff", "hertz", "--json", str(tmp_path / "no" / "t.json")]) == 2
    assert "does not exist" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["tradeoff", "nowhere"])


COSTLY = (
    Knob("h", 0.1, (Level(0.2), Level(0.01, costly=True)), "resolution"),
    Knob("m", "c", (Level("q", costly=True), Level("l"))),
    Knob("k", 1, (Level(2),)),
)


def test_costly_levels_run_after_the_cheap_ones():
    runs = first_design(COSTLY)
    assert [r.changed for r in runs] == ["default", "h=0.2", "m=l", "k=2", "h=0.01", "m=q"]
    assert [r.costly for r in runs] == [False] * 4 + [True] * 2
    assert is_costly(COSTLY, {"h": 0.01, "m": "l"}) and not is_costly(COSTLY, {"h": 0.2})


def test_a_study_runs_cheap_runs_then_costly_ones():
    def runner(scene_name, settings, timeout):
        h, slow = settings["h"], settings["m"] == "q"
        error = h * (0.5 if slow else 1.0) * (0.8 if settings["k"] == 2 else 1.0)
        seconds = (1.0 / h) * (5.0 if slow else 1.0)
        return {"error": error, "seconds": seconds, "cpu_seconds": seconds, "peak_mib": 1.0}

    trade = TradeScene("fake", COSTLY, "e", {}, lambda settings: {})
    doc = run_study(trade, None, None, None, runner=runner, say=lambda line: None)
    runs = doc["runs"]
    phases = [r["phase"] for r in runs]
    costly = [is_costly(COSTLY, r["changes"]) for r in runs]
    first_costly = costly.index(True)
    assert phases[:5] == ["warm-up", "default", "one knob", "one knob", "one knob"]
    assert phases[first_costly : first_costly + 2] == ["one knob", "one knob"]
    assert not any(costly[:first_costly])  # every cheap run before the first costly one
    assert "combined" in phases[4:first_costly]  # cheap combined runs before the costly ones
    assert phases[-1] == "repeat" and runs[-1]["error"] == runs[0]["error"]
    measured = [r for r in runs if r["phase"] not in ("warm-up", "repeat")]
    assert doc["default_verdict_best_of_two"]["cpu"] == default_verdict(measured, "cpu_seconds")
    assert refresh(doc, trade)["front"] == doc["front"]
    verdict = doc["default_verdict"]  # k=2: as fast, more accurate; good by the 10 % rule
    assert (verdict["on_front"], verdict["good"], verdict["time_ratio"]) == (False, True, 1.0)
    assert "k=2" in verdict["beaten_by"]


def test_the_tilted_walls_windows_and_richardson():
    dt = WINDOW / 4
    forces = np.arange(8.0)
    assert windows(dt, forces).tolist() == [1.5, 5.5]  # each window's mean
    with pytest.raises(ValueError, match="does not divide"):
        windows(WINDOW / 3.5, np.ones(7))
    # Three runs whose errors are 4e, 2e, e (order 1): the finest is off by e.
    exact = np.sin(np.linspace(0.0, 3.0, 40)) + 2.0
    runs = [(dt, exact + k * 1e-2 * np.cos(np.arange(40.0))) for k in (4.0, 2.0, 1.0)]
    est = richardson(runs)
    assert est["order"] == pytest.approx(1.0, rel=1e-9)
    true = np.linalg.norm(windows(*runs[2]) - windows(dt, exact)) / np.linalg.norm(
        windows(*runs[2])
    )
    assert est["finest_error"] == pytest.approx(true, rel=1e-9)
    assert len(REFERENCE["windows"]) == round(4e-3 / WINDOW)  # one period


def test_windows_of_several_forces_and_the_pin_joints_reference():
    # Two walls' forces (steps first): each window's mean, wall by wall.
    forces = np.arange(16.0).reshape(8, 2)
    assert windows(PIN_WINDOW / 4, forces, PIN_WINDOW).tolist() == [[3.0, 4.0], [11.0, 12.0]]
    assert np.shape(PIN_REFERENCE["windows"]) == (round(SPAN / PIN_WINDOW), len(WALLS))
    own = PIN_REFERENCE["richardson"]
    assert 0.0 < own["finest_error"] < own["difference_fine"] < own["difference_coarse"]
