"""A time step too coarse for an impact is not silent (CoarseTimeStepWarning)."""

from __future__ import annotations

import warnings

from mpi4py import MPI

import pytest

import dd_contact as dd
from dd_contact.paper import verify
from dd_contact.problem import MIN_CONTACT_STEPS


def test_a_contact_of_eight_steps_warns_and_names_the_fix():
    # CFL 10: the bar creates no energy but rebounds at 0.82 v0 (energy 0.95), its contact
    # lasting 8 steps (2 L/c over dt); before, nothing said so.
    with pytest.warns(dd.CoarseTimeStepWarning, match=r"after only \d time step") as caught:
        r = verify.bar_impact(n=40, cfl=10.0, comm=MPI.COMM_SELF)
    assert r["rebound"] < 0.9 and r["energy_ratio"] <= 1 + 1e-6
    message = str(caught[0].message)
    assert "use a smaller time step" in message and f"/ {MIN_CONTACT_STEPS} =" in message
    assert sum(issubclass(w.category, dd.CoarseTimeStepWarning) for w in caught) == 1  # once


def test_a_contact_of_eighty_steps_is_quiet():
    # CFL 1: 81 steps in contact, rebound 0.983 v0
    with warnings.catch_warnings():
        warnings.simplefilter("error", dd.CoarseTimeStepWarning)
        r = verify.bar_impact(n=40, cfl=1.0, comm=MPI.COMM_SELF)
    assert r["rebound"] == pytest.approx(1.0, abs=0.02)
    assert r["duration"] / (1.0 / 40) >= MIN_CONTACT_STEPS


def test_a_load_that_presses_and_lets_go_is_quiet_at_any_step():
    # The paper's bar pushed onto its wall by a slow periodic body force (about 13 axial
    # periods per load period, nearly quasi-static): its contact episodes are short in steps
    # but follow the load, not an impact; the warning used to fire here on every demo run.
    from dd_contact.paper import models

    scene = models.parallelepiped("tiny", algorithm="FULL", comm=MPI.COMM_SELF)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        warnings.simplefilter("error", dd.CoarseTimeStepWarning)
        problem = dd.TransientProblem(scene, 1e-4, algorithm="FULL")
        history = problem.run(60, progress=False, summary=False)
    problem.close()
    lengths, run = [], 0
    for record in history:  # the closed episodes' lengths, in steps
        if any(record["active"].values()):
            run += 1
        elif run:
            lengths.append(run)
            run = 0
    assert lengths and min(lengths) < MIN_CONTACT_STEPS
