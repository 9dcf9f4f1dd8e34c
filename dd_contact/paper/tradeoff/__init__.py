"""The speed/accuracy trade of a scene, measured (``dd-contact tradeoff SCENE``).

* :mod:`~dd_contact.paper.tradeoff.design`: the knobs, the runs a study does (one knob at a
  time, then combined moves along the front), the Pareto front and the default's verdict.
* :mod:`~dd_contact.paper.tradeoff.scenes`: the scenes (``hertz``, ``bar-impact``,
  ``tilted-wall``), their knobs, references and errors; :mod:`~dd_contact.paper.tradeoff.tilted`:
  the tilted wall's runs, its converged reference and Richardson estimate.
* :mod:`~dd_contact.paper.tradeoff.study`: running a study, each run in a worker process
  (:mod:`~dd_contact.paper.tradeoff.worker`), the JSON written after every run, the budget.
* :mod:`~dd_contact.paper.tradeoff.chart`: the Pareto chart.
"""

from dd_contact.paper.tradeoff.design import (
    Knob,
    Level,
    Run,
    combined_design,
    default_verdict,
    first_design,
    front_time_at,
    is_costly,
    pareto_front,
)
from dd_contact.paper.tradeoff.scenes import SCENES, TradeScene, scene
from dd_contact.paper.tradeoff.study import BudgetExceeded, run_in_process, run_study

__all__ = [
    "SCENES",
    "BudgetExceeded",
    "Knob",
    "Level",
    "Run",
    "TradeScene",
    "combined_design",
    "default_verdict",
    "first_design",
    "front_time_at",
    "is_costly",
    "pareto_front",
    "run_in_process",
    "run_study",
    "scene",
]
