"""The seams of contact pairs and friction: regions of two blocks, unsymmetric, with history."""

from mpi4py import MPI

import numpy as np
import pytest
import scipy.sparse as sp

from dd_contact.blocks import Block, BlockSystem, ContactRegion, refuse_unsolvable
from dd_contact.solvers.engine import BlockEliminationSolver
from dd_contact.solvers.schedule import Schedule, region_blocks
from dd_contact.solvers.worklog import WorkLog

SIZES = {"u:A": 30, "u:B": 30, "v:I": 12, "w:a": 6, "w:b": 9}
LAYOUTS = {
    "u:A": [("v:I", np.arange(6)), ("w:a", np.arange(6))],
    "u:B": [("v:I", np.arange(6, 12)), ("w:b", np.arange(9))],
}


def _schedule(regions, order="v-w-u"):
    return Schedule(order, SIZES, LAYOUTS, set(), regions)


def test_two_obstacle_regions_are_eliminated_apart():
    schedule = _schedule({"top": "w:a", "bottom": "w:b"})
    assert [g.name for g in schedule.groups[0]] == ["w:a", "w:b"]
    assert schedule.stale_groups(schedule.touched(*schedule.regions["top"])) == {"w:a", "v:I"}


def test_a_pair_of_two_w_blocks_is_one_group_and_a_change_refactorises_it():
    schedule = _schedule({"pair": ("w:a", "w:b")})
    assert schedule.regions["pair"] == region_blocks(("w:a", "w:b"))
    assert [g.name for g in schedule.groups[0]] == ["w:a+w:b"]
    ops = schedule.change("pair")
    factorised = [op.target for op in ops if op.kind == "dense_factor"]
    assert factorised == ["w:a+w:b", "v:I"]
    sizes = {op.target: op.size for op in ops if op.kind == "dense_factor"}
    assert sizes == {"w:a+w:b": 15, "v:I": 12}


def test_a_pair_in_the_last_level_solves_once_per_change_and_release():
    schedule = _schedule({"pair": ("w:a", "w:b")}, order="w-v-u")
    assert [g.name for g in schedule.groups[-1]] == ["w:a+w:b"]
    release = schedule.release("pair")
    assert [op.kind for op in release if op.target == "w:a+w:b"] == ["dense_solve"]
    assert not [op for op in release if op.kind.endswith("factor")]


def test_a_region_of_no_block_is_refused():
    with pytest.raises(ValueError, match="at least one block"):
        region_blocks(())


def test_a_pair_region_splits_its_matrix_into_the_block_pairs_it_fills():
    a, b = Block("w", "a"), Block("w", "b")
    region = ContactRegion("pair", a, np.array([0, 2]), sp.eye_array(3).tocsr(), b, np.array([1]))
    assert region.blocks == (a, b)
    matrix = sp.csr_array(np.arange(9.0).reshape(3, 3))
    pieces = region.in_blocks(matrix, {a: 3, b: 2})
    assert sorted(pieces) == [(a, a), (a, b), (b, a), (b, b)]
    assert pieces[(a, a)].toarray().tolist() == [[0, 0, 1], [0, 0, 0], [3, 0, 4]]
    assert pieces[(a, b)].toarray().tolist() == [[0, 2], [0, 0], [0, 5]]
    assert pieces[(b, b)].toarray().tolist() == [[0, 0], [0, 8]]
    assert region.shifted({a: 10, b: 20}).dofs.tolist() == [10, 12, 21]
    refuse_unsolvable([region])  # solved now: nothing raised


def test_friction_seams_are_solved_except_on_a_subdomain_in_the_orders():
    """An unsymmetric region with history (friction) is solved where it is a surface block;
    on a subdomain's own boundary only FULL solves it (the orders keep subdomains symmetric)."""
    seam = {"symmetric": False, "history": True}
    region = ContactRegion("pad", Block("w", "a"), np.arange(3), sp.eye_array(3).tocsr(), **seam)
    assert region.blocks == (Block("w", "a"),)
    refuse_unsolvable([region])  # solved: nothing raised
    own = ContactRegion("pad", Block("u", "a"), np.arange(3), sp.eye_array(3).tocsr(), **seam)
    refuse_unsolvable([own], monolithic=True)  # FULL takes MUMPS's LU
    with pytest.raises(NotImplementedError, match="'pad' has friction on a subdomain's own"):
        refuse_unsolvable([own])
    system = BlockSystem({Block("u", "a"): 3}, {Block("u", "a"): 0})
    system.add(Block("u", "a"), Block("u", "a"), sp.eye_array(3))
    with pytest.raises(NotImplementedError, match="use a ContactInterface"):
        BlockEliminationSolver(MPI.COMM_SELF, system, [own], WorkLog(), "v-u")
