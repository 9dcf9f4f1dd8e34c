"""Blocks and contact regions: the typed names the assembly, schedule and solvers share."""

from __future__ import annotations

import pickle

from mpi4py import MPI

import numpy as np
import pytest
import scipy.sparse as sp

import dd_contact as dd
from dd_contact.blocks import Block, ContactRegion
from dd_contact.paper import verify


def test_a_block_is_its_key():
    block = Block("u", "left")
    assert (block.kind, block.name) == ("u", "left")
    assert block == "u:left" and {block: 1}["u:left"] == 1 and {"u:left": 2}[block] == 2
    assert Block.parse("w:pad:1") == Block("w", "pad:1")  # only the first colon separates
    assert Block.parse(block) is block
    copy = pickle.loads(pickle.dumps(block))  # how blocks travel between ranks
    assert type(copy) is Block and (copy.kind, copy.name) == ("u", "left")


@pytest.mark.parametrize("key", ["left", "x:left"])
def test_a_malformed_block_name_is_refused(key):
    with pytest.raises(ValueError, match="block"):
        Block.parse(key)


def test_a_contact_region_shifts_into_a_larger_matrix():
    region = ContactRegion("pad", Block("w", "pad"), np.arange(3), sp.eye_array(3).tocsr())
    moved = region.shifted(10)
    assert moved.dofs.tolist() == [10, 11, 12] and region.dofs.tolist() == [0, 1, 2]
    assert moved.block is region.block and moved.pattern is region.pattern


@pytest.mark.parametrize(
    ("kind", "kinds"),
    [
        ("interface", {"u": 2, "v": 1, "w": 1}),
        ("boundary", {"u": 2, "v": 1}),
        ("single", {"u": 1, "w": 1}),
    ],
)
def test_assembly_names_every_block_from_the_scene(kind, kinds):
    scene = verify.order_scene(kind, False, 1e4, MPI.COMM_SELF)
    problem = dd.StaticProblem(scene, algorithm="FULL")
    sizes = problem.solver.system.sizes
    assert all(type(b) is Block for b in sizes)
    counted = {k: sum(b.kind == k for b in sizes) for k in "uvw"}
    assert {k: n for k, n in counted.items() if n} == kinds
    assert {sub.block for sub in scene.subdomains} == {b for b in sizes if b.kind == "u"}
    for zone, contact in zip(problem.zones, scene.contacts, strict=True):
        region = zone.region
        assert region.name == contact.name and region.block == contact.block
        assert region.block.kind == ("u" if kind == "boundary" else "w")
        assert region.pattern.shape == (len(region.dofs), len(region.dofs))
    problem.close()
