"""The schedule's plan of an energy-safe release solve (Schedule.release), per order."""

from __future__ import annotations

import numpy as np
import pytest

from dd_contact.blocks import Block
from dd_contact.solvers.schedule import FullSchedule, Schedule, run_operations


def _tied(*blocks: tuple[str, int]) -> list:
    return [(Block.parse(b), np.arange(n)) for b, n in blocks]


def _ops(ops) -> list[tuple]:
    return [(str(o.target), o.kind, o.what, o.size, o.nrhs) for o in ops]


# One subdomain A (30 dofs) tied to an interface v (6) and a contact interface w (4).
_SIZES = {"u:A": 30, "v:i": 6, "w:c": 4}
_LAYOUTS = {"u:A": _tied(("v:i", 6), ("w:c", 4))}


@pytest.mark.parametrize(
    ("order", "expected"),
    [
        # w eliminated first: its new rhs is eliminated forward (its coupling to v's 6 dofs
        # times y), v solved, w solved back (v's solution times its coupling first)
        (
            "v-w-u",
            [
                ("w:c", "dense_solve", "y", 4, 1),
                ("w:c", "dense_product", "y", 4, 6),
                ("v:i", "dense_solve", "x", 6, 1),
                ("w:c", "dense_product", "x", 4, 6),
                ("w:c", "dense_solve", "x", 4, 1),
            ],
        ),
        # w last: only its solve (v's right-hand side did not change; its elimination into
        # w, a product with its coupling, is redone in every surface solve)
        (
            "w-v-u",
            [("v:i", "dense_product", "y", 6, 4), ("w:c", "dense_solve", "x", 4, 1)],
        ),
    ],
)
def test_a_contact_interface_release_solves_its_w_rows_and_no_subdomain(order, expected):
    plan = Schedule(order, _SIZES, _LAYOUTS, set(), {"end": "w:c"}).release("end")
    assert _ops(plan) == expected


def test_a_contact_boundary_release_sweeps_its_subdomain_once():
    sizes = {"u:A": 30, "u:B": 20, "v:i": 6}
    layouts = {"u:A": _tied(("v:i", 6)), "u:B": _tied(("v:i", 6))}
    plan = Schedule("v-u", sizes, layouts, set(), {"end": "u:A"}).release("end")
    # A's new rhs: its reduction (forward sweep), the v solve, its expansion; B untouched
    assert _ops(plan) == [
        ("u:A", "sparse_forward", "u_hat", 30, 1),
        ("v:i", "dense_solve", "x", 6, 1),
        ("u:A", "sparse_backward", "u", 30, 1),
    ]


def test_full_re_substitutes_and_a_run_adds_up_its_parts():
    full = FullSchedule(40, {"end": "w:c"})
    assert _ops(full.release("end")) == [("FULL", "sparse_solve", "", 40, 1)]
    run = run_operations(full, n_steps=5, changes={"end": 2}, releases={"end": 3})
    kinds = [o.kind for o in run]
    # set-up, 5 steps, 2 changes (factorise + solve), 3 releases (a solve each)
    assert kinds.count("sparse_factor") == 1 + 2 and kinds.count("sparse_solve") == 5 + 2 + 3
